// The hot loops for x86-64-v4 only (simd_clones.hpp).
#define GEL_SIMD_CLONES [[gnu::target("arch=x86-64-v4"), gnu::abi_tag("simd_clone_v4")]]
#define GEL_SIMD_CLONES_RUN run_v4
#include "simd_clones_probe.inc"
