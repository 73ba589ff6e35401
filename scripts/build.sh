#!/usr/bin/env bash
# Configures and builds the project (COLMAP 3.8 + our code) in BUILD_DIR.
# Usage: scripts/build.sh [BUILD_DIR]   (default: build)
set -euo pipefail
ROOT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${1:-${ROOT_DIR}/build}"
JOBS="${JOBS:-$(nproc)}"

"${ROOT_DIR}/scripts/setup.sh" "${BUILD_DIR}"
if [[ ! -f "${BUILD_DIR}/build.ninja" ]]; then
  # GLOMAP_CMAKE_ARGS: extra configure arguments (scripts/test.sh --sanitize).
  read -r -a extra_args <<< "${GLOMAP_CMAKE_ARGS:-}"
  cmake -S "${ROOT_DIR}" -B "${BUILD_DIR}" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    "${extra_args[@]}"
fi
echo "[build] building in ${BUILD_DIR} with ${JOBS} jobs"
cmake --build "${BUILD_DIR}" -- -j"${JOBS}"
echo "[build] done: ${BUILD_DIR}/bin/colmap"
