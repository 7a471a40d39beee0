#!/usr/bin/env bash
# The symmetric-scene benchmark (issue 9): synthetic scenes whose opposite
# walls look alike, with a rate of mirror-twin false pairs; colmap_irav4's
# mapper and COLMAP 3.8's incremental mapper (on a copy of the database) in
# the same run. Per run: models written, registered images, cameras turned by
# more than 30 deg against the exact ground truth, centre error (median, mean;
# metres), the fold score and outcome of ours, and the wall time.
#
#   scripts/symmetric_benchmark.sh WORKSPACE [RATES] [SEEDS] [NUM_IMAGES] [LAYOUT]
#
# Defaults: RATES "0 0.05 0.1 0.2 0.3", SEEDS "1 2 3", NUM_IMAGES 80,
# LAYOUT courtyard. COLMAP=0 in the environment skips COLMAP.
set -euo pipefail
if [ $# -lt 1 ]; then
  echo "usage: $0 WORKSPACE [RATES] [SEEDS] [NUM_IMAGES] [LAYOUT]" >&2
  exit 2
fi
workspace=$1
rates=${2:-"0 0.05 0.1 0.2 0.3"}
seeds=${3:-"1 2 3"}
num_images=${4:-80}
layout=${5:-courtyard}
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$root/build}
run_colmap=${COLMAP:-1}
for tool in colmap_irav4 scene_generator fold_eval; do
  [ -x "$build/$tool" ] || { echo "ERROR: $build/$tool: not built" >&2; exit 1; }
done
mkdir -p "$workspace"
table=$workspace/table.txt
printf "%-6s %-4s %-7s %-7s %-6s %-5s %-7s %-9s %-9s %-7s %s\n" rate seed pairs mapper models reg turned c_med_m c_mean_m wall_s fold > "$table"

for rate in $rates; do
  for seed in $seeds; do
    scene=$workspace/${layout}_r${rate}_s${seed}
    rm -rf "$scene"
    "$build/scene_generator" --output_path "$scene" --layout "$layout" \
      --num_images "$num_images" --mirror_pair_rate "$rate" --seed "$seed" \
      > "$scene.generator.log" 2>&1 ||
      { echo "ERROR: scene_generator failed, see $scene.generator.log" >&2; exit 1; }
    pairs=$(sqlite3 "file:$scene/database.db?immutable=1" \
      "select count(*) from two_view_geometries where rows > 0")

    rm -rf "$scene/ours"; mkdir -p "$scene/ours"
    /usr/bin/time -f "%e" -o "$scene/ours.time" env OMP_NUM_THREADS=2 \
      "$build/colmap_irav4" mapper --database_path "$scene/database.db" \
      --output_path "$scene/ours" --Mapper.num_threads 2 \
      > "$scene/ours.log" 2>&1 || echo "ours failed (see $scene/ours.log)" >&2
    eval_line=$("$build/fold_eval" "$scene/gt" "$scene/ours" 2>/dev/null || echo "models 0 registered 0 turned - centre_median_m - centre_mean_m -")
    fold=$(python3 - "$scene/ours/summary.json" <<'EOF' 2>/dev/null || echo "-"
import json, sys
summary = json.load(open(sys.argv[1]))
print(";".join("%.3f:%s" % (m.get("fold_score") or -1, m.get("fold_outcome", "").replace(" ", "_"))
               for m in summary["models"]))
EOF
)
    read -r _ models _ reg _ turned _ cmed _ cmean <<< "$eval_line"
    printf "%-6s %-4s %-7s %-7s %-6s %-5s %-7s %-9s %-9s %-7s %s\n" "$rate" "$seed" "$pairs" ours \
      "$models" "$reg" "$turned" "$cmed" "$cmean" "$(cat "$scene/ours.time")" "$fold" | tee -a "$table"

    if [ "$run_colmap" = 1 ]; then
      rm -rf "$scene/colmap" "$scene/colmap.db"; mkdir -p "$scene/colmap"
      cp "$scene/database.db" "$scene/colmap.db"
      /usr/bin/time -f "%e" -o "$scene/colmap.time" colmap mapper \
        --database_path "$scene/colmap.db" --image_path "$scene" \
        --output_path "$scene/colmap" --Mapper.num_threads 2 \
        > "$scene/colmap.log" 2>&1 || echo "colmap failed (see $scene/colmap.log)" >&2
      eval_line=$("$build/fold_eval" "$scene/gt" "$scene/colmap" 2>/dev/null || echo "models 0 registered 0 turned - centre_median_m - centre_mean_m -")
      read -r _ models _ reg _ turned _ cmed _ cmean <<< "$eval_line"
      printf "%-6s %-4s %-7s %-7s %-6s %-5s %-7s %-9s %-9s %-7s %s\n" "$rate" "$seed" "$pairs" colmap \
        "$models" "$reg" "$turned" "$cmed" "$cmean" "$(cat "$scene/colmap.time")" "-" | tee -a "$table"
      rm -f "$scene/colmap.db"
    fi
  done
done
echo "table: $table"
