#!/usr/bin/env bash
# `drivetap generate`: reproducible, decoded exactly as injected, bad options refused.
#   tests/generate.sh DRIVETAP_BIN
# 1. The same seed gives byte-identical byte logs, pcapngs and truth files; another seed differs.
# 2. drivetap read of the byte log and of the pcapng reports what --truth says was injected:
#    frames, checksums bad and swapped, exceptions, timeouts, noise, parity marks, timing-rule
#    breaks, and no other finding; per link, every frame has the link's protocol and the link's
#    own counts. The pcapng equals what `drivetap read LOG -w` writes of the byte log.
# 3. Bad options: one line naming the option, exit 2.
set -uo pipefail
drivetap="$1"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failed=0
fail() { echo "FAIL: $*"; failed=1; }
# value KEY FILE-or-TEXT: the first number after "KEY": in a JSON text.
value() { grep -o "\"$1\":[0-9]*" <<<"$2" | head -1 | cut -d: -f2; }

frames=20000
gen() { "$drivetap" generate --frames $frames "$@" 2>/dev/null; }

# 1. Reproducible.
gen --seed 7 -o "$work/a.log" -w "$work/a.pcapng" --truth "$work/a.json" || fail "generate exit $?"
gen --seed 7 -o "$work/b.log" -w "$work/b.pcapng" --truth "$work/b.json" || fail "generate exit $?"
gen --seed 8 -o "$work/c.log" || fail "generate exit $?"
cmp -s "$work/a.log" "$work/b.log" || fail "same seed, byte logs differ"
cmp -s "$work/a.pcapng" "$work/b.pcapng" || fail "same seed, pcapngs differ"
cmp -s "$work/a.json" "$work/b.json" || fail "same seed, truth files differ"
cmp -s "$work/a.log" "$work/c.log" && fail "seeds 7 and 8 gave the same byte log"
# -o and -w alone write what they write together.
gen --seed 7 -w "$work/d.pcapng" || fail "generate -w exit $?"
cmp -s "$work/a.pcapng" "$work/d.pcapng" || fail "-w alone differs from -o and -w together"
# The pcapng is `drivetap read LOG -w`'s.
"$drivetap" read --stats -w "$work/e.pcapng" "$work/a.log" >/dev/null || fail "read -w exit $?"
cmp -s "$work/a.pcapng" "$work/e.pcapng" || fail "generate -w differs from read LOG -w"

# 2. Decoded as injected, from both files, with the stations bound as the truth file says.
truth=$(cat "$work/a.json")
total=$(grep '^"total"' <<<"$truth")
[ "$(value frames "$total")" -ge $((frames * 9 / 10)) ] || fail "only $(value frames "$total") frames"
for k in exceptions timeouts bad_replies checksum_bad checksum_swapped noise_records parity_errors timing_rule; do
  [ "$(value $k "$total")" -gt 0 ] || fail "truth: no $k injected"
done
bindings=()
for b in $(grep -o '"drives":"[^"]*"' <<<"$truth" | head -1 | cut -d'"' -f4); do bindings+=(--drive "$b"); done
for file in a.log a.pcapng; do
  s=$("$drivetap" read --stats -T json "${bindings[@]}" "$work/$file") || fail "$file: read exit $?"
  check() {  # check NAME DECODED TRUTH
    [ "$2" = "$3" ] || fail "$file: $1 decoded $2, injected $3"
  }
  check frames "$(value frames "$s")" "$(value frames "$total")"
  check "checksum bad" "$(grep -o '"checksum":{[^}]*}' <<<"$s" | grep -o '"bad":[0-9]*' | cut -d: -f2)" "$(value checksum_bad "$total")"
  check "checksum swapped" "$(grep -o '"checksum":{[^}]*}' <<<"$s" | grep -o '"swapped":[0-9]*' | cut -d: -f2)" "$(value checksum_swapped "$total")"
  tx=$(grep -o '"transactions":{[^}]*}' <<<"$s")
  check transactions "$(value total "$tx")" "$(value requests "$total")"
  check ok "$(value ok "$tx")" "$(value ok "$total")"
  check exceptions "$(value exception "$tx")" "$(value exceptions "$total")"
  check timeouts "$(value timeout "$tx")" "$(value timeouts "$total")"
  check "bad replies" "$(value bad_reply "$tx")" "$(value bad_replies "$total")"
  check "noise records" "$(value noise_records "$s")" "$(value noise_records "$total")"
  check "noise bytes" "$(value noise_bytes "$s")" "$(value noise_bytes "$total")"
  check bytes "$(value bytes "$s")" "$(value bytes "$total")"
  an=$(grep -o '"anomalies":{[^}]*}' <<<"$s")
  check "uart_parity" "$(value uart_parity "$an")" "$(value parity_errors "$total")"
  check "timing_rule" "$(value timing_rule "$an")" "$(value timing_rule "$total")"
  check "unanswered_request" "$(value unanswered_request "$an")" "$(value timeouts "$total")"
  # No finding besides the injected ones.
  others=$(grep -o '"[a-z_]*":[1-9][0-9]*' <<<"$an" |
           grep -v '"\(checksum_bad\|checksum_swapped\|noise\|unanswered_request\|uart_parity\|timing_rule\)"')
  [ -z "$others" ] || fail "$file: findings not injected: $others"
done

# Per link, from the JSON lines: frames with the link's protocol, its checksum errors, noise.
json=$("$drivetap" read -T json "${bindings[@]}" "$work/a.log")
while read -r link; do
  ch=$(grep -o '"channel":"[a-z]*"' <<<"$link" | cut -d'"' -f4)
  proto=$(grep -o '"protocol":"[a-z-]*"' <<<"$link" | cut -d'"' -f4)
  frames_ch=$(grep '^{"type":"frame"' <<<"$json" | grep -c "\"channel\":\"$ch\",")
  proto_ch=$(grep '^{"type":"frame"' <<<"$json" | grep "\"channel\":\"$ch\"," | grep -c "\"protocol\":\"$proto\"")
  bad_ch=$(grep '^{"type":"frame"' <<<"$json" | grep "\"channel\":\"$ch\"," | grep -c '"checksum":"bad"')
  noise_ch=$(grep '^{"type":"noise"' <<<"$json" | grep -c "\"channel\":\"$ch\",")
  [ "$frames_ch" = "$(value frames "$link")" ] || fail "link $ch: $frames_ch frames decoded, $(value frames "$link") written"
  [ "$proto_ch" = "$frames_ch" ] || fail "link $ch: $((frames_ch - proto_ch)) frames not decoded as $proto"
  [ "$bad_ch" = "$(value checksum_bad "$link")" ] || fail "link $ch: $bad_ch bad checksums decoded, $(value checksum_bad "$link") injected"
  [ "$noise_ch" = "$(value noise_records "$link")" ] || fail "link $ch: $noise_ch noise records decoded, $(value noise_records "$link") written"
done < <(grep '^{"channel"' <<<"$truth")
[ "$(grep -c '^{"channel"' <<<"$truth")" = 4 ] || fail "truth: expected 4 links with --mix all"

# --plain: the frames alone. The same as `read LOG -w FILE --plain`, a fraction of the size, and
# read back to the same counts but for the UART marks it leaves out; tshark decodes its Modbus RTU.
gen --seed 7 --plain -w "$work/p.pcapng" || fail "generate --plain exit $?"
"$drivetap" read --stats --plain -w "$work/q.pcapng" "$work/a.log" >/dev/null || fail "read -w --plain exit $?"
cmp -s "$work/p.pcapng" "$work/q.pcapng" || fail "generate --plain differs from read LOG -w --plain"
[ $(($(stat -c %s "$work/p.pcapng") * 3)) -lt "$(stat -c %s "$work/a.pcapng")" ] ||
  fail "--plain: $(stat -c %s "$work/p.pcapng") bytes, not under a third of $(stat -c %s "$work/a.pcapng")"
rich=$("$drivetap" read --stats -T json "${bindings[@]}" "$work/a.pcapng" | grep -o '"summary".*')
plain=$("$drivetap" read --stats -T json "${bindings[@]}" "$work/p.pcapng" | grep -o '"summary".*')
for k in frames noise_records noise_bytes bytes good bad swapped total ok exception timeout bad_reply \
  checksum_bad checksum_swapped unanswered_request timing_rule; do
  [ "$(value $k "$plain")" = "$(value $k "$rich")" ] ||
    fail "--plain: $k read back $(value $k "$plain"), from the full pcapng $(value $k "$rich")"
done
latency() { grep -o '"latency_ms":{[^}]*}' <<<"$1"; }
[ "$(latency "$plain")" = "$(latency "$rich")" ] ||
  fail "--plain: latencies $(latency "$plain"), from the full pcapng $(latency "$rich")"
expected=$(($(value anomalies_total "$rich") - $(value uart_parity "$rich")))
[ "$(value anomalies_total "$plain")" = "$expected" ] ||
  fail "--plain: $(value anomalies_total "$plain") findings, the full pcapng's less its UART marks: $expected"
[ -z "$(value uart_parity "$plain")" ] || [ "$(value uart_parity "$plain")" = 0 ] ||
  fail "--plain: UART marks read back from a file that has none"
if command -v tshark >/dev/null; then
  rtu_frames=$(grep '^{"channel":"rtu"' <<<"$truth" | grep -o '"frames":[0-9]*' | cut -d: -f2)
  mbrtu=$(tshark -r "$work/p.pcapng" -Y mbrtu 2>/dev/null | wc -l)
  [ "$mbrtu" = "$rtu_frames" ] || fail "--plain: tshark decodes $mbrtu Modbus RTU packets, $rtu_frames written"
fi

# --mix modbus-rtu: one link, Modbus RTU only.
gen --mix modbus-rtu -o "$work/r.log" --truth "$work/r.json" || fail "generate --mix modbus-rtu exit $?"
[ "$(grep -c '^{"channel"' "$work/r.json")" = 1 ] || fail "--mix modbus-rtu: more than one link"
grep -v '^#' "$work/r.log" | grep -qv ' rtu ' && fail "--mix modbus-rtu: a line on another channel"

# Time order across channels: no frame out of order in text and JSON, no negative time delta in
# the pcapng, from 3000 frames on four links, three of them detecting at first.
"$drivetap" generate --frames 3000 -o "$work/o.log" -w "$work/o.pcapng" 2>/dev/null || fail "generate exit $?"
# out_of_order: how many of the times on stdin (one a line) are earlier than the one before.
out_of_order() { awk 'NR > 1 && $1 < last { n++ } { last = $1 } END { print n + 0 }'; }
text=$("$drivetap" read "$work/o.log") || fail "read exit $?"
times=$(grep -E '^ +[0-9]+ +-?[0-9]+\.[0-9]+ ' <<<"$text" | awk '{ print $2 }')
[ "$(wc -l <<<"$times")" = 3000 ] || fail "order: $(wc -l <<<"$times") frame lines in the text, 3000 written"
[ "$(out_of_order <<<"$times")" = 0 ] || fail "order: $(out_of_order <<<"$times") text frames out of time order"
json=$("$drivetap" read -T json "$work/o.log") || fail "read -T json exit $?"
times=$(grep -E '^\{"type":"(frame|noise|event)"' <<<"$json" | grep -o '"t":-\?[0-9.]*' | cut -d: -f2)
[ "$(out_of_order <<<"$times")" = 0 ] || fail "order: $(out_of_order <<<"$times") JSON records out of time order"
if command -v tshark >/dev/null; then
  deltas=$(tshark -r "$work/o.pcapng" -T fields -e frame.time_delta 2>/dev/null)
  [ "$(wc -l <<<"$deltas")" = 3000 ] || fail "order: tshark reads $(wc -l <<<"$deltas") packets, 3000 written"
  negative=$(awk '$1 < 0' <<<"$deltas" | wc -l)
  [ "$negative" = 0 ] || fail "order: $negative pcapng packets with a negative time delta (tshark)"
fi

# 3. Bad options: one line naming the option, exit 2.
for args in "--frames 0" "--frames 12x" "--frames -5" "--seed abc" "--mix modbus" "--plain" ""; do
  err=$("$drivetap" generate $args -o "$work/x.log" 2>&1 >/dev/null); rc=$?
  [ -z "$args" ] && { err=$("$drivetap" generate 2>&1 >/dev/null); rc=$?; args="(no output)"; }
  opt=${args%% *}
  [ "$rc" = 2 ] || fail "generate $args: exit $rc, expected 2"
  [ "$(wc -l <<<"$err")" = 1 ] || fail "generate $args: more than one line: $err"
  [[ "$err" == "drivetap: "* ]] || fail "generate $args: stderr was: $err"
  [ "$opt" = "(no" ] || [[ "$err" == *"$opt"* ]] || fail "generate $args: error does not name $opt: $err"
done
err=$("$drivetap" generate -o /nonexistent/dir/x.log 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] && [[ "$err" == "drivetap: -o /nonexistent/dir/x.log: cannot create: "* ]] ||
  fail "unwritable -o: exit $rc, stderr: $err"

[ $failed = 0 ] && echo "generate: all checks passed"
exit $failed
