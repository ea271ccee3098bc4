#pragma once
// A configuration: particles, bonds with their body-fixed contact points, the box and, once
// compression started, the walls. It is what the generator writes, what the engine starts
// from, and what a compression snapshot holds.
//
// File format (documented in docs/gelsim.md "Configuration files"): the gel.v1.Configuration message
// of proto/gel/v1/scene.proto, written either as JSON through Protocol Buffers' JSON mapping
// (files ending in .json; doubles print in round-trip form, so reading back is bit exact) or
// as binary protobuf (any other ending, e.g. .pb).
#include <cstdint>
#include <string>
#include <vector>

#include "gel/v1/scene.pb.h"
#include "gel_version.hpp"  // gel::program_version()

namespace gel {

// A bond between particles i and j. The contact points are unit vectors in each particle's
// body frame: the lab-frame contact direction on i is R(theta_i) (bix, biy).
struct BondRecord {
  std::int32_t i = 0;
  std::int32_t j = 0;
  double bix = 1, biy = 0;
  double bjx = -1, bjy = 0;
};

enum WallSide : std::int8_t { kNoWall = 0, kBottomWall = 1, kTopWall = 2 };

struct Configuration {
  double lx = 0;
  double ly = 0;
  bool periodic_y = true;  // false once walls replaced the y boundary (or for an open box)
  std::vector<double> x, y, theta;
  // Velocities [a/t0] and angular velocities [1/t0]: empty (at rest) or one per particle.
  std::vector<double> vx, vy, omega;
  std::vector<BondRecord> bonds;
  std::vector<std::int8_t> wall;  // empty (no walls) or one WallSide per particle
  double wall_bottom = 0;
  double wall_top = 0;
  std::uint64_t seed = 0;
  gel::v1::Generator generator;  // parameters that made it, if generated

  std::size_t size() const { return x.size(); }
  bool has_walls() const { return !wall.empty(); }
  bool has_velocities() const { return !vx.empty(); }
  // Height available to the particles: the wall gap between walls, L_y otherwise.
  double height() const { return has_walls() ? wall_top - wall_bottom : ly; }
  // phi = pi a^2 N / (L_x height).
  double packing_fraction() const;
  // Mean number of bonds per particle, 2 N_b / N.
  double mean_contact_number() const;
  // Adds a particle; returns its index.
  std::int32_t add_particle(double px, double py, double ptheta = 0.0);
  // Bonds i and j as touching now: contact points along the current line of centres
  // (minimum image), expressed in each body frame.
  void add_bond_at_contact(std::int32_t i, std::int32_t j);
  // Minimum-image separation r_j - r_i.
  void separation(std::int32_t i, std::int32_t j, double& dx, double& dy) const;
};

gel::v1::Configuration to_proto(const Configuration& config);
// Validates sizes and values; throws InvalidArgument naming the field.
Configuration from_proto(const gel::v1::Configuration& message);

// The frame of a file that holds several (GSD, extended XYZ): an index from 0, or from the end
// when negative; kLastFrame is the last one.
inline constexpr std::int64_t kLastFrame = -1;

// Reads a gel.v1 configuration (.json or binary protobuf), or a frame of a GSD (.gsd) or
// extended XYZ (.xyz, .extxyz) file through gel/import.hpp. A gel.v1 file is one frame (0 or
// kLastFrame). Throws InvalidArgument (field "path") when the file cannot be read or used,
// ("frame") when it has no such frame.
Configuration read_configuration(const std::string& path, std::int64_t frame = kLastFrame);
// Writes atomically (temporary file, then rename).
void write_configuration(const Configuration& config, const std::string& path);

// Writes `contents` to `path` atomically: a temporary file in the same folder, fsync, rename.
void write_file_atomically(const std::string& path, const std::string& contents);
std::string read_file(const std::string& path);
// Writes all `size` bytes at `offset` of the open file `fd`, retrying short writes. Throws
// NoSpaceError when the file system is full, std::runtime_error otherwise; `what` names the
// file in the message.
void write_at(int fd, const void* data, std::size_t size, std::uint64_t offset, const std::string& what);


}  // namespace gel
