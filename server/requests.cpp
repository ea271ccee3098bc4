#include "requests.hpp"

#include <algorithm>
#include <chrono>

namespace geld {

std::int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

ApiError shutting_down_error() {
  return ApiError(grpc::StatusCode::UNAVAILABLE, "geld is shutting down; retry when it is back");
}

bool is_terminal(gel::v1::JobState state) {
  return state == gel::v1::JOB_STATE_SUCCEEDED || state == gel::v1::JOB_STATE_FAILED ||
         state == gel::v1::JOB_STATE_CANCELLED;
}

void require_id_size(const std::string& field, const std::string& id) {
  constexpr std::size_t kMaxIdBytes = 64;
  if (id.size() > kMaxIdBytes)
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT,
                   field + ": " + std::to_string(id.size()) + " bytes, the limit is " + std::to_string(kMaxIdBytes));
}

std::int64_t parse_page_token(const std::string& token, const std::string& method) {
  if (token.empty()) return 0;
  std::int64_t before = 0;
  try {
    std::size_t pos = 0;
    before = std::stoll(token, &pos);
    if (pos != token.size() || before <= 0) throw std::invalid_argument("");
  } catch (const std::exception&) {
    throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "page_token: not a token from a previous " + method);
  }
  return before;
}

Page Page::parse(int page_size, const std::string& page_token, const std::string& method) {
  if (page_size < 0) throw ApiError(grpc::StatusCode::INVALID_ARGUMENT, "page_size: must be >= 0");
  Page page;
  page.size = page_size == 0 ? 50 : std::min(page_size, 1000);
  page.before_seq = parse_page_token(page_token, method);
  return page;
}

}  // namespace geld
