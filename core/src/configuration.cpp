#include "gel/configuration.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <google/protobuf/util/json_util.h>

#include "gel/errors.hpp"
#include "gel/import.hpp"
#include "proto_json.hpp"
#include "gel/units.hpp"

namespace gel {

double Configuration::packing_fraction() const {
  return kPi * kRadius * kRadius * static_cast<double>(size()) / (lx * height());
}

double Configuration::mean_contact_number() const {
  return size() == 0 ? 0.0 : 2.0 * static_cast<double>(bonds.size()) / static_cast<double>(size());
}

std::int32_t Configuration::add_particle(double px, double py, double ptheta) {
  x.push_back(px);
  y.push_back(py);
  theta.push_back(ptheta);
  if (!wall.empty()) wall.push_back(kNoWall);
  if (has_velocities()) {
    vx.push_back(0.0);
    vy.push_back(0.0);
    omega.push_back(0.0);
  }
  return static_cast<std::int32_t>(x.size() - 1);
}

void Configuration::separation(std::int32_t i, std::int32_t j, double& dx, double& dy) const {
  dx = x[j] - x[i];
  dy = y[j] - y[i];
  if (lx > 0) dx -= lx * std::round(dx / lx);
  if (periodic_y && ly > 0) dy -= ly * std::round(dy / ly);
}

void Configuration::add_bond_at_contact(std::int32_t i, std::int32_t j) {
  double dx, dy;
  separation(i, j, dx, dy);
  const double r = std::sqrt(dx * dx + dy * dy);
  const double nx = dx / r, ny = dy / r;
  BondRecord bond;
  bond.i = i;
  bond.j = j;
  // Rotate the lab-frame directions n and -n into each body frame: R(-theta).
  const double ci = std::cos(theta[i]), si = std::sin(theta[i]);
  const double cj = std::cos(theta[j]), sj = std::sin(theta[j]);
  bond.bix = ci * nx + si * ny;
  bond.biy = -si * nx + ci * ny;
  bond.bjx = -(cj * nx + sj * ny);
  bond.bjy = -(-sj * nx + cj * ny);
  bonds.push_back(bond);
}

gel::v1::Configuration to_proto(const Configuration& config) {
  gel::v1::Configuration message;
  message.set_format_version(1);
  message.set_lx(config.lx);
  message.set_ly(config.ly);
  message.set_periodic_y(config.periodic_y);
  message.mutable_x()->Assign(config.x.begin(), config.x.end());
  message.mutable_y()->Assign(config.y.begin(), config.y.end());
  message.mutable_theta()->Assign(config.theta.begin(), config.theta.end());
  message.mutable_vx()->Assign(config.vx.begin(), config.vx.end());
  message.mutable_vy()->Assign(config.vy.begin(), config.vy.end());
  message.mutable_omega()->Assign(config.omega.begin(), config.omega.end());
  for (const BondRecord& bond : config.bonds) {
    message.add_bond_i(bond.i);
    message.add_bond_j(bond.j);
    message.add_bond_bix(bond.bix);
    message.add_bond_biy(bond.biy);
    message.add_bond_bjx(bond.bjx);
    message.add_bond_bjy(bond.bjy);
  }
  for (std::int8_t side : config.wall) message.add_wall(side);
  message.set_wall_bottom(config.wall_bottom);
  message.set_wall_top(config.wall_top);
  message.set_seed(config.seed);
  *message.mutable_generator() = config.generator;
  message.set_program_version(program_version());
  return message;
}

Configuration from_proto(const gel::v1::Configuration& message) {
  Configuration config;
  config.lx = message.lx();
  config.ly = message.ly();
  require_positive("configuration.lx", config.lx);
  require_positive("configuration.ly", config.ly);
  config.periodic_y = message.periodic_y();
  const int n = message.x_size();
  if (message.y_size() != n || message.theta_size() != n)
    throw InvalidArgument("configuration.x", "x, y and theta must have the same length");
  if (n == 0) throw InvalidArgument("configuration.x", "a configuration needs at least one particle");
  config.x.assign(message.x().begin(), message.x().end());
  config.y.assign(message.y().begin(), message.y().end());
  config.theta.assign(message.theta().begin(), message.theta().end());
  for (int i = 0; i < n; ++i) {
    require_finite("configuration.x[" + std::to_string(i) + "]", config.x[i]);
    require_finite("configuration.y[" + std::to_string(i) + "]", config.y[i]);
    require_finite("configuration.theta[" + std::to_string(i) + "]", config.theta[i]);
  }
  if (message.vx_size() != 0 || message.vy_size() != 0 || message.omega_size() != 0) {
    if (message.vx_size() != n || message.vy_size() != n || message.omega_size() != n)
      throw InvalidArgument("configuration.vx", "vx, vy and omega need one entry per particle (or none: at rest)");
    config.vx.assign(message.vx().begin(), message.vx().end());
    config.vy.assign(message.vy().begin(), message.vy().end());
    config.omega.assign(message.omega().begin(), message.omega().end());
    for (int i = 0; i < n; ++i) {
      require_finite("configuration.vx[" + std::to_string(i) + "]", config.vx[i]);
      require_finite("configuration.vy[" + std::to_string(i) + "]", config.vy[i]);
      require_finite("configuration.omega[" + std::to_string(i) + "]", config.omega[i]);
    }
  }
  const int nb = message.bond_i_size();
  if (message.bond_j_size() != nb || message.bond_bix_size() != nb || message.bond_biy_size() != nb ||
      message.bond_bjx_size() != nb || message.bond_bjy_size() != nb)
    throw InvalidArgument("configuration.bond_i", "all bond arrays must have the same length");
  config.bonds.resize(nb);
  for (int b = 0; b < nb; ++b) {
    BondRecord& bond = config.bonds[b];
    bond.i = message.bond_i(b);
    bond.j = message.bond_j(b);
    if (bond.i < 0 || bond.i >= n || bond.j < 0 || bond.j >= n || bond.i == bond.j)
      throw InvalidArgument("configuration.bond_i[" + std::to_string(b) + "]",
                            "bond joins invalid particles " + std::to_string(bond.i) + ", " + std::to_string(bond.j));
    bond.bix = message.bond_bix(b);
    bond.biy = message.bond_biy(b);
    bond.bjx = message.bond_bjx(b);
    bond.bjy = message.bond_bjy(b);
    const double norm_i = bond.bix * bond.bix + bond.biy * bond.biy;
    const double norm_j = bond.bjx * bond.bjx + bond.bjy * bond.bjy;
    if (!(std::abs(norm_i - 1) < 1e-6) || !(std::abs(norm_j - 1) < 1e-6))
      throw InvalidArgument("configuration.bond_bix[" + std::to_string(b) + "]", "contact points must be unit vectors");
  }
  if (message.wall_size() != 0) {
    if (message.wall_size() != n) throw InvalidArgument("configuration.wall", "needs one entry per particle");
    for (int i = 0; i < n; ++i) {
      const int side = message.wall(i);
      if (side < 0 || side > 2) throw InvalidArgument("configuration.wall[" + std::to_string(i) + "]", "must be 0, 1 or 2");
      config.wall.push_back(static_cast<std::int8_t>(side));
    }
  }
  config.wall_bottom = message.wall_bottom();
  config.wall_top = message.wall_top();
  if (config.has_walls() && config.periodic_y)
    throw InvalidArgument("configuration.periodic_y", "a configuration with walls cannot be periodic in y");
  if (config.has_walls() && !(config.wall_top > config.wall_bottom))
    throw InvalidArgument("configuration.wall_top", "walls need wall_top > wall_bottom");
  config.seed = message.seed();
  config.generator = message.generator();
  return config;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidArgument("path", "cannot open '" + path + "'");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

namespace {
// The error for a failed write: NoSpaceError when the file system is full, so that the caller
// can wait for space instead of failing the run.
[[noreturn]] void write_failed(const std::string& what, int error) {
  const std::string message = what + ": " + std::strerror(error);
  if (error == ENOSPC || error == EDQUOT) throw NoSpaceError(message);
  throw std::runtime_error(message);
}
}  // namespace

void write_at(int fd, const void* data, std::size_t size, std::uint64_t offset, const std::string& what) {
  const char* bytes = static_cast<const char*>(data);
  std::size_t written = 0;
  while (written < size) {
    const ssize_t n = ::pwrite(fd, bytes + written, size - written, static_cast<off_t>(offset + written));
    if (n <= 0) write_failed("write to '" + what + "' failed", n < 0 ? errno : ENOSPC);  // 0 bytes: no room left
    written += static_cast<std::size_t>(n);
  }
}

void write_file_atomically(const std::string& path, const std::string& contents) {
  const std::string temporary = path + ".tmp";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) write_failed("cannot write '" + temporary + "'", errno);
  try {
    write_at(fd, contents.data(), contents.size(), 0, temporary);
  } catch (...) {
    ::close(fd);
    ::unlink(temporary.c_str());
    throw;
  }
  if (::fsync(fd) != 0) {
    const int error = errno;
    ::close(fd);
    ::unlink(temporary.c_str());
    write_failed("fsync of '" + temporary + "' failed", error);
  }
  ::close(fd);
  if (std::rename(temporary.c_str(), path.c_str()) != 0)
    write_failed("cannot rename '" + temporary + "' to '" + path + "'", errno);
}

namespace {
bool is_json_path(const std::string& path) {
  return path.size() >= 5 && path.compare(path.size() - 5, 5, ".json") == 0;
}

// What a configuration file may be, for the messages that refuse one.
constexpr char kConfigurationFormats[] =
    "a gel is read from a gel.v1 configuration (JSON in a .json file, binary protobuf in any other, as gelsim "
    "generate and a run's snapshots/ write them), a GSD file (.gsd) or an extended XYZ file (.xyz, .extxyz)";

std::string lower_extension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension;
}
}  // namespace

Configuration read_configuration(const std::string& path, std::int64_t frame) {
  const std::string extension = lower_extension(path);
  if (extension == ".gsd") return importing::read_gsd(path, frame);
  if (extension == ".xyz" || extension == ".extxyz") return importing::read_extended_xyz(path, frame);
  // VTU is written for viewing: named, rather than read as a damaged protobuf message.
  if (extension == ".vtu" || extension == ".pvd")
    throw InvalidArgument("path", "'" + path + "': VTK files are written for viewing and not read back: " + kConfigurationFormats);
  importing::resolve_frame(path, frame, 1);  // one configuration: frame 0 or -1
  const std::string contents = read_file(path);
  gel::v1::Configuration message;
  if (is_json_path(path)) {
    // Checked first: protobuf's parser says what is wrong without naming the field.
    if (const JsonProblem problem = json_problem(contents, *gel::v1::Configuration::descriptor()))
      throw InvalidArgument("path", "'" + path + "' is not a configuration: " +
                                        (problem.field.empty() ? "" : problem.field + ": ") + problem.message);
    const auto status = google::protobuf::util::JsonStringToMessage(contents, &message);
    if (!status.ok()) throw InvalidArgument("path", "'" + path + "' is not a configuration: " + status.ToString());
  } else if (!message.ParseFromString(contents)) {
    throw InvalidArgument("path", "'" + path + "' is not a binary gel.v1 configuration: " + kConfigurationFormats);
  }
  return from_proto(message);
}

void write_configuration(const Configuration& config, const std::string& path) {
  const gel::v1::Configuration message = to_proto(config);
  std::string contents;
  if (is_json_path(path)) {
    contents = message_to_json(message).dump();
  } else {
    message.SerializeToString(&contents);
  }
  write_file_atomically(path, contents);
}

}  // namespace gel
