#!/usr/bin/env bash
# Interleaved A/B timing of `drivetap read` builds: N rounds, each running every binary once in
# turn on the same arguments (so a spell of this VM's neighbours falls on all of them alike), then
# the least and the median of each binary's CPU time (perf stat's task-clock: every thread) and
# wall time (bash's EPOCHREALTIME), in ms. Output goes to /dev/null. Needs perf (linux-perf).
#
#   bench/ab.sh ROUNDS READ_ARGS... -- BINARY...
#   bench/ab.sh 10 --drive none bus.pcapng -- ./drivetap-before build-bench/drivetap
set -euo pipefail
usage() { echo "usage: bench/ab.sh ROUNDS READ_ARGS... -- BINARY..." >&2; exit 2; }
[ $# -ge 3 ] || usage
rounds=$1
shift
[[ $rounds =~ ^[1-9][0-9]*$ ]] || { echo "ab.sh: ROUNDS=$rounds is not a positive number" >&2; exit 2; }
args=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
  args+=("$1")
  shift
done
[ $# -ge 2 ] || usage
shift
binaries=("$@")
command -v perf >/dev/null || { echo "ab.sh: needs perf (apt-get install linux-perf)" >&2; exit 2; }
for b in "${binaries[@]}"; do
  [ -x "$b" ] || { echo "ab.sh: $b is not an executable" >&2; exit 2; }
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
declare -A cpu wall
for ((round = 0; round < rounds; ++round)); do
  for b in "${binaries[@]}"; do
    start=$EPOCHREALTIME
    perf stat -x, -e task-clock -o "$work/stat" "$b" read "${args[@]}" >/dev/null 2>"$work/err" || {
      echo "ab.sh: $b read ${args[*]} failed: $(tail -1 "$work/err")" >&2
      exit 1
    }
    end=$EPOCHREALTIME
    cpu[$b]+="$(grep task-clock "$work/stat" | cut -d, -f1) "
    wall[$b]+="$(awk -v s="$start" -v e="$end" 'BEGIN { printf "%.3f", (e - s) * 1000 }') "
  done
done
# least_and_median LIST: "least/median" of the numbers in LIST.
least_and_median() {
  tr ' ' '\n' <<<"$1" | grep . | sort -n |
    awk '{ v[NR] = $1 } END { printf "%.1f/%.1f", v[1], v[int((NR + 1) / 2)] }'
}
echo "drivetap read ${args[*]}: least/median of $rounds interleaved runs, ms"
for b in "${binaries[@]}"; do
  echo "$b  CPU $(least_and_median "${cpu[$b]}")  wall $(least_and_median "${wall[$b]}")"
done
