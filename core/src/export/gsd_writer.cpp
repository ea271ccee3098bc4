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
// The hoomd schema keeps positions in a box centred on the origin: x - L_x/2, y - L_y/2, and
// its particle data in float. The exact state (log/gel/..., log/particles/theta, the bonds'
// body-frame contact points), the contact forces and torques, the per-bond state and the
// compression state go to log/ chunks, which gsd.hoomd returns in frame.log (docs/gelsim.md "Data out").
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "file_output.hpp"
#include "gsd_file_layer.hpp"
#include "gel/export.hpp"
#include "gel/units.hpp"

namespace gel::exporting {
namespace {

using namespace gel::gsd;

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
  kVelocity,
  kAngmom,
  kMomentInertia,
  kParticleDiameter,
  kBondsN,
  kBondTypes,
  kBondTypeid,
  kBondGroup,
  kLogTheta,
  kLogForces,
  kLogTorques,
  kLogPhi,
  kLogK,
  kLogP,
  kLogWallBottom,
  kLogWallTop,
  kLogGelBox,
  kLogGelWalls,
  kLogGelPeriodicY,
  kLogGelSeed,
  kLogGelPosition,
  kLogGelVelocity,
  kLogBodyContactI,
  kLogBodyContactJ,
  kLogBondGap,
  kLogContactI,
  kLogContactJ,
  kLogSliding,
  kLogBending,
  kLogNormalForce,
  kLogSlidingForce,
  kLogRollingMoment,
  kNameCount
};
constexpr std::array<const char*, kNameCount> kNames = {
    "configuration/step", "configuration/dimensions", "configuration/box", "particles/N", "particles/types",
    "particles/typeid", "particles/position", "particles/orientation", "particles/velocity", "particles/angmom",
    "particles/moment_inertia", "particles/diameter", "bonds/N", "bonds/types", "bonds/typeid", "bonds/group",
    "log/particles/theta", "log/particles/forces", "log/particles/torques", "log/compression/phi",
    "log/compression/k", "log/compression/P", "log/walls/bottom", "log/walls/top", "log/gel/box", "log/gel/walls",
    "log/gel/periodic_y", "log/gel/seed", "log/gel/position", "log/gel/velocity", "log/bonds/body_contact_i",
    "log/bonds/body_contact_j", "log/bonds/gap", "log/bonds/contact_i", "log/bonds/contact_j",
    "log/bonds/sliding_displacement", "log/bonds/bending_angle", "log/bonds/normal_force", "log/bonds/sliding_force",
    "log/bonds/rolling_moment"};

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
    std::vector<float> position(3 * n), orientation(4 * n), velocity(3 * n, 0.f), angmom(4 * n, 0.f),
        moment_inertia(3 * n, 0.f), diameter(n, float(kDiameter));
    std::vector<double> exact_position(2 * n), exact_velocity(3 * n, 0.0);
    for (std::uint64_t i = 0; i < n; ++i) {
      typeid_[i] = c.has_walls() ? static_cast<std::uint32_t>(c.wall[i]) : 0;
      position[3 * i] = float(c.x[i] - 0.5 * c.lx);
      position[3 * i + 1] = float(c.y[i] - 0.5 * c.ly);
      position[3 * i + 2] = 0;
      // A rotation by theta about z: q = (cos theta/2, 0, 0, sin theta/2), scalar first.
      const double q_w = std::cos(0.5 * c.theta[i]), q_z = std::sin(0.5 * c.theta[i]);
      orientation[4 * i] = float(q_w);
      orientation[4 * i + 3] = float(q_z);
      moment_inertia[3 * i + 2] = float(kInertia);
      exact_position[2 * i] = c.x[i];
      exact_position[2 * i + 1] = c.y[i];
      if (!c.has_velocities()) continue;
      velocity[3 * i] = float(c.vx[i]);
      velocity[3 * i + 1] = float(c.vy[i]);
      // HOOMD's angular momentum quaternion p = 2 q (0, L) with the body-frame L = (0, 0, I omega).
      const double l_z = kInertia * c.omega[i];
      angmom[4 * i] = float(-2 * q_z * l_z);
      angmom[4 * i + 3] = float(2 * q_w * l_z);
      exact_velocity[3 * i] = c.vx[i];
      exact_velocity[3 * i + 1] = c.vy[i];
      exact_velocity[3 * i + 2] = c.omega[i];
    }
    chunk(kParticleTypeid, kUint32, n, 1, typeid_.data(), n * sizeof(std::uint32_t));
    chunk(kPosition, kFloat, n, 3, position.data(), position.size() * sizeof(float));
    chunk(kOrientation, kFloat, n, 4, orientation.data(), orientation.size() * sizeof(float));
    chunk(kVelocity, kFloat, n, 3, velocity.data(), velocity.size() * sizeof(float));
    chunk(kAngmom, kFloat, n, 4, angmom.data(), angmom.size() * sizeof(float));
    chunk(kMomentInertia, kFloat, n, 3, moment_inertia.data(), moment_inertia.size() * sizeof(float));
    chunk(kParticleDiameter, kFloat, n, 1, diameter.data(), diameter.size() * sizeof(float));
    const std::uint32_t bond_count = static_cast<std::uint32_t>(bonds);
    chunk(kBondsN, kUint32, 1, 1, &bond_count, sizeof bond_count);
    const auto bond_types = type_matrix({"bond"}, width);
    chunk(kBondTypes, kInt8, 1, width, bond_types.data(), bond_types.size());
    std::vector<std::uint32_t> bond_typeid(bonds, 0), group(2 * bonds);
    std::vector<double> body_i(2 * bonds), body_j(2 * bonds);
    for (std::uint64_t b = 0; b < bonds; ++b) {
      group[2 * b] = static_cast<std::uint32_t>(c.bonds[b].i);
      group[2 * b + 1] = static_cast<std::uint32_t>(c.bonds[b].j);
      body_i[2 * b] = c.bonds[b].bix;
      body_i[2 * b + 1] = c.bonds[b].biy;
      body_j[2 * b] = c.bonds[b].bjx;
      body_j[2 * b + 1] = c.bonds[b].bjy;
    }
    // Written even when empty: a chunk missing from a frame would be read from frame 0.
    chunk(kBondTypeid, kUint32, bonds, 1, bond_typeid.data(), bonds * sizeof(std::uint32_t));
    chunk(kBondGroup, kUint32, bonds, 2, group.data(), group.size() * sizeof(std::uint32_t));
    chunk(kLogTheta, kDouble, n, 1, c.theta.data(), n * sizeof(double));
    // Contact forces and torques as HOOMD logs them (N x 3), NaN when the bond law is unknown.
    const BondState state = bond_state(c, frame.bond_law ? &*frame.bond_law : nullptr, frame.effects);
    const ParticleLoads loads = particle_loads(c, state);
    const double unknown = std::numeric_limits<double>::quiet_NaN();
    std::vector<double> forces(3 * n, state.with_forces ? 0.0 : unknown), torques(3 * n, state.with_forces ? 0.0 : unknown);
    for (std::uint64_t i = 0; i < n && state.with_forces; ++i) {
      forces[3 * i] = loads.fx[i];
      forces[3 * i + 1] = loads.fy[i];
      torques[3 * i + 2] = loads.torque[i];
    }
    chunk(kLogForces, kDouble, n, 3, forces.data(), forces.size() * sizeof(double));
    chunk(kLogTorques, kDouble, n, 3, torques.data(), torques.size() * sizeof(double));
    const double phi = frame_phi(frame);
    chunk(kLogPhi, kDouble, 1, 1, &phi, sizeof phi);
    // Always written (k = -1, NaN when unknown) for the same reason.
    const std::int32_t k = frame.k;
    chunk(kLogK, kInt32, 1, 1, &k, sizeof k);
    chunk(kLogP, kDouble, 1, 1, &frame.p, sizeof frame.p);
    const double bottom = c.has_walls() ? c.wall_bottom - 0.5 * c.ly : unknown;
    const double top = c.has_walls() ? c.wall_top - 0.5 * c.ly : unknown;
    chunk(kLogWallBottom, kDouble, 1, 1, &bottom, sizeof bottom);
    chunk(kLogWallTop, kDouble, 1, 1, &top, sizeof top);
    // The exact state in the configuration's own frame (origin at the box corner, doubles), which
    // gelsim reads back bit for bit: a run can start from any frame (src/import/gsd_reader.cpp).
    const std::array<double, 2> box_exact = {c.lx, c.ly};
    chunk(kLogGelBox, kDouble, 2, 1, box_exact.data(), sizeof box_exact);
    const std::array<double, 2> walls_exact = {c.has_walls() ? c.wall_bottom : unknown, c.has_walls() ? c.wall_top : unknown};
    chunk(kLogGelWalls, kDouble, 2, 1, walls_exact.data(), sizeof walls_exact);
    const std::uint8_t periodic_y = c.periodic_y ? 1 : 0;
    chunk(kLogGelPeriodicY, kUint8, 1, 1, &periodic_y, 1);
    chunk(kLogGelSeed, kUint64, 1, 1, &c.seed, sizeof c.seed);
    chunk(kLogGelPosition, kDouble, n, 2, exact_position.data(), exact_position.size() * sizeof(double));
    chunk(kLogGelVelocity, kDouble, n, 3, exact_velocity.data(), exact_velocity.size() * sizeof(double));
    chunk(kLogBodyContactI, kDouble, bonds, 2, body_i.data(), body_i.size() * sizeof(double));
    chunk(kLogBodyContactJ, kDouble, bonds, 2, body_j.data(), body_j.size() * sizeof(double));
    // Per-bond state (gel/export.hpp BondState); forces NaN when the bond law is unknown.
    const auto pairs = [&](const std::vector<double>& first, const std::vector<double>& second) {
      std::vector<double> out(2 * bonds, unknown);
      for (std::uint64_t b = 0; b < bonds && !first.empty(); ++b) {
        out[2 * b] = first[b];
        out[2 * b + 1] = second[b];
      }
      return out;
    };
    const auto known = [&](const std::vector<double>& column) { return column.empty() ? std::vector<double>(bonds, unknown) : column; };
    const auto per_bond = [&](Name name, const std::vector<double>& column, std::uint32_t columns) {
      chunk(name, kDouble, bonds, columns, column.data(), column.size() * sizeof(double));
    };
    per_bond(kLogBondGap, state.gap, 1);
    per_bond(kLogContactI, pairs(state.contact_ix, state.contact_iy), 2);
    per_bond(kLogContactJ, pairs(state.contact_jx, state.contact_jy), 2);
    per_bond(kLogSliding, pairs(state.sliding_x, state.sliding_y), 2);
    per_bond(kLogBending, state.bending, 1);
    per_bond(kLogNormalForce, known(state.normal_force), 1);
    per_bond(kLogSlidingForce, pairs(state.sliding_force_x, state.sliding_force_y), 2);
    per_bond(kLogRollingMoment, known(state.rolling_moment), 1);
    for (std::size_t e = 1; e < entries.size(); ++e)
      if (entries[e].id <= entries[e - 1].id) throw std::logic_error("GSD chunks out of name order");
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
      throw corrupt("written by another program or another version of gelsim (its chunk names differ)");
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
