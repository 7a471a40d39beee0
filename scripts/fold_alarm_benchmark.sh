#!/usr/bin/env bash
# False fold alarms beside detected folds, in one run (issue 23): our mapper
# on
#   nonsym  courtyards without mirror pairs whose match counts vary like
#           real captures (the V1 and V2 variations of
#           docs/notes/2026-12-02-fold-false-alarms.md), at --sizes and
#           --seeds;
#   plain   the symmetric suite of docs/BENCHMARKS.md: courtyard 100 at
#           mirror pair rates 0 0.05 0.1 0.2 0.3;
#   v2mirror V2 courtyard 100 with mirror pairs (0.1 0.2 0.3): folds under
#           varying match rates;
#   tower   tower 60 at 0.2 0.4 0.5 (--point_density 15 --noise_px 0.5);
#   real    every database given by REAL_DBS (default the Strecha scenes of
#           the shared data, errors against their gt_cameras).
# The synthetic suites go through scripts/symmetric_benchmark.sh (COLMAP=0,
# REUSE=1 by default here: a scene generated once, and our mapper's result
# on it, is reused; REUSE=0 generates and maps again).
#
#   scripts/fold_alarm_benchmark.sh WORKSPACE [--sizes 100,300] [--seeds 1,2,3]
#       [--variations V1,V2] [--suites nonsym,plain,v2mirror,tower,real]
#
# --seeds applies to every synthetic suite. One table row per scene: models
# written, registered images, cameras turned by more than 30 deg (against the
# generator's exact model, or the Strecha ground truth), the distinct fold
# outcomes of its models, the mapper's exit code (3: a model written flagged
# folded), CPU seconds and a verdict:
#   scenes without mirror pairs (nonsym, rate 0, real): "ok" only for one
#     model, outcome clean (or "clean after refinement"), exit 0 and no
#     camera turned; anything else is a false alarm, "FAIL:" with what failed
#     (models, outcome, exit, turned: a rigidity split into several models or
#     a camera turned in a clean model counts too, the issue asks for one
#     clean model);
#   scenes with mirror pairs: "detected" when a model's outcome names a fold
#     (resolved, folded, or a fold split; "split (not rigid)" alone does
#     not), "SILENT FOLD" (a miss) when none does and cameras are turned,
#     "no fold" when none does and no camera is turned (the mirror pairs
#     folded nothing that was written: neither a detection nor a miss).
# Then the false-alarm rate (with how many of those scenes name a fold or
# exit 3: fold alarms proper) and the detection rate (detected of detected +
# silent folds) side by side. The table is also written to
# WORKSPACE/fold_alarms_TAG.txt. Runs in order: real,
# plain, v2mirror, tower, nonsym (sizes in the order given), one mapper at a
# time. Environment: BUILD, TAG, THREADS (default 1), OURS_ARGS as for
# symmetric_benchmark.sh; REAL_DBS (space-separated databases; each needs
# gt_cameras beside it for the turned count); DATA_DIR (default
# $COLMAP_IRAV4_DATA_DIR, else ../shared/data from the project root).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
usage() {
  echo "usage: $0 WORKSPACE [--sizes 100,300] [--seeds 1,2,3] [--variations V1,V2]" \
       "[--suites nonsym,plain,v2mirror,tower,real]" >&2
  exit 2
}
[ $# -ge 1 ] || usage
workspace=$1
shift
sizes="100 300"
seeds="1 2 3"
variations="V1 V2"
suites="nonsym plain v2mirror tower real"
while [ $# -gt 0 ]; do
  [ $# -ge 2 ] || usage
  case $1 in
    --sizes) sizes=${2//,/ } ;;
    --seeds) seeds=${2//,/ } ;;
    --variations) variations=${2//,/ } ;;
    --suites) suites=${2//,/ } ;;
    *) usage ;;
  esac
  shift 2
done
build=${BUILD:-$root/build}
tag=${TAG:-ours}
threads=${THREADS:-1}
ours_args=${OURS_ARGS:-}
export BUILD=$build TAG=$tag THREADS=$threads OURS_ARGS=$ours_args
export REUSE=${REUSE:-1} COLMAP=0 OURS=1
data_dir=${DATA_DIR:-${COLMAP_IRAV4_DATA_DIR:-$root/../shared/data}}
real_dbs=${REAL_DBS:-$(ls "$data_dir"/strecha/*/database.db 2> /dev/null || true)}
# The variations (history: docs/notes/2026-12-02-fold-false-alarms.md).
V1="--random_pair_rate 0.02 --max_keypoints_per_image 1000 --match_angle_falloff_deg 25 --match_distance_falloff 20 --match_rate_sigma 0.3"
V2="--random_pair_rate 0.02 --max_keypoints_per_image 600 --match_angle_falloff_deg 20 --match_distance_falloff 15 --match_rate_sigma 0.5"
TOWER="--point_density 15 --noise_px 0.5"
for tool in colmap_irav4 scene_generator fold_eval; do
  [ -x "$build/$tool" ] || { echo "ERROR: $build/$tool: not built" >&2; exit 1; }
done
mkdir -p "$workspace"
workspace=$(cd "$workspace" && pwd)
rows=$workspace/fold_alarms_${tag}.rows
: > "$rows"

has() { [[ " $suites " == *" $1 "* ]]; }

# Appends symmetric_benchmark.sh's rows of our mapper to $rows, prefixed by
# the suite's name: suite layout size gen_args rates.
synthetic() {
  local suite=$1 layout=$2 size=$3 gen_args=$4 rates=$5 gen_tag table
  echo "== $suite: $layout $size, rates $rates, seeds $seeds${gen_args:+, $gen_args}" >&2
  GEN_ARGS="$gen_args" "$root/scripts/symmetric_benchmark.sh" "$workspace" \
    "$rates" "$seeds" "$size" "$layout" > /dev/null
  gen_tag=$(echo "$gen_args" | tr -s ' -' '_' | sed 's/^_//; s/_$//')
  table=$workspace/table_${layout}_n${size}${gen_tag:+_$gen_tag}_${tag}.txt
  # "not run" is two words: one field "not_run".
  awk -v suite="$suite" -v size="$size" -v tag="$tag" \
    'NR > 1 && $6 == tag { sub(/not run/, "not_run"); print suite, size, $0 }' \
    "$table" >> "$rows"
}

# Our mapper on a real database, then the same row fields as
# symmetric_benchmark.sh's: turned and registered summed over the models,
# rotation errors by model_comparer --gt_path per model.
real() {
  local db=$1 name dir gt code models reg turned fold wall user sys cpu
  name=$(basename "$(dirname "$db")")
  dir=$workspace/real/$name
  gt=$(dirname "$db")/gt_cameras
  echo "== real: $name" >&2
  mkdir -p "$dir"
  if [ "$REUSE" != 1 ] || [ ! -s "$dir/$tag.time" ]; then
    rm -rf "${dir:?}/$tag" && mkdir -p "$dir/$tag"
    code=0
    # shellcheck disable=SC2086
    /usr/bin/time -f "%e %U %S" -o "$dir/$tag.time" env OMP_NUM_THREADS=1 \
      "$build/colmap_irav4" mapper --database_path "$db" \
      --output_path "$dir/$tag" --Mapper.num_threads "$threads" \
      --Mapper.progress 0 $ours_args > "$dir/$tag.log" 2>&1 || code=$?
    echo "$code" > "$dir/$tag.exit"
  fi
  models=0 turned=0
  for model in "$dir/$tag"/[0-9]*; do
    [ -d "$model" ] || continue
    models=$((models + 1))
    if [ -d "$gt" ]; then
      "$build/colmap_irav4" model_comparer --input_path1 "$model" \
        --gt_path "$gt" --per_image 1 > "$model.comparer.txt" 2>&1 || true
      # Per-image lines: name, rotation-only, similarity rotation, centre
      # error (fold_eval counts the similarity one).
      turned=$((turned + $(awk 'p && NF >= 4 && $3 > 30 {++n} /^per image/ {p = 1} END {print n + 0}' \
                             "$model.comparer.txt")))
    else
      turned="-"
    fi
  done
  reg=$(python3 -c 'import json, sys; print(sum(m["num_registered_images"] for m in json.load(open(sys.argv[1]))["models"]))' \
          "$dir/$tag/summary.json" 2> /dev/null || echo "-")
  fold=$(python3 - "$dir/$tag/summary.json" <<'PY' 2>/dev/null || echo "-"
import json, sys
summary = json.load(open(sys.argv[1]))
print(";".join("%.3f:%s" % (-1 if m.get("fold_score") is None else m["fold_score"],
                            m.get("fold_outcome", "").replace(" ", "_"))
               for m in summary["models"]) or "no_model")
PY
)
  read -r wall user sys < <(tail -n 1 "$dir/$tag.time") || true
  cpu=$(awk -v u="${user:-0}" -v s="${sys:-0}" 'BEGIN { printf "%.1f", u + s }')
  # The fields of symmetric_benchmark.sh's rows (pairs and centre errors
  # left out).
  echo "real - real 0 $name - 0 $tag $models $reg $turned - - ${wall:--} $cpu $(cat "$dir/$tag.exit") $fold" >> "$rows"
}

if has real; then
  [ -n "$real_dbs" ] || echo "WARNING: no database under $data_dir/strecha" \
    "(set DATA_DIR or REAL_DBS): no real scene" >&2
  for db in $real_dbs; do real "$db"; done
fi
has plain && synthetic plain courtyard 100 "" "0 0.05 0.1 0.2 0.3"
has v2mirror && synthetic v2mirror courtyard 100 "$V2" "0.1 0.2 0.3"
has tower && synthetic tower tower 60 "$TOWER" "0.2 0.4 0.5"
if has nonsym; then
  for size in $sizes; do
    for variation in $variations; do
      case $variation in
        V1) synthetic "nonsym_V1" courtyard "$size" "$V1" 0 ;;
        V2) synthetic "nonsym_V2" courtyard "$size" "$V2" 0 ;;
        *) echo "ERROR: unknown variation $variation (V1 or V2)" >&2; exit 2 ;;
      esac
    done
  done
fi

# Row fields: 1 suite, 2 size, 3 layout (or "real"), 4 rate, 5 seed (or the
# real scene's name), 6 pairs, 7 mirror pairs, 8 mapper, 9 models,
# 10 registered, 11 turned, 12-13 centre errors, 14 wall, 15 cpu, 16 exit,
# 17 fold score:outcome per model (";"-separated, spaces as "_").
out=$workspace/fold_alarms_${tag}.txt
awk '
  function outcomes(field,    n, k, parts, o, seen, list) {
    n = split(field, parts, ";")
    list = ""
    for (k = 1; k <= n; ++k) {
      o = parts[k]; sub(/^[-0-9.]*:/, "", o); gsub(/_/, " ", o)
      if (o == "") o = "(none)"
      if (!(o in seen)) { seen[o] = 1; list = list (list == "" ? "" : ", ") o }
    }
    return list
  }
  # A model outcome that names a fold: resolved, folded, a fold split. The
  # rigidity split ("split (not rigid)") and clean outcomes do not.
  function fired(field,    n, k, parts, o) {
    n = split(field, parts, ";")
    for (k = 1; k <= n; ++k) {
      o = parts[k]; sub(/^[-0-9.]*:/, "", o); gsub(/_/, " ", o)
      sub(/(, )?split \(not rigid\)$/, "", o)
      # "-" and "no model": no summary.json or no model, no outcome.
      if (o != "" && o != "-" && o != "no model" && o != "clean" &&
          o != "clean after refinement") return 1
    }
    return 0
  }
  function clean_only(field,    n, k, parts, o) {
    n = split(field, parts, ";")
    for (k = 1; k <= n; ++k) {
      o = parts[k]; sub(/^[-0-9.]*:/, "", o); gsub(/_/, " ", o)
      if (o != "clean" && o != "clean after refinement") return 0
    }
    return n > 0
  }
  BEGIN {
    fmt = "%-10s %-26s %-6s %-6s %-4s %-6s %-7s %-4s %-20s %s\n"
    printf fmt, "suite", "scene", "mirror", "models", "reg", "turned", \
      "cpu_s", "exit", "verdict", "fold outcomes"
  }
  {
    if ($3 == "real") scene = $5
    else scene = sprintf("%s %s r%s s%s", $3, $2, $4, $5)
    if ($9 == "not_run") {
      printf fmt, $1, scene, $7, "not run", "-", "-", "-", "-", "-", ""
      ++not_run; next
    }
    mirror = ($7 == "-") ? ($4 > 0) : ($7 > 0)
    if (!mirror) {
      # What keeps the scene from being one clean model (turned "-": a real
      # database without gt_cameras).
      why = ($9 != 1 ? "+models" : "") (clean_only($17) ? "" : "+outcome") \
            ($16 != 0 ? "+exit" : "") ($11 != "-" && $11 > 0 ? "+turned" : "")
      ok = (why == "")
      verdict = ok ? ($11 == "-" ? "ok (no gt)" : "ok") : "FAIL:" substr(why, 2)
      ++scenes_without; alarms += !ok
      fold_alarms += (fired($17) || $16 == 3)
      if ($1 == "real") { ++real_n; real_alarms += !ok }
    } else {
      f = fired($17)
      verdict = f ? "detected" : ($11 > 0 ? "SILENT FOLD" : "no fold")
      ++scenes_with; detected += f; silent += (!f && $11 > 0)
      quiet += (!f && $11 == 0)
      turned_with += $11; exit3 += ($16 == 3)
    }
    printf fmt, $1, scene, $7, $9, $10, $11, $15, $16, verdict, outcomes($17)
  }
  END {
    printf "false-alarm rate: %d of %d scenes without mirror pairs (real: %d of %d;" \
      " a fold named or exit 3 on %d)" \
      " | detection rate: %d of %d folded scenes (silent folds %d; %d of %d" \
      " scenes with mirror pairs without a fold written; cameras turned >" \
      " 30 deg in all %d; exit 3 on %d)%s\n",
      alarms, scenes_without, real_alarms, real_n, fold_alarms, detected,
      detected + silent,
      silent, quiet, scenes_with, turned_with, exit3,
      not_run ? sprintf("; %d not run", not_run) : ""
  }' "$rows" > "$out"
cat "$out"
echo "(threads per mapper: $threads; binary: $build/colmap_irav4; table: $out)"
