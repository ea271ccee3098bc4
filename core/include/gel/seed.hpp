#pragma once
// The one seed rule of gelsim and geld: a seed is a whole number from 1 to 2^63-1. 0 means "the
// default" in a scene (it resolves to 1), so as a seed given explicitly it would run as 1 while
// being recorded as 0; above 2^63-1 a seed does not fit the store's integers (and a wrapped
// negative number, -1 as 18446744073709551615, is not what its user meant).
#include <cstdint>
#include <limits>
#include <string>

#include "gel/errors.hpp"

namespace gel {

inline constexpr std::uint64_t kMaxSeed = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());

// "" when `text` (decimal digits, as on a command line or in JSON) is a seed; otherwise why not,
// in the words every front end uses: "-1 is not a seed; seeds are whole numbers from 1 to
// 9223372036854775807 (2^63-1)". A sign, a fraction or an exponent is refused, never wrapped.
inline std::string seed_problem(const std::string& text) {
  const std::string rule = " is not a seed; seeds are whole numbers from 1 to 9223372036854775807 (2^63-1)";
  const bool digits = !text.empty() && text.size() <= 19 && text.find_first_not_of("0123456789") == std::string::npos;
  if (!digits || text.find_first_not_of('0') == std::string::npos) return (text.empty() ? "''" : text.substr(0, 40)) + rule;
  const std::uint64_t value = std::stoull(text);  // at most 19 digits: fits
  return value <= kMaxSeed ? "" : text + rule;
}
inline std::string seed_problem(std::uint64_t seed) { return seed_problem(std::to_string(seed)); }

// Throws InvalidArgument(field, seed_problem(...)) unless `seed` is a seed.
inline void require_seed(const std::string& field, std::uint64_t seed) {
  if (std::string problem = seed_problem(seed); !problem.empty()) throw InvalidArgument(field, problem);
}
inline std::uint64_t parse_seed(const std::string& field, const std::string& text) {
  if (std::string problem = seed_problem(text); !problem.empty()) throw InvalidArgument(field, problem);
  return std::stoull(text);
}

}  // namespace gel
