#!/usr/bin/env bash
# Installs the built tree (build/) into a temporary prefix, then configures,
# builds and runs the minimal consumer (examples/consumer) against it: the
# check that another CMake project can find_package(colmap_irav4) and call the
# library in-process. Needs a configured and built build/ (run_example.sh).
#   scripts/check_install.sh [BUILD_DIR (default build)]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
tmp=$(mktemp -d /tmp/colmap_irav4_install.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log"
test -x "$tmp/prefix/bin/colmap_irav4"
test -f "$tmp/prefix/lib/cmake/colmap_irav4/colmap_irav4-config.cmake"
test -f "$tmp/prefix/include/colmap_irav4/rotation_averaging/irav4.h"
"$tmp/prefix/bin/colmap_irav4" help > /dev/null
# The Python module, when built: installed into the interpreter's module
# path below the prefix (COLMAP_IRAV4_PYTHON_INSTALL_DIR).
python_dir=$(sed -n 's/^COLMAP_IRAV4_PYTHON_INSTALL_DIR:STRING=//p' \
  "$build/CMakeCache.txt")
if grep -q '^COLMAP_IRAV4_BUILD_PYTHON:BOOL=ON' "$build/CMakeCache.txt"; then
  python=$(sed -n 's/^Python3_EXECUTABLE:FILEPATH=//p' "$build/CMakeCache.txt")
  PYTHONPATH="$tmp/prefix/$python_dir" "$python" -c \
    "import colmap_irav4; assert 'irav4' in colmap_irav4.rotation_averaging_methods"
  echo "== Python module installed in $tmp/prefix/$python_dir"
fi
launcher=()
if command -v ccache > /dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
cmake -S examples/consumer -B "$tmp/consumer" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$tmp/prefix" "${launcher[@]}" > "$tmp/configure.log"
cmake --build "$tmp/consumer" -j2 > "$tmp/build.log"
echo "== consumer of the installed package ($tmp/prefix)"
"$tmp/consumer/consumer"
