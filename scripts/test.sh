#!/usr/bin/env bash
# The project's test command: installs what it needs (Debian packages, COLMAP
# 3.8 source), builds, and runs every test with ctest. Safe to run twice.
# Also installs Debian's stock `colmap` (3.8) package so that tests can check
# that stock COLMAP reads our models.
#
# Usage: scripts/test.sh [--sanitize] [BUILD_DIR]
#   default BUILD_DIR: build (build-asan with --sanitize)
#   --sanitize  builds everything (COLMAP included) with AddressSanitizer and
#               UBSan in its own build folder and runs the whole suite there;
#               any report fails the test that made it.
set -euo pipefail
ROOT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

sanitize=0
if [[ "${1:-}" == "--sanitize" ]]; then
  sanitize=1
  shift
fi
if [[ "${sanitize}" == 1 ]]; then
  BUILD_DIR="${1:-${ROOT_DIR}/build-asan}"
  export GLOMAP_CMAKE_ARGS="-DGLOMAP_SANITIZE=ON"
  # Leaks are reported too; Qt's and Mesa's own at exit are not ours.
  export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:suppressions=${ROOT_DIR}/tests/sanitizers/asan.supp}"
  export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=${ROOT_DIR}/tests/sanitizers/lsan.supp:print_suppressions=0}"
  export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1:suppressions=${ROOT_DIR}/tests/sanitizers/ubsan.supp}"
else
  BUILD_DIR="${1:-${ROOT_DIR}/build}"
fi

export GLOMAP_EXTRA_PACKAGES="colmap clang libclang-rt-14-dev"
"${ROOT_DIR}/scripts/build.sh" "${BUILD_DIR}"
cd "${BUILD_DIR}"
echo "[test] running ctest"
ctest --output-on-failure -j1
if [[ "${sanitize}" == 0 ]]; then "${ROOT_DIR}/scripts/fuzz.sh" --seconds 60 "$(pwd)"; fi  # fuzz the database reader for 60 s (tests/fuzz/README.md)
