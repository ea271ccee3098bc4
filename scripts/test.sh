#!/usr/bin/env bash
# Sets up, builds and runs every test: first the Release build, then the same suite once more
# under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS="$(nproc)"
# The Slurm tests start their own one-node cluster; here a cluster that cannot start fails them
# instead of skipping them unseen. GEL_REQUIRE_SLURM=0 allows the skip (no root, no Slurm).
export GEL_REQUIRE_SLURM="${GEL_REQUIRE_SLURM:-1}"
export GEL_WITH_SLURM="${GEL_WITH_SLURM:-1}"

GEL_BUILD_DIR=build scripts/setup.sh
(cd build && ctest --output-on-failure -j "$JOBS" --timeout 900)

if [ "${GEL_SKIP_SANITIZERS:-0}" != "1" ]; then
  GEL_BUILD_DIR=build-asan scripts/setup.sh -DCMAKE_BUILD_TYPE=RelWithDebInfo -DGEL_SANITIZE=ON
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export LSAN_OPTIONS="suppressions=$PWD/tests/lsan_suppressions.txt"
  (cd build-asan && GEL_SANITIZED=1 ctest --output-on-failure -j "$JOBS" --timeout 1800)
fi
