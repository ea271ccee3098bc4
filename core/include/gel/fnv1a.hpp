#pragma once
// 64-bit FNV-1a (Fowler, Noll, Vo; the published offset basis and prime): a hash that is the same
// in every process, on every machine and with every standard library (std::hash is none of
// these). The project's one copy: checkpoint checksums, geld's cache keys and the bootstrap
// streams of the study analysis all use it.
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace gel {

inline constexpr std::uint64_t kFnv1aOffsetBasis = 14695981039346656037ull;
inline constexpr std::uint64_t kFnv1aPrime = 1099511628211ull;

constexpr std::uint64_t fnv1a(std::string_view bytes) {
  std::uint64_t hash = kFnv1aOffsetBasis;
  for (const char c : bytes) {
    hash ^= static_cast<unsigned char>(c);
    hash *= kFnv1aPrime;
  }
  return hash;
}

// As 16 lower-case hex digits.
inline std::string fnv1a_hex(std::string_view bytes) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(fnv1a(bytes)));
  return hex;
}

}  // namespace gel
