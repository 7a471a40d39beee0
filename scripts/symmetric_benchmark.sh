#!/usr/bin/env bash
# The symmetric-scene benchmark: synthetic scenes whose opposite
# walls look alike (scene_generator), with a rate of mirror-twin false pairs;
# colmap_irav4's mapper and COLMAP 3.8's incremental mapper (on a copy of the
# database) on the same scenes in the same run. Per run: models written,
# registered images, cameras turned by more than 30 deg against the exact
# ground truth, centre error over all registered cameras (median, mean;
# metres), wall and CPU seconds, our fold score:outcome per model and the
# mapper's exit code (3: a model written flagged folded). Then the detection
# rate (scenes with mirror pairs where our fold check fired: an outcome
# other than clean) beside the false-alarm rate (scenes without mirror pairs
# with an outcome other than clean or a non-zero exit), and the silent folds
# (cameras turned, outcome clean).
#
#   scripts/symmetric_benchmark.sh WORKSPACE [RATES] [SEEDS] [NUM_IMAGES] [LAYOUT]
#
# Defaults: RATES "0 0.05 0.1 0.2 0.3", SEEDS "1 2 3", NUM_IMAGES 100,
# LAYOUT courtyard. Two queues run side by side, one process each: scene
# generation followed by our mapper, and COLMAP (which starts on a scene as
# soon as it is generated). Environment:
#   BUILD   directory holding colmap_irav4, scene_generator and fold_eval
#   OURS=0  skips our mapper;  COLMAP=0 skips COLMAP
#   TAG     name of our output directory in each scene (default ours), so
#           that two builds can be compared on the same scenes
#   REUSE=1 keeps scenes and mapper results that already exist
#   THREADS threads per mapper (default 1)
#   OURS_ARGS extra arguments to our mapper
#   GEN_ARGS  extra arguments to scene_generator (e.g. "--point_density 15
#             --noise_px 0.5 --false_pair_inlier_fraction 0.7"); scenes are
#             named by them, so that different settings do not share a scene
# COLMAP 3.8's mapper requires --image_path to be a directory; the scenes
# have no image files, so the scene directory is passed (COLMAP then only
# warns that it cannot read the colours).
set -euo pipefail
if [ $# -lt 1 ]; then
  echo "usage: $0 WORKSPACE [RATES] [SEEDS] [NUM_IMAGES] [LAYOUT]" >&2
  exit 2
fi
workspace=$1
rates=${2:-"0 0.05 0.1 0.2 0.3"}
seeds=${3:-"1 2 3"}
num_images=${4:-100}
layout=${5:-courtyard}
root=$(cd "$(dirname "$0")/.." && pwd)
build=${BUILD:-$root/build}
run_colmap=${COLMAP:-1}
run_ours=${OURS:-1}
tag=${TAG:-ours}
reuse=${REUSE:-0}
threads=${THREADS:-1}
ours_args=${OURS_ARGS:-}
gen_args=${GEN_ARGS:-}
gen_tag=$(echo "$gen_args" | tr -s ' -' '_' | sed 's/^_//; s/_$//')
for tool in colmap_irav4 scene_generator fold_eval; do
  [ -x "$build/$tool" ] || { echo "ERROR: $build/$tool: not built" >&2; exit 1; }
done
if [ "$run_colmap" = 1 ]; then
  command -v colmap > /dev/null || { echo "ERROR: colmap not on PATH" >&2; exit 1; }
fi
mkdir -p "$workspace"
workspace=$(cd "$workspace" && pwd)
format="%-9s %-6s %-4s %-6s %-6s %-7s %-6s %-5s %-6s %-9s %-9s %-7s %-7s %-4s %s\n"

scene_dir() {  # rate seed
  echo "$workspace/${layout}_n${num_images}${gen_tag:+_$gen_tag}_r$1_s$2"
}

row() {  # scene mapper rate seed: prints the table row
  local scene=$1 mapper=$2 rate=$3 seed=$4
  local eval_line fold="-" wall="-" user=0 sys=0 cpu pairs mirror
  pairs=$(sqlite3 "file:$scene/database.db?immutable=1" \
    "select count(*) from two_view_geometries where rows > 0" 2>/dev/null || echo -)
  # The generator's summary line ("N true, M mirror-twin"), not its warning.
  mirror=$(grep -o "true, [0-9]* mirror-twin" "$scene.generator.log" \
             2>/dev/null | awk 'NR == 1 {print $2}' || true)
  if [ ! -f "$scene/$mapper.time" ]; then
    printf "$format" "$layout" "$rate" "$seed" "$pairs" "${mirror:--}" "$mapper" \
      "not run" - - - - - - - -
    return
  fi
  eval_line=$("$build/fold_eval" "$scene/gt" "$scene/$mapper" 2>/dev/null ||
              echo "models 0 registered 0 turned - centre_median_m - centre_mean_m -")
  read -r _ models _ reg _ turned _ cmed _ cmean <<< "$eval_line"
  # The last line of the time file: /usr/bin/time prepends a line when the
  # command exits non-zero.
  read -r wall user sys < <(tail -n 1 "$scene/$mapper.time") || true
  cpu=$(awk -v u="${user:-0}" -v s="${sys:-0}" 'BEGIN { printf "%.1f", u + s }')
  if [ -f "$scene/$mapper/summary.json" ]; then
    fold=$(python3 - "$scene/$mapper/summary.json" <<'PY' 2>/dev/null || echo "-"
import json, sys
summary = json.load(open(sys.argv[1]))
print(";".join("%.3f:%s" % (-1 if m.get("fold_score") is None else m["fold_score"],
                            m.get("fold_outcome", "").replace(" ", "_"))
               for m in summary["models"]) or "no_model")
PY
)
  fi
  local code
  code=$(cat "$scene/$mapper.exit" 2>/dev/null || echo -)
  printf "$format" "$layout" "$rate" "$seed" "$pairs" "${mirror:--}" "$mapper" \
    "$models" "$reg" "$turned" "$cmed" "$cmean" "$wall" "$cpu" "$code" "$fold"
}

scenes=()
for rate in $rates; do
  for seed in $seeds; do
    scenes+=("$rate $seed")
  done
done

generate_and_map_ours() {
  for item in "${scenes[@]}"; do
    read -r rate seed <<< "$item"
    local scene
    scene=$(scene_dir "$rate" "$seed")
    if [ "$reuse" != 1 ] || [ ! -f "$scene/.generated" ]; then
      rm -rf "$scene"
      # shellcheck disable=SC2086
      if ! "$build/scene_generator" --output_path "$scene" --layout "$layout" \
          --num_images "$num_images" --mirror_pair_rate "$rate" --seed "$seed" \
          $gen_args > "$scene.generator.log" 2>&1; then
        echo "ERROR: scene_generator failed, see $scene.generator.log" >&2
        mkdir -p "$scene" && touch "$scene/.failed"
        continue
      fi
      touch "$scene/.generated"
    fi
    # A run that was stopped leaves an empty time file: mapped again.
    if [ "$run_ours" = 1 ] &&
        { [ "$reuse" != 1 ] || [ ! -s "$scene/$tag.time" ]; }; then
      rm -rf "${scene:?}/$tag" && mkdir -p "$scene/$tag"
      local code=0
      # shellcheck disable=SC2086
      /usr/bin/time -f "%e %U %S" -o "$scene/$tag.time" env OMP_NUM_THREADS=1 \
        "$build/colmap_irav4" mapper --database_path "$scene/database.db" \
        --output_path "$scene/$tag" --Mapper.num_threads "$threads" \
        --Mapper.progress 0 $ours_args > "$scene/$tag.log" 2>&1 || code=$?
      echo "$code" > "$scene/$tag.exit"
      case $code in
        0) ;;
        3) echo "ours: a model is flagged folded (exit 3, $scene/$tag.log)" >&2 ;;
        *) echo "ours failed (see $scene/$tag.log)" >&2 ;;
      esac
    fi
  done
}

map_colmap() {
  for item in "${scenes[@]}"; do
    read -r rate seed <<< "$item"
    local scene
    scene=$(scene_dir "$rate" "$seed")
    while [ ! -f "$scene/.generated" ] && [ ! -f "$scene/.failed" ]; do
      sleep 2
    done
    [ -f "$scene/.generated" ] || continue
    if [ "$reuse" = 1 ] && [ -f "$scene/colmap.time" ]; then
      continue
    fi
    # Another run of this script on the same workspace may be mapping the
    # scene (several COLMAP queues): the lock directory says so.
    mkdir "$scene/colmap.lock" 2> /dev/null || continue
    rm -rf "$scene/colmap" && mkdir -p "$scene/colmap"
    cp "$scene/database.db" "$scene/colmap.db"
    /usr/bin/time -f "%e %U %S" -o "$scene/colmap.time" colmap mapper \
      --database_path "$scene/colmap.db" --image_path "$scene" \
      --output_path "$scene/colmap" --Mapper.num_threads "$threads" \
      > "$scene/colmap.log" 2>&1 || echo "colmap failed (see $scene/colmap.log)" >&2
    rm -f "$scene/colmap.db"
    rmdir "$scene/colmap.lock"
  done
}

# A stale marker of an earlier run must not let COLMAP start on a scene that
# is being regenerated.
if [ "$reuse" != 1 ]; then
  for item in "${scenes[@]}"; do
    read -r rate seed <<< "$item"
    rm -f "$(scene_dir "$rate" "$seed")/.generated"
  done
fi
generate_and_map_ours &
ours_pid=$!
if [ "$run_colmap" = 1 ]; then
  map_colmap
fi
wait "$ours_pid" || true

table=$workspace/table_${layout}_n${num_images}${gen_tag:+_$gen_tag}_${tag}.txt
{
  printf "$format" layout rate seed pairs mirror mapper models reg turned \
    c_med_m c_mean_m wall_s cpu_s exit fold
  for item in "${scenes[@]}"; do
    read -r rate seed <<< "$item"
    scene=$(scene_dir "$rate" "$seed")
    row "$scene" "$tag" "$rate" "$seed"
    if [ "$run_colmap" = 1 ] || [ -f "$scene/colmap.time" ]; then
      row "$scene" colmap "$rate" "$seed"
    fi
  done
} > "$table"
cat "$table"
echo "(images per scene: $num_images, layout: $layout, threads per mapper: $threads)"
# Our rows: the fold check fired (any model's outcome other than clean or
# "clean after refinement", where only the check after positioning saw weak
# pairs) on
# scenes with and without mirror pairs (column 5 counts them; the rate
# column where the generator's log is missing).
awk -v tag="$tag" 'NR > 1 && $6 == tag && $7 != "not" {
    mirror = ($5 == "-") ? ($2 > 0) : ($5 > 0)
    fired = 0
    n = split($15, models, ";")
    for (k = 1; k <= n; ++k) if (models[k] !~ /:clean(_after_refinement)?$/) fired = 1
    if (mirror) { ++folded; detected += fired; silent += (!fired && $9 > 0) }
    else { ++clean; alarms += (fired || $14 != 0) }
  }
  END {
    printf "ours (%s): detection rate %d of %d scenes with mirror pairs, " \
      "silent folds (turned, outcome clean) %d; false-alarm rate %d of %d " \
      "scenes without (outcome not clean or exit not 0)\n",
      tag, detected, folded, silent, alarms, clean
  }' "$table"
