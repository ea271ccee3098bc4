// The project's one FNV-1a against the published 64-bit test vectors (Fowler, Noll and Vo's
// reference test suite): checkpoint checksums, geld's cache keys and the study analysis's
// bootstrap streams all depend on it being the published hash, and a copy of it in geld once
// carried a wrong offset basis.
#include <gtest/gtest.h>

#include "gel/fnv1a.hpp"

namespace gel {
namespace {

TEST(Fnv1a, MatchesThePublishedTestVectors) {
  EXPECT_EQ(fnv1a(""), 0xcbf29ce484222325ull);  // the offset basis itself
  EXPECT_EQ(fnv1a("a"), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(fnv1a("foobar"), 0x85944171f73967e8ull);
  EXPECT_EQ(fnv1a_hex("a"), "af63dc4c8601ec8c");
  EXPECT_EQ(fnv1a_hex(""), "cbf29ce484222325");
  static_assert(fnv1a("") == 14695981039346656037ull);
}

TEST(Fnv1a, HashesBytesNotCharacters) {
  // Bytes above 0x7f are taken unsigned: the same hash wherever char is signed.
  const std::string high("\xff\x80", 2);
  std::uint64_t expected = 14695981039346656037ull;
  for (const unsigned byte : {0xffu, 0x80u}) expected = (expected ^ byte) * 1099511628211ull;
  EXPECT_EQ(fnv1a(high), expected);
  // An embedded NUL is part of the input.
  EXPECT_NE(fnv1a(std::string("a\0b", 3)), fnv1a("a"));
}

}  // namespace
}  // namespace gel
