#include "gel/resources.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "gel/compression.hpp"
#include "gel/generator.hpp"
#include "gel/system.hpp"
#include "gel/units.hpp"

namespace gel {
namespace {

// The densest packing of equal disks covers 0.9069 of the plane, so no disk has more centres
// within distance r of its own than fit into a disk of radius r + a at that density.
double neighbours_within(double r) {
  return std::max(0.0, kMaxPackingFraction * (r + kRadius) * (r + kRadius) / (kRadius * kRadius) - 1.0);
}

// Bytes per item of the engine's state (core/include/gel/system.hpp, core/src/engine/bond_kernels.hpp),
// with the copies a run makes of it: a snapshot (Configuration and its message) per row and a
// checkpoint (EngineState message and its serialised bytes).
constexpr double kBytesPerParticle =
    10 * 8 + 1        // positions, orientation (cos, sin), velocities, forces: SoA doubles; wall side
    + 5 * 4           // neighbour rebuild: degree, cell index and members, cell starts, fill
    + 8               // stiffness check's per-particle sum
    + 2 * (6 * 8 + 4) // snapshot: x, y, theta, velocities, wall; as a Configuration and as its message
    + 2 * (10 * 8);   // checkpoint: the state as a message and serialised
constexpr double kBytesPerBond =
    2 * (2 * 4 + 6 * 8)  // Bond (i, j, contact points, image shift), vector capacity up to 2x
    + 2 * (2 * 4 + 6 * 8 + 4 + 1)  // the bond loop's blocks (a bond across two blocks is in both)
    + 2 * 4                        // its places there
    + 1 + 2 * 4          // break marks; rebuild's partner list
    + 2 * (2 * 4 + 4 * 8) // snapshot
    + 2 * (2 * 4 + 6 * 8); // checkpoint
constexpr double kBytesPerPair = 2 * 24 + 2 * 24;  // candidate (capacity up to 2x), checkpoint copies
constexpr double kBytesPerRowSlice = 4 * 3 * 8;    // phi and 3 stress profiles: curve row, its message and JSON
constexpr double kBytesPerRow = 1024;              // the rest of a curve row, with copies
constexpr double kGeneratorBytesPerArea = 3.1;     // cell grid and walk [bytes per a^2]: 690 MB at 2.25e8 a^2

// On disk: a snapshot per row (gel.v1.Configuration protobuf: 6 doubles and a wall per
// particle, 2 ints and 4 doubles per bond), two checkpoints, and a GSD frame (docs/gelsim.md "Data out":
// the hoomd chunks in float, the exact state, forces and per-bond state in double).
constexpr double kSnapshotBytesPerParticle = 6 * 9 + 2, kSnapshotBytesPerBond = 2 * 5 + 4 * 9;
constexpr double kCheckpointBytesPerParticle = 10 * 9 + 2, kCheckpointBytesPerBond = 2 * 5 + 6 * 9;
constexpr double kCheckpointBytesPerPair = 2 * 5 + 2 * 9;
constexpr double kFrameBytesPerParticle = 4 + 3 * 4 + 4 * 4 + 3 * 4 + 4 * 4 + 3 * 4 + 4  // hoomd chunks, float
                                          + 8 + 3 * 8 + 3 * 8 + 2 * 8 + 3 * 8,           // theta, forces, torques, exact state
                 kFrameBytesPerBond = 4 + 2 * 4 + 4 * 8 + 11 * 8;  // type, group, body-frame contacts, bond state
// A thermo log line (14 numbers in shortest round-trip text), at most one per chunk of 128 steps.
constexpr double kThermoBytesPerLine = 256, kThermoShortestInterval = 128;

}  // namespace

ResourceEstimate estimate_resources(const gel::v1::Scene& resolved, bool write_snapshots) {
  ResourceEstimate e;
  const gel::v1::Generator& g = resolved.generator();
  const gel::v1::Compression& c = resolved.compression();
  const SimParams params = resolve_sim_params(resolved);
  e.particles = static_cast<std::int64_t>(g.n_floc()) * g.n_clusters();
  const double n = static_cast<double>(e.particles);
  e.bonds = static_cast<std::int64_t>(std::ceil(0.5 * n * std::floor(neighbours_within(kDiameter))));
  e.neighbour_pairs = static_cast<std::int64_t>(std::ceil(0.5 * n * neighbours_within(kDiameter + params.skin)));
  e.rows = c.steps() + 1;
  const double bonds = static_cast<double>(e.bonds), pairs = static_cast<double>(e.neighbour_pairs);
  const double rows = static_cast<double>(e.rows);

  const double state = n * kBytesPerParticle + bonds * kBytesPerBond;
  const double neighbour_list = pairs * kBytesPerPair;
  const double curve = rows * (kBytesPerRow + kBytesPerRowSlice * c.profile_slices());
  const double generator = kGeneratorBytesPerArea * g.lx() * g.ly();
  const double largest = std::max({state, neighbour_list, curve});
  e.memory_driver = largest == state ? "generator" : largest == neighbour_list ? "integration.skin" : "compression.profile_slices";
  // The generator's grid is freed before the compression allocates its state.
  e.memory_bytes = static_cast<std::int64_t>(std::max(generator, state + neighbour_list + curve));

  // Steps: both walls walk from the extreme particles (height ~ L_y) to phi_max's height, at
  // most walk_dt_factor x dt per step (the walk step, while the walls carry little) or at most
  // loaded_wall_factor x v_wall (while they carry more): the larger of the two bounds the walk.
  const double phi0 = kPi * kRadius * kRadius * n / (g.lx() * g.ly());
  const double longest_step = std::max({1.0, c.walk_dt_factor(), c.loaded_wall_factor()}) * params.dt;
  const double walk = g.ly() * std::max(0.0, 1.0 - phi0 / c.phi_max()) / (2.0 * c.v_wall() * longest_step);
  const double exams = c.quasistatic() ? 0.0 : static_cast<double>(c.steps()) * static_cast<double>(c.m_exam());
  e.steps = static_cast<std::int64_t>(std::min(walk + exams, 9e18));
  e.particle_steps = n * static_cast<double>(e.steps);

  const double snapshots = write_snapshots ? rows * (n * kSnapshotBytesPerParticle + bonds * kSnapshotBytesPerBond) : 0.0;
  const double checkpoints = 2.0 * (n * kCheckpointBytesPerParticle + bonds * kCheckpointBytesPerBond + pairs * kCheckpointBytesPerPair);
  const std::int64_t every = resolved.output().trajectory_every();
  const double frames = every > 0 ? static_cast<double>(e.steps) / static_cast<double>(every) + rows + 1 : 0.0;
  const double trajectory = frames * (n * kFrameBytesPerParticle + bonds * kFrameBytesPerBond);
  e.disk_driver = trajectory > snapshots + checkpoints ? "output.trajectory_every" : "generator";
  const std::int64_t thermo_every = resolved.output().thermo_every();
  const double thermo =
      thermo_every > 0
          ? (static_cast<double>(e.steps) / std::max(static_cast<double>(thermo_every), kThermoShortestInterval) + rows + 1) *
                kThermoBytesPerLine
          : 0.0;
  e.disk_bytes = static_cast<std::int64_t>(std::min(snapshots + checkpoints + trajectory + thermo + rows * kBytesPerRow, 9e18));
  return e;
}

std::string format_bytes(double bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
  int unit = 0;
  while (bytes >= 1024 && unit < 5) {
    bytes /= 1024;
    ++unit;
  }
  char text[32];
  std::snprintf(text, sizeof text, unit == 0 ? "%.0f %s" : "%.3g %s", bytes, units[unit]);
  return text;
}

}  // namespace gel
