#pragma once
// The hot loops (core/src/engine/*_kernels.hpp) compiled for one instruction set each, in the
// files simd_clones_{v4,v3,baseline}.cpp, run on the same input: test_simd_clones.cpp checks
// that every clone gives the baseline's bits, the promise of simd_dispatch.hpp that makes a run
// reproducible across the machines of a cluster. The Release build's own dispatch runs only the
// widest clone the CPU has, and the sanitizer build compiles the baseline alone.
#include <cstdint>
#include <vector>

namespace gel::simd_clones {

// Every output of the loops, as raw bits.
using Bits = std::vector<std::uint64_t>;

// Runs the bond loop (every bond effect, thresholds, periodic shifts), the velocity-Verlet kicks
// (with drag) and one FIRE update on a fixed pseudo-random input of `n` particles.
Bits run_v4(int n);
Bits run_v3(int n);
Bits run_baseline(int n);

}  // namespace gel::simd_clones
