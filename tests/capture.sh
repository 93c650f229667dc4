#!/usr/bin/env bash
# Integration tests of `drivetap capture` on the simulated bus (tools/drivetap-simbus: Modbus RTU
# written to a pseudo-terminal at the true character timing): every frame arrives, framed and
# paired, at 9600 and 115200 baud, with clean gaps, with USB-like bursts that hide every gap (no
# latency or silence rule judged once the timing is distrusted), read with a wrong -s (the rate
# the arrivals imply named), and
# with noise; SIGINT mid-run and an adapter that disappears leave a pcapng that tshark reads to
# the end with the frame count of the summary; -c stops after N frames.
# Usage: tests/capture.sh DRIVETAP SIMBUS
set -uo pipefail
drivetap=$1
simbus=$2
tmp=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; rm -rf "$tmp"' EXIT
failed=0
fail() { echo "FAIL: $*"; failed=1; }

# truth_count FILE: frames (non-garbage lines) and garbage records the simulator sent.
truth_frames() { grep -v '^#' "$1" | grep -vc '# garbage'; }
truth_garbage() { grep -c '# garbage' "$1"; }
summary_field() { sed -n "s/^$2: *\([0-9]*\).*/\1/p" "$1"; }
# disturbed TRUTH...: records the simulator wrote with a pause inside or behind their schedule (it
# was preempted): each may run into a neighbour or come apart.
disturbed() { cat "$@" | grep -c 'pause inside as written\|behind its schedule'; }

# until_true SECONDS COMMAND...: waits for a state (COMMAND succeeds), polling every 20 ms; false
# when it has not come after SECONDS. The tests wait for what they need, never a fixed time.
until_true() {
  local end=$((SECONDS + $1))
  shift
  until "$@"; do
    [ "$SECONDS" -ge "$end" ] && return 1
    sleep 0.02
  done
}
# at_least N PATTERN FILE: FILE has N lines matching PATTERN.
at_least() { [ "$(grep -c -- "$2" "$3" 2>/dev/null)" -ge "$1" ]; }

# The simulator and the capture whose counts are checked run at real-time priority where allowed:
# on a busy machine a normal process loses the CPU for milliseconds, longer than the silences that
# cut the frames. The counts allow for what the simulator still reports late; a capture preempted
# itself cannot be told from a broken bus.
rt=()
if chrt -f 10 true 2>/dev/null; then
  rt=(chrt -f 10)
else
  echo "note: no real-time priority here (chrt -f refused): timing may slip on a busy machine"
fi

# run NAME SERIAL SIMBUS-ARGS... : simulator and capture until the simulator ends (the pty hangs
# up: the capture ends as for an unplugged adapter).
run() {
  local name=$1 serial=$2
  shift 2
  local link="$tmp/$name.tty"
  "${rt[@]}" "$simbus" --link "$link" --serial "$serial" --wait-ms 600 --truth "$tmp/$name.truth" \
    "$@" 2>"$tmp/$name.sim" &
  local sim=$!
  for _ in $(seq 50); do [ -e "$link" ] && break; sleep 0.02; done
  "${rt[@]}" "$drivetap" capture -i "$link" -s "$serial" -P rtu --drive none \
    -w "$tmp/$name.pcapng" >"$tmp/$name.txt" 2>"$tmp/$name.err"
  echo $? >"$tmp/$name.rc"
  wait "$sim"
}

# check NAME: every frame sent was captured with a good CRC, garbage as noise, files valid.
check() {
  local name=$1
  [ "$(cat "$tmp/$name.rc")" = 1 ] || fail "$name: exit $(cat "$tmp/$name.rc"), expected 1 (pty gone)"
  grep -q "adapter unplugged or gone" "$tmp/$name.err" || fail "$name: no unplugged message"
  check_counts "$name" "$tmp/$name.txt" "$(truth_frames "$tmp/$name.truth")" \
    "$(truth_garbage "$tmp/$name.truth")" "$(disturbed "$tmp/$name.truth")"
}

# check_counts NAME SUMMARY SENT GARBAGE DISTURBED: the summary's frames, good CRCs and noise
# records against what the simulators sent, and NAME's pcapng. A simulator preempted inside a
# frame puts a real gap in it, and one preempted around a write() shortens a silence (the truth
# notes either: DISTURBED records): such a record may be cut in two or run into its neighbour, a
# garbage record into a frame (a bad CRC), a frame's tail into the next garbage (noise). Every
# other frame must come with a good CRC and every other garbage record as noise.
check_counts() {
  local name=$1 out=$2 sent=$3 garbage=$4 disturbed=$5 frames ok noise
  frames=$(summary_field "$out" frames)
  ok=$(sed -n 's/^frames: *[0-9]* (checksum ok \([0-9]*\),.*/\1/p' "$out")
  noise=$(sed -n 's/.*noise: \([0-9]*\) records\?.*/\1/p' "$out")
  [ "$disturbed" -gt 0 ] &&
    echo "note: $name: $disturbed records written late or with a pause inside (preempted simulator)"
  [ "${ok:-0}" -le "$sent" ] && [ "${ok:-0}" -ge $((sent - disturbed)) ] &&
    [ "${frames:-0}" -ge $((sent - disturbed)) ] && [ "${frames:-0}" -le $((sent + disturbed)) ] ||
    fail "$name: $sent frames sent, captured $frames ($ok with a good CRC)"
  # On a loaded machine the pty may also deliver a garbage record in two reads far apart, which
  # makes two noise records of it.
  [ "${noise:-0}" -ge $((garbage - disturbed)) ] &&
    [ "${noise:-0}" -le $((2 * garbage + 2 * disturbed)) ] ||
    fail "$name: $garbage garbage records sent, $noise noise records"
  check_pcapng "$name" $((${frames:-0} + ${noise:-0}))
}

# check_pcapng NAME PACKETS: tshark reads the file to its end, one packet per frame/noise record.
check_pcapng() {
  if ! command -v tshark >/dev/null; then
    [ "${DRIVETAP_REQUIRE_TSHARK:-0}" = 1 ] && fail "tshark not installed"
    return
  fi
  local packets
  packets=$(tshark -r "$tmp/$1.pcapng" 2>"$tmp/$1.tshark" | wc -l)
  # (tshark warns about running as root; anything else on stderr is a complaint about the file)
  local complaint
  complaint=$(grep -v "Running as user" "$tmp/$1.tshark" | head -1)
  [ -n "$complaint" ] && fail "$1: tshark: $complaint"
  [ "$packets" = "$2" ] || fail "$1: tshark reads $packets packets, the summary says $2"
}

run slow "9600 8E1" --frames 40
check slow
run fast "115200 8N1" --frames 120
check fast
# Bytes delivered every 16 ms, as through an FTDI adapter: no gap is visible, content frames.
run burst "115200 8N1" --frames 120 --burst 16
check burst
grep -q "^source: .*timing not trusted: USB burst artefacts" "$tmp/burst.txt" ||
  fail "burst: no USB burst verdict in the summary"
# Timing not trusted: from the verdict on, no latency is printed and no silence rule judged
# (the few telegrams before it may still show theirs).
grep -q "^timing: *not trusted" "$tmp/burst.txt" || fail "burst: no 'timing: not trusted' line"
grep -q "timing not trusted: .*; from here on no latency or silence rule is judged" "$tmp/burst.err" ||
  fail "burst: no warning when timing stopped being trusted: $(head -3 "$tmp/burst.err")"
measured=$(grep -c "reply to #[0-9]* in [0-9.]* ms" "$tmp/burst.txt")
hidden=$(grep -c "latency hidden: timing not trusted" "$tmp/burst.txt")
[ "$hidden" -ge 30 ] && [ "$measured" -le 5 ] ||
  fail "burst: $measured latencies printed, $hidden hidden for untrusted timing"
grep -q "^anomalies:.*\(intra_frame_gap\|short_interframe_gap\)" "$tmp/burst.txt" &&
  [ "$(grep -c "gap inside frame\|silence before frame" "$tmp/burst.txt")" -gt 5 ] &&
  fail "burst: silence findings judged on untrusted timing"
# A wrong -s whose bytes arrive intact (19200 8E1 read as 9600 8E1 on a pty, which keeps no line
# pace): the arrivals name the line's rate, and its timing is not trusted.
link="$tmp/wrong.tty"
"${rt[@]}" "$simbus" --link "$link" --serial "19200 8E1" --wait-ms 600 --frames 60 2>/dev/null &
for _ in $(seq 50); do [ -e "$link" ] && break; sleep 0.02; done
"${rt[@]}" "$drivetap" capture -i "$link" -s "9600 8E1" -P rtu --drive none >"$tmp/wrong.txt" \
  2>"$tmp/wrong.err"
grep -q "faster than 9600 8E1 carries one (1145 us): the line runs at 19200 baud" "$tmp/wrong.err" ||
  fail "wrong baud: no rate named: $(grep -v "^drivetap: capturing" "$tmp/wrong.err" | head -3)"
grep -q "^timing: *not trusted" "$tmp/wrong.txt" || fail "wrong baud: timing still trusted"
grep -q "^source: .*kernel counters\|^source: .*TIOCGICOUNT" "$tmp/slow.txt" ||
  fail "slow: no kernel counter line in the summary"
run noisy "19200 8E1" --frames 80 --noise 0.3
check noisy
[ "$(truth_garbage "$tmp/noisy.truth")" -gt 0 ] || fail "noisy: the simulator sent no garbage"

# SIGINT mid-run: exit 130, the files closed valid with the summary's frame count.
link="$tmp/int.tty"
"$simbus" --link "$link" --serial "19200 8E1" --wait-ms 300 --duration 6 2>/dev/null &
sim=$!
for _ in $(seq 50); do [ -e "$link" ] && break; sleep 0.02; done
"$drivetap" capture -i "$link" -s "19200 8E1" -P rtu --drive none -w "$tmp/int.pcapng" \
  >"$tmp/int.txt" 2>"$tmp/int.err" &
cap=$!
until_true 20 at_least 30 "crc ok" "$tmp/int.txt" || fail "SIGINT: 30 frames not captured in 20 s"
kill -INT "$cap"
wait "$cap"
rc=$?
kill "$sim" 2>/dev/null
wait "$sim" 2>/dev/null
[ "$rc" = 130 ] || fail "SIGINT: exit $rc, expected 130"
frames=$(summary_field "$tmp/int.txt" frames)
noise=$(sed -n 's/.*noise: \([0-9]*\) records\?.*/\1/p' "$tmp/int.txt")
[ "${frames:-0}" -gt 20 ] || fail "SIGINT: only '${frames}' frames before the interrupt"
check_pcapng int $((frames + noise))

# -c N: stops by itself after N frames, exit 0.
link="$tmp/count.tty"
"$simbus" --link "$link" --serial "19200 8E1" --wait-ms 300 --duration 6 2>/dev/null &
sim=$!
for _ in $(seq 50); do [ -e "$link" ] && break; sleep 0.02; done
"$drivetap" capture -i "$link" -s "19200 8E1" -P rtu --drive none -c 10 >"$tmp/count.txt" \
  2>"$tmp/count.err"
rc=$?
kill "$sim" 2>/dev/null
wait "$sim" 2>/dev/null
[ "$rc" = 0 ] || fail "-c 10: exit $rc"
[ "$(summary_field "$tmp/count.txt" frames)" = 10 ] || fail "-c 10: $(grep '^frames' "$tmp/count.txt")"

# start_sim NAME SERIAL SECONDS: a simulator in the background ($sim), its link ready.
start_sim() {
  link="$tmp/$1.tty"
  "$simbus" --link "$link" --serial "$2" --wait-ms 300 --duration "$3" 2>/dev/null &
  sim=$!
  for _ in $(seq 50); do [ -e "$link" ] && break; sleep 0.02; done
}
stop_sim() { kill "$sim" 2>/dev/null; wait "$sim" 2>/dev/null; }

# Full disk (a file-size limit stands in for it): one error line, exit 1, and a file cut back to
# its last whole packet, which tshark reads to the end.
start_sim full "19200 8E1" 5
(ulimit -f 16; "$drivetap" capture -i "$link" -s "19200 8E1" -P rtu --drive none \
  -w "$tmp/full.pcapng" >"$tmp/full.txt" 2>"$tmp/full.err")
rc=$?
stop_sim
[ "$rc" = 1 ] && grep -q "^drivetap: -w $tmp/full.pcapng: write failed: File too large" "$tmp/full.err" ||
  fail "full disk: exit $rc, $(tail -1 "$tmp/full.err")"
if command -v tshark >/dev/null; then
  packets=$(tshark -r "$tmp/full.pcapng" 2>/dev/null | wc -l)
  complaint=$(tshark -r "$tmp/full.pcapng" 2>&1 >/dev/null | grep -v "Running as user" | head -1)
  [ -z "$complaint" ] && [ "$packets" -gt 20 ] || fail "full disk: file not valid: $complaint ($packets)"
fi

# Ring of files (-b): rotated by duration, only the newest 2 kept, each readable to its end.
mkdir "$tmp/ring"
start_sim ring "19200 8E1" 4
"$drivetap" capture -i "$link" -s "19200 8E1" -P rtu --drive none -w "$tmp/ring/bus.pcapng" \
  -b duration:1 -b files:2 -a duration:3.5 >"$tmp/ring.txt" 2>"$tmp/ring.err"
rc=$?
stop_sim
[ "$rc" = 0 ] || fail "ring: exit $rc: $(tail -1 "$tmp/ring.err")"
files=$(ls "$tmp/ring" | grep -c '^bus_[0-9]\{5\}_[0-9]\{14\}\.pcapng$')
[ "$files" = 2 ] || fail "ring: $files files kept, expected 2: $(ls "$tmp/ring")"
for f in "$tmp"/ring/*.pcapng; do
  cp "$f" "$tmp/ringfile.pcapng"
  check_pcapng ringfile "$(tshark -r "$f" 2>/dev/null | wc -l)"
done

# The short form (drivetap -i PORT) and --scan (on a pty every setting hears the traffic: this
# checks the mechanics, not the choice).
start_sim short "19200 8E1" 3
"$drivetap" -i "$link" -s "19200 8E1" -P rtu --drive none -c 5 >"$tmp/short.txt" 2>/dev/null ||
  fail "short form: exit $?"
stop_sim
grep -q "^frames: *5 " "$tmp/short.txt" || fail "short form: $(grep '^frames' "$tmp/short.txt")"
# (48 settings, 0.2 s each.) A pty checks no parity and applies no rate: every setting ties, and
# the scan says so, and why, rather than name one.
start_sim scan "19200 8E1" 14
out=$("$drivetap" capture --scan --scan-time 0.2 -i "$link" -P rtu 2>&1); rc=$?
stop_sim
[ "$rc" = 0 ] && grep -q '^best: [0-9]* settings alike ([0-9]* to [0-9]* frames with a good checksum' <<<"$out" &&
  grep -q '^not told apart: 8 rates gave the same frames: the port applies no baud rate' <<<"$out" &&
  grep -q 'alike: the port reported no parity or framing mark' <<<"$out" &&
  grep -q '^  19200 7E1 ' <<<"$out" || fail "--scan: exit $rc: $out"

# --reconnect: the adapter goes (the simulator ends, its pty and link vanish) and comes back (a
# new simulator on the same link): the capture goes on with both parts, until SIGINT.
link="$tmp/again.tty"
"${rt[@]}" "$simbus" --link "$link" --serial "19200 8E1" --wait-ms 300 --frames 20 2>/dev/null &
sim=$!
for _ in $(seq 50); do [ -e "$link" ] && break; sleep 0.02; done
"${rt[@]}" "$drivetap" capture -i "$link" -s "19200 8E1" -P rtu --drive none --reconnect \
  >"$tmp/again.txt" 2>"$tmp/again.err" &
cap=$!
wait "$sim"
# The capture has read every byte once it says the port is gone.
until_true 20 at_least 1 "gone" "$tmp/again.err" || fail "--reconnect: the port's loss not seen"
"${rt[@]}" "$simbus" --link "$link" --serial "19200 8E1" --wait-ms 800 --frames 20 2>/dev/null
until_true 20 at_least 2 "gone" "$tmp/again.err" || fail "--reconnect: the second loss not seen"
kill -INT "$cap"
wait "$cap"
rc=$?
[ "$rc" = 130 ] || fail "--reconnect: exit $rc"
grep -q "reconnected" "$tmp/again.err" || fail "--reconnect: no reconnection: $(cat "$tmp/again.err")"
[ "$(summary_field "$tmp/again.txt" frames)" = 40 ] ||
  fail "--reconnect: $(grep '^frames' "$tmp/again.txt"), expected 40"

# Two ports at once (two buses, or the two pairs of a 4-wire link): merged in time order, each a
# channel and a pcapng interface; the pcapng streamed to stdout (-w -) while the text summary
# goes to stderr.
"${rt[@]}" "$simbus" --link "$tmp/a.tty" --serial "19200 8E1" --wait-ms 600 --frames 30 --seed 1 \
  --truth "$tmp/a.truth" 2>/dev/null &
sim_a=$!
"${rt[@]}" "$simbus" --link "$tmp/b.tty" --serial "19200 8E1" --wait-ms 600 --frames 30 --seed 2 \
  --truth "$tmp/b.truth" 2>/dev/null &
sim_b=$!
for _ in $(seq 50); do [ -e "$tmp/a.tty" ] && [ -e "$tmp/b.tty" ] && break; sleep 0.02; done
# (--reconnect: the first simulator to end must not stop the capture of the other.)
"${rt[@]}" "$drivetap" capture -i "$tmp/a.tty=busA" -i "$tmp/b.tty=busB" -s "19200 8E1" -P rtu \
  --drive none --reconnect -w - >"$tmp/two.pcapng" 2>"$tmp/two.err" &
cap=$!
wait "$sim_a" "$sim_b"
until_true 20 at_least 2 "gone" "$tmp/two.err" || fail "two ports: the ports' loss not seen"
kill -INT "$cap"
wait "$cap"
# 60 frames, no garbage; as for one port, a frame the simulator was late with may be cut.
check_counts two "$tmp/two.err" 60 0 "$(disturbed "$tmp/a.truth" "$tmp/b.truth")"
if command -v tshark >/dev/null; then
  interfaces=$(tshark -r "$tmp/two.pcapng" -T fields -e frame.interface_name 2>/dev/null | sort -u | tr '\n' ' ')
  [ "$interfaces" = "busA busB " ] || fail "two ports: interfaces '$interfaces'"
fi

# Bad ports: one line naming the port, exit 1.
err=$("$drivetap" capture -i /nonexistent/ttyUSB9 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] && [ "$(wc -l <<<"$err")" = 1 ] && grep -q "^drivetap: /nonexistent/ttyUSB9: " <<<"$err" ||
  fail "missing port: exit $rc, stderr: $err"
err=$("$drivetap" capture -i "$tmp" 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] && grep -q "not a serial port\|directory" <<<"$err" || fail "directory as port: $err"

[ "$failed" = 0 ] && echo "ok capture"
exit "$failed"
