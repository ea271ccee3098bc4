#pragma once
// Stepwise uniaxial compression (MODEL.md "Protocols"): generate (or load) a gel, replace the
// y boundary by walls, and compress through the schedule phi_k, recording every equilibrium.
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "gel/configuration.hpp"
#include "gel/system.hpp"
#include "gel/v1/scene.pb.h"

namespace gel {

// Built-in scene presets: "quick" (a few hundred particles, a few steps, under a minute),
// "paper-bond1", "paper-bond2". Throws InvalidArgument (field "preset") otherwise.
gel::v1::Scene scene_preset(std::string_view name);
std::vector<std::string> scene_preset_names();

// Fills every unset field of a compression scene from its preset and the defaults, and
// validates it (throws InvalidArgument naming the field). The result is what gets stored.
gel::v1::Scene resolve_compression_scene(const gel::v1::Scene& scene);

// Parses a scene from JSON (Protocol Buffers' JSON mapping); throws InvalidArgument.
gel::v1::Scene scene_from_json(const std::string& json);
std::string scene_to_json(const gel::v1::Scene& scene);

// The schedule: phi_1 = w0 phi_0, phi_k = w^(k-1) phi_1, w = (phi_max/phi_1)^(1/(k'-1)).
std::vector<double> compression_targets(double phi0, double w0, double phi_max, int steps);

// A run's GSD trajectory in its output directory, whoever asks for it (gelsim's
// --trajectory-every or the scene's output.trajectory_every).
std::string default_trajectory_path(const std::string& out_dir);
// The same for the thermo log (gelsim's --thermo-every or the scene's output.thermo_every).
std::string default_thermo_path(const std::string& out_dir);

struct RunOptions {
  std::string out_dir;  // checkpoint, curve.csv/json, snapshots; empty = keep in memory only
  std::function<void(const gel::v1::Progress&)> on_progress;  // may be empty: costs nothing
  std::function<void(const gel::v1::CurveRow&)> on_row;       // called at every equilibrium
  const std::atomic<bool>* stop = nullptr;  // set to stop: checkpoint and return
  double progress_interval_seconds = 0.5;
  bool write_snapshots = true;
  int threads = 0;  // of the engine (bit-identical for any number); 0: scene integration.threads, else 1
  // A GSD trajectory (gel/export.hpp): a frame at the start and then at the first chunk boundary
  // at or after every multiple of trajectory_every engine steps (0: none). Relaxation
  // iterations of the quasi-static method take no steps, so they add no frames. Writing frames
  // reads the state and never changes it: the run is bit-identical with or without them. A
  // resumed run drops the file's frames past its checkpoint and goes on from there.
  std::string trajectory_path;
  std::int64_t trajectory_every = 0;
  // A thermo log (docs/compression.md "Thermo log"): a CSV line of the state (step, time, phi,
  // P_top, P_bot, energies, ruptures) at the start, at the first chunk boundary at or after every
  // multiple of thermo_every engine steps, and at the end (0: none), each flushed at once. It
  // reads the state and never changes it (bit-identical with or without). A resumed run drops
  // the lines past its checkpoint and appends from there.
  std::string thermo_path;
  std::int64_t thermo_every = 0;
};

struct CompressionResult {
  gel::v1::Curve curve;
  bool stopped = false;   // stopped on request before the end (resumable from out_dir)
  bool finished = false;  // all targets done
  // A resume whose last checkpoint could not be read goes on from the one before it (the
  // run is deterministic, so the result is the same, only later): then this is set, and
  // checkpoint_problem says what was wrong with the last one.
  bool resumed_from_previous_checkpoint = false;
  std::string checkpoint_problem;
};

// Runs a resolved or unresolved compression scene from its generator (or the configuration
// `initial` if given). With out_dir set, a checkpoint there is written at every equilibrium
// and every checkpoint_seconds of wall time.
CompressionResult run_compression(const gel::v1::Scene& scene, const RunOptions& options,
                                  const Configuration* initial = nullptr);

// One equilibrium test of MODEL.md, as the protocol runs it every m_exam steps once the walls
// stopped: |P_top - P_bot|/P < A, |P - P'|/P < B and no bond ruptured since P' (breaks and
// resets, or breaks only with exam_ruptures "normal"). When |P| and |P'|
// are both below stress_floor the relative tests are meaningless (no network carries stress):
// then the step is at equilibrium when no bond broke and every free particle is slower than
// rest_speed. `compression` is a resolved Compression message.
struct EquilibriumSample {
  double p_top = 0, p_bot = 0;  // now [F0/a^2]
  double previous_p = 0;        // P' = P at the previous test (or when the walls stopped)
  bool bond_broke = false;      // a counted rupture (compression.exam_ruptures) since P'
  double max_speed = 0;         // fastest free particle [a/t0]
  bool spans = true;            // the network connects the walls; if not, only rest counts
};
bool equilibrium_reached(const EquilibriumSample& sample, const gel::v1::Compression& compression);

// The ruptures the third test counts, from the engine's event counters: a normal break, a
// sliding reset and a rolling reset each count one (MODEL.md: the published study calls all three
// "bond ruptures"); with compression.exam_ruptures "normal" (all_modes false) only breaks count.
// Bonds formed are not ruptures. EquilibriumSample::bond_broke is this count changing since P'.
std::int64_t exam_ruptures(const EventCounts& events, bool all_modes);
// The same for a resolved Compression message's exam_ruptures.
std::int64_t exam_ruptures(const EventCounts& events, const gel::v1::Compression& compression);

// Continues from out_dir's checkpoint (checkpoint.bin, or checkpoint.prev.bin when that cannot
// be read); the result is identical to an uninterrupted run. Throws InvalidArgument naming
// each file's problem when neither can be read.
CompressionResult resume_compression(const RunOptions& options);
bool has_checkpoint(const std::string& out_dir);

}  // namespace gel
