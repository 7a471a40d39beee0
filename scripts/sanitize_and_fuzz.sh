#!/usr/bin/env bash
# CI's sanitizer and fuzzing stage, run by .ci/run after the
# Release build and tests:
#  1. one clang build in build_asan with AddressSanitizer + UndefinedBehavior-
#     Sanitizer (UB is fatal), the library also instrumented for libFuzzer
#     (-fsanitize=fuzzer-no-link), so that one build serves both steps. Only
#     the unit tests and the fuzzers are built (the `unit_tests` and `fuzzers`
#     targets): the program, the tools and the end-to-end tests are the
#     Release stage's. -O1 without NDEBUG: Eigen's and our asserts stay on,
#     and the build takes about half the CPU time of -O3;
#  2. the unit tests (ctest label `unit`) under the sanitizers, LeakSanitizer
#     on (tests/fuzz/lsan.supp: third-party leaks only);
#  3. every libFuzzer target of tests/fuzz for FUZZ_SECONDS (default 30) from
#     its committed seed corpus (new inputs go to a scratch directory, the
#     committed corpus is only read).
# Needs clang and libFuzzer (Debian: clang, libclang-rt-14-dev), installed
# here if missing.
#   scripts/sanitize_and_fuzz.sh  (FUZZ_SECONDS, FUZZ_SEED, JOBS: environment)
set -euo pipefail
cd "$(dirname "$0")/.."
FUZZ_SECONDS=${FUZZ_SECONDS:-30}
# A fixed libFuzzer seed: CI's verdict depends on the code, not on the draw
# (FUZZ_SEED=0: a new random seed each run, for longer local fuzzing).
FUZZ_SEED=${FUZZ_SEED:-1}
JOBS=${JOBS:-2}

bash scripts/install_packages.sh clang libclang-rt-14-dev

launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
SANITIZE="-fsanitize=address,undefined -fno-sanitize-recover=undefined"
SANITIZE+=" -fno-omit-frame-pointer -g1"
echo "== sanitizer build (build_asan: clang -O1, $SANITIZE)"
start=$(date +%s)
# No Python module here: an instrumented extension cannot be loaded into
# Debian's uninstrumented python3 (ASan's runtime must come first in the
# process, i.e. LD_PRELOAD into the interpreter, whose own allocations
# LeakSanitizer then reports); its tests run in the Release stage.
CXX=clang++ cmake -S . -B build_asan -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_FLAGS_RELEASE="-O1" "${launcher[@]}" \
  -DCOLMAP_IRAV4_BUILD_FUZZERS=ON -DCOLMAP_IRAV4_BUILD_PYTHON=OFF \
  -DCMAKE_CXX_FLAGS="$SANITIZE -fsanitize=fuzzer-no-link" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" > /dev/null
cmake --build build_asan -j"$JOBS" --target unit_tests fuzzers > \
  build_asan/build.log 2>&1 || { tail -50 build_asan/build.log; exit 1; }
echo "== sanitizer build: $(( $(date +%s) - start )) s"

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS=suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0
# One BLAS/OpenMP thread per process: ctest runs JOBS processes at once.
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 GOTO_NUM_THREADS=1
# Excluded here (the Release stage runs it): RunSummary's resident-set test.
# Under ASan, freeing its 256 MiB block makes 32 MiB of shadow memory
# resident (one byte per 8), so the next stage's peak rises; not a defect.
# (The two TwoViewGeometry tests once excluded here for clang's other
# results now pass: their scenes were drawn in an order clang and gcc
# evaluate differently; util/random.h draws in one order.)
EXCLUDE='RunSummary\.StageTimerRecordsThePeakItRaises'
echo "== unit tests under ASan+UBSan (ctest -L unit, excluded: $EXCLUDE)"
start=$(date +%s)
ctest --test-dir build_asan --output-on-failure -j"$JOBS" -L unit \
  -E "$EXCLUDE"
echo "== unit tests under ASan+UBSan: $(( $(date +%s) - start )) s"

scratch=$(mktemp -d /tmp/colmap_irav4_fuzz.XXXXXX)
trap 'rm -rf "$scratch"' EXIT
# Crashing inputs are kept (build_asan/fuzz_artifacts) to reproduce with
# ./build_asan/NAME INPUT.
artifacts=build_asan/fuzz_artifacts
rm -rf "$artifacts"
mkdir -p "$artifacts"
for fuzzer in tests/fuzz/*_fuzzer.cc; do
  name=$(basename "$fuzzer" .cc)
  mkdir -p "$scratch/$name"
  echo "== fuzzing $name for ${FUZZ_SECONDS} s"
  status=0
  # TMPDIR: the fuzzers' own scratch files go where the trap removes them.
  TMPDIR="$scratch" ./build_asan/"$name" -seed="$FUZZ_SEED" -max_total_time="$FUZZ_SECONDS" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$artifacts/$name-" \
    "$scratch/$name" "tests/fuzz/corpus/$name" > "$scratch/$name.log" 2>&1 ||
    status=$?
  grep -E "^(#[0-9]+.*DONE|Done|stat::number_of_executed_units|==[0-9]+==ERROR|SUMMARY|.*runtime error)" \
    "$scratch/$name.log" || true
  if [ "$status" -ne 0 ] || ls "$artifacts/$name"-* >/dev/null 2>&1; then
    tail -40 "$scratch/$name.log"
    echo "FUZZ FAILURE: $name (exit $status); crashing input:" \
      "$artifacts/$name"-* || true
    exit 1
  fi
done
echo "== sanitizers and fuzzing: clean"
