#!/usr/bin/env bash
# Installs colmap_irav4's dependencies from Debian's packages (Debian 12) and
# builds it in Release into build/. Safe to re-run: installs only what is
# missing and rebuilds incrementally.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake pkg-config
  libeigen3-dev libceres-dev libsuitesparse-dev
  libsqlite3-dev sqlite3
  libgoogle-glog-dev libgflags-dev
  libgtest-dev libgmock-dev
  libopencv-core-dev libopencv-imgcodecs-dev libopencv-imgproc-dev
  python3-matplotlib
  python3-dev python3-numpy pybind11-dev
  colmap time
  clang-format
)

bash scripts/install_packages.sh "${PACKAGES[@]}"

# COLMAP_IRAV4_WERROR=ON (as .ci/run sets it) turns warnings into errors.
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release \
  -DCOLMAP_IRAV4_WERROR="${COLMAP_IRAV4_WERROR:-OFF}"
cmake --build build -j"$(nproc)"
