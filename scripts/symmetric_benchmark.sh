#!/usr/bin/env bash
# The symmetric-scene benchmark (issue 9): synthetic scenes whose opposite
# walls look alike (tools/scene_generator), with a rate of mirror-twin false
# pairs; colmap_irav4's mapper and COLMAP 3.8's incremental mapper (on a copy
# of the database) in the same run, side by side. Per run: models written,
# registered images, cameras turned by more than 30 deg against the exact
# ground truth, centre error over all registered cameras (median, mean;
# metres), wall and CPU seconds, and our fold score:outcome per model.
#
#   scripts/symmetric_benchmark.sh WORKSPACE [RATES] [SEEDS] [NUM_IMAGES] [LAYOUT]
#
# Defaults: RATES "0 0.05 0.1 0.2 0.3", SEEDS "1 2 3", NUM_IMAGES 80,
# LAYOUT courtyard. Environment: COLMAP=0 skips COLMAP; JOBS (default 2)
# scenes at a time; THREADS (default 1) threads per mapper; BUILD the
# directory holding colmap_irav4, scene_generator and fold_eval.
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
jobs=${JOBS:-2}
threads=${THREADS:-1}
for tool in colmap_irav4 scene_generator fold_eval; do
  [ -x "$build/$tool" ] || { echo "ERROR: $build/$tool: not built" >&2; exit 1; }
done
mkdir -p "$workspace"
format="%-6s %-4s %-6s %-6s %-7s %-6s %-5s %-6s %-9s %-9s %-7s %-7s %s\n"

row() {  # scene mapper rate seed pairs mirror: prints the table row
  local scene=$1 mapper=$2 rate=$3 seed=$4 pairs=$5 mirror=$6
  local eval_line fold="-" wall cpu
  eval_line=$("$build/fold_eval" "$scene/gt" "$scene/$mapper" 2>/dev/null ||
              echo "models 0 registered 0 turned - centre_median_m - centre_mean_m -")
  read -r _ models _ reg _ turned _ cmed _ cmean <<< "$eval_line"
  read -r wall user sys < "$scene/$mapper.time" || true
  cpu=$(awk -v u="${user:-0}" -v s="${sys:-0}" 'BEGIN { printf "%.1f", u + s }')
  if [ "$mapper" = ours ]; then
    fold=$(python3 - "$scene/ours/summary.json" <<'EOF' 2>/dev/null || echo "-"
import json, sys
summary = json.load(open(sys.argv[1]))
print(";".join("%.3f:%s" % (-1 if m.get("fold_score") is None else m["fold_score"],
                            m.get("fold_outcome", "").replace(" ", "_"))
               for m in summary["models"]))
EOF
)
  fi
  printf "$format" "$rate" "$seed" "$pairs" "$mirror" "$mapper" "$models" "$reg" \
    "$turned" "$cmed" "$cmean" "${wall:--}" "$cpu" "$fold"
}

run_scene() {  # rate seed: generates, maps with both, writes $scene.rows
  local rate=$1 seed=$2
  local scene=$workspace/${layout}_n${num_images}_r${rate}_s${seed}
  rm -rf "$scene"
  "$build/scene_generator" --output_path "$scene" --layout "$layout" \
    --num_images "$num_images" --mirror_pair_rate "$rate" --seed "$seed" \
    > "$scene.generator.log" 2>&1 ||
    { echo "ERROR: scene_generator failed, see $scene.generator.log" >&2; return 1; }
  local pairs mirror
  pairs=$(sqlite3 "file:$scene/database.db?immutable=1" \
    "select count(*) from two_view_geometries where rows > 0")
  mirror=$(grep -o "[0-9]* mirror-twin" "$scene.generator.log" | awk '{print $1}' || true)
  mkdir -p "$scene/ours" "$scene/colmap"
  /usr/bin/time -f "%e %U %S" -o "$scene/ours.time" env OMP_NUM_THREADS=1 \
    "$build/colmap_irav4" mapper --database_path "$scene/database.db" \
    --output_path "$scene/ours" --Mapper.num_threads "$threads" \
    --Mapper.progress 0 > "$scene/ours.log" 2>&1 &
  local ours_pid=$!
  if [ "$run_colmap" = 1 ]; then
    cp "$scene/database.db" "$scene/colmap.db"
    /usr/bin/time -f "%e %U %S" -o "$scene/colmap.time" colmap mapper \
      --database_path "$scene/colmap.db" --image_path "$scene" \
      --output_path "$scene/colmap" --Mapper.num_threads "$threads" \
      > "$scene/colmap.log" 2>&1 || echo "colmap failed (see $scene/colmap.log)" >&2
    rm -f "$scene/colmap.db"
  fi
  wait "$ours_pid" || echo "ours failed (see $scene/ours.log)" >&2
  {
    row "$scene" ours "$rate" "$seed" "$pairs" "$mirror"
    if [ "$run_colmap" = 1 ]; then
      row "$scene" colmap "$rate" "$seed" "$pairs" "$mirror"
    fi
  } > "$scene.rows"
  cat "$scene.rows"
}

printf "$format" rate seed pairs mirror mapper models reg turned c_med_m c_mean_m wall_s cpu_s fold
scenes=()
for rate in $rates; do
  for seed in $seeds; do
    scenes+=("$rate $seed")
  done
done
running=0
for item in "${scenes[@]}"; do
  read -r rate seed <<< "$item"
  run_scene "$rate" "$seed" > /dev/null &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait || true
table=$workspace/table.txt
{
  printf "$format" rate seed pairs mirror mapper models reg turned c_med_m c_mean_m wall_s cpu_s fold
  for item in "${scenes[@]}"; do
    read -r rate seed <<< "$item"
    cat "$workspace/${layout}_n${num_images}_r${rate}_s${seed}.rows" 2>/dev/null ||
      echo "$rate $seed: no result"
  done
} > "$table"
cat "$table"
echo "(images per scene: $num_images, layout: $layout, threads per mapper: $threads)"
