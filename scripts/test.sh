#!/usr/bin/env bash
# The test command of the README and of CI (docs/testing.md "Stages"): installs dependencies, then
#   1. release build (GCC, the README's build) and every test in it, the exhaustive sweeps too;
#   2. the sanitizer build (clang, ASan+UBSan, the libFuzzer targets in the same build): every
#      unit, golden and regression test, and the command-line suites over the cases of
#      tests/sanitizer_sample.txt (chosen by coverage: scripts/choose_sample.py);
#   3. the ThreadSanitizer pass of the threaded parts (scripts/tsan.sh);
#   4. every fuzz target for FUZZ_SECONDS (default 30) s after its regression reproducers, from
#      the sanitizer build's objects (scripts/fuzz.sh; FUZZ_SECONDS=0 skips it).
# Compilers run through ccache, shared by every clone on the machine. Each stage's wall time is
# printed as it ends and in a table at the end.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
root=$(pwd)
jobs=$(nproc 2>/dev/null || echo 2)
stages=()
stage_started=$(date +%s)
stage_done() {  # stage_done NAME: the time since the previous stage ended
  local now
  now=$(date +%s)
  stages+=("$(printf '%-28s %5d s' "$1" $((now - stage_started)))")
  echo "== stage $1: $((now - stage_started)) s"
  stage_started=$now
}
summary() {
  local rc=$? total=0 line
  echo "== stages"
  for line in "${stages[@]}"; do
    echo "$line"
    total=$((total + $(awk '{ print $(NF - 1) }' <<<"$line")))
  done
  printf '%-28s %5d s\n' total "$total"
  exit "$rc"
}
trap summary EXIT

# clang with its libFuzzer runtime (only a recommendation of clang, so named) for the sanitizer
# and fuzz build, xxd and unzip for the fuzz seeds, ccache for every build.
bash scripts/install-deps.sh clang libclang-rt-14-dev xxd unzip ccache
stage_done install

# ccache: the objects of another clone in another folder serve this one (paths are hashed relative
# to the clone, not with the working directory).
export CCACHE_BASEDIR=$root CCACHE_NOHASHDIR=true CCACHE_COMPILERCHECK=content
ccache=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
require=(DRIVETAP_REQUIRE_TSHARK=1 DRIVETAP_REQUIRE_SIGROK=1 DRIVETAP_REQUIRE_CHROMIUM=1
         DRIVETAP_REQUIRE_PYMODBUS=1)

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${ccache[@]}" > /dev/null
cmake --build build -j "$jobs"
stage_done "release build"
env "${require[@]}" ctest --test-dir build --output-on-failure -j "$jobs"
stage_done "release tests"

cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_COMPILER=clang++ \
  -DDRIVETAP_SANITIZE=ON -DDRIVETAP_FUZZ=ON "${ccache[@]}" > /dev/null
cmake --build build-asan -j "$jobs" --target all fuzz
stage_done "sanitizer build"
env "${require[@]}" ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j "$jobs"
stage_done "sanitizer tests"

bash scripts/tsan.sh build-tsan
stage_done "thread sanitizer"

fuzz_seconds=${FUZZ_SECONDS:-30}
if [ "$fuzz_seconds" != 0 ]; then
  FUZZ_BUILD=$root/build-asan FUZZ_JOBS=${FUZZ_JOBS:-$jobs} bash scripts/fuzz.sh "$fuzz_seconds"
  stage_done fuzz
fi
