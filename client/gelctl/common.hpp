#pragma once
// What several gelctl sub-commands share: exit codes and the errors that choose them, the
// connection to geld, job formatting, and following a job.
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include <grpcpp/grpcpp.h>
#include <nlohmann/json.hpp>

#include "gel/v1/service.grpc.pb.h"

namespace gelctl {

using json = nlohmann::json;

inline constexpr int kExitSuccess = 0;
inline constexpr int kExitFailure = 1;     // a failed call, or anything else unexpected
inline constexpr int kExitBadInput = 2;    // ours, or the server's INVALID_ARGUMENT
inline constexpr int kExitJobUnsuccessful = 3;  // a watched job ended failed or cancelled

// Bad input on our side: exit 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A failed call: exit 1 (2 for INVALID_ARGUMENT).
struct CallError : std::runtime_error {
  CallError(const grpc::Status& s, std::string text) : std::runtime_error(std::move(text)), status(s) {}
  grpc::Status status;
};

// Throws CallError with the status code's name and the first line of the server's message.
void throw_if_failed(const grpc::Status& status);

// Throws UsageError naming `source` (--server or GELD_SERVER) unless `server` is HOST:PORT or
// one of gRPC's own target forms (unix:PATH, dns:, ipv4:, ipv6:).
void require_host_port(const std::string& server, const std::string& source);

// The bearer token: the first line of `token_file` when given, else $GELD_TOKEN, else none.
std::string resolve_token(const std::string& token_file);

// TLS towards a geld started with --tls-cert (PEM file paths; empty ca: plain text).
struct TlsFiles {
  std::string ca;           // the CA that signed geld's certificate
  std::string certificate;  // this client's certificate, for a geld with --tls-client-ca
  std::string key;
};

class Client {
 public:
  Client(const std::string& server, std::string token, double timeout_seconds, const TlsFiles& tls = {});

  // A call's context with the token and, unless `with_deadline` is false (streams that last as
  // long as a job), the per-call timeout.
  std::unique_ptr<grpc::ClientContext> context(bool with_deadline = true) const;
  gel::v1::GelService::Stub& stub() { return *stub_; }

 private:
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<gel::v1::GelService::Stub> stub_;
  std::string token_;
  double timeout_seconds_;
};

// "queued", "running", ...: the enum's name without JOB_STATE_, in lower case; "unspecified"
// for UNSPECIFIED or a value this build does not know.
std::string state_name(gel::v1::JobState state);
// A job or study that will not change state again (succeeded, failed or cancelled).
bool is_terminal(gel::v1::JobState state);
// "running", "RUNNING" or "JOB_STATE_RUNNING"; UsageError naming --state otherwise.
gel::v1::JobState parse_state(const std::string& text);

std::string read_file(const std::string& path);
// "key=value" into its two halves; UsageError naming `option` otherwise.
std::pair<std::string, std::string> split_label(const std::string& text, const std::string& option);

std::string format_number(double value, int significant_digits = 4);
// "42s", "3m05s" or "2h10m"; "?" for an unknown (negative or non-finite) duration.
std::string format_duration(double seconds);
// ISO 8601 in UTC, or "-" for a time not reached yet (0).
std::string format_unix_ms(std::int64_t unix_ms);

json job_json(const gel::v1::Job& job);

// Streams the job's updates to stdout until it ends (or the stream does) and returns the exit
// code: success unless the job ended failed or cancelled.
int watch_job(Client& client, const std::string& job_id, bool json_lines);

}  // namespace gelctl
