#pragma once
// What the request handlers of jobs and studies share: the error a client gets with its gRPC
// status code, the checks on ids, list pages, and which job states are final.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <grpcpp/support/status.h>

#include "gel/v1/service.pb.h"

namespace geld {

// An error with the gRPC status code the client gets.
class ApiError : public std::runtime_error {
 public:
  ApiError(grpc::StatusCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  grpc::StatusCode code() const { return code_; }

 private:
  grpc::StatusCode code_;
};

std::int64_t now_ms();

// UNAVAILABLE: what every call gets while geld shuts down.
ApiError shutting_down_error();

// Succeeded, failed or cancelled: the job (or study) will not change again.
bool is_terminal(gel::v1::JobState state);

// Job and study ids are short: a longer one is refused as such (INVALID_ARGUMENT naming
// `field`), never looked up or echoed whole in an error.
void require_id_size(const std::string& field, const std::string& id);

// A list call's page token (the seq of the last item of the previous page): 0 for none; an
// ApiError INVALID_ARGUMENT naming `method` for anything else that is not a positive number.
std::int64_t parse_page_token(const std::string& token, const std::string& method);

// One page of a list call (ListJobs, ListStudies): newest first, `size` items before `before_seq`.
struct Page {
  int size = 50;                // 0 asks for the default, 50; at most 1000
  std::int64_t before_seq = 0;  // from the page token; 0: from the newest

  // From the request's page_size and page_token; throws the ApiError of a bad one.
  static Page parse(int page_size, const std::string& page_token, const std::string& method);

  // `rows` as (seq, item), read with one row more than `size` to know whether a next page
  // exists: the next page's token, "" when this page is the last. Drops the extra row.
  template <class Item>
  std::string next_token(std::vector<std::pair<std::int64_t, Item>>& rows) const {
    if (rows.size() <= static_cast<std::size_t>(size)) return "";
    rows.resize(static_cast<std::size_t>(size));
    return std::to_string(rows.back().first);
  }
};

}  // namespace geld
