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
  colmap time
  clang-format
)

missing=()
for package in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null |
      grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "Installing: ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q \
    --no-install-recommends "${missing[@]}"
fi

# COLMAP_IRAV4_WERROR=ON (as .ci/run sets it) turns warnings into errors.
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release \
  -DCOLMAP_IRAV4_WERROR="${COLMAP_IRAV4_WERROR:-OFF}"
cmake --build build -j"$(nproc)"
