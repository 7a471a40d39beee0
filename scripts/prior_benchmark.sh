#!/usr/bin/env bash
# Pose priors side by side, in one run, on synthetic scenes with GPS-like
# priors (scene_generator --pose_priors: 3 m horizontal, 5 m vertical noise,
# gravity with 1 deg noise; with and without 5% outliers 30-100 m off):
#   ours_priors      colmap_irav4 mapper on database_colmap4.db (WGS84
#                    positions with covariance, gravity), no alignment;
#   ours_positions   the same on database_colmap311.db (positions only);
#   ours_no_priors   --Mapper.use_pose_priors 0, similarity-aligned to the
#                    truth (for reference: what the images alone give);
#   colmap38         COLMAP 3.8's `colmap mapper` then `colmap model_aligner
#                    --ref_images_path pose_priors_enu.txt --ref_is_gps 0
#                    --robust_alignment 1 --robust_alignment_max_error 10`,
#                    no alignment after that;
# every error against the truth in the priors' frame (gt_prior).
#
#   scripts/prior_benchmark.sh [--out DIR] [--sizes 100,300] [--seed 1]
#       [--threads 2] [--no_colmap]
#
# COLMAP's mapper runs once per scene (its input does not depend on the
# priors) on a copy of the database; existing runs (ours and COLMAP's
# DIR/colmap_N_sS/ with its .time) are reused: delete them to rerun. Writes DIR/results.csv: scene, outliers,
# mapper, CPU seconds (user + system, GNU time; COLMAP's is mapper +
# aligner), wall seconds, registered images, rotation and centre errors
# (median, max; deg and m).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=prior_benchmark_results
sizes=100,300
seed=1
threads=2
run_colmap=1
while [ $# -gt 0 ]; do
  case $1 in
    --out) out=$2; shift 2 ;;
    --sizes) sizes=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --no_colmap) run_colmap=0; shift ;;
    *) echo "unknown option $1" >&2; exit 1 ;;
  esac
done
binary=${COLMAP_IRAV4:-$root/build/colmap_irav4}
generator=${SCENE_GENERATOR:-$root/build/scene_generator}
for tool in "$binary" "$generator"; do
  [ -x "$tool" ] || { echo "ERROR: $tool not built" >&2; exit 1; }
done
if [ "$run_colmap" = 1 ] && ! command -v colmap > /dev/null; then
  echo "ERROR: colmap not on the PATH (or --no_colmap)" >&2
  exit 1
fi
mkdir -p "$out"
out=$(cd "$out" && pwd)
results=$out/results.csv
echo "scene,outliers,mapper,cpu_seconds,wall_seconds,registered,rotation_median_deg,rotation_max_deg,center_median_m,center_max_m" > "$results"

# timed OUTPUT_PREFIX COMMAND...: runs it under GNU time; sets cpu, wall.
timed() {
  local prefix=$1
  shift
  /usr/bin/time -f "%e %U %S" -o "$prefix.time" "$@" > "$prefix.log" 2>&1
  read -r wall user sys < "$prefix.time"
  cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }')
}

# compare SCENE OUTLIERS MAPPER CPU WALL MODEL GT ALIGNMENT
compare() {
  local row="$1,$2,$3,$4,$5"
  if "$binary" model_comparer --input_path1 "$6" --input_path2 "$7" \
      --Comparer.alignment "$8" > "$6.compare" 2>&1; then
    local registered rot c
    registered=$(sed -n 's/.*(model 1: \([0-9]*\),.*/\1/p' "$6.compare")
    rot=$(sed -n 's/^rotation error \[deg\]: median \([0-9.e+-]*\), max \([0-9.e+-]*\).*/\1,\2/p' "$6.compare")
    c=$(sed -n 's/^centre error: median \([0-9.e+-]*\), max \([0-9.e+-]*\).*/\1,\2/p' "$6.compare")
    echo "$row,$registered,$rot,$c" >> "$results"
  else
    echo "$row,0,,,," >> "$results"
  fi
  tail -1 "$results" >&2
}

IFS=',' read -r -a size_list <<< "$sizes"
for n in "${size_list[@]}"; do
  for outliers in 0.05 0; do
    scene=courtyard_${n}_s${seed}_outliers${outliers}
    dir=$out/scenes/$scene
    mkdir -p "$out/scenes"
    if [ ! -f "$dir/database_colmap4.db" ]; then
      "$generator" --output_path "$dir" --overwrite 1 --layout courtyard \
        --num_images "$n" --seed "$seed" --pose_priors 1 \
        --prior_outlier_fraction "$outliers" > "$dir.txt"
    fi
    mkdir -p "$dir/images"
    runs=$out/runs/$scene
    mkdir -p "$runs"
    for variant in priors positions no_priors; do
      case $variant in
        priors) args=(--database_path "$dir/database_colmap4.db") ;;
        positions) args=(--database_path "$dir/database_colmap311.db") ;;
        no_priors) args=(--database_path "$dir/database.db"
                         --Mapper.use_pose_priors 0) ;;
      esac
      if [ -f "$runs/ours_$variant/0/images.bin" ] &&
          [ -f "$runs/ours_$variant.time" ]; then
        read -r wall user sys < "$runs/ours_$variant.time"  # reused
        cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }')
      else
        rm -rf "$runs/ours_$variant"
        mkdir -p "$runs/ours_$variant"
        echo "== $scene: ours_$variant" >&2
        timed "$runs/ours_$variant" env OMP_NUM_THREADS="$threads" "$binary" \
          mapper "${args[@]}" --image_path "$dir/images" \
          --output_path "$runs/ours_$variant" --Mapper.num_threads "$threads"
      fi
      alignment=none
      [ "$variant" = no_priors ] && alignment=similarity
      compare "$scene" "$outliers" "ours_$variant" "$cpu" "$wall" \
        "$runs/ours_$variant/0" "$dir/gt_prior" "$alignment"
    done
    if [ "$run_colmap" = 1 ]; then
      # One COLMAP mapper run per size (the scene is the same for both
      # prior sets), its time added to each aligner's.
      colmap_dir=$out/colmap_${n}_s${seed}
      if [ ! -f "$colmap_dir/0/images.bin" ]; then
        rm -rf "$colmap_dir"
        mkdir -p "$colmap_dir"
        cp "$dir/database.db" "$colmap_dir.db"
        chmod u+w "$colmap_dir.db"
        echo "== $scene: colmap mapper" >&2
        timed "$colmap_dir" colmap mapper --database_path "$colmap_dir.db" \
          --image_path "$dir/images" --output_path "$colmap_dir" \
          --Mapper.num_threads "$threads"
        rm -f "$colmap_dir.db"
      fi
      read -r mapper_wall mapper_user mapper_sys < "$colmap_dir.time"
      aligned=$runs/colmap38_aligned
      rm -rf "$aligned"
      mkdir -p "$aligned"
      timed "$aligned" colmap model_aligner --input_path "$colmap_dir/0" \
        --output_path "$aligned" --ref_images_path "$dir/pose_priors_enu.txt" \
        --ref_is_gps 0 --alignment_type custom --robust_alignment 1 \
        --robust_alignment_max_error 10
      total_cpu=$(awk -v a="$cpu" -v u="$mapper_user" -v s="$mapper_sys" \
        'BEGIN { printf "%.2f", a + u + s }')
      total_wall=$(awk -v a="$wall" -v b="$mapper_wall" \
        'BEGIN { printf "%.2f", a + b }')
      compare "$scene" "$outliers" colmap38_model_aligner "$total_cpu" \
        "$total_wall" "$aligned" "$dir/gt_prior" none
    fi
  done
done
echo "Results in $results" >&2
