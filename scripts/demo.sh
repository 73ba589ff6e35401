#!/usr/bin/env bash
# The main job on the project's own default data: builds everything, makes a
# synthetic scene (a real COLMAP 3.8 database with ground truth), runs
# `colmap global_mapper` on it, prints the accuracy against the ground truth,
# and leaves a model that `colmap gui` opens. Safe to run twice.
# Usage: scripts/demo.sh [BUILD_DIR]   (default: build)
set -euo pipefail
ROOT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${1:-${ROOT_DIR}/build}"
DEMO_DIR="${BUILD_DIR}/demo"
COLMAP="${BUILD_DIR}/bin/colmap"

"${ROOT_DIR}/scripts/build.sh" "${BUILD_DIR}"

SCENE="${DEMO_DIR}/scene"
if [[ ! -f "${SCENE}/database.db" ]]; then
  rm -rf "${SCENE}"
  "${BUILD_DIR}/bin/make_synthetic_scene" --output_path "${SCENE}" \
    --num_images 100 --camera_model SIMPLE_RADIAL --prior_focal_length 0 \
    --pixel_noise_px 1.0 --wrong_match_ratio 0.2 --random_seed 0
fi
mkdir -p "${SCENE}/images"

echo "[demo] colmap global_mapper on ${SCENE}/database.db"
"${COLMAP}" global_mapper --database_path "${SCENE}/database.db" \
  --image_path "${SCENE}/images" --output_path "${DEMO_DIR}/sparse"

echo "[demo] accuracy against the ground truth:"
"${COLMAP}" model_evaluator --input_path "${DEMO_DIR}/sparse/0" \
  --gt_path "${SCENE}/gt" --json_path "${DEMO_DIR}/evaluation.json"

echo "[demo] model statistics:"
"${COLMAP}" model_analyzer --path "${DEMO_DIR}/sparse/0"

cat <<MSG
[demo] done. Open the model with:
  ${COLMAP} gui --import_path ${DEMO_DIR}/sparse/0 \\
    --database_path ${SCENE}/database.db --image_path ${SCENE}/images
MSG
