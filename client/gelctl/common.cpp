#include "common.hpp"
#include "duration_text.hpp"
#include "proto_json.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string_view>
#include <vector>

#include <google/protobuf/util/json_util.h>

namespace gelctl {

namespace {

const char* status_code_name(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE: return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    default: return "UNKNOWN";
  }
}

// A terminal gets one progress bar redrawn in place; a pipe or file gets a progress line at
// most every 2 s, so that logs stay readable.
class WatchPrinter {
 public:
  explicit WatchPrinter(bool json_lines) : json_lines_(json_lines), tty_(!json_lines && isatty(STDOUT_FILENO)) {}

  void update(const gel::v1::JobUpdate& update) {
    using Kind = gel::v1::JobUpdate;
    if (json_lines_) {
      std::cout << gel::message_to_json(update, false).dump() << std::endl;
      if (update.kind() == Kind::SNAPSHOT || update.kind() == Kind::STATE) state_ = update.job().state();
      return;
    }
    switch (update.kind()) {
      case Kind::SNAPSHOT:
      case Kind::STATE: {
        const auto& job = update.job();
        state_ = job.state();
        members_ = job.seeds_size();
        clear_bar();
        std::cout << job.id() << ": " << state_name(job.state());
        if (update.kind() == Kind::SNAPSHOT) {
          std::cout << " (" << job.particles() << " particles, " << job.seeds_size() << " seed"
                    << (job.seeds_size() == 1 ? "" : "s") << ", " << job.rows() << " rows so far)";
        }
        if (!job.error().empty()) std::cout << ": " << job.error();
        std::cout << std::endl;
        break;
      }
      case Kind::ROW: {
        const auto& row = update.row();
        clear_bar();
        std::cout << "  " << member_tag(update) << "k " << std::setw(2) << row.k() << "  phi "
                  << format_number(row.phi(), 5) << "  P " << format_number(row.p(), 5) << "  P_top "
                  << format_number(row.p_top(), 4) << "  P_bot " << format_number(row.p_bot(), 4) << "  z "
                  << format_number(row.contact_number(), 4) << (row.equilibrated() ? "" : "  (max wait)")
                  << std::endl;
        break;
      }
      case Kind::PROGRESS: {
        const auto& progress = update.progress();
        const auto now = std::chrono::steady_clock::now();
        if (!tty_ && now - last_line_ < std::chrono::seconds(2)) break;
        last_line_ = now;
        std::ostringstream line;
        line << member_tag(update) << (progress.phase().empty() ? "" : progress.phase() + " ") << "phi "
             << format_number(progress.phi(), 4) << " -> " << format_number(progress.target_phi(), 4) << "  step "
             << progress.k() << "/" << progress.k_total() << "  P " << format_number(progress.p(), 4)
             << "  elapsed " << format_duration(progress.elapsed_seconds()) << "  ETA "
             << format_duration(progress.remaining_seconds());
        // Quasi-static runs: show the relaxation converging.
        if (progress.relax_iterations() > 0)
          line << "  residual " << format_number(progress.residual_force(), 3) << " (target "
               << format_number(progress.residual_target(), 3) << ", " << progress.relax_iterations() << " it)";
        if (tty_) {
          const int width = 24;
          const double done =
              progress.k_total() > 0 ? std::clamp((progress.k() - 1.0) / progress.k_total(), 0.0, 1.0) : 0.0;
          const int filled = static_cast<int>(done * width);
          std::cout << "\r\033[K[" << std::string(filled, '#') << std::string(width - filled, '.') << "] "
                    << line.str() << std::flush;
          bar_shown_ = true;
        } else {
          std::cout << "  " << line.str() << std::endl;
        }
        break;
      }
      case Kind::LOG:
        clear_bar();
        std::cout << "  log: " << update.message() << std::endl;
        break;
      default:
        break;
    }
  }
  void finish() { clear_bar(); }
  gel::v1::JobState state() const { return state_; }

 private:
  std::string member_tag(const gel::v1::JobUpdate& update) const {
    return members_ > 1 ? "[seed " + std::to_string(update.seed()) + "] " : "";
  }
  void clear_bar() {
    if (bar_shown_) std::cout << "\r\033[K" << std::flush;
    bar_shown_ = false;
  }
  bool json_lines_;
  bool tty_;
  bool bar_shown_ = false;
  int members_ = 1;
  gel::v1::JobState state_ = gel::v1::JOB_STATE_UNSPECIFIED;
  std::chrono::steady_clock::time_point last_line_{};
};

}  // namespace

void throw_if_failed(const grpc::Status& status) {
  if (status.ok()) return;
  std::string message = status.error_message();
  if (auto newline = message.find('\n'); newline != std::string::npos) message.resize(newline);
  throw CallError(status, std::string(status_code_name(status.error_code())) + ": " + message);
}

void require_host_port(const std::string& server, const std::string& source) {
  // A host without a port is dialled on a port gRPC chooses (0 here), where no geld listens.
  for (const char* scheme : {"unix:", "unix-abstract:", "dns:", "ipv4:", "ipv6:", "vsock:"})
    if (server.rfind(scheme, 0) == 0) return;
  const std::size_t colon = server.rfind(':');
  const std::string host = colon == std::string::npos ? server : server.substr(0, colon);
  const std::string port = colon == std::string::npos ? "" : server.substr(colon + 1);
  const bool bracketed = host.size() > 2 && host.front() == '[' && host.back() == ']';
  const bool host_ok = !host.empty() && (bracketed || host.find_first_of(":[]") == std::string::npos);
  const bool port_ok = !port.empty() && port.size() <= 5 && port.find_first_not_of("0123456789") == std::string::npos &&
                       std::stoi(port) >= 1 && std::stoi(port) <= 65535;
  if (!host_ok || !port_ok)
    throw UsageError(source + ": '" + server + "' is not HOST:PORT" + (port.empty() || !host_ok ? " (no port)" : " (port 1 to 65535)") +
                     "; geld listens on 127.0.0.1:50051 unless started with another --listen");
}

std::string resolve_token(const std::string& token_file) {
  std::string token;
  if (!token_file.empty()) {
    std::istringstream in(read_file(token_file));
    std::getline(in, token);
    while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back()))) token.pop_back();
  } else if (const char* from_environment = std::getenv("GELD_TOKEN")) {
    token = from_environment;
  }
  return token;
}

namespace {
std::shared_ptr<grpc::ChannelCredentials> channel_credentials(const TlsFiles& tls) {
  if (tls.ca.empty()) {
    if (!tls.certificate.empty() || !tls.key.empty()) throw UsageError("--tls-cert/--tls-key: need --tls-ca (the CA of geld's certificate)");
    return grpc::InsecureChannelCredentials();
  }
  if (tls.certificate.empty() != tls.key.empty()) throw UsageError("--tls-cert and --tls-key go together");
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = read_file(tls.ca);
  if (!tls.certificate.empty()) {
    ssl.pem_cert_chain = read_file(tls.certificate);
    ssl.pem_private_key = read_file(tls.key);
  }
  return grpc::SslCredentials(ssl);
}
}  // namespace

Client::Client(const std::string& server, std::string token, double timeout_seconds, const TlsFiles& tls)
    : token_(std::move(token)), timeout_seconds_(timeout_seconds) {
  grpc::ChannelArguments args;
  // Curves (GetCurve, QueryCurves) can exceed gRPC's 4 MiB default for what a client receives.
  args.SetMaxReceiveMessageSize(256 * 1024 * 1024);
  channel_ = grpc::CreateCustomChannel(server, channel_credentials(tls), args);
  stub_ = gel::v1::GelService::NewStub(channel_);
}

std::unique_ptr<grpc::ClientContext> Client::context(bool with_deadline) const {
  auto context = std::make_unique<grpc::ClientContext>();
  if (!token_.empty()) context->AddMetadata("authorization", "Bearer " + token_);
  if (with_deadline && timeout_seconds_ > 0) {
    context->set_deadline(std::chrono::system_clock::now() +
                          std::chrono::milliseconds(static_cast<std::int64_t>(timeout_seconds_ * 1000)));
  }
  return context;
}

// The names are the proto enum's own, without the prefix and in lower case
// (JOB_STATE_RUNNING -> "running"): the words geld stores and prints, with no table here to keep
// in step with service.proto.
constexpr std::string_view kStatePrefix = "JOB_STATE_";

std::string state_name(gel::v1::JobState state) {
  const std::string& name = gel::v1::JobState_Name(state);  // "" for a value this build does not know
  if (state == gel::v1::JOB_STATE_UNSPECIFIED || name.rfind(kStatePrefix, 0) != 0) return "unspecified";
  std::string lower;
  for (char c : name.substr(kStatePrefix.size())) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower;
}

gel::v1::JobState parse_state(const std::string& text) {
  std::string upper;
  for (char c : text) upper += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (upper.rfind(kStatePrefix, 0) != 0) upper = std::string(kStatePrefix) + upper;
  gel::v1::JobState state = gel::v1::JOB_STATE_UNSPECIFIED;
  if (gel::v1::JobState_Parse(upper, &state) && state != gel::v1::JOB_STATE_UNSPECIFIED) return state;
  std::string known;
  for (int value = gel::v1::JobState_MIN; value <= gel::v1::JobState_MAX; ++value)
    if (gel::v1::JobState_IsValid(value) && value != gel::v1::JOB_STATE_UNSPECIFIED)
      known += (known.empty() ? "" : ", ") + state_name(static_cast<gel::v1::JobState>(value));
  throw UsageError("--state: unknown state '" + text + "' (" + known + ")");
}

bool is_terminal(gel::v1::JobState state) {
  return state == gel::v1::JOB_STATE_SUCCEEDED || state == gel::v1::JOB_STATE_FAILED ||
         state == gel::v1::JOB_STATE_CANCELLED;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError("cannot read " + path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::pair<std::string, std::string> split_label(const std::string& text, const std::string& option) {
  auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) throw UsageError(option + ": '" + text + "' is not key=value");
  return {text.substr(0, eq), text.substr(eq + 1)};
}

std::string format_number(double value, int significant_digits) {
  std::ostringstream out;
  out << std::setprecision(significant_digits) << value;
  return out.str();
}

std::string format_duration(double seconds) { return gel::duration_text(seconds); }

std::string format_unix_ms(std::int64_t unix_ms) {
  if (unix_ms <= 0) return "-";
  std::time_t seconds = unix_ms / 1000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

json job_json(const gel::v1::Job& job) {
  json j;
  j["id"] = job.id();
  j["name"] = job.name();
  j["state"] = state_name(job.state());
  j["labels"] = json::object();
  for (const auto& [key, value] : job.labels()) j["labels"][key] = value;
  j["seeds"] = std::vector<std::uint64_t>(job.seeds().begin(), job.seeds().end());
  j["particles"] = job.particles();
  j["bond_preset"] = job.bond_preset();
  j["created"] = format_unix_ms(job.created_unix_ms());
  j["started"] = format_unix_ms(job.started_unix_ms());
  j["finished"] = format_unix_ms(job.finished_unix_ms());
  j["error"] = job.error();
  j["member"] = job.member();
  j["rows"] = job.rows();
  j["out_dir"] = job.out_dir();
  j["program_version"] = job.program_version();
  if (job.has_progress()) {
    const auto& progress = job.progress();
    j["progress"] = {{"k", progress.k()},
                     {"k_total", progress.k_total()},
                     {"phi", progress.phi()},
                     {"target_phi", progress.target_phi()},
                     {"P", progress.p()},
                     {"elapsed_seconds", progress.elapsed_seconds()},
                     {"remaining_seconds", progress.remaining_seconds()},
                     {"phase", progress.phase()}};
    if (progress.relax_iterations() > 0) {
      j["progress"]["residual_force"] = progress.residual_force();
      j["progress"]["residual_target"] = progress.residual_target();
      j["progress"]["relax_iterations"] = progress.relax_iterations();
    }
  }
  j["scene"] = gel::message_to_json(job.scene(), false);
  return j;
}

int watch_job(Client& client, const std::string& job_id, bool json_lines) {
  gel::v1::WatchJobRequest request;
  request.set_job_id(job_id);
  auto context = client.context(false);
  auto reader = client.stub().WatchJob(context.get(), request);
  WatchPrinter printer(json_lines);
  gel::v1::JobUpdate update;
  while (reader->Read(&update)) printer.update(update);
  printer.finish();
  throw_if_failed(reader->Finish());
  if (printer.state() == gel::v1::JOB_STATE_SUCCEEDED) return kExitSuccess;
  if (is_terminal(printer.state())) return kExitJobUnsuccessful;
  return kExitSuccess;
}

}  // namespace gelctl
