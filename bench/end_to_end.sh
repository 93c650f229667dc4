#!/usr/bin/env bash
# End to end against tshark (issue 8): the same Modbus RTU pcapng through `drivetap read` in text,
# JSON and --stats modes and through tshark (text, -T fields, -q -z io,stat,0), side by side:
# seconds, frames/s, drivetap's ratio to tshark, peak RSS. Writes bench/RESULTS.md.
#
#   bench/end_to_end.sh [BUILD_DIR] [SIZE_MB]     default: build 45 (about 1 M frames)
#
# The capture comes from bench/gen_bytelog.py (random register reads of several stations; to be
# replaced by the multi-family generator), written to pcapng by drivetap itself.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$root/build}
size=${2:-45}
drivetap="$build/drivetap"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

python3 "$root/bench/gen_bytelog.py" "$size" "$work/bus.log" >/dev/null
"$drivetap" read --drive none --stats -w "$work/bus.pcapng" "$work/bus.log" >/dev/null
packets=$(tshark -r "$work/bus.pcapng" -q -z io,stat,0 2>/dev/null |
          sed -n 's/^| *0\.0 <> [0-9.]* *| *\([0-9]*\) .*/\1/p')

rows=()
# measure NAME COMMAND...: wall seconds and peak RSS of one run, output to /dev/null.
measure() {
  local name=$1
  shift
  /usr/bin/time -f "%e %M" -o "$work/time" "$@" >/dev/null 2>"$work/stderr" || {
    echo "$name failed: $(tail -1 "$work/stderr")" >&2
    exit 1
  }
  read -r seconds rss <"$work/time"
  rows+=("$name|$seconds|$rss|$*")
  echo "$name: $seconds s, $((rss / 1024)) MB" >&2
}

measure "tshark text" tshark -r "$work/bus.pcapng"
measure "tshark -T fields" tshark -r "$work/bus.pcapng" -T fields -e modbus.func_code
measure "tshark io,stat" tshark -r "$work/bus.pcapng" -q -z io,stat,0
measure "drivetap text" "$drivetap" read --drive none "$work/bus.pcapng"
measure "drivetap -T json" "$drivetap" read --drive none -T json "$work/bus.pcapng"
measure "drivetap --stats" "$drivetap" read --drive none --stats "$work/bus.pcapng"
measure "drivetap text, drives" "$drivetap" read "$work/bus.pcapng"

seconds_of() { for r in "${rows[@]}"; do [ "${r%%|*}" = "$1" ] && cut -d'|' -f2 <<<"$r"; done; }
{
  echo "# End-to-end results (bench/end_to_end.sh)"
  echo
  echo "Machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores;"
  echo "$(date -u +%Y-%m-%d); capture: $packets packets (bench/gen_bytelog.py $size MB, as pcapng"
  echo "$(du -m "$work/bus.pcapng" | cut -f1) MB); drivetap $(git -C "$root" rev-parse --short HEAD)."
  echo
  echo "| run | seconds | packets/s | peak RSS MB | vs tshark | command |"
  echo "|---|---|---|---|---|---|"
  for r in "${rows[@]}"; do
    IFS='|' read -r name seconds rss cmd <<<"$r"
    rate=$(awk -v p="$packets" -v s="$seconds" 'BEGIN { printf "%.0f", (s > 0 ? p / s : 0) }')
    ratio=""
    case $name in
      "drivetap text"*) ratio=$(awk -v a="$(seconds_of 'tshark text')" -v b="$seconds" 'BEGIN { printf "%.1fx text", a / b }') ;;
      "drivetap -T json") ratio=$(awk -v a="$(seconds_of 'tshark -T fields')" -v b="$seconds" 'BEGIN { printf "%.1fx fields", a / b }') ;;
      "drivetap --stats") ratio=$(awk -v a="$(seconds_of 'tshark io,stat')" -v b="$seconds" 'BEGIN { printf "%.1fx io,stat", a / b }') ;;
    esac
    echo "| $name | $seconds | $rate | $((rss / 1024)) | $ratio | \`${cmd//$work\//}\` |"
  done
} >"$root/bench/RESULTS.md"
cat "$root/bench/RESULTS.md"
