#!/usr/bin/env bash
# The test command of the README and of CI: installs dependencies, builds, runs every unit and
# golden test, repeats the whole suite in an ASan+UBSan build, runs the ThreadSanitizer pass of
# the threaded parts (scripts/tsan.sh), then a short fuzz pass: every
# libFuzzer target for FUZZ_SECONDS (default 30) seconds, one per core at a time, after the
# regression reproducers of captures/regressions/ (scripts/fuzz.sh; FUZZ_SECONDS=0 skips it).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bash scripts/install-deps.sh
jobs=$(nproc 2>/dev/null || echo 2)

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo
cmake --build build -j "$jobs"
DRIVETAP_REQUIRE_TSHARK=1 DRIVETAP_REQUIRE_SIGROK=1 DRIVETAP_REQUIRE_CHROMIUM=1 ctest --test-dir build --output-on-failure -j "$jobs"

cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DDRIVETAP_SANITIZE=ON
cmake --build build-asan -j "$jobs"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  DRIVETAP_REQUIRE_TSHARK=1 DRIVETAP_REQUIRE_SIGROK=1 DRIVETAP_REQUIRE_CHROMIUM=1 ctest --test-dir build-asan --output-on-failure -j "$jobs"

bash scripts/tsan.sh build-tsan

fuzz_seconds=${FUZZ_SECONDS:-30}
if [ "$fuzz_seconds" != 0 ]; then
  FUZZ_JOBS=${FUZZ_JOBS:-$jobs} bash scripts/fuzz.sh "$fuzz_seconds"
fi
