// Every instruction-set clone of the hot loops gives the baseline's bits (simd_dispatch.hpp):
// the bond loop, the velocity-Verlet kicks and a FIRE update, each compiled for x86-64-v4, -v3
// and the baseline in its own file (simd_clones.hpp), run on the same input, compared word for
// word. A run dispatches to one clone only, the widest its CPU has, so without this test the
// others would run nowhere on this machine; under the sanitizers it also runs each of them.
#include <gtest/gtest.h>

#include <iostream>

#include "simd_clones.hpp"

namespace gel::simd_clones {
namespace {

TEST(SimdClones, EveryInstructionSetGivesTheBaselinesBits) {
  __builtin_cpu_init();
  const bool v3 = __builtin_cpu_supports("x86-64-v3"), v4 = __builtin_cpu_supports("x86-64-v4");
  // Sizes around the vector widths and the 8 reduction lanes: tails of every length.
  for (int n : {1, 2, 7, 8, 9, 37, 300}) {
    const Bits baseline = run_baseline(n);
    ASSERT_GT(baseline.size(), 10u * static_cast<std::size_t>(n));
    if (v3) {
      EXPECT_EQ(run_v3(n), baseline) << "x86-64-v3 differs from the baseline at n = " << n;
    }
    if (v4) {
      EXPECT_EQ(run_v4(n), baseline) << "x86-64-v4 differs from the baseline at n = " << n;
    }
  }
  if (!v3 || !v4) std::cout << "[ note ] this CPU runs " << (v3 ? "x86-64-v3" : "neither x86-64-v3 nor -v4")
                            << " at most: the wider clones are not checked here\n";
}

}  // namespace
}  // namespace gel::simd_clones
