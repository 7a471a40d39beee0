#!/usr/bin/env bash
# One benchmark run, side by side: colmap_irav4's mapper, COLMAP 3.8's
# incremental mapper and (when a COLMAP >= 4 binary is given by
# --global_mapper or $COLMAP4, is /opt/colmap4/bin/colmap or is `colmap` on
# the PATH) COLMAP 4's global_mapper, on the Strecha databases and on
# synthetic scenes with exact ground truth (tools/scene_generator).
#
#   scripts/benchmark.sh [--out DIR] [--sizes 100,300,1000] [--large]
#       [--layout courtyard] [--seeds 1[,2,...]] [--scale_noise] [--threads 2]
#       [--colmap_max_images 300] [--no_colmap] [--no_strecha]
#       [--global_mapper BINARY] [--global_mapper_max_images 1000]
#       [--timeout SECONDS]
#
# --layout photo: photo collections (scene_generator --layout photo, with
# 10% random false pairs, 5% mirror-twin pairs and detector repeatability:
# $photo_args below); each mapper's models are also scored against the
# landmarks by scripts/evaluate_photo_models.py into DIR/photo.csv
# (registered images a true pair connects and false registrations, models
# against parts, rotation, centre and focal medians, each model aligned on
# its own).
# --large adds 3000 and 5000 images. --seeds maps a scene of each size per
# generator seed (--seed S: one seed); with more than one the scenes are named
# *_N_sS and accuracy_summary.csv gives the error ratios over the seeds (one
# scene's figure depends on its noise draw: compare mappers over several).
# --scale_noise generates scenes whose
# keypoints have scales and noise proportional to them (scene_generator
# --keypoint_scales 1 --noise_scale_exponent 1; scenes named *_scalenoise_N),
# as SIFT's on real images. COLMAP runs on a copy of each database
# (it writes to it); ours opens it read-only. Per run: wall time and peak
# resident memory (GNU time), CPU time, registered images, models, rotation
# and camera-centre errors against the ground truth (colmap_irav4
# model_comparer on the largest model; centre errors in millimetres, both
# ground truths being metric). Writes DIR/results.csv (one row per run),
# DIR/comparison.csv (one row per scene, ours beside COLMAP with ratios),
# DIR/results.json, DIR/stages.csv (our stages' wall and CPU time, resident
# memory after each, the peak so far and how much each raised it),
# DIR/memory.csv (our peak, the stage that reached it, bytes per observation
# of the models and per verified pair), DIR/machine.txt, and
# the plots (scripts/plot_benchmarks.py) when matplotlib is installed.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=benchmark_results
sizes=100,300,1000
layout=courtyard
seeds=1
generator_args=()
scene_suffix=""
threads=2
colmap_max_images=300
run_colmap=1
run_strecha=1
# COLMAP 4's binary: --global_mapper, else $COLMAP4, else a build installed
# under /opt/colmap4, else `colmap` when it has global_mapper.
global_mapper=${COLMAP4:-}
[ -z "$global_mapper" ] && [ -x /opt/colmap4/bin/colmap ] && global_mapper=/opt/colmap4/bin/colmap
global_mapper_max_images=1000
timeout_seconds=7200
data_dir=$(cd "$root/.." && pwd)/shared/data
# Debian's python3 (python3-matplotlib), not a python3 earlier on the PATH.
python=${PYTHON:-python3}
[ -x /usr/bin/python3 ] && python=${PYTHON:-/usr/bin/python3}
while [ $# -gt 0 ]; do
  case $1 in
    --out) out=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --large) sizes="$sizes,3000,5000"; shift ;;
    --layout) layout=$2; shift 2 ;;
    --seed|--seeds) seeds=$2; shift 2 ;;
    --scale_noise) generator_args=(--keypoint_scales 1 --noise_scale_exponent 1)
      scene_suffix=_scalenoise; shift ;;
    --threads) threads=$2; shift 2 ;;
    --colmap_max_images) colmap_max_images=$2; shift 2 ;;
    --no_colmap) run_colmap=0; shift ;;
    --no_strecha) run_strecha=0; shift ;;
    --global_mapper) global_mapper=$2; shift 2 ;;
    --global_mapper_max_images) global_mapper_max_images=$2; shift 2 ;;
    --timeout) timeout_seconds=$2; shift 2 ;;
    --data_dir) data_dir=$2; shift 2 ;;
    -h|--help) sed -n '2,39p' "$0"; exit 0 ;;
    *) echo "ERROR: unknown option $1 (see $0 --help)" >&2; exit 2 ;;
  esac
done
binary=${COLMAP_IRAV4:-$root/build/colmap_irav4}
generator=${SCENE_GENERATOR:-$root/build/scene_generator}
for tool in "$binary" "$generator"; do
  [ -x "$tool" ] || { echo "ERROR: $tool: not built (run scripts/setup.sh)" >&2; exit 1; }
done
[ -x /usr/bin/time ] || { echo "ERROR: /usr/bin/time missing (apt-get install time)" >&2; exit 1; }
if [ "$run_colmap" = 1 ] && ! command -v colmap > /dev/null; then
  echo "ERROR: colmap not on the PATH (apt-get install colmap, or --no_colmap)" >&2
  exit 1
fi
# COLMAP >= 4's global_mapper: named by the flag, or `colmap` when it has it.
if [ -z "$global_mapper" ] && command -v colmap > /dev/null &&
    colmap help 2>&1 | grep -q global_mapper; then
  global_mapper=$(command -v colmap)
fi
mkdir -p "$out"
out=$(cd "$out" && pwd)
mkdir -p "$out/scenes" "$out/runs"

{
  echo "date: $(date -u '+%Y-%m-%d %H:%M UTC')"
  echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores"
  echo "memory: $(free -g | awk '/Mem:/ {print $2}') GB"
  echo "load at start: $(cut -d' ' -f1-3 /proc/loadavg)"
  echo "colmap_irav4: $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "colmap: $({ colmap help 2>&1 || true; } | grep -m1 -i COLMAP || echo none)"
  echo "global_mapper: ${global_mapper:-none}"
  echo "threads per mapper: $threads"
} > "$out/machine.txt"

results=$out/results.csv
echo "scene,kind,num_images,mapper,status,seconds,cpu_seconds,peak_mib,registered,models,rotation_median_deg,rotation_max_deg,center_median_mm,center_max_mm" > "$results"
echo "scene,stage,seconds,cpu_seconds,memory_mib,peak_memory_mib,peak_rise_mib" > "$out/stages.csv"
echo "scene,peak_mib,peak_stage,observations,verified_pairs,bytes_per_observation,bytes_per_pair" > "$out/memory.csv"

# The model directory with the most images under $1 (COLMAP numbers models
# in the order found, not by size).
largest_model() {
  local best="" best_size=-1 dir size
  for dir in "$1"/*/; do
    [ -f "$dir/images.bin" ] || continue
    size=$(stat -c %s "$dir/images.bin")
    if [ "$size" -gt "$best_size" ]; then best=$dir; best_size=$size; fi
  done
  echo "${best%/}"
}

# run_mapper SCENE KIND NUM_IMAGES MAPPER OUTPUT_DIR GT_ARGS... -- COMMAND...
run_mapper() {
  local scene=$1 kind=$2 num_images=$3 mapper=$4 output=$5
  shift 5
  local gt_args=()
  while [ "$1" != "--" ]; do gt_args+=("$1"); shift; done
  shift
  rm -rf "$output"
  mkdir -p "$output"
  local status=ok seconds="" cpu="" peak="" registered=0 models=0
  local rot_med="" rot_max="" c_med="" c_max=""
  echo "== $scene: $mapper" >&2
  if timeout "$timeout_seconds" /usr/bin/time -f "%e %U %S %M" -o "$output.time" \
      "$@" > "$output.log" 2>&1; then
    read -r seconds user sys kib < "$output.time"
    cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }')
    peak=$((kib / 1024))
  else
    local rc=$?
    status=failed
    [ "$rc" = 124 ] && status=timeout
    if [ -f "$output.time" ] && [ "$status" = failed ]; then
      read -r seconds user sys kib < <(tail -1 "$output.time") || true
    fi
    echo "   $status (exit $rc), see $output.log" >&2
  fi
  if [ "$status" = ok ]; then
    models=$(find "$output" -mindepth 1 -maxdepth 1 -type d | wc -l)
    local model
    model=$(largest_model "$output")
    if [ -n "$model" ] &&
        "$binary" model_comparer --input_path1 "$model" "${gt_args[@]}" \
          > "$output.compare" 2>&1; then
      registered=$(sed -n 's/.*(model 1: \([0-9]*\),.*/\1/p' "$output.compare")
      read -r rot_med rot_max < <(sed -n 's/^rotation error \[deg\]: median \([0-9.e+-]*\), max \([0-9.e+-]*\).*/\1 \2/p' "$output.compare")
      read -r c_med c_max < <(sed -n 's/^centre error: median \([0-9.e+-]*\), max \([0-9.e+-]*\).*/\1 \2/p' "$output.compare" |
        awk '{ printf "%.2f %.2f\n", 1000 * $1, 1000 * $2 }')
    else
      registered=$(sed -n 's/.*(model 1: \([0-9]*\),.*/\1/p' "$output.compare" 2>/dev/null || true)
      status=no_alignment
    fi
  fi
  echo "   ${seconds:-?} s, ${peak:-?} MiB, ${registered:-0} registered, rotation ${rot_med:-?} deg, centre ${c_med:-?} mm" >&2
  echo "$scene,$kind,$num_images,$mapper,$status,$seconds,$cpu,$peak,${registered:-0},$models,$rot_med,$rot_max,$c_med,$c_max" >> "$results"
}

# skip_row SCENE KIND NUM_IMAGES MAPPER REASON
skip_row() {
  echo "$1,$2,$3,$4,$5,,,,,,,,," >> "$results"
}

# bench_scene SCENE KIND NUM_IMAGES DATABASE IMAGE_PATH GT_ARGS...
bench_scene() {
  local scene=$1 kind=$2 num_images=$3 database=$4 image_path=$5
  shift 5
  local runs=$out/runs/$scene
  mkdir -p "$runs"
  run_mapper "$scene" "$kind" "$num_images" colmap_irav4 "$runs/irav4" "$@" -- \
    env OMP_NUM_THREADS="$threads" "$binary" mapper --database_path "$database" \
      --image_path "$image_path" --output_path "$runs/irav4" \
      --Mapper.num_threads "$threads"
  if [ -f "$runs/irav4/summary.json" ]; then
    "$python" - "$runs/irav4/summary.json" "$scene" "$out/stages.csv" "$out/memory.csv" <<'EOF'
import json, sys
summary = json.load(open(sys.argv[1]))
scene = sys.argv[2]
stages = list(summary.get("stages", []))
for model in summary.get("models", [])[:1]:
    stages += model.get("stages", [])
with open(sys.argv[3], "a") as out:
    for stage in stages:
        out.write("%s,%s,%.3f,%.3f,%.1f,%.1f,%.1f\n" % (
            scene, stage["name"].replace(",", ";"), stage["seconds"],
            stage.get("cpu_seconds", 0), stage.get("memory_mib", 0),
            stage.get("peak_memory_mib", 0), stage.get("peak_rise_mib", 0)))
observations = sum(m.get("num_observations", 0) for m in summary.get("models", []))
peak = summary.get("peak_memory_mib") or 0
stage = summary.get("peak_memory_stage", "")
per_observation = summary.get("peak_bytes_per_observation") or 0
per_pair = summary.get("peak_bytes_per_pair") or 0
with open(sys.argv[4], "a") as out:
    out.write("%s,%.1f,%s,%d,%d,%.0f,%.0f\n" % (
        scene, peak, stage.replace(",", ";"), observations,
        summary.get("num_database_pairs", 0), per_observation, per_pair))
sys.stderr.write("   memory: peak %.0f MiB in %s, %.0f bytes per observation "
                 "(%d), %.0f per verified pair (%d)\n" % (
                     peak, stage or "?", per_observation, observations,
                     per_pair, summary.get("num_database_pairs", 0)))
EOF
  fi
  if [ "$run_colmap" = 1 ]; then
    if [ "$num_images" -le "$colmap_max_images" ]; then
      cp "$database" "$runs/colmap.db"
      chmod u+w "$runs/colmap.db"
      run_mapper "$scene" "$kind" "$num_images" colmap38_incremental "$runs/colmap" "$@" -- \
        colmap mapper --database_path "$runs/colmap.db" --image_path "$image_path" \
          --output_path "$runs/colmap" --Mapper.num_threads "$threads"
      rm -f "$runs/colmap.db"
    else
      skip_row "$scene" "$kind" "$num_images" colmap38_incremental "skipped_above_$colmap_max_images"
    fi
  fi
  if [ -n "$global_mapper" ]; then
    if [ "$num_images" -le "$global_mapper_max_images" ]; then
      cp "$database" "$runs/global.db"
      chmod u+w "$runs/global.db"
      run_mapper "$scene" "$kind" "$num_images" colmap4_global_mapper "$runs/global" "$@" -- \
        "$global_mapper" global_mapper --database_path "$runs/global.db" \
          --image_path "$image_path" --output_path "$runs/global"
      rm -f "$runs/global.db"
    else
      skip_row "$scene" "$kind" "$num_images" colmap4_global_mapper "skipped_above_$global_mapper_max_images"
    fi
  fi
}

if [ "$run_strecha" = 1 ]; then
  for dir in "$data_dir"/strecha/*/; do
    dir=${dir%/}
    [ -f "$dir/database.db" ] || continue
    name=$(basename "$dir")
    n=$(ls "$dir/gt_cameras" | grep -c '\.camera$' || true)
    bench_scene "$name" strecha "$n" "$dir/database.db" "$dir/images" --gt_path "$dir/gt_cameras"
  done
fi

# The photo-collection protocol (docs/notes/2026-12-03-photo-collection-scenes.md).
photo_args=(--random_pair_rate 0.1 --mirror_pair_rate 0.05
  --max_keypoints_per_image 3000 --match_angle_falloff_deg 40
  --match_distance_falloff 60 --match_rate_sigma 0.5)
[ "$layout" = photo ] && generator_args+=("${photo_args[@]}")

IFS=',' read -r -a size_list <<< "$sizes"
IFS=',' read -r -a seed_list <<< "$seeds"
for n in "${size_list[@]}"; do
  for seed in "${seed_list[@]}"; do
    scene=${layout}${scene_suffix}_$n
    [ "${#seed_list[@]}" -gt 1 ] && scene=${scene}_s$seed
    scene_dir=$out/scenes/$scene
    if [ ! -f "$scene_dir/database.db" ]; then
      "$generator" --output_path "$scene_dir" --overwrite 1 --layout "$layout" \
        --num_images "$n" --seed "$seed" "${generator_args[@]}" | tee "$scene_dir.txt" >&2
    fi
    mkdir -p "$scene_dir/images"  # no pixels: grey points
    bench_scene "$scene" synthetic "$n" "$scene_dir/database.db" "$scene_dir/images" \
      --input_path2 "$scene_dir/gt"
    if [ "$layout" = photo ]; then
      for mapper in irav4 colmap global; do
        [ -d "$out/runs/$scene/$mapper" ] || continue
        header=()
        [ -f "$out/photo.csv" ] || header=(--header)
        "$python" "$root/scripts/evaluate_photo_models.py" "${header[@]}" \
          --scene "$scene_dir" --models "$out/runs/$scene/$mapper" \
          --binary "$binary" --label "$scene/$mapper" >> "$out/photo.csv"
      done
    fi
  done
done

echo "load at end: $(cut -d' ' -f1-3 /proc/loadavg)" >> "$out/machine.txt"

# One row per scene, ours beside COLMAP (ratios), JSON, and the plots when
# matplotlib is installed.
"$python" "$root/scripts/plot_benchmarks.py" --results "$results" --out "$out"
echo "Results in $out (results.csv, comparison.csv, accuracy_summary.csv, results.json, stages.csv, memory.csv, machine.txt)"
