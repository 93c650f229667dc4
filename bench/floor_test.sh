#!/usr/bin/env bash
# bench.floor (ctest): drivetap_floor's checksum verdicts are those of `drivetap read --stats` on
# generated Modbus RTU traffic, and a file that is no pcapng is refused with its name and offset.
#
#   bench/floor_test.sh DRIVETAP DRIVETAP_FLOOR
set -euo pipefail
drivetap=$1
floor=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$drivetap" generate --frames 3000 --seed 1 --mix modbus-rtu --plain -w "$work/bus.pcapng" 2>/dev/null
# "frames: N (checksum ok G, bad B, swapped S); noise: R records, ..." -> "G S B R"
summary=$("$drivetap" read --drive none --stats "$work/bus.pcapng" | grep '^frames:')
expected=$(sed -E 's/.*checksum ok ([0-9]+), bad ([0-9]+), swapped ([0-9]+)[^)]*\); noise: ([0-9]+) record.*/\1 \3 \2 \4/' <<<"$summary")
# "runs N: crc ok G, swapped S, bad B; shorter than 4 bytes R" -> "G S B R"
counted=$("$floor" "$work/bus.pcapng")
got=$(sed -E 's/.*crc ok ([0-9]+), swapped ([0-9]+), bad ([0-9]+); shorter than 4 bytes ([0-9]+)/\1 \2 \3 \4/' <<<"$counted")
echo "read --stats: $summary"
echo "floor:        $counted"
[[ $expected =~ ^[0-9]+\ [0-9]+\ [0-9]+\ [0-9]+$ ]] || { echo "FAIL: no counts in read's summary" >&2; exit 1; }
[ "$got" = "$expected" ] || { echo "FAIL: floor counts $got, read --stats $expected (ok swapped bad noise)" >&2; exit 1; }
[ "${expected%% *}" -gt 2000 ] || { echo "FAIL: too few good frames to compare: $expected" >&2; exit 1; }
printf 'not a capture\n' >"$work/text.pcapng"
if "$floor" "$work/text.pcapng" 2>"$work/err"; then
  echo "FAIL: a text file was read as a capture" >&2
  exit 1
fi
grep -q "text.pcapng: offset 0: not a pcapng file" "$work/err" || { echo "FAIL: error was: $(cat "$work/err")" >&2; exit 1; }
echo "ok"
