#!/usr/bin/env bash
# Installs and builds (scripts/setup.sh), then runs colmap_irav4 on the bundled
# real example (tests/data/fountain-P11.db) and prints its summary.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
out=${1:-/tmp/colmap_irav4_example}
mkdir -p "$out"
./build/colmap_irav4 view_graph --database_path tests/data/fountain-P11.db \
  --output_path "$out/relpose.txt"
echo "Relative poses written to $out/relpose.txt"
