#pragma once
// The engine's floating-point mode: subnormal numbers are flushed to zero.
//
// Why: an isolated cluster that relaxes (FIRE at a target, or drag in the walk) sees its forces
// and velocities decay geometrically, and on the way to zero they pass through the subnormal
// range (below 2.2e-308), where every x86 operation on them takes a microcode assist of about a
// hundred cycles. In a profile of FIRE at the first target of `gelsim compress --preset
// paper-bond1 --seed 1` its particle loop (fire_update) took 57 % of the time instead of the 17 %
// it takes elsewhere. With the flush the same run reaches the first three rows in the same
// number of steps (the same trajectory) with 11.5 s less CPU (64 s against 75 s to row 1, the two
// binaries side by side, 2026-12-07); paper-bond2 seed 1 reaches row 2 with 128 s against
// 165 s. Values of 1e-308 F0 or a/t0 carry no physics (relaxation stops at 1e-6 F0), so the
// engine runs with FTZ (results that would be subnormal are 0) and DAZ (subnormal inputs count
// as 0).
//
// Determinism: every public engine call that moves or evaluates the system sets the mode for
// its duration (FlushSubnormals, restoring the caller's mode after), and WorkerPool copies the
// caller's mode into its threads for each parallel region, so results stay bit-identical for any
// thread count and across checkpoint/resume. Off x86 the guard does nothing.
#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

namespace gel::detail {

#if defined(__SSE2__)
constexpr unsigned kFlushToZero = 0x8000;      // MXCSR.FTZ
constexpr unsigned kDenormalsAreZero = 0x0040; // MXCSR.DAZ

constexpr unsigned kExceptionFlags = 0x003f;  // MXCSR's sticky status bits, not part of the mode

// The control bits (rounding, exception masks, FTZ, DAZ), without the status flags.
inline unsigned floating_point_mode() { return _mm_getcsr() & ~kExceptionFlags; }
inline void set_floating_point_mode(unsigned mode) {
  const unsigned now = _mm_getcsr();
  if ((now & ~kExceptionFlags) != mode) _mm_setcsr(mode | (now & kExceptionFlags));
}

class FlushSubnormals {
 public:
  FlushSubnormals() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | kFlushToZero | kDenormalsAreZero); }
  ~FlushSubnormals() { _mm_setcsr(saved_); }  // the caller's mode and flags, as they were
  FlushSubnormals(const FlushSubnormals&) = delete;
  FlushSubnormals& operator=(const FlushSubnormals&) = delete;

 private:
  unsigned saved_;
};
#else
inline unsigned floating_point_mode() { return 0; }
inline void set_floating_point_mode(unsigned) {}
class FlushSubnormals {};
#endif

}  // namespace gel::detail
