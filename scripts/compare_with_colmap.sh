#!/usr/bin/env bash
# Side by side on one database: COLMAP 3.8's incremental mapper and
# colmap_irav4's global mapper, 2 threads each; prints wall time and peak
# memory of both, then compares the two models (and each with ground truth
# when a Strecha gt_cameras directory is given).
#   scripts/compare_with_colmap.sh DATABASE IMAGES WORKSPACE [GT_CAMERAS_DIR]
# The database is copied into WORKSPACE first: COLMAP opens it read-write.
set -euo pipefail
if [ $# -lt 3 ]; then
  echo "usage: $0 DATABASE IMAGES WORKSPACE [GT_CAMERAS_DIR]" >&2
  exit 2
fi
database=$1
images=$2
workspace=$3
gt=${4:-}
root=$(cd "$(dirname "$0")/.." && pwd)
binary=${COLMAP_IRAV4:-$root/build/colmap_irav4}
[ -f "$database" ] || { echo "ERROR: $database: no such file" >&2; exit 1; }
[ -x "$binary" ] || { echo "ERROR: $binary: not built (run scripts/setup.sh)" >&2; exit 1; }
rm -rf "$workspace"
mkdir -p "$workspace/colmap" "$workspace/irav4"
cp "$database" "$workspace/colmap.db"
cp "$database" "$workspace/irav4.db"
chmod u+w "$workspace"/*.db

measure() {  # name, command...: prints "name seconds peak_MiB"
  local name=$1; shift
  /usr/bin/time -f "%e %M" -o "$workspace/$name.time" "$@" \
    > "$workspace/$name.log" 2>&1 ||
    { echo "ERROR: $name failed, see $workspace/$name.log" >&2; tail -5 "$workspace/$name.log" >&2; exit 1; }
  read -r seconds kib < "$workspace/$name.time"
  echo "$name $seconds $((kib / 1024))"
}

colmap_line=$(measure colmap colmap mapper --database_path "$workspace/colmap.db" \
  --image_path "$images" --output_path "$workspace/colmap" --Mapper.num_threads 2)
irav4_line=$(measure irav4 env OMP_NUM_THREADS=2 "$binary" mapper \
  --database_path "$workspace/irav4.db" --image_path "$images" \
  --output_path "$workspace/irav4" --Mapper.num_threads 2)

printf "%-22s %10s %12s\n" mapper "wall [s]" "peak [MiB]"
read -r _ c_s c_m <<< "$colmap_line"
read -r _ i_s i_m <<< "$irav4_line"
printf "%-22s %10s %12s\n" "colmap mapper (3.8)" "$c_s" "$c_m"
printf "%-22s %10s %12s\n" "colmap_irav4 mapper" "$i_s" "$i_m"
awk -v c="$c_s" -v i="$i_s" 'BEGIN { if (i > 0) printf "speed-up: %.1fx\n", c / i }'

echo "== colmap_irav4 vs colmap"
"$binary" model_comparer --input_path1 "$workspace/irav4/0" \
  --input_path2 "$workspace/colmap/0"
if [ -n "$gt" ]; then
  echo "== colmap vs ground truth"
  "$binary" model_comparer --input_path1 "$workspace/colmap/0" --gt_path "$gt"
  echo "== colmap_irav4 vs ground truth"
  "$binary" model_comparer --input_path1 "$workspace/irav4/0" --gt_path "$gt"
fi
