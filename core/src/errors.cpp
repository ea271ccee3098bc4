#include "gel/errors.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "proto_json.hpp"

namespace gel {
namespace {
std::string describe(double value) {
  std::ostringstream out;
  out.precision(17);
  out << value;
  return out.str();
}
}  // namespace

void require_finite(const std::string& field, double value) {
  if (!std::isfinite(value)) throw InvalidArgument(field, "must be a finite number, got " + describe(value));
}

void require_json_message(const std::string& what, const std::string& text, const google::protobuf::Descriptor& type) {
  if (const JsonProblem problem = json_problem(text, type))
    throw InvalidArgument(problem.field.empty() ? what : what + "." + problem.field, problem.message);
}

void require_positive(const std::string& field, double value) {
  require_finite(field, value);
  if (!(value > 0)) throw InvalidArgument(field, "must be positive, got " + describe(value));
}

void require_within(const std::string& field, double value, double lo, double hi, const std::string& why) {
  require_finite(field, value);
  if (!(value >= lo && value <= hi))
    throw InvalidArgument(field, "must be between " + describe(lo) + " and " + describe(hi) + " (" + why + "), got " + describe(value));
}

namespace {
// The longest prefix of at most max_bytes that ends on a UTF-8 character boundary (a
// continuation byte is 10xxxxxx), so that a cut text is still valid UTF-8.
std::string utf8_prefix(const std::string& text, std::size_t max_bytes) {
  std::size_t cut = std::min(max_bytes, text.size());
  while (cut > 0 && cut < text.size() && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return text.substr(0, cut);
}
}  // namespace

std::string quoted(const std::string& value, std::size_t max_characters) {
  // Built with append: GCC 12's -Wrestrict misfires on "'" + value + "'".
  std::string out("'");
  if (value.size() <= max_characters) return out.append(value).append("'");
  return out.append(utf8_prefix(value, max_characters)).append("...' (").append(std::to_string(value.size())).append(" bytes)");
}

std::string truncated(const std::string& text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return text;
  return utf8_prefix(text, max_bytes) + "... (" + std::to_string(text.size()) + " bytes in all)";
}

void require_non_negative(const std::string& field, double value) {
  require_finite(field, value);
  if (value < 0) throw InvalidArgument(field, "must not be negative, got " + describe(value));
}

}  // namespace gel
