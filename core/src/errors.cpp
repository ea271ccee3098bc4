#include "gel/errors.hpp"

#include <cmath>
#include <sstream>

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

void require_positive(const std::string& field, double value) {
  require_finite(field, value);
  if (!(value > 0)) throw InvalidArgument(field, "must be positive, got " + describe(value));
}

void require_non_negative(const std::string& field, double value) {
  require_finite(field, value);
  if (value < 0) throw InvalidArgument(field, "must not be negative, got " + describe(value));
}

}  // namespace gel
