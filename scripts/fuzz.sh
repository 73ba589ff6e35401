#!/usr/bin/env bash
# Fuzzes the database reader (glomap::ReadDatabase) with libFuzzer,
# AddressSanitizer and UBSan: builds tests/fuzz/database_reader_fuzzer.cc
# with Debian's clang 14 against the static COLMAP libraries of an existing
# build (scripts/build.sh), makes the seed corpus, replays the reproducers in
# tests/fuzz/regressions/, then fuzzes for N seconds. Installs clang and the
# libFuzzer runtime when missing (Debian, as root). Safe to run twice: the
# fuzzer is rebuilt only when a source is newer, the working corpus grows
# from run to run.
#
# Usage: scripts/fuzz.sh [--seconds N] [BUILD_DIR] [-- LIBFUZZER_ARGS...]
#   --seconds N  fuzzing time (default 60)
#   BUILD_DIR    a configured and built main build (default: build)
#   LIBFUZZER_ARGS are passed to libFuzzer as they are (e.g. -jobs=2).
# Everything goes to BUILD_DIR/fuzz/: the fuzzer, seeds/ (made by
# tests/fuzz/make_seed_corpus.py, never written by libFuzzer), corpus/ (the
# working corpus), artifacts/ (crashes, leaks, timeouts, OOMs) and the log
# of the last run, fuzz.log.
# Exits non-zero when a reproducer fails or the run finds anything.
set -euo pipefail
ROOT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

seconds=60
if [[ "${1:-}" == "--seconds" ]]; then
  seconds="${2:?--seconds needs a number}"
  shift 2
fi
BUILD_DIR="${ROOT_DIR}/build"
if [[ $# -gt 0 && "$1" != "--" ]]; then
  BUILD_DIR="$1"
  shift
fi
if [[ "${1:-}" == "--" ]]; then
  shift
fi
extra_args=("$@")
BUILD_DIR="$(cd "${BUILD_DIR}" && pwd)"
FUZZ_DIR="${BUILD_DIR}/fuzz"
FUZZER="${FUZZ_DIR}/database_reader_fuzzer"
CXX=clang++-14

# 1. clang 14 and its libFuzzer runtime.
runtime_exists() {
  command -v "${CXX}" >/dev/null 2>&1 &&
    [[ -f "$("${CXX}" -print-resource-dir)/lib/linux/libclang_rt.fuzzer-x86_64.a" ]]
}
if ! runtime_exists; then
  echo "[fuzz] installing clang 14 and its libFuzzer runtime"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq clang libclang-rt-14-dev
  runtime_exists || { echo "[fuzz] ${CXX} or libFuzzer still missing" >&2; exit 1; }
fi

# 2. The fuzzer: our sources compiled with clang (instrumented), COLMAP and
# the system libraries as the main build links them (not instrumented). The
# include paths and definitions (COLMAP's matter for Eigen's alignment) are
# the main build's, read from its ninja file.
if [[ ! -f "${BUILD_DIR}/build.ninja" || ! -f "${BUILD_DIR}/colmap/src/libcolmap.a" ]]; then
  echo "[fuzz] ${BUILD_DIR} is not a built main build; run scripts/build.sh first" >&2
  exit 1
fi
sources=("${ROOT_DIR}/tests/fuzz/database_reader_fuzzer.cc"
  "${ROOT_DIR}/src/glomap/io/database_reader.cc"
  "${ROOT_DIR}/src/glomap/scene/view_graph.cc")
needs_build=0
if [[ ! -x "${FUZZER}" ]]; then
  needs_build=1
elif [[ -n "$(find "${sources[@]}" "${ROOT_DIR}"/src/glomap/{io/database_reader,scene/view_graph,util/status}.h \
  "${BASH_SOURCE[0]}" "${BUILD_DIR}/build.ninja" \
  "${BUILD_DIR}/colmap/src/libcolmap.a" -newer "${FUZZER}" 2>/dev/null)" ]]; then
  needs_build=1
fi
if [[ "${needs_build}" == 1 ]]; then
  echo "[fuzz] building ${FUZZER}"
  build_start=${SECONDS}
  mkdir -p "${FUZZ_DIR}/obj"
  # -D, -I, -isystem and -std of the main build's database_reader.cc.
  compile_line="$(ninja -C "${BUILD_DIR}" -t commands glomap_database_reader |
    grep -- '-c [^ ]*/database_reader\.cc$' | tail -n 1)"
  read -r -a words <<< "${compile_line}"
  cxxflags=()
  for ((i = 0; i < ${#words[@]}; ++i)); do
    case "${words[i]}" in
      -D* | -I* | -std=*) cxxflags+=("${words[i]}") ;;
      -isystem) cxxflags+=("${words[i]}" "${words[i + 1]}"); i=$((i + 1)) ;;
    esac
  done
  [[ ${#cxxflags[@]} -gt 0 ]] || { echo "[fuzz] no compile flags found in ${BUILD_DIR}" >&2; exit 1; }
  # The libraries of the main build's database_reader_test, without the
  # test's own and ours (compiled here).
  link_line="$(ninja -C "${BUILD_DIR}" -t commands database_reader_test |
    grep -- '-o tests/database_reader_test ' | tail -n 1)"
  link_line="${link_line#*-o tests/database_reader_test }"
  link_line="${link_line%%&&*}"
  read -r -a words <<< "${link_line}"
  libs=()
  for word in "${words[@]}"; do
    case "${word}" in
      src/glomap/* | tests/* | *gtest*) ;;
      -*) libs+=("${word}") ;;
      /*) libs+=("${word}") ;;
      *) libs+=("${BUILD_DIR}/${word}") ;;
    esac
  done
  sanitize=(-fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all)
  objects=()
  pids=()
  for source in "${sources[@]}"; do
    object="${FUZZ_DIR}/obj/$(basename "${source}" .cc).o"
    objects+=("${object}")
    # Two at a time at most (the machine may be busy with other builds).
    if [[ ${#pids[@]} -ge 2 ]]; then
      wait "${pids[0]}"
      pids=("${pids[@]:1}")
    fi
    "${CXX}" "${cxxflags[@]}" "${sanitize[@]}" -g -O1 -fno-omit-frame-pointer \
      -c "${source}" -o "${object}" &
    pids+=($!)
  done
  for pid in "${pids[@]}"; do wait "${pid}"; done
  "${CXX}" "${sanitize[@]}" -o "${FUZZER}.tmp" "${objects[@]}" "${libs[@]}"
  mv "${FUZZER}.tmp" "${FUZZER}"
  echo "[fuzz] built in $((SECONDS - build_start)) s"
fi

# 3. The seed corpus (remade when its generator changes) and the working
# corpus, which starts as a copy of the seeds.
SEEDS="${FUZZ_DIR}/seeds"
CORPUS="${FUZZ_DIR}/corpus"
if [[ ! -d "${SEEDS}" || "${ROOT_DIR}/tests/fuzz/make_seed_corpus.py" -nt "${SEEDS}" ]]; then
  python3 "${ROOT_DIR}/tests/fuzz/make_seed_corpus.py" "${SEEDS}"
fi
if [[ ! -d "${CORPUS}" ]]; then
  mkdir -p "${CORPUS}"
  cp "${SEEDS}"/* "${CORPUS}/"
fi
mkdir -p "${FUZZ_DIR}/artifacts"

# Sanitizer settings: stop at the first report, with a stack.
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# Units larger than the largest seed bring nothing new; 64 KB at least.
max_len=$(find "${SEEDS}" -type f -printf '%s\n' | sort -n | tail -n 1)
max_len=$(( (max_len > 65536 ? max_len : 65536) + 4096 ))
fuzzer_args=(-max_len="${max_len}" -rss_limit_mb=4096 -timeout=10
  -artifact_prefix="${FUZZ_DIR}/artifacts/" -print_final_stats=1)

# 4. Known reproducers, once each: they must pass before anything new counts.
shopt -s nullglob
regressions=("${ROOT_DIR}"/tests/fuzz/regressions/*)
shopt -u nullglob
if [[ ${#regressions[@]} -gt 0 ]]; then
  echo "[fuzz] replaying ${#regressions[@]} reproducers from tests/fuzz/regressions"
  if ! "${FUZZER}" "${fuzzer_args[@]}" "${regressions[@]}" \
    >"${FUZZ_DIR}/regressions.log" 2>&1; then
    tail -n 40 "${FUZZ_DIR}/regressions.log" >&2
    echo "[fuzz] FAILED: a reproducer in tests/fuzz/regressions still fails" \
      "(log: ${FUZZ_DIR}/regressions.log)" >&2
    exit 1
  fi
fi

# 5. Fuzz. New units go to corpus/; seeds/ is read only.
echo "[fuzz] fuzzing for ${seconds} s (log: ${FUZZ_DIR}/fuzz.log)"
artifacts_before=$(find "${FUZZ_DIR}/artifacts" -type f | wc -l)
status=0
"${FUZZER}" "${fuzzer_args[@]}" -max_total_time="${seconds}" \
  ${extra_args[@]+"${extra_args[@]}"} "${CORPUS}" "${SEEDS}" \
  >"${FUZZ_DIR}/fuzz.log" 2>&1 || status=$?
artifacts_after=$(find "${FUZZ_DIR}/artifacts" -type f | wc -l)

runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "${FUZZ_DIR}/fuzz.log" | tail -n 1)
rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "${FUZZ_DIR}/fuzz.log" | tail -n 1)
last=$(grep -E '^#[0-9]+' "${FUZZ_DIR}/fuzz.log" | tail -n 1 || true)
echo "[fuzz] executions: ${runs:-?} (${rate:-?}/s); last status: ${last:-none}"
echo "[fuzz] corpus: $(find "${CORPUS}" -type f | wc -l) files in ${CORPUS}"
if [[ "${status}" != 0 || "${artifacts_after}" != "${artifacts_before}" ]] ||
  grep -qE '^(==[0-9]+==ERROR|SUMMARY: (Address|Undefined|Leak)Sanitizer)|runtime error:' \
    "${FUZZ_DIR}/fuzz.log"; then
  grep -E 'ERROR|SUMMARY|runtime error|Test unit written|^    #[0-9]' "${FUZZ_DIR}/fuzz.log" |
    head -n 40 >&2 || true
  echo "[fuzz] FAILED: libFuzzer exited with ${status}; artifacts in" \
    "${FUZZ_DIR}/artifacts, log in ${FUZZ_DIR}/fuzz.log" >&2
  exit 1
fi
echo "[fuzz] no findings"
