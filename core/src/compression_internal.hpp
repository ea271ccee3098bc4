#pragma once
// Shared between the compression source files: the resolved protocol parameters as plain
// numbers (read once from the resolved scene, so the step loop never touches protobuf).
#include <cstdint>

#include "gel/compression.hpp"
#include "gel/system.hpp"
#include "gel/v1/scene.pb.h"

namespace gel {

struct CompressionSettings {
  double w0 = 0, phi_max = 0;
  int steps = 0;
  double v_wall = 0;              // each wall [a/t0]
  std::int64_t m_exam = 0;
  double a_tolerance = 0, b_tolerance = 0;
  double max_wait_time = 0;       // [t0] per target
  double stress_floor = 0;        // [P0]
  double rest_speed = 0;          // [a/t0]
  bool approach_shortcut = false;
  double adaptive_wall_max_factor = 1;    // 1 = the published constant wall speed
  double adaptive_wall_drag_fraction = 0;
  int profile_slices = 0;
  double checkpoint_seconds = 0;
  bool exam_all_ruptures = true;  // the third test counts resets too (MODEL.md)
  bool quasistatic = false;
  bool affine_steps = false;      // quasi-static approach: affine strain steps, not wall motion
  bool affine_after_spanning = false;  // wall motion until a relaxed row spans, affine steps after
  double strain_step = 0;         // max d ln(phi) per affine step
  RelaxOptions relax;
  std::int64_t relax_max_iterations = 0;  // per strain step
};

// From a scene already passed through resolve_compression_scene.
CompressionSettings compression_settings(const gel::v1::Compression& resolved);

// equilibrium_reached() on the plain settings (the protocol's form).
bool equilibrium_reached(const EquilibriumSample& sample, const CompressionSettings& settings);

}  // namespace gel
