#!/usr/bin/env bash
# Display filter cost: `drivetap read --stats` of a generated Modbus RTU capture against the same
# with -Y: filters on the JSON record's keys, field-tree ids, a drive value, a typed finding id
# and the info line (docs/performance.md "Display filters"). Each row is the best wall and CPU
# time of REPEAT runs; the last column is the ratio to the unfiltered --stats row (the target: at
# most 1.5).
# Usage: bash bench/filter.sh [BUILD_DIR] [FRAMES]    (default: build-bench 1000000)
set -euo pipefail
build=${1:-build-bench}
frames=${2:-1000000}
repeat=${REPEAT:-3}
drivetap=$build/drivetap
[ -x "$drivetap" ] || { echo "filter.sh: no $drivetap (build it in Release first)" >&2; exit 2; }
command -v /usr/bin/time >/dev/null || { echo "filter.sh: needs GNU time" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
capture=$tmp/f.pcapng
"$drivetap" generate --frames "$frames" --seed 1 --mix modbus-rtu --plain -w "$capture" >/dev/null 2>&1

# best wall and CPU seconds of $repeat runs of `drivetap read --stats ARGS capture`
best() {
  local wall=999999 cpu=999999
  for _ in $(seq "$repeat"); do
    local t0 t1 w c
    t0=$EPOCHREALTIME
    /usr/bin/time -f '%U %S' -o "$tmp/time" "$drivetap" read --stats "$@" "$capture" >/dev/null
    t1=$EPOCHREALTIME
    w=$(echo "$t1 - $t0" | bc -l)
    c=$(awk '{print $1 + $2}' "$tmp/time")
    wall=$(echo "if ($w < $wall) $w else $wall" | bc -l)
    cpu=$(echo "if ($c < $cpu) $c else $cpu" | bc -l)
  done
  echo "$wall $cpu"
}

echo "| run | wall s | CPU s | CPU ratio to --stats |"
echo "|---|---:|---:|---:|"
read -r base_wall base_cpu < <(best)
printf '| `read --stats` | %.3f | %.3f | 1.00 |\n' "$base_wall" "$base_cpu"
row() {
  local label=$1
  shift
  read -r wall cpu < <(best "$@")
  printf '| `%s` | %.3f | %.3f | %.2f |\n' "$label" "$wall" "$cpu" "$(echo "$cpu / $base_cpu" | bc -l)"
}
row "read --stats -Y 'addr == 2 && fc == 3'" -Y 'addr == 2 && fc == 3'
row "read --stats -Y 'checksum_bad || latency_ms > 20'" -Y 'checksum_bad || latency_ms > 20'
# The tree's ids of station and function, as the registry names them today.
"$drivetap" read -T json "$capture" 2>/dev/null | head -50 >"$tmp/head.json" || true
tree_filter="$(python3 -c '
import json, sys
ids = [k for l in sys.stdin for r in [json.loads(l)] if r["type"] == "frame" for k in r["fields"]]
unit = next((k for k in ids if k.endswith("unit_id") or k.endswith(".addr")), ids[0])
fc = next((k for k in ids if k.endswith("func_code") or k.endswith(".fc")), ids[1])
print("%s == 2 && %s == 3" % (unit, fc))' <"$tmp/head.json")"
row "read --stats -Y '$tree_filter'" -Y "$tree_filter"
# A tree id no telegram head holds: every telegram's field tree is dissected.
row "read --stats -Y 'modbus.word_cnt > 4'" -Y 'modbus.word_cnt > 4'
# A drive value: read from the values the drive level hands over with each telegram.
row "read --stats -Y 'drive.output_frequency > 10'" -Y 'drive.output_frequency > 10'
# A typed finding id: judged on the head's finding kinds; decoded only where its kind is there.
row "read --stats -Y 'mbrtu.intra_frame_gap'" -Y 'mbrtu.intra_frame_gap'
# The info line after a head key: decoded only where the key matched.
row "read --stats -Y 'addr == 2 && summary contains \"Read\"'" -Y 'addr == 2 && summary contains "Read"'
# The info line alone: every telegram is decoded with its texts (on a thread of the filter's).
row "read --stats -Y 'summary contains \"Read\"'" -Y 'summary contains "Read"'
