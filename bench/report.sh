#!/usr/bin/env bash
# `drivetap report` against `drivetap read --stats` of the same capture (docs/reference.md
# "Report": the page takes at most twice the time of --stats, its size and memory stay flat):
# for each size, generated traffic of all five drive families (`drivetap generate --seed 1`, as a
# byte log and as drivetap's pcapng), the best of REPEAT runs of each: wall seconds, CPU seconds
# (user + system, GNU time), the report's ratio to --stats, peak RSS and the page's size.
#
#   bench/report.sh [BUILD_DIR] [FRAMES...]     default: build 1000000 3000000
#   REPEAT=N bench/report.sh ...                  each row the best of N runs (default 3)
#
# Needs GNU time's /usr/bin/time (Debian: apt-get install time). Prints a Markdown table.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$root/build}
shift || true
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(1000000 3000000)
repeat=${REPEAT:-3}
drivetap="$build/drivetap"
die() { echo "report.sh: $*" >&2; exit 2; }
[ -x "$drivetap" ] || die "$drivetap: no drivetap there (first argument: the build directory)"
[ -x /usr/bin/time ] || die "/usr/bin/time missing (Debian: apt-get install time)"
for n in "${sizes[@]}"; do
  [[ "$n" =~ ^[1-9][0-9]*$ ]] || die "$n: frames must be a positive whole number"
done
[[ "$repeat" =~ ^[1-9][0-9]*$ ]] || die "REPEAT=$repeat: a positive whole number"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# best_of CMD...: "wall cpu rss_kb" of the fastest of $repeat runs (CPU and RSS of that run).
best_of() {
  local best="" i wall cpu rss
  for ((i = 0; i < repeat; i++)); do
    /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$@" > /dev/null 2> "$work/stderr" ||
      die "failed: $* ($(tail -1 "$work/stderr"))"
    read -r wall user sys rss < "$work/time"
    cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }')
    if [ -z "$best" ] || awk -v a="$wall" -v b="${best%% *}" 'BEGIN { exit !(a < b) }'; then
      best="$wall $cpu $rss"
    fi
  done
  echo "$best"
}

echo "| frames | capture | read --stats s (cpu) | report s (cpu) | ratio wall (cpu) | report peak RSS | page size |"
echo "|---:|---|---:|---:|---:|---:|---:|"
for n in "${sizes[@]}"; do
  echo "generating $n frames" >&2
  "$drivetap" generate --frames "$n" --seed 1 -o "$work/g.log" -w "$work/g.pcapng" > /dev/null 2>&1
  for capture in g.log g.pcapng; do
    read -r sw sc _ < <(best_of "$drivetap" read --stats --no-progress "$work/$capture")
    read -r rw rc rr < <(best_of "$drivetap" report --no-progress "$work/$capture" -o "$work/page.html")
    size=$(stat -c %s "$work/page.html")
    ratio=$(awk -v a="$rw" -v b="$sw" -v c="$rc" -v d="$sc" \
      'BEGIN { printf "%.2f (%.2f)", a / b, (d > 0 ? c / d : 0) }')
    echo "| $n | ${capture#g.} | $sw ($sc) | $rw ($rc) | $ratio | $((rr / 1024)) MB | $((size / 1024)) KB |"
  done
done
