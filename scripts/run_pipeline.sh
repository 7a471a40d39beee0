#!/usr/bin/env bash
# From images to a COLMAP sparse model with colmap_irav4:
#   scripts/run_pipeline.sh IMAGES WORKSPACE [CAMERA_MODEL]
# COLMAP 3.8 extracts SIFT features and matches exhaustively into
# WORKSPACE/database.db, colmap_irav4 maps into WORKSPACE/sparse/N, and
# `colmap model_analyzer` checks and summarises every model. The exit code is
# the mapper's: 3 when a model was written flagged FOLDED (summary.json says
# which), after every model has been summarised.
# Photos with an EXIF orientation tag (phones' portrait shots) are used as
# stored, as COLMAP reads them: the models' cameras are then turned by the
# tag's angle against what an image viewer shows.
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: $0 IMAGES WORKSPACE [CAMERA_MODEL (default SIMPLE_RADIAL)]" >&2
  exit 2
fi
images=$(realpath "$1")
workspace=$2
camera_model=${3:-SIMPLE_RADIAL}
root=$(cd "$(dirname "$0")/.." && pwd)
binary=${COLMAP_IRAV4:-$root/build/colmap_irav4}
[ -d "$images" ] || { echo "ERROR: $images: not a directory" >&2; exit 1; }
[ -x "$binary" ] || { echo "ERROR: $binary: not built (run scripts/setup.sh)" >&2; exit 1; }
mkdir -p "$workspace/sparse"
db=$workspace/database.db

colmap feature_extractor --database_path "$db" --image_path "$images" \
  --ImageReader.camera_model "$camera_model" --ImageReader.single_camera 1 \
  --SiftExtraction.use_gpu 0
colmap exhaustive_matcher --database_path "$db" --SiftMatching.use_gpu 0
status=0
"$binary" mapper --database_path "$db" --image_path "$images" \
  --output_path "$workspace/sparse" || status=$?
for model in "$workspace"/sparse/*/; do
  [ -f "$model/images.bin" ] || continue
  echo "== $model"
  colmap model_analyzer --path "$model"
done
case $status in
  0) ;;
  3) echo "WARNING: a model is flagged FOLDED (see $workspace/sparse/summary.json)" >&2 ;;
  *) echo "ERROR: the mapper failed (exit $status)" >&2 ;;
esac
exit "$status"
