#pragma once
// The GSD file layer (version 2.0) as the published specification lays it out: a 256-byte
// header, a name list, an index of 32-byte entries sorted by frame, and raw data chunks. Shared
// by the writer (src/export/gsd_writer.cpp) and the reader (src/import/gsd_reader.cpp).
#include <cstdint>

namespace gel::gsd {

constexpr std::uint64_t kMagic = 0x65DF65DF65DF65DFULL;
constexpr std::uint32_t version(std::uint32_t major, std::uint32_t minor) { return major << 16 | minor; }
constexpr std::uint64_t kNameSize = 64;  // the name list is allocated in 64-byte segments

struct Header {
  std::uint64_t magic;
  std::uint64_t index_location;
  std::uint64_t index_allocated_entries;
  std::uint64_t namelist_location;
  std::uint64_t namelist_allocated_entries;
  std::uint32_t schema_version;
  std::uint32_t gsd_version;
  char application[64];
  char schema[64];
  char reserved[80];
};
static_assert(sizeof(Header) == 256);

struct IndexEntry {
  std::uint64_t frame;
  std::uint64_t N;
  std::int64_t location;  // 0: an unused entry, the end of the index
  std::uint32_t M;
  std::uint16_t id;       // position of the chunk's name in the name list
  std::uint8_t type;
  std::uint8_t flags;
};
static_assert(sizeof(IndexEntry) == 32);

enum Type : std::uint8_t { kUint8 = 1, kUint16, kUint32, kUint64, kInt8, kInt16, kInt32, kInt64, kFloat, kDouble };

inline std::uint64_t type_size(std::uint8_t type) {
  switch (type) {
    case kUint8: case kInt8: return 1;
    case kUint16: case kInt16: return 2;
    case kUint32: case kInt32: case kFloat: return 4;
    case kUint64: case kInt64: case kDouble: return 8;
    default: return 0;
  }
}

}  // namespace gel::gsd
