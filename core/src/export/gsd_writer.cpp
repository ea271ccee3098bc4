// GSD (HOOMD-blue's "general simulation data", file layer 2.0, schema "hoomd" 1.4), written
// from the published specification: a 256-byte header, a name list, an index of 32-byte
// entries sorted by (frame, name id), and raw data chunks. Readers: gsd.hoomd (python3-gsd),
// OVITO, freud, HOOMD-blue itself.
//
// Layout choices: every name this writer uses is in the name list from the start, so the list
// never moves. The index has room for many frames and is moved to the end of the file, twice
// as large, when full. Each frame is appended as data chunks first and index entries second,
// so a run killed mid-frame leaves the frames before it readable.
//
// The hoomd schema keeps positions in a box centred on the origin: x - L_x/2, y - L_y/2. The
// exact angle theta (the orientation quaternion is float) and the compression state go to
// log/ chunks, which gsd.hoomd returns in frame.log.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>

#include "file_output.hpp"
#include "gel/export.hpp"
#include "gel/units.hpp"

namespace gel::exporting {
namespace {

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
  std::int64_t location;
  std::uint32_t M;
  std::uint16_t id;
  std::uint8_t type;
  std::uint8_t flags;
};
static_assert(sizeof(IndexEntry) == 32);

enum Type : std::uint8_t { kUint8 = 1, kUint16, kUint32, kUint64, kInt8, kInt16, kInt32, kInt64, kFloat, kDouble };

// Chunk names; a frame's entries are written in this order, which is the order of their ids.
enum Name : std::uint16_t {
  kStep,
  kDimensions,
  kBox,
  kParticlesN,
  kParticleTypes,
  kParticleTypeid,
  kPosition,
  kOrientation,
  kParticleDiameter,
  kBondsN,
  kBondTypes,
  kBondTypeid,
  kBondGroup,
  kLogTheta,
  kLogPhi,
  kLogK,
  kLogP,
  kLogWallBottom,
  kLogWallTop,
  kNameCount
};
constexpr std::array<const char*, kNameCount> kNames = {
    "configuration/step", "configuration/dimensions", "configuration/box", "particles/N", "particles/types",
    "particles/typeid", "particles/position", "particles/orientation", "particles/diameter", "bonds/N",
    "bonds/types", "bonds/typeid", "bonds/group", "log/particles/theta", "log/compression/phi",
    "log/compression/k", "log/compression/P", "log/walls/bottom", "log/walls/top"};

// Particle types are the wall membership: typeid 0 free, 1 bottom wall, 2 top wall.
constexpr std::array<const char*, 3> kParticleTypeNames = {"free", "bottom_wall", "top_wall"};

std::string namelist_block() {
  std::string names;
  for (const char* name : kNames) names.append(name).push_back('\0');
  const std::uint64_t segments = names.size() / kNameSize + 1;  // at least one 0 byte at the end
  names.resize(segments * kNameSize, '\0');
  return names;
}

// Type names as the hoomd schema stores them: an int8 matrix, one 0-padded name per row.
std::vector<std::int8_t> type_matrix(const std::vector<const char*>& names, std::uint32_t& width) {
  width = 0;
  for (const char* name : names) width = std::max<std::uint32_t>(width, static_cast<std::uint32_t>(std::strlen(name)) + 1);
  std::vector<std::int8_t> matrix(names.size() * width, 0);
  for (std::size_t row = 0; row < names.size(); ++row)
    std::memcpy(matrix.data() + row * width, names[row], std::strlen(names[row]));
  return matrix;
}

class GsdWriter final : public FrameWriter {
 public:
  GsdWriter(const std::string& path, bool reopen, std::int64_t last_step, std::int64_t* last_kept_step)
      : file_(path, !reopen) {
    std::int64_t kept = -1;
    if (reopen && file_.size() > 0) {
      kept = load(last_step);
    } else {
      create();
    }
    if (last_kept_step) *last_kept_step = kept;
  }

  void append(const Frame& frame) override {
    const Configuration& c = frame.configuration;
    const std::uint64_t n = c.size(), bonds = c.bonds.size();
    std::vector<IndexEntry> entries;
    const auto chunk = [&](Name name, Type type, std::uint64_t rows, std::uint32_t columns, const void* data, std::size_t bytes) {
      IndexEntry entry{};
      entry.frame = frames_;
      entry.N = rows;
      entry.M = columns;
      entry.id = name;
      entry.type = type;
      entry.location = static_cast<std::int64_t>(file_.append(data, bytes));
      entries.push_back(entry);
    };
    const std::uint64_t step = static_cast<std::uint64_t>(frame.step);
    chunk(kStep, kUint64, 1, 1, &step, sizeof step);
    const std::uint8_t dimensions = 2;
    chunk(kDimensions, kUint8, 1, 1, &dimensions, 1);
    const std::array<float, 6> box = {float(c.lx), float(c.ly), 0.f, 0.f, 0.f, 0.f};
    chunk(kBox, kFloat, 6, 1, box.data(), sizeof box);
    const std::uint32_t particle_count = static_cast<std::uint32_t>(n);
    chunk(kParticlesN, kUint32, 1, 1, &particle_count, sizeof particle_count);
    std::uint32_t width = 0;
    const auto particle_types = type_matrix({kParticleTypeNames.begin(), kParticleTypeNames.end()}, width);
    chunk(kParticleTypes, kInt8, kParticleTypeNames.size(), width, particle_types.data(), particle_types.size());
    std::vector<std::uint32_t> typeid_(n);
    std::vector<float> position(3 * n), orientation(4 * n), diameter(n, float(kDiameter));
    for (std::uint64_t i = 0; i < n; ++i) {
      typeid_[i] = c.has_walls() ? static_cast<std::uint32_t>(c.wall[i]) : 0;
      position[3 * i] = float(c.x[i] - 0.5 * c.lx);
      position[3 * i + 1] = float(c.y[i] - 0.5 * c.ly);
      position[3 * i + 2] = 0;
      // A rotation by theta about z: q = (cos theta/2, 0, 0, sin theta/2), scalar first.
      orientation[4 * i] = float(std::cos(0.5 * c.theta[i]));
      orientation[4 * i + 3] = float(std::sin(0.5 * c.theta[i]));
    }
    chunk(kParticleTypeid, kUint32, n, 1, typeid_.data(), n * sizeof(std::uint32_t));
    chunk(kPosition, kFloat, n, 3, position.data(), position.size() * sizeof(float));
    chunk(kOrientation, kFloat, n, 4, orientation.data(), orientation.size() * sizeof(float));
    chunk(kParticleDiameter, kFloat, n, 1, diameter.data(), diameter.size() * sizeof(float));
    const std::uint32_t bond_count = static_cast<std::uint32_t>(bonds);
    chunk(kBondsN, kUint32, 1, 1, &bond_count, sizeof bond_count);
    const auto bond_types = type_matrix({"bond"}, width);
    chunk(kBondTypes, kInt8, 1, width, bond_types.data(), bond_types.size());
    std::vector<std::uint32_t> bond_typeid(bonds, 0), group(2 * bonds);
    for (std::uint64_t b = 0; b < bonds; ++b) {
      group[2 * b] = static_cast<std::uint32_t>(c.bonds[b].i);
      group[2 * b + 1] = static_cast<std::uint32_t>(c.bonds[b].j);
    }
    // Written even when empty: a chunk missing from a frame would be read from frame 0.
    chunk(kBondTypeid, kUint32, bonds, 1, bond_typeid.data(), bonds * sizeof(std::uint32_t));
    chunk(kBondGroup, kUint32, bonds, 2, group.data(), group.size() * sizeof(std::uint32_t));
    chunk(kLogTheta, kDouble, n, 1, c.theta.data(), n * sizeof(double));
    const double phi = frame_phi(frame);
    chunk(kLogPhi, kDouble, 1, 1, &phi, sizeof phi);
    // Always written (k = -1, NaN when unknown) for the same reason.
    const std::int32_t k = frame.k;
    chunk(kLogK, kInt32, 1, 1, &k, sizeof k);
    chunk(kLogP, kDouble, 1, 1, &frame.p, sizeof frame.p);
    const double no_wall = std::numeric_limits<double>::quiet_NaN();
    const double bottom = c.has_walls() ? c.wall_bottom - 0.5 * c.ly : no_wall;
    const double top = c.has_walls() ? c.wall_top - 0.5 * c.ly : no_wall;
    chunk(kLogWallBottom, kDouble, 1, 1, &bottom, sizeof bottom);
    chunk(kLogWallTop, kDouble, 1, 1, &top, sizeof top);
    // A frame number must stay below the index size, and the frame's entries must fit.
    while (used_ + entries.size() + 1 > header_.index_allocated_entries || frames_ + 1 >= header_.index_allocated_entries)
      grow_index();
    file_.write(entries.data(), entries.size() * sizeof(IndexEntry), header_.index_location + used_ * sizeof(IndexEntry));
    used_ += entries.size();
    ++frames_;
  }

  std::vector<std::string> files() const override { return {file_.path()}; }

 private:
  void create() {
    header_ = Header{};
    header_.magic = kMagic;
    header_.gsd_version = version(2, 0);
    header_.schema_version = version(1, 4);
    std::strncpy(header_.application, ("gelsim " + program_version()).c_str(), sizeof header_.application - 1);
    std::strncpy(header_.schema, "hoomd", sizeof header_.schema - 1);
    const std::string names = namelist_block();
    header_.namelist_location = sizeof(Header);
    header_.namelist_allocated_entries = names.size() / kNameSize;
    header_.index_location = header_.namelist_location + names.size();
    header_.index_allocated_entries = 1024;
    file_.write(&header_, sizeof header_, 0);
    file_.write(names.data(), names.size(), header_.namelist_location);
    const std::vector<IndexEntry> empty(header_.index_allocated_entries, IndexEntry{});
    file_.write(empty.data(), empty.size() * sizeof(IndexEntry), header_.index_location);
  }

  // Reads a file this writer made and keeps the frames up to last_step; returns the step of
  // the last frame kept (-1: none).
  std::int64_t load(std::int64_t last_step) {
    const auto corrupt = [&](const std::string& why) {
      return std::runtime_error("cannot continue the trajectory '" + file_.path() + "': " + why);
    };
    if (!file_.read(&header_, sizeof header_, 0) || header_.magic != kMagic) throw corrupt("not a GSD file");
    if (header_.gsd_version != version(2, 0) || std::string(header_.schema) != "hoomd") throw corrupt("not a GSD 2.0 hoomd file");
    const std::string names = namelist_block();
    std::string stored(names.size(), '\0');
    if (header_.namelist_allocated_entries * kNameSize != names.size() || !file_.read(stored.data(), stored.size(), header_.namelist_location) ||
        stored != names)
      throw corrupt("written by another program (its chunk names differ)");
    std::vector<IndexEntry> index(header_.index_allocated_entries);
    if (!file_.read(index.data(), index.size() * sizeof(IndexEntry), header_.index_location)) throw corrupt("its index is cut short");
    used_ = 0;
    while (used_ < index.size() && index[used_].location != 0) ++used_;
    // Drop every frame from the first one whose step is past last_step.
    std::size_t keep = used_;
    std::int64_t last_kept_step = -1;
    for (std::size_t e = 0; e < used_; ++e) {
      if (index[e].id != kStep) continue;
      std::uint64_t step = 0;
      if (!file_.read(&step, sizeof step, static_cast<std::uint64_t>(index[e].location))) throw corrupt("a step chunk is cut short");
      if (static_cast<std::int64_t>(step) > last_step) {
        keep = e;
        break;
      }
      last_kept_step = static_cast<std::int64_t>(step);
    }
    frames_ = keep == 0 ? 0 : index[keep - 1].frame + 1;
    if (keep < used_) {
      std::uint64_t first_dropped = file_.size();
      for (std::size_t e = keep; e < used_; ++e) first_dropped = std::min<std::uint64_t>(first_dropped, index[e].location);
      const std::vector<IndexEntry> empty(used_ - keep, IndexEntry{});
      file_.write(empty.data(), empty.size() * sizeof(IndexEntry), header_.index_location + keep * sizeof(IndexEntry));
      // The dropped frames' data go too, unless the index was moved behind them; then they stay
      // as unused bytes, which no reader looks at.
      const std::uint64_t index_end = header_.index_location + header_.index_allocated_entries * sizeof(IndexEntry);
      if (index_end <= first_dropped) file_.truncate(first_dropped);
    }
    used_ = keep;
    return last_kept_step;
  }

  void grow_index() {
    std::vector<IndexEntry> index(2 * header_.index_allocated_entries, IndexEntry{});
    if (!file_.read(index.data(), used_ * sizeof(IndexEntry), header_.index_location))
      throw std::runtime_error("cannot read back the index of '" + file_.path() + "'");
    const std::uint64_t location = file_.append(index.data(), index.size() * sizeof(IndexEntry));
    header_.index_location = location;
    header_.index_allocated_entries = index.size();
    file_.write(&header_, sizeof header_, 0);
  }

  OutputFile file_;
  Header header_{};
  std::uint64_t used_ = 0;    // index entries in use
  std::uint64_t frames_ = 0;  // frames written
};

}  // namespace

std::unique_ptr<FrameWriter> make_gsd_writer(const std::string& path, bool reopen, std::int64_t last_step,
                                             std::int64_t* last_kept_step) {
  return std::make_unique<GsdWriter>(path, reopen, last_step, last_kept_step);
}

}  // namespace gel::exporting
