#pragma once
// Runtime dispatch of the hot loops (bond forces, integrator). The default Release build targets
// baseline x86-64 (SSE2), which runs everywhere but uses a quarter of an AVX-512 core's vector
// width. GCC function multiversioning compiles each marked function three times and the loader
// picks the widest one the CPU supports (an ifunc resolved once at start-up).
//
// Every clone gives the same bits: core/ is compiled with -ffp-contract=off, so no clone fuses a
// multiply and an add that the baseline rounds twice, and the loops are written so that their
// reductions do not depend on the vector width (fixed lanes, see kReductionLanes). A run is
// therefore reproducible across the machines of a cluster, whatever their instruction sets.
#include <cstddef>

// GEL_NO_SIMD_CLONES (the sanitizer build defines it, CMakeLists.txt) compiles these loops once,
// for baseline x86-64. A process only ever runs the clone its CPU selects, so the sanitizer build
// with clones compiled all three (a third of its compile time) and checked the widest alone; now
// it checks the baseline, and the Release build, which keeps the clones, runs the widest the CPU
// has (docs/testing.md "Instruction sets").
//
// A file that defines GEL_SIMD_CLONES itself before including the loops compiles them for the
// one instruction set it names (tests/core/simd_clones_*.cpp: each clone checked bit for bit).
#if defined(GEL_SIMD_CLONES)
#elif defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(GEL_NO_SIMD_CLONES)
#define GEL_SIMD_CLONES [[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
#else
#define GEL_SIMD_CLONES
#endif

namespace gel {

// Sums and maxima over particles are kept in this many independent partial results (lane l takes
// the indices i = l mod kReductionLanes, in order) and combined in a fixed order at the end, so
// the result is the same for 2-, 4- and 8-wide vectors.
inline constexpr std::size_t kReductionLanes = 8;

}  // namespace gel
