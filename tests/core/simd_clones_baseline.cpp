// The hot loops for baseline x86-64 (what the sanitizer build runs) only (simd_clones.hpp).
#define GEL_SIMD_CLONES [[gnu::abi_tag("simd_clone_baseline")]]
#define GEL_SIMD_CLONES_RUN run_baseline
#include "simd_clones_probe.inc"
