// A frame of a GSD file (schema "hoomd") as a configuration: HOOMD-blue's and gsd.hoomd's files,
// and gelsim's own exports and trajectories (src/export/gsd_writer.cpp).
//
// As in gsd.hoomd, a chunk missing from the frame is read from frame 0, and one missing there
// takes the schema's default. Where gelsim's writer left its exact state (log/gel/...,
// log/particles/theta, log/bonds/body_contact_i/j), that state is read, so that its own files
// come back bit for bit; otherwise the hoomd chunks are used: positions shifted from the
// centred box into [0, L), theta = 2 atan2(q_z, q_w), omega from the angular momentum, and bonds
// bonded where the particles stand (their contact points along the line of centres).
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "../export/gsd_file_layer.hpp"
#include "gel/errors.hpp"
#include "gel/import.hpp"
#include "gel/units.hpp"

namespace gel::importing {
namespace {

using namespace gel::gsd;

class GsdFile {
 public:
  explicit GsdFile(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    if (!in_) throw InvalidArgument("path", "cannot open '" + path + "'");
    Header header{};
    if (!read(&header, sizeof header, 0) || header.magic != kMagic)
      throw refuse("not a GSD file (no GSD header)");
    const std::uint32_t major = header.gsd_version >> 16;
    if (major < 1 || major > 2) throw refuse(fmt::format("GSD file layer {}.{} is not read (1.x and 2.x are)", major, header.gsd_version & 0xffff));
    schema_ = std::string(header.schema, strnlen(header.schema, sizeof header.schema));
    if (schema_ != "hoomd") throw refuse("its schema is '" + schema_ + "', not HOOMD's ('hoomd')");
    // The name list: null-terminated names one after the other (1.x pads each to 64 bytes).
    std::string names(header.namelist_allocated_entries * kNameSize, '\0');
    if (!read(names.data(), names.size(), header.namelist_location)) throw refuse("its name list is cut short");
    std::uint16_t id = 0;
    for (std::size_t at = 0; at < names.size();) {
      const std::size_t end = names.find('\0', at);
      const std::string name = names.substr(at, (end == std::string::npos ? names.size() : end) - at);
      if (!name.empty()) ids_[name] = id++;
      if (end == std::string::npos) break;
      at = end + 1;
    }
    std::vector<IndexEntry> index(header.index_allocated_entries);
    if (!read(index.data(), index.size() * sizeof(IndexEntry), header.index_location)) throw refuse("its index is cut short");
    for (const IndexEntry& entry : index) {
      if (entry.location == 0) break;
      if (type_size(entry.type) == 0) throw refuse(fmt::format("an index entry has the unknown type {}", entry.type));
      chunks_[{entry.frame, entry.id}] = entry;
      frames_ = std::max<std::uint64_t>(frames_, entry.frame + 1);
    }
  }

  std::uint64_t frames() const { return frames_; }

  // The chunk of `frame`, else frame 0's (gsd.hoomd's rule), else none.
  const IndexEntry* find(std::uint64_t frame, const std::string& name) const {
    const auto id = ids_.find(name);
    if (id == ids_.end()) return nullptr;
    for (const std::uint64_t f : {frame, std::uint64_t{0}}) {
      const auto chunk = chunks_.find({f, id->second});
      if (chunk != chunks_.end()) return &chunk->second;
    }
    return nullptr;
  }

  // The chunk's values as doubles (any numeric type), row by row; none when it is absent.
  // A chunk of another shape than rows x columns is refused.
  std::optional<std::vector<double>> numbers(std::uint64_t frame, const std::string& name, std::uint64_t rows,
                                             std::uint32_t columns) const {
    const IndexEntry* entry = find(frame, name);
    if (!entry) return std::nullopt;
    if (entry->N != rows || entry->M != columns)
      throw refuse(fmt::format("{} is {} x {} in frame {}, expected {} x {}", name, entry->N, entry->M, frame, rows, columns));
    const std::uint64_t count = rows * columns, size = type_size(entry->type);
    std::vector<unsigned char> bytes(count * size);
    if (!read(bytes.data(), bytes.size(), static_cast<std::uint64_t>(entry->location))) throw refuse(name + " is cut short");
    std::vector<double> values(count);
    for (std::uint64_t v = 0; v < count; ++v) values[v] = element(bytes.data() + v * size, entry->type);
    return values;
  }

  // A uint64 scalar read as its 64 bits (a double holds 53).
  std::optional<std::uint64_t> uint64(std::uint64_t frame, const std::string& name) const {
    const IndexEntry* entry = find(frame, name);
    if (!entry) return std::nullopt;
    if (entry->type != kUint64 || entry->N != 1 || entry->M != 1) throw refuse(name + " is not one uint64");
    std::uint64_t value = 0;
    if (!read(&value, sizeof value, static_cast<std::uint64_t>(entry->location))) throw refuse(name + " is cut short");
    return value;
  }

  // The names of a type list chunk (an int8 matrix, one 0-padded name per row).
  std::optional<std::vector<std::string>> names(std::uint64_t frame, const std::string& name) const {
    const IndexEntry* entry = find(frame, name);
    if (!entry) return std::nullopt;
    if (entry->type != kInt8 && entry->type != kUint8) throw refuse(name + " is not a list of names");
    std::string bytes(entry->N * entry->M, '\0');
    if (!read(bytes.data(), bytes.size(), static_cast<std::uint64_t>(entry->location))) throw refuse(name + " is cut short");
    std::vector<std::string> out;
    for (std::uint64_t row = 0; row < entry->N; ++row) out.emplace_back(bytes.c_str() + row * entry->M, strnlen(bytes.c_str() + row * entry->M, entry->M));
    return out;
  }

  InvalidArgument refuse(const std::string& why) const { return InvalidArgument("path", "'" + path_ + "': " + why); }

 private:
  bool read(void* data, std::uint64_t size, std::uint64_t offset) const {
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(offset));
    in_.read(static_cast<char*>(data), static_cast<std::streamsize>(size));
    return static_cast<std::uint64_t>(in_.gcount()) == size;
  }

  static double element(const unsigned char* p, std::uint8_t type) {
    const auto as = [p]<class T>(T) {
      T value;
      std::memcpy(&value, p, sizeof value);
      return static_cast<double>(value);
    };
    switch (type) {
      case kUint8: return as(std::uint8_t{});
      case kUint16: return as(std::uint16_t{});
      case kUint32: return as(std::uint32_t{});
      case kUint64: return as(std::uint64_t{});
      case kInt8: return as(std::int8_t{});
      case kInt16: return as(std::int16_t{});
      case kInt32: return as(std::int32_t{});
      case kInt64: return as(std::int64_t{});
      case kFloat: return as(float{});
      default: return as(double{});
    }
  }

  std::string path_;
  mutable std::ifstream in_;
  std::string schema_;
  std::map<std::string, std::uint16_t> ids_;
  std::map<std::pair<std::uint64_t, std::uint16_t>, IndexEntry> chunks_;
  std::uint64_t frames_ = 0;
};

// x into [0, length): a centred coordinate shifted by length/2 may land on length itself.
double wrap(double x, double length) {
  x -= length * std::floor(x / length);
  return x >= length ? 0.0 : x;
}

}  // namespace

Configuration read_gsd(const std::string& path, std::int64_t frame_choice) {
  const GsdFile file(path);
  const std::uint64_t f = resolve_frame(path, frame_choice, file.frames());
  const auto refuse = [&](const std::string& why) { return file.refuse(fmt::format("frame {}: {}", f, why)); };
  const auto scalar = [&](const std::string& name, double fallback) {
    const auto value = file.numbers(f, name, 1, 1);
    return value ? (*value)[0] : fallback;
  };

  const std::uint64_t n = static_cast<std::uint64_t>(scalar("particles/N", 0));
  if (n == 0) throw refuse("no particles (particles/N is 0)");
  // The box: L_x, L_y, L_z, xy, xz, yz; the hoomd schema's default is a unit cube.
  const std::vector<double> box = file.numbers(f, "configuration/box", 6, 1).value_or(std::vector<double>{1, 1, 1, 0, 0, 0});
  // HOOMD-blue 2 kept L_z = 1 in 2D: the dimensions, where given, say what the box is.
  const int dimensions = static_cast<int>(scalar("configuration/dimensions", box[2] == 0 ? 2 : 3));
  if (dimensions != 2)
    throw refuse(fmt::format("a {}D box (configuration/dimensions = {}, L_z = {}): gelsim simulates a 2D gel", dimensions, dimensions, box[2]));
  if (box[3] != 0 || box[4] != 0 || box[5] != 0)
    throw refuse(fmt::format("a sheared box (tilt factors xy = {}, xz = {}, yz = {}): gelsim's box is rectangular", box[3], box[4], box[5]));

  Configuration c;
  const auto exact_box = file.numbers(f, "log/gel/box", 2, 1);
  c.lx = exact_box ? (*exact_box)[0] : box[0];
  c.ly = exact_box ? (*exact_box)[1] : box[1];
  if (!(c.lx > 0) || !(c.ly > 0)) throw refuse(fmt::format("the box is {} x {}: both sides must be positive", c.lx, c.ly));

  // Every particle is a disk of radius a: diameter 2 in gelsim's unit of length.
  const std::vector<double> diameter = file.numbers(f, "particles/diameter", n, 1).value_or(std::vector<double>(n, 1.0));
  for (std::uint64_t i = 0; i < n; ++i)
    if (std::abs(diameter[i] - kDiameter) > 1e-6)
      throw refuse(fmt::format("particle {} has diameter {}{}: gelsim's particles are disks of diameter 2 (lengths in units of "
                               "the radius a); write particles/diameter = 2, with positions and box in units of a",
                               i, diameter[i], file.find(f, "particles/diameter") ? "" : " (the hoomd default: no particles/diameter)"));

  // gsd.hoomd leaves out what equals the schema's default (here 0): a frame may have no positions.
  const std::vector<double> position_or_origin = file.numbers(f, "particles/position", n, 3).value_or(std::vector<double>(3 * n, 0.0));
  const std::vector<double>* position = &position_or_origin;
  for (std::uint64_t i = 0; i < n; ++i)
    if ((*position)[3 * i + 2] != 0) throw refuse(fmt::format("particle {} lies out of the plane (z = {})", i, (*position)[3 * i + 2]));
  if (const auto exact = file.numbers(f, "log/gel/position", n, 2)) {
    for (std::uint64_t i = 0; i < n; ++i) {
      c.x.push_back((*exact)[2 * i]);
      c.y.push_back((*exact)[2 * i + 1]);
    }
  } else {
    for (std::uint64_t i = 0; i < n; ++i) {
      c.x.push_back(wrap((*position)[3 * i] + 0.5 * c.lx, c.lx));
      c.y.push_back(wrap((*position)[3 * i + 1] + 0.5 * c.ly, c.ly));
    }
  }

  // Orientation: a rotation about z only, q = (cos theta/2, 0, 0, sin theta/2).
  std::vector<double> q = file.numbers(f, "particles/orientation", n, 4).value_or(std::vector<double>{});
  if (q.empty())
    for (std::uint64_t i = 0; i < n; ++i) q.insert(q.end(), {1.0, 0.0, 0.0, 0.0});
  for (std::uint64_t i = 0; i < n; ++i) {
    const double norm = std::sqrt(q[4 * i] * q[4 * i] + q[4 * i + 1] * q[4 * i + 1] + q[4 * i + 2] * q[4 * i + 2] + q[4 * i + 3] * q[4 * i + 3]);
    if (!(norm > 0) || std::abs(q[4 * i + 1]) > 1e-6 * norm || std::abs(q[4 * i + 2]) > 1e-6 * norm)
      throw refuse(fmt::format("particle {}'s orientation ({}, {}, {}, {}) is not a rotation about z", i, q[4 * i], q[4 * i + 1],
                               q[4 * i + 2], q[4 * i + 3]));
  }
  if (const auto theta = file.numbers(f, "log/particles/theta", n, 1)) {
    c.theta = *theta;
  } else {
    for (std::uint64_t i = 0; i < n; ++i) c.theta.push_back(2 * std::atan2(q[4 * i + 3], q[4 * i]));
  }

  // Velocities: gelsim's exact ones, else particles/velocity and omega = L_z / I_z from the
  // angular momentum quaternion p = 2 q (0, L). None at all: at rest.
  if (const auto exact = file.numbers(f, "log/gel/velocity", n, 3)) {
    for (std::uint64_t i = 0; i < n; ++i) {
      c.vx.push_back((*exact)[3 * i]);
      c.vy.push_back((*exact)[3 * i + 1]);
      c.omega.push_back((*exact)[3 * i + 2]);
    }
  } else {
    const auto velocity = file.numbers(f, "particles/velocity", n, 3);
    const auto angmom = file.numbers(f, "particles/angmom", n, 4);
    const auto inertia = file.numbers(f, "particles/moment_inertia", n, 3);
    if (velocity || angmom) {
      c.vx.assign(n, 0.0);
      c.vy.assign(n, 0.0);
      c.omega.assign(n, 0.0);
    }
    for (std::uint64_t i = 0; i < n && velocity; ++i) {
      if ((*velocity)[3 * i + 2] != 0) throw refuse(fmt::format("particle {} moves out of the plane (v_z = {})", i, (*velocity)[3 * i + 2]));
      c.vx[i] = (*velocity)[3 * i];
      c.vy[i] = (*velocity)[3 * i + 1];
    }
    for (std::uint64_t i = 0; i < n && angmom && inertia; ++i) {
      const double norm = std::hypot(q[4 * i], q[4 * i + 3]);
      const double l_z = 0.5 * ((q[4 * i] * (*angmom)[4 * i + 3] - q[4 * i + 3] * (*angmom)[4 * i]) / norm);
      const double i_z = (*inertia)[3 * i + 2];
      c.omega[i] = i_z > 0 ? l_z / i_z : 0.0;
    }
  }

  // Walls: gelsim's particle types bottom_wall and top_wall, with the walls' positions.
  const std::vector<std::string> types = file.names(f, "particles/types").value_or(std::vector<std::string>{"A"});
  const std::vector<double> typeid_ = file.numbers(f, "particles/typeid", n, 1).value_or(std::vector<double>(n, 0.0));
  bool walls = false;
  std::vector<std::int8_t> side(n, kNoWall);
  for (std::uint64_t i = 0; i < n; ++i) {
    const auto t = static_cast<std::size_t>(typeid_[i]);
    if (t >= types.size()) throw refuse(fmt::format("particle {} has type id {}, but particles/types names {} types", i, t, types.size()));
    if (types[t] == "bottom_wall" || types[t] == "top_wall") {
      side[i] = types[t] == "bottom_wall" ? kBottomWall : kTopWall;
      walls = true;
    }
  }
  if (walls) {
    c.wall = side;
    if (const auto exact = file.numbers(f, "log/gel/walls", 2, 1)) {
      c.wall_bottom = (*exact)[0];
      c.wall_top = (*exact)[1];
    } else {
      const auto bottom = file.numbers(f, "log/walls/bottom", 1, 1), top = file.numbers(f, "log/walls/top", 1, 1);
      if (!bottom || !top)
        throw refuse("particles of type bottom_wall or top_wall, but no wall positions (log/walls/bottom and log/walls/top, "
                     "in the centred box)");
      c.wall_bottom = (*bottom)[0] + 0.5 * c.ly;
      c.wall_top = (*top)[0] + 0.5 * c.ly;
    }
  }
  c.periodic_y = scalar("log/gel/periodic_y", walls ? 0 : 1) != 0;
  c.seed = file.uint64(f, "log/gel/seed").value_or(0);

  // Bonds, with gelsim's body-frame contact points where it wrote them.
  const std::uint64_t nb = static_cast<std::uint64_t>(scalar("bonds/N", 0));
  if (nb > 0) {
    const auto group = file.numbers(f, "bonds/group", nb, 2);
    if (!group) throw refuse(fmt::format("bonds/N is {} but there is no bonds/group", nb));
    const auto body_i = file.numbers(f, "log/bonds/body_contact_i", nb, 2);
    const auto body_j = file.numbers(f, "log/bonds/body_contact_j", nb, 2);
    for (std::uint64_t b = 0; b < nb; ++b) {
      const double i = (*group)[2 * b], j = (*group)[2 * b + 1];
      if (i >= static_cast<double>(n) || j >= static_cast<double>(n) || i == j)
        throw refuse(fmt::format("bond {} joins particles {} and {} (there are {})", b, i, j, n));
      if (body_i && body_j) {
        c.bonds.push_back(BondRecord{static_cast<std::int32_t>(i), static_cast<std::int32_t>(j), (*body_i)[2 * b],
                                     (*body_i)[2 * b + 1], (*body_j)[2 * b], (*body_j)[2 * b + 1]});
      } else {
        c.add_bond_at_contact(static_cast<std::int32_t>(i), static_cast<std::int32_t>(j));
      }
    }
  }
  // The checks every configuration passes (finite numbers, walls in order, unit contact points).
  try {
    return from_proto(to_proto(c));
  } catch (const InvalidArgument& e) {
    throw refuse(e.what());
  }
}

}  // namespace gel::importing
