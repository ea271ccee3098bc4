#pragma once
// What one compression run (one ensemble member) will hold and cost, from its resolved scene,
// before it runs: geld admits or refuses a job by it (docs/api.md "Budgets and bounds"), and
// `gelsim compress --estimate` prints it. Memory and disk are bounds: every count that the run
// can only grow to is taken at its largest (the densest disk packing), so that a run admitted
// by them cannot outgrow them; docs/api.md holds the estimate against measured peaks.
#include <cstdint>
#include <string>

#include "gel/v1/scene.pb.h"

namespace gel {

struct ResourceEstimate {
  std::int64_t particles = 0;
  std::int64_t bonds = 0;            // at most 7 per particle (its contacts at the densest packing), halved
  std::int64_t neighbour_pairs = 0;  // pairs within 2a + skin at the densest packing
  std::int64_t rows = 0;             // targets + the initial row
  // Resident memory of the run's state [bytes], without the program itself (kProgramBytes).
  std::int64_t memory_bytes = 0;
  // Its largest term's field, to name in a refusal: "generator" (particles and bonds),
  // "integration.skin" (the neighbour list), "compression.profile_slices" (the curve).
  std::string memory_driver;
  std::int64_t disk_bytes = 0;       // snapshots, two checkpoints, curve and trajectory
  std::string disk_driver;           // "generator" (snapshots, checkpoints) or "output.trajectory_every"
  // Steps the walls need to walk from phi_0 to phi_max at v_wall, plus one equilibrium exam per
  // target where the fidelity waits (not the quasi-static relaxations, which take about a tenth
  // of the walk): a lower bound on the run's steps.
  std::int64_t steps = 0;
  double particle_steps = 0;         // particles x steps
};

// Resident size of a program that runs one member (gelsim, measured: 12 MB for `quick`).
inline constexpr std::int64_t kProgramBytes = 16ll << 20;

// `resolved` is a scene passed through resolve_compression_scene. write_snapshots: a
// configuration file per row (gelsim's default, and geld's).
ResourceEstimate estimate_resources(const gel::v1::Scene& resolved, bool write_snapshots = true);

// "1.5 GiB", "12 MiB", "800 B": for messages.
std::string format_bytes(double bytes);

}  // namespace gel
