#pragma once
// The compression's checkpoint (one writer, one reader): the protocol state besides the engine
// and the curve, and the file DIR/checkpoint.bin that holds all three. A checkpoint taken
// between two chunks and resumed continues bit for bit (compression_protocol.cpp).
#include <cstdint>
#include <optional>
#include <string>

#include "gel/system.hpp"
#include "gel/v1/checkpoint.pb.h"

namespace gel {

// The numbers are the checkpoint's ProtocolState.phase.
enum Phase : std::int32_t { kMoving = 0, kWaiting = 1, kDone = 2, kRelaxing = 3 };

// Everything besides the engine and the curve that the protocol needs to continue.
struct CompressionState {
  double phi0 = 0;                      // packing fraction at the start (row 0)
  std::int32_t k = 1;                   // current target, 1..k'
  Phase phase = kMoving;
  std::int64_t next_exam_step = 0;        // engine step of the next equilibrium test
  double wait_start_time = 0;             // simulated time when the walls stopped
  double previous_p = 0;                  // P' (P at the previous test, or at the stop)
  std::int64_t ruptures_at_previous = 0;  // ruptures the third test counts, at the previous test
  bool spanned = false;                   // the network spans: no more approach shortcut, and
                                          // walls-then-affine goes on in affine steps
  double wall_seconds_before = 0;       // wall-clock seconds of earlier sessions
  double wall_speed_factor = 1;         // adaptive wall: current v / v_wall
  double drag_at_control = 0;           // adaptive wall: ledger at the previous control
  double wall_work_at_control = 0;
  RelaxState relax;                     // quasi-static: the relaxation of the current strain step
};

std::string checkpoint_path(const std::string& out_dir);
// The checkpoint before the last: a resume falls back to it when the last one cannot be read.
std::string previous_checkpoint_path(const std::string& out_dir);

// Writes DIR/checkpoint.bin atomically; the one it replaces becomes checkpoint.prev.bin.
void write_checkpoint(const std::string& out_dir, const gel::v1::Curve& curve, const CompressionState& state,
                      const System& system);

struct LoadedCheckpoint {
  gel::v1::Curve curve;
  CompressionState state;
  std::optional<System> system;
};

// Reads one checkpoint file; every problem is an InvalidArgument naming the file.
LoadedCheckpoint load_checkpoint(const std::string& path);

}  // namespace gel
