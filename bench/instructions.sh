#!/usr/bin/env bash
# Instructions a record, per thread, of `drivetap read` in each mode (callgrind): the measure of
# the code that this VM's neighbours do not move, where wall and CPU seconds vary from one spell
# to the next (docs/performance.md). The decoding thread bounds --stats. Text and JSON are
# formatted by a writer thread and by the decoding thread whenever its next batch would wait
# (ThreadedSink helpers): how the batches fall between the two depends on the scheduling (under
# callgrind, which runs one thread at a time, the decoding thread formats most), so for those
# modes the column "all threads" is the measure, the work both cores share.
#
#   bench/instructions.sh [BUILD_DIR] [RECORDS]     default build-bench, 100000
#
# The captures come from `drivetap generate`: Modbus RTU alone as a --plain pcapng (seed 1, the
# end-to-end comparison's traffic) and all links (seed 7). Counts include start-up (the dynamic
# linker, the built-in drive profiles when bound), a share that shrinks as RECORDS grows.
# Needs valgrind (apt-get install valgrind); about two minutes at 100 000 records.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$root/build-bench}
records=${2:-100000}
drivetap="$build/drivetap"
command -v valgrind >/dev/null || { echo "instructions.sh: needs valgrind (apt-get install valgrind)" >&2; exit 2; }
[ -x "$drivetap" ] || { echo "instructions.sh: no drivetap in $build (build it first)" >&2; exit 2; }
[[ $records =~ ^[1-9][0-9]*$ ]] || { echo "instructions.sh: RECORDS=$records is not a positive number" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$drivetap" generate --frames "$records" --seed 1 --mix modbus-rtu --plain -w "$work/rtu.pcapng" 2>/dev/null
"$drivetap" generate --frames "$records" --seed 7 -w "$work/mix.pcapng" 2>/dev/null

# count NAME FILE ARGS...: one table row.
count() {
  local name=$1 file=$2 decoding=0 writer=0 ahead=0 total=0 f n
  shift 2
  rm -f "$work"/cg.*
  valgrind --tool=callgrind --separate-threads=yes --callgrind-out-file="$work/cg.%p" \
    "$drivetap" read "$@" "$work/$file" >/dev/null 2>"$work/log" || {
    echo "instructions.sh: $name failed: $(tail -1 "$work/log")" >&2
    exit 1
  }
  # One file a thread: the main one decodes; the others are told apart by their entry function.
  for f in "$work"/cg.*; do
    n=$(grep -m1 '^summary:' "$f" | cut -d' ' -f2 || true)
    [ -n "$n" ] || continue  # (the process's own file, without counts, beside its threads')
    total=$((total + n))
    if grep -q 'ThreadedSink::run' "$f"; then
      writer=$((writer + n))
    elif grep -q 'ReadAhead::run' "$f"; then
      ahead=$((ahead + n))
    else
      decoding=$((decoding + n))
    fi
  done
  local writes="-"
  [ "$writer" = 0 ] || writes=$((writer / records))
  echo "| $name | $((decoding / records)) | $writes | $((ahead / records)) | $((total / records)) | \`drivetap read${*:+ $*} $file\` |"
}

echo "Instructions a record (callgrind), $records records, drivetap $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '?'):"
echo
echo "| mode | decoding | writer | read-ahead | all threads | command |"
echo "| --- | --- | --- | --- | --- | --- |"
count "--stats" rtu.pcapng --drive none --stats
count "text" rtu.pcapng --drive none
count "-T json" rtu.pcapng --drive none -T json
count "text with drives (default)" rtu.pcapng
count "-T json with drives" rtu.pcapng -T json
count "text with drives, all links" mix.pcapng
