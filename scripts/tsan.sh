#!/usr/bin/env bash
# ThreadSanitizer pass of the README's test command (scripts/test.sh): builds drivetap and the test
# sources of the threaded parts (drivetap_thread_tests) with -DDRIVETAP_TSAN=ON, runs their suites
# (ThreadedSink with and without helpers formatting on several threads, ReadAhead, the drive
# annotation written on the writer thread, telegrams decoded on the writer thread), then
# `drivetap read` of generated captures (all five drive families as pcapng and byte log; plain
# Modbus RTU) in every mode that runs the read-ahead and writer threads, and the display filter's
# thread. Captures of 20 000 records keep both threads busy at once: the golden captures are too
# small for that (a race planted in ThreadedSink::run() passes them and is caught here). Any
# report fails the pass (halt_on_error, exit code 66).
#
#   scripts/tsan.sh [BUILD_DIR]     default build-tsan
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
build=${1:-build-tsan}
jobs=$(nproc 2>/dev/null || echo 2)

cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDRIVETAP_TSAN=ON \
  -DDRIVETAP_BENCH=OFF ${CCACHE_BASEDIR:+-DCMAKE_CXX_COMPILER_LAUNCHER=ccache} > /dev/null
cmake --build "$build" -j "$jobs" --target drivetap drivetap_thread_tests
export TSAN_OPTIONS="halt_on_error=1 exitcode=66 second_deadlock_stack=1"

"$build/tests/drivetap_thread_tests" --gtest_brief=1 \
  --gtest_filter='ThreadedSink.*:ReadAhead.*:DriveAnnotation.*:Pipeline.TelegramsHandedOver*:Pipeline.FormattedOnSeveralThreads*'

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
drivetap=$build/drivetap
"$drivetap" generate --frames 20000 --seed 3 -w "$work/mix.pcapng" -o "$work/mix.log"
"$drivetap" generate --frames 20000 --seed 1 --mix modbus-rtu --plain -w "$work/rtu.pcapng"
# (--stats -Y of a filter that decodes telegrams: the filter judges them on a thread of its own.)
modes=("" "-V" "-T json" "--drive none" "--drive none -T json" "--stats" "--events"
       "-w $work/out.pcapng" "--stats -w $work/out.pcapng" "--stats -Y summary"
       "--stats -Y drive" "--stats -Y modbus.word_cnt" "-T json -Y drive")
for input in mix.pcapng mix.log rtu.pcapng; do
  for mode in "${modes[@]}"; do
    # shellcheck disable=SC2086  # the mode's words are separate options
    if ! "$drivetap" read $mode "$work/$input" >/dev/null 2>"$work/stderr"; then
      echo "tsan: drivetap read $mode $input failed:" >&2
      cat "$work/stderr" >&2
      exit 1
    fi
  done
done
echo "tsan: ${#modes[@]} modes of read on 3 captures, no report"
