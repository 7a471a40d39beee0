#!/usr/bin/env bash
# CI's sanitizer and fuzzing stage (issue 10), run by .ci/run after the
# Release build and tests:
#  1. one clang build in build_asan with AddressSanitizer + UndefinedBehavior-
#     Sanitizer (UB is fatal), the library also instrumented for libFuzzer
#     (-fsanitize=fuzzer-no-link), so that one build serves both steps;
#  2. the unit tests under the sanitizers (ctest -LE/-E below excludes the
#     long end-to-end tests on real data, which the Release stage runs);
#  3. every libFuzzer target of tests/fuzz for FUZZ_SECONDS (default 25) from
#     its committed seed corpus (new inputs go to a scratch directory, the
#     committed corpus is only read).
# Needs clang and libFuzzer (Debian: clang, libclang-rt-14-dev), installed
# here if missing.
set -euo pipefail
cd "$(dirname "$0")/.."
FUZZ_SECONDS=${FUZZ_SECONDS:-25}
JOBS=${JOBS:-2}

bash scripts/install_packages.sh clang libclang-rt-14-dev

launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
SANITIZE="-fsanitize=address,undefined -fno-sanitize-recover=undefined"
SANITIZE+=" -fno-omit-frame-pointer -g1"
echo "== sanitizer build (build_asan: clang, $SANITIZE)"
start=$(date +%s)
CXX=clang++ cmake -S . -B build_asan -DCMAKE_BUILD_TYPE=Release \
  "${launcher[@]}" -DCOLMAP_IRAV4_BUILD_FUZZERS=ON \
  -DCMAKE_CXX_FLAGS="$SANITIZE -fsanitize=fuzzer-no-link" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" > /dev/null
cmake --build build_asan -j"$JOBS"
echo "== sanitizer build: $(( $(date +%s) - start )) s"

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# Excluded under the sanitizers (run in the Release stage): end-to-end tests
# on the real data sets and the long synthetic pipelines.
EXCLUDE='E2E|Strecha|Reliability|Maupertuis|OneDsfm.*Real|SyntheticPipeline'
echo "== unit tests under ASan+UBSan (excluded: $EXCLUDE)"
start=$(date +%s)
ctest --test-dir build_asan --output-on-failure -j"$JOBS" -E "$EXCLUDE"
echo "== unit tests under ASan+UBSan: $(( $(date +%s) - start )) s"

scratch=$(mktemp -d /tmp/colmap_irav4_fuzz.XXXXXX)
trap 'rm -rf "$scratch"' EXIT
for fuzzer in tests/fuzz/*_fuzzer.cc; do
  name=$(basename "$fuzzer" .cc)
  mkdir -p "$scratch/$name"
  echo "== fuzzing $name for ${FUZZ_SECONDS} s"
  ./build_asan/"$name" -max_total_time="$FUZZ_SECONDS" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$scratch/$name-" \
    "$scratch/$name" "tests/fuzz/corpus/$name" 2>&1 |
    grep -E "^(#[0-9]+.*DONE|Done|stat::number_of_executed_units|==[0-9]+==ERROR|SUMMARY|.*runtime error)" || true
  if ls "$scratch/$name"-* >/dev/null 2>&1; then
    echo "FUZZ FAILURE: $name found a crashing input:" "$scratch/$name"-*
    exit 1
  fi
done
echo "== sanitizers and fuzzing: clean"
