#!/usr/bin/env bash
# bench/end_to_end.sh kept working: a small run of it writes the whole report.
#   tests/end_to_end.sh DRIVETAP_BIN
# 1. On 3000 frames and 3000 noise bytes, into a report of its own (RESULTS=, not
#    bench/RESULTS.md): exit 0, the headline ratios, every row of every table (both sources,
#    default mode and --drive none) with its figures and ratios to tshark, the packet counts and
#    the memory lines.
# 2. Bad arguments: one line naming the argument, exit 2, before any run.
# Without tshark or /usr/bin/time the test is skipped (77), unless DRIVETAP_REQUIRE_TSHARK=1 (CI).
set -uo pipefail
drivetap="$1"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
script="$root/bench/end_to_end.sh"
build=$(dirname "$drivetap")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failed=0
fail() { echo "FAIL: $*"; failed=1; }

for tool in tshark /usr/bin/time; do
  if ! command -v "$tool" >/dev/null; then
    [ "${DRIVETAP_REQUIRE_TSHARK:-0}" = 1 ] && { echo "FAIL: $tool not installed"; exit 1; }
    echo "SKIP: $tool not installed"
    exit 77
  fi
done

# 2. Bad arguments.
refused() {  # refused WHAT ARGUMENT... : exit 2 and one line naming WHAT
  local what=$1
  shift
  "$@" >"$work/out" 2>"$work/err"
  local rc=$?
  [ $rc = 2 ] || fail "$what: exit $rc, not 2"
  [ "$(wc -l <"$work/err")" = 1 ] || fail "$what: not one line: $(cat "$work/err")"
  grep -q -- "$what" "$work/err" || fail "$what: not named in: $(cat "$work/err")"
}
refused "FRAMES 12x" bash "$script" "$build" 12x
refused "REPEAT=0" env REPEAT=0 bash "$script" "$build" 100
refused "NOISE_BYTES=-1" env NOISE_BYTES=-1 bash "$script" "$build" 100
refused "$work/none/drivetap" bash "$script" "$work/none" 100
refused "RESULTS=$work/none/R.md" env RESULTS="$work/none/R.md" bash "$script" "$build" 100

# 1. A small run.
report="$work/RESULTS.md"
if ! RESULTS="$report" NOISE_BYTES=3000 bash "$script" "$build" 3000 >"$work/out" 2>"$work/err"; then
  fail "end_to_end.sh exit $?: $(tail -3 "$work/err")"
fi
[ -s "$report" ] || fail "no report written"
cmp -s "$report" "$work/out" || fail "the report is not what it printed"
grep -q '^## 3000 frames$' "$report" || fail "no section for 3000 frames"
grep -q '^### Generated: 3[0-9][0-9][0-9] packets' "$report" ||
  fail "generated packet count: $(grep '^### Generated' "$report")"
grep -q '^### Foreign: 3000 packets' "$report" || fail "no foreign table: $(grep '^### Foreign' "$report")"
# The headline: each output's ratio, default and --drive none, on both sources.
for out in "text (tshark text)" "-T json (tshark -T fields)" "--stats (tshark io,stat)"; do
  grep -Eq "^\| $(sed 's/[][\.*^$+?(){}|/-]/\\&/g' <<<"$out") \| [0-9.]+x \| [0-9.]+x \| [0-9.]+x \| [0-9.]+x \|$" "$report" ||
    fail "headline row '$out' missing or malformed: $(grep -F "| $out |" "$report")"
done
# rows TABLE NAME RATIO-REGEX: in the table that begins with TABLE, a row with seconds, CPU,
# packets/s, RSS, ratio, command.
row() {
  local table=$1 name=$2 ratio=$3 line
  line=$(awk -v t="$table" 'index($0, t) == 1 { on = 1; next } /^##/ { on = 0 } on' "$report" |
    grep -F "| $name |" | head -1)
  [ -n "$line" ] || { fail "$table: no row '$name'"; return; }
  grep -Eq "^\| $(sed 's/[][\.*^$+?(){}|/]/\\&/g' <<<"$name") \| [0-9]+\.[0-9]{3} \| [0-9]+\.[0-9]{2} \| [0-9]+ \| [0-9]+ \| $ratio \| \`.+\` \|$" <<<"$line" ||
    fail "$table: row '$name' malformed: $line"
}
for table in "### Generated" "### Foreign"; do
  case $table in
    *Generated) row "$table" "generate --mix modbus-rtu --plain" "" ;;
    *) row "$table" "bench/foreign_pcapng.py" "" ;;
  esac
  row "$table" "tshark text" ""
  row "$table" "tshark -T fields" ""
  row "$table" "tshark io,stat" ""
  row "$table" "cat (no decoding)" "[0-9.]+x io,stat"
  # (drivetap_floor is built with the benchmarks, where Google Benchmark is installed.)
  [ ! -x "$build/bench/drivetap_floor" ] || row "$table" "floor: read + CRC, one thread" "[0-9.]+x io,stat"
  row "$table" "drivetap text" "[0-9.]+x text"
  row "$table" "drivetap -T json" "[0-9.]+x fields"
  row "$table" "drivetap --stats" "[0-9.]+x io,stat"
  row "$table" "drivetap text, --drive none" "[0-9.]+x text"
  row "$table" "drivetap -T json, --drive none" "[0-9.]+x fields"
  row "$table" "drivetap --stats, --drive none" "[0-9.]+x io,stat"
done
for name in "generate --mix modbus-rtu (full)" "cat, full pcapng" "drivetap --stats, full pcapng" \
  "drivetap text, full pcapng" "generate --mix all" "drivetap text, mix, drives"; do
  grep -Eq "^\| $(sed 's/[][\.*^$+?(){}|/]/\\&/g' <<<"$name") \| [0-9]+\.[0-9]{3} \| [0-9]+\.[0-9]{2} \| [0-9]+ \| \`.+\` \|$" "$report" ||
    fail "drivetap-alone row '$name' missing or malformed"
done
grep -Eq '^- 3000 frames: generated [0-9]+ / [0-9]+ / [0-9]+; foreign [0-9]+ / [0-9]+ / [0-9]+$' "$report" ||
  fail "no memory line for 3000 frames"
grep -q '^3000 bytes of noise' "$report" || fail "no noise table"
for name in "drivetap --stats, noise log" "drivetap -T json, noise log" \
  "drivetap --stats, noise pcapng" "drivetap -T json, noise pcapng" "drivetap text, noise pcapng"; do
  grep -Eq "^\| $name \| [0-9]+\.[0-9]{3} \| [0-9]+\.[0-9]{2} \| [0-9]+ \| \`.+\` \|$" "$report" ||
    fail "noise row '$name' missing or malformed"
done
# The script's work directory (mktemp -d: tmp.XXXXXXXXXX) is left out of the commands.
tmp_work="$(dirname "$work")/tmp\.[A-Za-z0-9]{10}/"
grep -qE "$tmp_work" "$report" && fail "a work directory in the report: $(grep -m1 -E "$tmp_work" "$report")"

[ $failed = 0 ] && echo "end_to_end.sh: the report of a 3000-frame run has every row"
exit $failed
