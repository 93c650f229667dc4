#!/usr/bin/env bash
# Hostile input and situations: each case is named after the bug it once was, and
# fails on the code that had it. Inputs too large to keep in captures/ are made by
# tests/hostile/make_inputs.py; the small ones that `read` can golden-test are in
# captures/regressions/. Run in the release and in the sanitizer build (ctest cli.hostile), where
# each numbered part is a case of the sample (tests/cases.sh).
#   bash tests/hostile.sh BUILD/drivetap
set -uo pipefail
drivetap=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
work=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; rm -rf "$work"' EXIT
# shellcheck source=tests/expect.sh
source "$root/tests/expect.sh"
# shellcheck source=tests/cases.sh
source "$root/tests/cases.sh"
cases_init hostile
# stopped NAME PID SECONDS: waits up to SECONDS for PID to end (killing it when it does not);
# true with its exit status in $rc when it ended.
stopped() {
  local name=$1 pid=$2 seconds=$3
  for _ in $(seq $((seconds * 10))); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$pid" 2>/dev/null; then
    fail "$name: still running $seconds s later"
    kill -9 "$pid"
    wait "$pid" 2>/dev/null
    return 1
  fi
  wait "$pid"
  rc=$?
  return 0
}
# until_process NAME PID CONDITION: waits up to 20 s until PID has installed its SIGINT and SIGTERM
# handlers and, for CONDITION "blocked", has a thread blocked writing to a pipe (no fixed sleep: the
# process's own state says when it is there).
until_process() {
  local name=$1 pid=$2 condition=$3 caught
  for _ in $(seq 400); do
    caught=$(sed -n 's/^SigCgt:[[:space:]]*//p' "/proc/$pid/status" 2>/dev/null)
    # SIGINT is bit 1, SIGTERM bit 14 of the mask.
    if [ -n "$caught" ] && (( (16#$caught & 0x4002) == 0x4002 )); then
      [ "$condition" != blocked ] && return 0
      cat /proc/"$pid"/task/*/wchan 2>/dev/null | grep -q "pipe_write" && return 0
    fi
    kill -0 "$pid" 2>/dev/null || { fail "$name: the process ended before it was $condition"; return 1; }
    sleep 0.05
  done
  fail "$name: not $condition after 20 s"
  return 1
}
log=$root/captures/session-e9/input.log
make() { python3 "$root/tests/hostile/make_inputs.py" "$work" "$@"; }

# 1. SIGFPE: a logic capture whose measured baud rounds to 0.
if case_begin h1-sigfpe-a-logic; then
make vcd-timescale-1s-sigfpe sigrok-1hz-sigfpe sigrok-3hz-sigfpe sigrok-duplicate-samplerate-sigfpe
for f in vcd-timescale-1s-sigfpe.vcd sigrok-1hz-sigfpe.sr sigrok-3hz-sigfpe.sr \
  sigrok-duplicate-samplerate-sigfpe.sr; do
  for cmd in read diagnose; do
    expect "$cmd $f" 1 "^drivetap: $work/$f: cannot detect the line settings: the pulses measure [0-9.]+ baud at [0-9]+ samples/s, outside the UART range 50\.\.4000000 baud" -- \
      "$drivetap" "$cmd" "$work/$f"
  done
  expect "read -s 9600 $f" 1 "^drivetap: $work/$f: line settings at [0-9]+ samples/s: .*samples per bit" -- \
    "$drivetap" read -s 9600 "$work/$f"
done

fi

# 2. Stack overflow in toml++: a dotted key of 100 000 parts, arrays nested 100 000 deep.
if case_begin h2-stack-overflow-in; then
python3 -c "print('[' + '.'.join(['a'] * 100000) + ']')" > "$work/dotted-key-100000-parts.toml"
python3 -c "print('a = ' + '[' * 100000)" > "$work/arrays-nested-100000-deep.toml"
for f in dotted-key-100000-parts arrays-nested-100000-deep; do
  expect "profiles $f" 1 "^drivetap: $work/$f.toml:1: .*(dots|nest deeper).*: not a drive profile$" -- \
    "$drivetap" profiles "$work/$f.toml"
  expect "read --profile $f" 1 "^drivetap: profile $work/$f.toml:1: " -- \
    "$drivetap" read --profile "$work/$f.toml" "$log"
  mkdir -p "$work/dir-$f" && cp "$work/$f.toml" "$work/dir-$f/"
  expect "read --profile-dir $f" 1 "^drivetap: profile $work/dir-$f/$f.toml:1: " -- \
    "$drivetap" read --profile-dir "$work/dir-$f" "$log"
done
# Nesting a real profile uses stays accepted.
printf '[a.b.c.d]\nx = [[1, 2], [3, [4, {y = 5}]]]\n' > "$work/shallow.toml"
"$drivetap" profiles "$work/shallow.toml" 2> "$work/err" >/dev/null
grep -q "dots\|nest deeper" "$work/err" && fail "a shallow nesting was refused: $(cat "$work/err")" || ok "shallow nesting passes the check"

fi

# 3. A text summary that comes first (memcpy from a null buffer; the sanitizer build aborts).
if case_begin h3-a-text-summary; then
expect "decode --stats of one frame" 0 '' -- "$drivetap" decode --stats "01 03 00 00 00 01 84 0A"
printf '# only comments\n# and more\n' > "$work/only-comments.log"
expect "read of a byte log of comments only" 0 '' -- "$drivetap" read "$work/only-comments.log"

fi

# 4. 4096 VCD variables on one identifier: refused before detection, not 4.4 GB later.
if case_begin h4-4096-vcd-variables; then
make vcd-4096-variables-one-identifier
expect "vcd 4096 variables, one identifier" 1 "more than 256 channels change level" -- \
  /usr/bin/time -f "%M" -o "$work/rss" "$drivetap" read "$work/vcd-4096-variables-one-identifier.vcd"
rss=$(tail -n 1 "$work/rss" 2>/dev/null || echo 0)
[ "${rss:-0}" -lt 1000000 ] || fail "vcd 4096 variables: peak RSS $rss KB, expected < 1 GB"

fi

# 5. Live capture on a flooded port: the stamps run ahead of the clock at most 500 ms, memory stays
if case_begin h5-live-capture-on; then
# bounded, and the note says once why times were taken at arrival.
python3 - "$work/flood.tty" > "$work/flood.out" 2>&1 <<'PY' &
import os, pty, sys, time
master, slave = pty.openpty()
os.symlink(os.ttyname(slave), sys.argv[1])
payload = bytes.fromhex("0203000000044439") * 512
end = time.time() + 8
while time.time() < end:
    try:
        os.write(master, payload)
    except BlockingIOError:
        pass
    except OSError:
        time.sleep(0.001)
PY
for _ in $(seq 50); do [ -e "$work/flood.tty" ] && break; sleep 0.1; done
/usr/bin/time -f "%M" -o "$work/flood.rss" timeout 30 "$drivetap" capture -i "$work/flood.tty" -s 9600 \
  -a duration:4 --stats -o "$work/flood.txt" 2> "$work/flood.err"
rc=$?
rss=$(tail -n 1 "$work/flood.rss" 2>/dev/null || echo 0)
if [ "$rc" -ne 0 ]; then
  fail "flooded capture: exit $rc: $(tail -c 300 "$work/flood.err")"
elif [ "$(grep -c "bytes came faster than 9600 8N1 allows" "$work/flood.txt")" -ne 1 ]; then
  fail "flooded capture: not one note that times were taken at arrival: $(tail -c 600 "$work/flood.txt")"
elif [ "${rss:-0}" -gt 400000 ]; then
  fail "flooded capture: peak RSS $rss KB, expected < 400 MB (the sanitizer build included)"
else
  ok "flooded live capture: bounded ($rss KB), said once"
fi
kill %1 2>/dev/null; wait 2>/dev/null

fi

# 7. Garbage must not be re-detected over and over: 2 MB of random packets, each closed by silence.
if case_begin h7-garbage-must-not; then
make random-packets
"$drivetap" read -T json "$work/random-packets.pcapng" > "$work/random.json" 2>/dev/null
detections=$(grep -c '"kind":"protocol_detected"' "$work/random.json")
[ "$detections" -le 20 ] && ok "random packets: $detections detections" ||
  fail "random packets: $detections protocol detections (re-detection does not back off)"

fi

# 8. Zip bomb: the decompressed samples are capped; what came before is decoded.
if case_begin h8-zip-bomb-the; then
make sigrok-zip-bomb
expect_last "sigrok zip bomb" 1 "^drivetap: $work/sigrok-zip-bomb.sr: logic-1-1: offset [0-9]+: the samples decompress to more than 16777216 bytes, the limit \(--logic-max; a zip bomb\?\): read up to there$" -- \
  "$drivetap" read --logic-max 16M "$work/sigrok-zip-bomb.sr"
grep -q "crc ok" "$work/out" && ok "zip bomb: the frames before the limit decoded" ||
  fail "zip bomb: nothing decoded before the limit"
"$drivetap" read --logic-max 1X "$work/sigrok-zip-bomb.sr" > /dev/null 2> "$work/err"
rc=$?
[ "$rc" -eq 2 ] && head -n 1 "$work/err" | grep -q "^drivetap: read: --logic-max: " && ok "--logic-max of no size" ||
  fail "--logic-max of no size: exit $rc: $(head -n 1 "$work/err")"

fi

# 9. Byte times before 0 written to pcapng must read back (and not as 18446744073 s in tshark).
if case_begin h9-byte-times-before; then
make pcapng-first-packet-at-zero pcapng-negative-tsoffset
for f in pcapng-first-packet-at-zero pcapng-negative-tsoffset; do
  "$drivetap" read "$work/$f.pcapng" -w "$work/$f.out.pcapng" > "$work/$f.txt" 2>/dev/null
  if ! "$drivetap" read "$work/$f.out.pcapng" > "$work/$f.back.txt" 2> "$work/err"; then
    fail "$f: the written pcapng does not read back: $(cat "$work/err")"
  elif ! diff -q <(grep -v '^capture:' "$work/$f.txt") <(grep -v '^capture:' "$work/$f.back.txt") >/dev/null; then
    fail "$f: read back differs: $(diff <(cat "$work/$f.txt") <(cat "$work/$f.back.txt") | head -5)"
  else
    ok "$f: written and read back"
  fi
  if command -v tshark >/dev/null; then
    first=$(tshark -r "$work/$f.out.pcapng" -T fields -e frame.time_epoch 2>/dev/null | head -n 1)
    awk -v t="$first" 'BEGIN { exit !(t != "" && t + 0 < 1000) }' ||
      fail "$f: tshark shows the first packet at $first s"
  fi
done

fi

# 10. A closed pipe on stdout: the -w file is closed whole, the exit is SIGPIPE's.
if case_begin h10-a-closed-pipe; then
"$drivetap" generate --frames 20000 --seed 3 -o "$work/g.log" 2>/dev/null
"$drivetap" read "$work/g.log" -w "$work/piped.pcapng" 2> "$work/err" | head -n 1 > /dev/null
rc=${PIPESTATUS[0]}
[ "$rc" -eq 141 ] || fail "closed pipe: exit $rc, expected 141 ($(cat "$work/err"))"
[ -s "$work/err" ] && fail "closed pipe: stderr not empty: $(head -c 200 "$work/err")"
"$drivetap" read --stats "$work/piped.pcapng" > "$work/piped.txt" 2> "$work/err" &&
  grep -q "^frames: *[1-9]" "$work/piped.txt" && ok "closed pipe: -w pcapng whole" ||
  fail "closed pipe: -w pcapng does not read back: $(cat "$work/err")"
"$drivetap" read "$work/g.log" --pcap -w "$work/piped.pcap" 2>/dev/null | head -n 1 > /dev/null
"$drivetap" read --stats "$work/piped.pcap" > /dev/null 2> "$work/err" && ok "closed pipe: --pcap whole" ||
  fail "closed pipe: --pcap does not read back: $(cat "$work/err")"

fi

# 10b. The listings into a pipe whose reader is gone (`drivetap fields | head -1`): silent, the
if case_begin h10b-the-listings-into; then
# exit SIGPIPE's (fmt::print's failed write once ended in std::terminate, "terminate called").
for listing in fields profiles; do
  out=$(python3 -c 'import os, subprocess, sys
r, w = os.pipe()
os.close(r)
p = subprocess.run(sys.argv[1:], stdout=w, stderr=subprocess.PIPE)
print(p.returncode, repr(p.stderr.decode()[:200]))' "$drivetap" "$listing")
  [ "$out" = "141 ''" ] && ok "closed pipe: drivetap $listing" ||
    fail "closed pipe: drivetap $listing: exit and stderr $out, expected 141 and nothing"
done

fi

# 11. SIGINT and SIGTERM while the output blocks (a FIFO nobody reads).
if case_begin h11-sigint-and-sigterm; then
[ -f "$work/g.log" ] || "$drivetap" generate --frames 20000 --seed 3 -o "$work/g.log" 2>/dev/null
for sig in INT TERM; do
  mkfifo "$work/blocked.$sig"
  sleep 60 < "$work/blocked.$sig" &
  holder=$!
  "$drivetap" read "$work/g.log" -o "$work/blocked.$sig" -w "$work/blocked.$sig.pcapng" 2> "$work/err" &
  pid=$!
  until_process "SIG$sig with a blocked output" "$pid" blocked
  kill -"$sig" "$pid"
  if stopped "SIG$sig with a blocked output" "$pid" 10; then
    [ "$rc" -eq 130 ] && grep -q "interrupted" "$work/err" && ok "SIG$sig with a blocked output" ||
      fail "SIG$sig with a blocked output: exit $rc: $(cat "$work/err")"
    "$drivetap" read --stats "$work/blocked.$sig.pcapng" > /dev/null 2>&1 ||
      fail "SIG$sig with a blocked output: the -w file does not read back"
  fi
  kill "$holder" 2>/dev/null
  wait "$holder" 2>/dev/null
done

fi

# 12. SIGINT during a logic capture's long idle stretch.
if case_begin h12-sigint-during-a; then
make logic-long-idle
"$drivetap" read --logic-max 0 "$work/logic-long-idle.sr" > /dev/null 2> "$work/err" &
pid=$!
until_process "SIGINT on a logic capture's idle line" "$pid" running
kill -INT "$pid"
if stopped "SIGINT on a logic capture's idle line" "$pid" 5; then
  [ "$rc" -eq 130 ] && tail -n 1 "$work/err" | grep -q "interrupted" && ok "SIGINT on a logic capture's idle line" ||
    fail "SIGINT on a logic capture's idle line: exit $rc: $(tail -n 1 "$work/err")"
fi

fi

# 13. An output that is an input, or another output.
if case_begin h13-an-output-that; then
"$drivetap" read "$log" -w "$work/y.pcapng" 2>/dev/null >/dev/null
cp "$work/y.pcapng" "$work/y.keep"
expect "read Y.pcapng -w Y.pcapng" 2 "^drivetap: -w $work/y.pcapng: is the same file as input $work/y.pcapng: refusing to overwrite it$" -- \
  "$drivetap" read "$work/y.pcapng" -w "$work/y.pcapng"
cmp -s "$work/y.pcapng" "$work/y.keep" || fail "read Y.pcapng -w Y.pcapng: the input was changed"
cp "$log" "$work/in.log"
expect "read X.log -o X.log" 2 "^drivetap: -o $work/in.log: is the same file as input" -- \
  "$drivetap" read "$work/in.log" -o "$work/in.log"
expect "read X.log -o ./X.log (another path)" 2 "is the same file as input" -- \
  bash -c 'cd "$1" && exec "$2" read "$1/in.log" -o ./in.log' _ "$work" "$drivetap"
ln "$work/in.log" "$work/hard.log"
expect "read X.log -o a hard link to it" 2 "is the same file as input" -- \
  "$drivetap" read "$work/in.log" -o "$work/hard.log"
expect "read -o F -w F" 2 "^drivetap: -w $work/f.out: is the same file as -o $work/f.out" -- \
  "$drivetap" read "$log" -o "$work/f.out" -w "$work/f.out"
expect "generate -o F -w F" 2 "^drivetap: -w $work/g.out: is the same file as -o $work/g.out" -- \
  "$drivetap" generate --frames 10 -o "$work/g.out" -w "$work/g.out"
expect "read -o /dev/null -w /dev/null (a device twice)" 0 '' -- \
  "$drivetap" read "$log" -o /dev/null -w /dev/null

fi

# 14. Write errors of every command.
if case_begin h14-write-errors-of; then
expect "diagnose > /dev/full" 1 '^drivetap: standard output: write failed: No space left on device$' -- \
  sh -c '"$0" diagnose "$1" > /dev/full' "$drivetap" "$log"
expect "profiles > /dev/full" 1 '^drivetap: standard output: write failed: No space left on device$' -- \
  sh -c '"$0" profiles > /dev/full' "$drivetap"
expect "decode > /dev/full" 1 '^drivetap: standard output: write failed: No space left on device$' -- \
  sh -c '"$0" decode "02 03 00 00 00 04 44 3A" > /dev/full' "$drivetap"

fi

# 15. Names that are not printable UTF-8 reach neither the terminal nor the JSON as they are.
if case_begin h15-names-that-are; then
printf '0.000000 b\xff\x1b[2Jus 02 03 00 00 00 04 44 3A\n0.100000 b\xff\x1b[2Jus 02 03 08 00 01 00 02 00 03 00 04 0D 14\n' > "$work/names.log"
"$drivetap" read "$work/names.log" > "$work/names.txt" 2> "$work/names.err"
if grep -q $'\x1b' "$work/names.txt" "$work/names.err" || LC_ALL=C grep -q $'\xff' "$work/names.txt"; then
  fail "hostile channel name: ESC or 0xFF reached the text output"
else
  grep -q 'b\\xFF\\x1B\[2Jus' "$work/names.txt" && ok "hostile channel name: escaped in text" ||
    fail "hostile channel name: not shown escaped: $(head -n 2 "$work/names.txt")"
fi
grep -q "1 channel name was not printable UTF-8" "$work/names.err" ||
  fail "hostile channel name: no note: $(cat "$work/names.err")"
"$drivetap" read -T json "$work/names.log" > "$work/names.json" 2>/dev/null
python3 -c '
import json, sys
for line in open(sys.argv[1], "rb"):
    json.loads(line.decode("utf-8", errors="strict"))
' "$work/names.json" && ok "hostile channel name: JSON is valid UTF-8" ||
  fail "hostile channel name: JSON is not valid UTF-8 JSON"
make pcapng-64k-interface-name
"$drivetap" read -T json "$work/pcapng-64k-interface-name.pcapng" > "$work/long.json" 2>/dev/null
longest=$(awk '{ if (length($0) > m) m = length($0) } END { print m + 0 }' "$work/long.json")
[ "$longest" -lt 4000 ] && ok "64 KiB interface name: shortened ($longest-character lines)" ||
  fail "64 KiB interface name: JSON lines of $longest characters"

fi

# 16. A FIFO as a profile must not hang.
if case_begin h16-a-fifo-as; then
mkfifo "$work/fifo.toml"
expect "--profile FIFO" 1 "^drivetap: profile $work/fifo.toml: is not a regular file" -- \
  timeout 10 "$drivetap" read --profile "$work/fifo.toml" "$log"
mkdir "$work/fifodir" && mkfifo "$work/fifodir/x.toml"
expect "--profile-dir with a FIFO" 1 "^drivetap: profile $work/fifodir/x.toml: is not a regular file" -- \
  timeout 10 "$drivetap" read --profile-dir "$work/fifodir" "$log"

fi

# Minor: a NUL in an error message, a VCD with a BOM, a channel named twice.
if case_begin minor; then
printf '0.0 bus 02 0\x003\n' > "$work/nul.log"
expect "error message with a NUL" 1 "bad byte '0\\\\x003'" -- "$drivetap" read "$work/nul.log"
vcd=$root/captures/vcd/hello_world_7o1_115200.vcd
{ printf '\xef\xbb\xbf'; cat "$vcd"; } > "$work/bom.vcd"
"$drivetap" read "$vcd" > "$work/plain.txt" 2>/dev/null
"$drivetap" read "$work/bom.vcd" > "$work/bom.txt" 2> "$work/err" &&
  cmp -s "$work/plain.txt" "$work/bom.txt" && ok "VCD with a UTF-8 BOM" ||
  fail "VCD with a UTF-8 BOM: $(head -n 1 "$work/err")"
expect "--channels 0,0" 1 "^drivetap: --channels: $vcd: channel '.*' is named twice" -- \
  "$drivetap" read --channels 0,0 "$vcd"

fi
cases_finish
echo "$failures hostile case(s) failed"
[ "$failures" -eq 0 ]
