#!/usr/bin/env bash
# The project's test command: installs what it needs (Debian packages, COLMAP
# 3.8 source), builds, and runs every test with ctest. Safe to run twice.
# Also installs Debian's stock `colmap` (3.8) package so that tests can check
# that stock COLMAP reads our models.
# Usage: scripts/test.sh [BUILD_DIR]   (default: build)
set -euo pipefail
ROOT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${1:-${ROOT_DIR}/build}"

export GLOMAP_EXTRA_PACKAGES="colmap"
"${ROOT_DIR}/scripts/build.sh" "${BUILD_DIR}"
cd "${BUILD_DIR}"
echo "[test] running ctest"
ctest --output-on-failure -j1
