#!/usr/bin/env bash
# Integration tests of `drivetap capture` on the simulated bus (tools/drivetap-simbus: Modbus RTU
# written to a pseudo-terminal at the true character timing): every frame arrives, framed and
# paired, at 9600 and 115200 baud, with clean gaps, with USB-like bursts that hide every gap, and
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

# run NAME SERIAL SIMBUS-ARGS... : simulator and capture until the simulator ends (the pty hangs
# up: the capture ends as for an unplugged adapter).
run() {
  local name=$1 serial=$2
  shift 2
  local link="$tmp/$name.tty"
  "$simbus" --link "$link" --serial "$serial" --wait-ms 600 --truth "$tmp/$name.truth" "$@" \
    2>"$tmp/$name.sim" &
  local sim=$!
  for _ in $(seq 50); do [ -e "$link" ] && break; sleep 0.02; done
  "$drivetap" capture -i "$link" -s "$serial" -P rtu --drive none -w "$tmp/$name.pcapng" \
    >"$tmp/$name.txt" 2>"$tmp/$name.err"
  echo $? >"$tmp/$name.rc"
  wait "$sim"
}

# check NAME: every frame sent was captured with a good CRC, garbage as noise, files valid.
check() {
  local name=$1
  local out="$tmp/$name.txt" sent garbage frames ok noise
  sent=$(truth_frames "$tmp/$name.truth")
  garbage=$(truth_garbage "$tmp/$name.truth")
  frames=$(summary_field "$out" frames)
  ok=$(sed -n 's/^frames: *[0-9]* (checksum ok \([0-9]*\),.*/\1/p' "$out")
  noise=$(sed -n 's/.*noise: \([0-9]*\) records.*/\1/p' "$out")
  [ "$(cat "$tmp/$name.rc")" = 1 ] || fail "$name: exit $(cat "$tmp/$name.rc"), expected 1 (pty gone)"
  grep -q "adapter unplugged or gone" "$tmp/$name.err" || fail "$name: no unplugged message"
  [ "$frames" = "$sent" ] && [ "$ok" = "$sent" ] ||
    fail "$name: $sent frames sent, captured $frames ($ok with a good CRC)"
  [ "$noise" = "$garbage" ] || fail "$name: $garbage garbage records sent, $noise noise records"
  check_pcapng "$name" $((frames + noise))
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
grep -q "timing trusted: no\|USB burst" "$tmp/burst.err" || fail "burst: no USB burst verdict"
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
sleep 2
kill -INT "$cap"
wait "$cap"
rc=$?
kill "$sim" 2>/dev/null
wait "$sim" 2>/dev/null
[ "$rc" = 130 ] || fail "SIGINT: exit $rc, expected 130"
frames=$(summary_field "$tmp/int.txt" frames)
noise=$(sed -n 's/.*noise: \([0-9]*\) records.*/\1/p' "$tmp/int.txt")
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

# Bad ports: one line naming the port, exit 1.
err=$("$drivetap" capture -i /nonexistent/ttyUSB9 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] && [ "$(wc -l <<<"$err")" = 1 ] && grep -q "^drivetap: /nonexistent/ttyUSB9: " <<<"$err" ||
  fail "missing port: exit $rc, stderr: $err"
err=$("$drivetap" capture -i "$tmp" 2>&1 >/dev/null); rc=$?
[ "$rc" = 1 ] && grep -q "not a serial port\|directory" <<<"$err" || fail "directory as port: $err"

[ "$failed" = 0 ] && echo "ok capture"
exit "$failed"
