#!/usr/bin/env bash
# From images to a COLMAP sparse model with colmap_irav4:
#   scripts/run_pipeline.sh IMAGES WORKSPACE [CAMERA_MODEL]
# COLMAP 3.8 extracts SIFT features and matches exhaustively into
# WORKSPACE/database.db, colmap_irav4 maps into WORKSPACE/sparse/N, and
# `colmap model_analyzer` checks and summarises every model.
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
"$binary" mapper --database_path "$db" --image_path "$images" \
  --output_path "$workspace/sparse"
for model in "$workspace"/sparse/*/; do
  echo "== $model"
  colmap model_analyzer --path "$model"
done
