#pragma once
// Errors the engine reports to its callers. Every message names what is wrong so that a user
// (or the service, which turns these into gRPC statuses) can act on it.
#include <stdexcept>
#include <string>

namespace google::protobuf {
class Descriptor;
}

namespace gel {

// A parameter or input that cannot be simulated. `field` is the dotted name of the offending
// field (e.g. "bond.k_normal"), so clients can point at it.
class InvalidArgument : public std::invalid_argument {
 public:
  InvalidArgument(std::string field, const std::string& message)
      : std::invalid_argument(field + ": " + message), field_(std::move(field)) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

// The integration went numerically wrong (non-finite value, blown-up overlap or speed). The
// run stops; the message names the step, the particle or bond, and the value.
class StabilityError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// How every front end (gelsim, geld's job error, the Slurm executor) introduces its message.
inline constexpr const char* kInstabilityPrefix = "numerical instability: ";

// A file could not be written because its file system is full (ENOSPC or a quota). Nothing
// is wrong with the run: it can go on from its last checkpoint once space is back, so callers
// that can wait (the service) treat it apart from other failures.
class NoSpaceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws InvalidArgument unless value is finite and > 0.
void require_positive(const std::string& field, double value);
// Throws InvalidArgument unless value is finite and >= 0.
void require_non_negative(const std::string& field, double value);
// Throws InvalidArgument unless value is finite.
void require_finite(const std::string& field, double value);
// Throws InvalidArgument unless lo <= value <= hi; `why` says what the bounds are, in the
// model's terms (it follows the numbers in the message).
void require_within(const std::string& field, double value, double lo, double hi, const std::string& why);

// Throws InvalidArgument unless `text` is the JSON of a `type` message (e.g. a --scene file):
// the field is `what` and the dotted name of the field at fault ("scene.compression.stepz"),
// or `what` alone when the text is not JSON.
void require_json_message(const std::string& what, const std::string& text, const google::protobuf::Descriptor& type);

// A value quoted in an error message, cut to at most `max_characters` (with "..." and the full
// length) so that an error about a huge value still fits in a status and names its field.
std::string quoted(const std::string& value, std::size_t max_characters = 64);
// The text itself when it has at most max_bytes, else its first max_bytes (cut on a UTF-8
// character boundary) and "... (N bytes in all)".
std::string truncated(const std::string& text, std::size_t max_bytes);

}  // namespace gel
