// The hot loops for x86-64-v3 only (simd_clones.hpp).
#define GEL_SIMD_CLONES [[gnu::target("arch=x86-64-v3"), gnu::abi_tag("simd_clone_v3")]]
#define GEL_SIMD_CLONES_RUN run_v3
#include "simd_clones_probe.inc"
