#!/usr/bin/env bash
# Installs and builds (scripts/setup.sh), then maps the bundled real example
# (tests/data/fountain-P11.db, Strecha's fountain, 11 images; no images are
# bundled, so the points are grey) and prints the run's summary.
#   scripts/run_example.sh [OUTPUT_DIR (default /tmp/colmap_irav4_example)]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
out=${1:-/tmp/colmap_irav4_example}
mkdir -p "$out"
./build/colmap_irav4 mapper --database_path tests/data/fountain-P11.db \
  --output_path "$out"
echo "== $out/summary.json"
cat "$out/summary.json"
echo "Model written to $out/0 (open it with: colmap gui --import_path $out/0)"
