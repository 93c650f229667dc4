#!/usr/bin/env bash
# Command-line checks of drive profiles: a bad user profile is refused with file:line: key, a
# --profile-dir profile replaces the built-in one of the same id, --drive none turns guessing off;
# and the rest of the checks numbered below (--stats, the libraries loaded at start-up, ...).
#   tests/cli.sh DRIVETAP_BIN
set -uo pipefail
drivetap="$1"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$here/.."
failed=0
fail() { echo "FAIL: $*"; failed=1; }

# 1. A profile with an error: exit 1, one line naming file, line and key; also via --profile-dir
#    and `drivetap profiles FILE`.
bad="$here/profiles/bad/bad-scale.toml"
for args in "read --profile $bad" "read --profile-dir $here/profiles/bad"; do
  err=$("$drivetap" $args "$root/captures/session-e9/input.log" 2>&1 >/dev/null); rc=$?
  [ "$rc" = 1 ] || fail "$args: exit $rc, expected 1"
  [ "$err" = "drivetap: profile $bad:11: key 'register[1].scale': expected a number" ] ||
    fail "$args: stderr was: $err"
done
err=$("$drivetap" profiles "$bad" 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] && [ "$err" = "drivetap: $bad:11: key 'register[1].scale': expected a number" ] ||
  fail "profiles FILE: exit $rc, stderr: $err"

# toml++ 3.3.0's undefined behaviour on a non-ASCII character after a key (a fuzz finding,
# captures/regressions/toml-unreachable-non-ascii-after-key): Debian's build gives the parse error.
bug="$root/captures/regressions/toml-unreachable-non-ascii-after-key/input.profile"
err=$("$drivetap" profiles "$bug" 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] &&
  [ "$err" = "drivetap: $bug:1: Error while parsing key-value pair: expected '=', saw '§'" ] ||
  fail "profiles $bug: exit $rc, stderr: $err"

# 2. --profile-dir: the site's e9 replaces the built-in one, and auto binding uses it.
out=$("$drivetap" read --profile-dir "$here/profiles/good" "$root/captures/session-e9/input.log")
grep -q "drive 2 bound to E-9 at pump station 3" <<<"$out" || fail "--profile-dir: not bound to the site profile"
grep -q "site setpoint 40.00 Hz" <<<"$out" || fail "--profile-dir: site register name not used"

# 3. --drive none: no binding, no drive lines; --drive 2=e9 binds without guessing.
out=$("$drivetap" read --drive none "$root/captures/session-e9/input.log")
grep -q "bound to\|^ *= drive" <<<"$out" && fail "--drive none still annotated"
out=$("$drivetap" read --drive 2=e9 "$root/captures/session-e9/input.log")
grep -q "bound to" <<<"$out" && fail "--drive 2=e9 still guessed"
grep -q "(bound with --drive)" <<<"$out" || fail "--drive 2=e9: summary does not say how it was bound"

# 4. Unknown profile id and malformed bindings are one-line errors naming the option.
err=$("$drivetap" read --drive 2=nope "$root/captures/session-e9/input.log" 2>&1 >/dev/null); rc=$?
[ "$rc" = 2 ] && [[ "$err" == "drivetap: --drive 2=nope: no profile 'nope' (known: "* ]] ||
  fail "--drive 2=nope: exit $rc, stderr: $err"
err=$("$drivetap" read --drive x=e9 "$root/captures/session-e9/input.log" 2>&1 >/dev/null); rc=$?
[ "$rc" = 2 ] && [[ "$err" == "drivetap: --drive x=e9: expected ADDRESS=PROFILE"* ]] ||
  fail "--drive x=e9: exit $rc, stderr: $err"
err=$("$drivetap" read --profile-dir /nonexistent "$root/captures/session-e9/input.log" 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] && [[ "$err" == "drivetap: --profile-dir /nonexistent: "* ]] ||
  fail "--profile-dir /nonexistent: exit $rc, stderr: $err"

# 5. --events prints only events (no frame lines, no summary).
out=$("$drivetap" read --events "$root/captures/session-e9/input.log")
grep -q " req \| rsp \|summary" <<<"$out" && fail "--events printed frames or the summary"
grep -q "fault 4 (output overcurrent) appeared" <<<"$out" || fail "--events: fault event missing"

# 6. Every golden polling session binds, with no option, to its family and to no other.
for pair in session-e9:"ERMAN E-9P/9G" session-erg:"ERMAN ER-G" session-e5-8200:"E5-8200" \
            session-e5-8200-ascii:"E5-8200" session-vlt-aqua-fc:"Danfoss VLT AQUA" \
            session-vlt-aqua-modbus:"Danfoss VLT AQUA" session-eds1000:"Easydrive EDS1000"; do
  dir=${pair%%:*}; family=${pair#*:}
  bindings=$("$drivetap" read --events "$root/captures/$dir/input.log" | grep -o "bound to [^(]*" | sort -u)
  [ "$bindings" = "bound to $family " ] || fail "$dir: bindings were '$bindings', expected '$family'"
done

# (Outputs are read whole before grep -q: under pipefail, grep leaving early would fail them.)
# 7. A sigrok session through the command: frames decoded from the samples; a bad --channels name
#    is a one-line error naming the option and the channels there are.
out=$("$drivetap" read "$root/captures/sigrok-flowmeter-graph-tool/flowmeter_graph_tool.sr" 2>/dev/null)
grep -q "^frames: *18 (checksum ok 18," <<<"$out" || fail ".sr: expected 18 good frames"
sr="$root/captures/uart-phy/errors_ampel64_4800_8n1_ok.sr"
err=$("$drivetap" read --channels 0,nope "$sr" 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] && [ "$err" = "drivetap: --channels: $sr: no channel 'nope' (channels: 0, 1, 2, RX, TX, 5, 6, 7)" ] ||
  fail "--channels nope: exit $rc, stderr: $err"

# 8. Line detection and diagnosis: brainchild (inverted 19200 8E1) with no option at all;
#    the flowmeter's line is healthy; an 8E1 bus read as 8N1 is named; bad option combinations
#    are one-line errors.
bc="$root/captures/sigrok-brainchild-io-16do/brainchild-io-16do.sr"
out=$("$drivetap" read "$bc" 2>&1)
grep -q "^transactions: *15 (ok 15," <<<"$out" || fail "brainchild with no option: expected 15 good transactions"
grep -q "line detected: 19200 8E1, inverted" <<<"$out" || fail "brainchild: detection note missing"
out=$("$drivetap" diagnose "$bc"); rc=$?
[ "$rc" = 0 ] || fail "diagnose brainchild: exit $rc"
grep -q "^line: *19200 8E1, inverted (detected)" <<<"$out" || fail "diagnose brainchild: line settings"
grep -q "\[inverted-line\]" <<<"$out" || fail "diagnose brainchild: no inverted-line verdict"
[ "$(grep -c '^  \[' <<<"$out")" = 1 ] || fail "diagnose brainchild: more than the inversion: $out"
grep -q '"id":"inverted-line"' <<<"$("$drivetap" diagnose -T json "$bc")" || fail "diagnose -T json"
for fm in sigrok-flowmeter-graph-tool/flowmeter_graph_tool.sr \
          sigrok-flowmeter-target-15liter-per-min/flowmeter_target_15liter_per_min.sr; do
  out=$("$drivetap" diagnose "$root/captures/$fm")
  grep -q "^verdict: *healthy line" <<<"$out" || fail "diagnose $fm: not healthy: $out"
done
out=$("$drivetap" diagnose -s "9600 8E1" --invert "$bc")
grep -q "\[baud-mismatch\] Baud rate mismatch: the line runs at 19200, not 9600" <<<"$out" ||
  fail "diagnose -s 9600: no baud mismatch: $out"
# The same capture as sigrok-cli exported it to VCD: the same line, the same transactions.
vcd="$root/captures/vcd/brainchild-io-16do.vcd"
out=$("$drivetap" read "$vcd" 2>&1)
grep -q "^transactions: *15 (ok 15," <<<"$out" || fail "brainchild VCD: expected 15 good transactions"
grep -q "\[inverted-line\]" <<<"$("$drivetap" diagnose "$vcd")" || fail "diagnose brainchild VCD"
# An 8E1 bus read as 8N1 (a byte log whose framing errors fall on exactly the bytes whose even
# parity bit is 0, every CRC good): the verdict names the parity, not the baud or the wiring; the
# same bytes read with the parity the verdict names decode with no UART error.
pb="$root/captures/parity-bit-read-as-stop-bit/input.log"
out=$("$drivetap" diagnose "$pb")
grep -q "\[parity-mismatch\] The line carries a parity bit: use 19200 8E1" <<<"$out" &&
  [ "$(grep -c '^  \[' <<<"$out")" = 1 ] || fail "diagnose 8E1 read as 8N1: $out"
out=$(sed 's/!f//g' "$pb" | "$drivetap" diagnose -s "19200 8E1" -)
grep -q "^verdict: *healthy line" <<<"$out" || fail "diagnose 8E1 read as 8E1: not healthy: $out"
# Where the settings came from: the capture's own, -s against them (a warning naming both), a
# part of them given, and the built-in default (a pcap of link type 147 says none).
e9="$root/captures/session-e9/input.log"
grep -q "^line: *4800 8N1 (from the capture; " <<<"$("$drivetap" diagnose "$e9")" ||
  fail "diagnose: the capture's settings not said to be the capture's"
prov_err=$(mktemp)
out=$("$drivetap" diagnose -s "19200 8E1" "$e9" 2>"$prov_err")
grep -q "^line: *19200 8E1 (as given; the capture says 4800 8N1; " <<<"$out" &&
  [ "$(cat "$prov_err")" = "drivetap: warning: -s 19200 8E1: the capture says 4800 8N1; decoding as 19200 8E1" ] ||
  fail "diagnose -s against the capture: $out / $(cat "$prov_err")"
rm -f "$prov_err"
grep -q "^line: *9600 8N1 (baud as given, format from the capture; the capture says 4800 8N1; " \
  <<<"$("$drivetap" diagnose -s 9600 "$e9" 2>/dev/null)" || fail "diagnose -s 9600: parts not told apart"
grep -q "^line: *9600 8N1 (default; " <<<"$("$drivetap" diagnose "$root/captures/dlt147-split-and-merged/input.pcap")" ||
  fail "diagnose: a default not said to be one"
err=$("$drivetap" read --invert "$bc" 2>&1 >/dev/null); rc=$?
[ "$rc" = 2 ] && grep -q "^drivetap: --invert: give the line settings too" <<<"$err" ||
  fail "--invert without -s: exit $rc, stderr: $err"

# 8b. One telegram pasted from a manual is a telegram: the protocol whose structure fits, a bad or
#     byte-swapped checksum and all, in every form people paste (a C array, braces, Intel's h);
#     hex bytes of a text protocol decode as that protocol. Random bytes stay noise.
while IFS='|' read -r text want_protocol want_checksum; do
  got=$("$drivetap" decode -T json --no-summary "$text" 2>/dev/null | python3 -c '
import json, sys
r = json.loads(sys.stdin.readline())
print(r.get("protocol", "-") if r["type"] == "frame" else "noise", r.get("checksum", "-"))')
  [ "$got" = "$want_protocol $want_checksum" ] || fail "decode \"$text\": $got, expected $want_protocol $want_checksum"
done <<'CASES'
02 03 00 00 00 04 3A 44|modbus-rtu|swapped
01 03 00 00 00 01 84 0B|modbus-rtu|bad
0x02,0x03,0x00,0x00,0x00,0x04,0x44,0x3A|modbus-rtu|good
{0x02, 0x03, 0x00, 0x00, 0x00, 0x04, 0x3A, 0x44}|modbus-rtu|swapped
02h 03h 00h 00h 00h 04h 44h 3Ah|modbus-rtu|good
02 0E 81 E1 9E 00 00 00 00 03 E8 04 7C 20 00 40|danfoss-fc|bad
7E 30 31 30 43 30 30 30 31 30 46 41 30 30 32 37 43 0D|easydrive|good
3A 30 31 30 33 32 35 32 33 30 30 30 31 42 33 0D 0A|modbus-ascii|good
DE AD BE EF 12 34 56 78|noise|-
CASES
# A telegram two protocols fit alike: decoded as the first, and the user told of the other.
err=$("$drivetap" decode "02 06 04 04 7C 20 00 59" 2>&1 >/dev/null)
grep -q "fits Danfoss FC as well as Modbus RTU: decoded as Modbus RTU; -P fc for the other" <<<"$err" ||
  fail "decode of a telegram two protocols fit: $err"

# 9. --stats: only the closing summary, the same as a full run's (text and JSON).
log="$root/captures/session-e9/input.log"
full=$("$drivetap" read "$log" | sed -n '/^--- summary ---$/,$p')
stats=$("$drivetap" read --stats "$log" | sed '/^$/d')
[ "$stats" = "$full" ] || fail "--stats: summary differs from a full run's"
[ "$("$drivetap" read --stats -T json "$log" | grep -c .)" = 1 ] || fail "--stats -T json: not one line"
grep -q '^{"type":"summary"' <<<"$("$drivetap" read --stats -T json "$log")" ||
  fail "--stats -T json: no summary"

# 10. Start-up: libpcap and libzip are loaded when a classic pcap or a sigrok session needs them,
#     not at every start (src/formats/shared_libraries.hpp); both still read and write.
needed=$(readelf -d "$drivetap" | grep NEEDED)
grep -Eq 'lib(pcap|zip)\.' <<<"$needed" && fail "drivetap links libpcap or libzip at start: $needed"
tmp=$(mktemp -d)
"$drivetap" read --pcap -w "$tmp/e9.pcap" "$log" >/dev/null || fail "read --pcap -w: exit $?"
# (Classic pcap keeps a time a frame, not a byte: the frames are the same, not the timing.)
[ "$("$drivetap" read "$tmp/e9.pcap" | grep '^frames:')" = "$(grep '^frames:' <<<"$full")" ] ||
  fail "the classic pcap written and read back: other frames"
sr="$root/captures/sigrok-brainchild-io-16do/brainchild-io-16do.sr"
out=$("$drivetap" read "$sr" 2>"$tmp/sr.err"); rc=$?
grep -q '^frames: .*checksum ok [1-9]' <<<"$out" ||
  fail "a sigrok session: no good frame (exit $rc; stderr: $(tail -n 3 "$tmp/sr.err"); $(grep -A3 '^frames:' <<<"$out"))"
rm -rf "$tmp"

[ "$failed" = 0 ] && echo "ok cli"
exit "$failed"
