#!/usr/bin/env bash
# Installs every build and test dependency from Debian's archive (idempotent, non-interactive)
# and builds the project into build/ (or $GEL_BUILD_DIR). Extra CMake arguments pass through.
# Slurm and munge are installed only with GEL_WITH_SLURM=1 (scripts/test.sh sets it).
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libeigen3-dev libspdlog-dev libsqlite3-dev libgtest-dev libgmock-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev libfmt-dev
  libfftw3-dev libcairo2-dev gnuplot-nox
  python3 python3-grpcio python3-protobuf
  python3-numpy python3-ase python3-gsd python3-vtk9 python3-pandas
  systemd openssl
)
# Slurm (daemons and munge) only where it is asked for: the Slurm executor's tests, or a
# machine that submits to a cluster. GEL_WITH_SLURM=1 (scripts/test.sh sets it).
if [ "${GEL_WITH_SLURM:-0}" = "1" ]; then
  PACKAGES+=(slurmctld slurmd slurm-client munge)
fi

missing=()
for package in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if ((${#missing[@]})); then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq
  $SUDO apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}"
fi

BUILD_DIR="${GEL_BUILD_DIR:-build}"
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$BUILD_DIR" -j "$(nproc)"
