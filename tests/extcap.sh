#!/usr/bin/env bash
# drivetap as a Wireshark extcap, called the way Wireshark calls it: --extcap-interfaces over a
# fake device tree (the same ports as drivetap -D), --extcap-dlts, --extcap-config (checked by
# tshark's own parser too), then --capture --fifo on the simulated bus (tools/drivetap-simbus):
# the stream tshark reads has the frames the simulator sent and the decode of `drivetap capture
# -w` of the same traffic; SIGTERM mid-run leaves a stream tshark reads to the end; the control
# pipe carries status-bar counts; a reader that goes away ends it quietly; bytes faster than the
# line settings are a warning in Wireshark's log; --detect searches the settings first; a missing
# port gives one line and a non-zero exit. Then a round trip through tshark itself: `drivetap
# wireshark --install` into a temporary HOME, tshark -D lists the port, tshark -i captures from
# the simulated bus; --uninstall takes it away again.
# Usage: tests/extcap.sh DRIVETAP SIMBUS
set -uo pipefail
drivetap=$1
simbus=$2
tmp=$(mktemp -d)
trap 'kill $(jobs -p) 2>/dev/null; rm -rf "$tmp"' EXIT
failed=0
fail() { echo "FAIL: $*"; failed=1; }
# until_status N FILE: waits (up to 20 s, polling) until the control messages in FILE hold a status
# bar count of N frames or more: the tests wait for what they need, never a fixed time.
until_status() {
  local end=$((SECONDS + 20)) n
  while [ "$SECONDS" -lt "$end" ]; do
    n=$(grep -ao "drivetap: [0-9]* frames" "$2" 2>/dev/null | tail -n 1 | tr -dc 0-9)
    [ -n "$n" ] && [ "$n" -ge "$1" ] && return 0
    sleep 0.02
  done
  return 1
}
# stop_capture: SIGTERM to the capture ($cap), its exit status in rc; then its two readers
# ($reader, $control_reader) end and the simulator ($sim) is stopped.
stop_capture() {
  kill -TERM "$cap"
  wait "$cap"
  rc=$?
  wait "$reader" "$control_reader"
  kill "$sim" 2>/dev/null
  wait "$sim" 2>/dev/null
}
have_tshark=0
if command -v tshark >/dev/null; then
  have_tshark=1
elif [ "${DRIVETAP_REQUIRE_TSHARK:-0}" = 1 ]; then
  fail "tshark not installed"
fi
rt=()
chrt -f 10 true 2>/dev/null && rt=(chrt -f 10)

# A fake device tree: three USB adapters (one with a by-id name), an ACM modem, a ttyS with a
# UART and one without (skipped), and a tty that is no serial port.
root="$tmp/root"
mkdir -p "$root/dev/serial/by-id" "$root/sys/class/tty/ttyS0" "$root/sys/class/tty/ttyS1"
for name in ttyUSB0 ttyUSB10 ttyUSB2 ttyACM0 ttyS0 ttyS1 tty; do : >"$root/dev/$name"; done
echo 4 >"$root/sys/class/tty/ttyS0/type"
echo 0 >"$root/sys/class/tty/ttyS1/type"
ln -s ../../ttyUSB2 "$root/dev/serial/by-id/usb-FTDI_USB-RS485_Cable_FT1234-if00-port0"

# --extcap-interfaces: the extcap sentence, one interface per port, the toolbar's log button.
got=$(DRIVETAP_DEVICE_ROOT=$root "$drivetap" --extcap-interfaces --extcap-version=4.0); rc=$?
expected='extcap {version=0.1.0}{display=drivetap RS-485 bus tap}
interface {value=/dev/ttyACM0}{display=RS-485 tap /dev/ttyACM0}
interface {value=/dev/ttyS0}{display=RS-485 tap /dev/ttyS0}
interface {value=/dev/ttyUSB0}{display=RS-485 tap /dev/ttyUSB0}
interface {value=/dev/ttyUSB2}{display=RS-485 tap /dev/ttyUSB2 (usb-FTDI_USB-RS485_Cable_FT1234-if00-port0)}
interface {value=/dev/ttyUSB10}{display=RS-485 tap /dev/ttyUSB10}
control {number=0}{type=button}{role=logger}{display=Log}{tooltip=drivetap'"'"'s notes on the port and the line}'
[ "$rc" = 0 ] && [ "$got" = "$expected" ] || fail "--extcap-interfaces (exit $rc): $got"
# The same ports as drivetap -D, in its order.
listed=$(DRIVETAP_DEVICE_ROOT=$root "$drivetap" -D | sed 's/^[0-9]*\. \([^ ]*\).*/\1/')
interfaces=$(sed -n 's/^interface {value=\([^}]*\)}.*/\1/p' <<<"$got")
[ "$listed" = "$interfaces" ] || fail "--extcap-interfaces lists other ports than -D: $listed"
# No port at all: still a valid answer, exit 0 (Wireshark shows no interface).
mkdir -p "$tmp/empty/dev"
got=$(DRIVETAP_DEVICE_ROOT=$tmp/empty "$drivetap" --extcap-interfaces); rc=$?
[ "$rc" = 0 ] && ! grep -q '^interface' <<<"$got" && grep -q '^extcap {version=' <<<"$got" ||
  fail "--extcap-interfaces without ports: exit $rc: $got"
# Through a link named drivetap-extcap (as installed), and as `drivetap extcap`.
ln -s "$(readlink -f "$drivetap")" "$tmp/drivetap-extcap"
[ "$(DRIVETAP_DEVICE_ROOT=$root "$tmp/drivetap-extcap" --extcap-interfaces)" = "$expected" ] ||
  fail "drivetap-extcap --extcap-interfaces differs"
[ "$(DRIVETAP_DEVICE_ROOT=$root "$drivetap" extcap --extcap-interfaces)" = "$expected" ] ||
  fail "drivetap extcap --extcap-interfaces differs"

# --extcap-dlts: the link type of the pcapng (exported PDU).
got=$("$drivetap" --extcap-dlts --extcap-interface /dev/ttyUSB0)
grep -qx 'dlt {number=252}{name=WIRESHARK_UPPER_PDU}{display=.*}' <<<"$got" &&
  [ "$(wc -l <<<"$got")" = 1 ] || fail "--extcap-dlts: $got"

# --extcap-config: well-formed sentences, every value for an argument declared before it, and
# every call an option the capture takes (each tried with its default or first value).
config=$(DRIVETAP_DEVICE_ROOT=$root "$drivetap" --extcap-config --extcap-interface /dev/ttyUSB0)
python3 - "$config" <<'EOF' || fail "--extcap-config: $config"
import re, sys
args, calls = {}, []
for line in sys.argv[1].splitlines():
    m = re.fullmatch(r"(arg|value) ((?:\{[a-z]+=[^{}]*\})+)", line)
    assert m, f"not a sentence: {line}"
    fields = dict(re.findall(r"\{([a-z]+)=([^{}]*)\}", m.group(2)))
    if m.group(1) == "arg":
        n = int(fields["number"])
        assert n not in args, f"argument {n} twice"
        assert fields["type"] in {"integer", "unsigned", "long", "double", "string", "selector",
                                  "radio", "boolflag", "boolean", "multicheck", "fileselect",
                                  "password", "timestamp"}, line
        args[n] = fields
        calls.append(fields["call"])
    else:
        assert int(fields["arg"]) in args, f"value of an undeclared argument: {line}"
        assert fields["default"] in ("true", "false"), line
for call in ("--baud", "--line-format", "--protocol", "--drive", "--t35", "--timeout",
             "--second-port"):
    assert call in calls, f"no {call}"
EOF
# Each offered value is taken by the capture's option parser (a bad one would exit 2 at once).
while read -r arg value; do
  err=$("$drivetap" extcap --capture --extcap-interface /nonexistent/tty --fifo "$tmp/never" \
    "$arg" ${value:+"$value"} 2>&1)
  rc=$?
  [ "$rc" = 1 ] && grep -q "^drivetap: /nonexistent/tty: " <<<"$err" ||
    fail "config value $arg '$value': exit $rc: $err"
done < <(python3 - "$config" <<'EOF'
import re, sys
calls = {}
for line in sys.argv[1].splitlines():
    f = dict(re.findall(r"\{([a-z]+)=([^{}]*)\}", line))
    if line.startswith("arg"):
        calls[f["number"]] = f["call"]
        if f["type"] == "boolflag":
            print(f["call"])  # (Wireshark passes a flag alone, when set)
        elif "default" in f:
            print(f["call"], f["default"])
    elif f["value"]:
        print(calls[f["arg"]], f["value"])
EOF
)
[ -e "$tmp/never" ] && fail "a failed capture created its --fifo path"

# A missing port: one line on stderr, exit 1, nothing on stdout.
out=$("$drivetap" --capture --extcap-interface /nonexistent/ttyUSB9 --fifo "$tmp/never" \
  2>"$tmp/missing.err"); rc=$?
[ "$rc" = 1 ] && [ -z "$out" ] && [ "$(wc -l <"$tmp/missing.err")" = 1 ] &&
  grep -q "^drivetap: /nonexistent/ttyUSB9: " "$tmp/missing.err" ||
  fail "missing port: exit $rc, stderr: $(cat "$tmp/missing.err")"
# Capture filters are not supported: Wireshark's check prints a reason (invalid), a capture fails.
[ -n "$("$drivetap" --extcap-capture-filter "port 80" --extcap-interface /dev/ttyUSB0)" ] ||
  fail "a capture filter passes Wireshark's check"

# sim NAME SECONDS SEED: a simulator at 19200 8E1 in the background ($sim).
sim() {
  "${rt[@]}" "$simbus" --link "$tmp/$1.tty" --serial "19200 8E1" --wait-ms 600 --frames "$2" \
    --seed "$3" --truth "$tmp/$1.truth" 2>/dev/null &
  sim=$!
  for _ in $(seq 50); do [ -e "$tmp/$1.tty" ] && break; sleep 0.02; done
}
disturbed() { grep -c 'pause inside as written\|behind its schedule' "$@"; }
truth_frames() { grep -v '^#' "$1" | grep -vc '# garbage'; }
# decode FILE: each packet's Modbus unit and function as tshark sees them.
decode() { tshark -r "$1" -T fields -e mbrtu.unit_id -e modbus.func_code 2>/dev/null; }

# --capture --fifo on the simulated bus, the fifo read by tshark as Wireshark would, against
# `drivetap capture -w` of the same traffic (the simulator's same seed) and the simulator's truth.
# The pty hangs up when the simulator ends: the extcap ends as for an unplugged adapter.
sim ref 60 7
"${rt[@]}" "$drivetap" capture -i "$tmp/ref.tty" -s "19200 8E1" -P rtu --drive none \
  -w "$tmp/ref.pcapng" >/dev/null 2>&1
wait "$sim"
sim ext 60 7
mkfifo "$tmp/ext.fifo"
tee "$tmp/ext.pcapng" <"$tmp/ext.fifo" | { [ "$have_tshark" = 1 ] && tshark -r - 2>/dev/null | wc -l || cat >/dev/null; } >"$tmp/ext.count" &
reader=$!
"${rt[@]}" "$drivetap" --capture --extcap-interface "$tmp/ext.tty" --fifo "$tmp/ext.fifo" \
  --baud 19200 --line-format 8E1 --protocol rtu --drive none >"$tmp/ext.out" 2>"$tmp/ext.err"
rc=$?
wait "$sim" "$reader"
[ "$rc" = 1 ] && [ "$(wc -l <"$tmp/ext.err")" = 1 ] &&
  grep -q "adapter unplugged or gone" "$tmp/ext.err" ||
  fail "capture until the pty hangs up: exit $rc, stderr: $(cat "$tmp/ext.err")"
[ -s "$tmp/ext.out" ] && fail "--capture wrote to stdout: $(head -c 200 "$tmp/ext.out")"
late=$(($(disturbed "$tmp/ref.truth") + $(disturbed "$tmp/ext.truth")))
sent=$(truth_frames "$tmp/ext.truth")
if [ "$have_tshark" = 1 ]; then
  packets=$(cat "$tmp/ext.count")
  [ "$packets" -ge $((sent - late)) ] && [ "$packets" -le $((sent + late)) ] ||
    fail "--capture: tshark reads $packets packets from the fifo, the simulator sent $sent"
  if [ "$late" = 0 ]; then
    [ "$(decode "$tmp/ext.pcapng")" = "$(decode "$tmp/ref.pcapng")" ] ||
      fail "--capture decodes differently from capture -w: $(diff <(decode "$tmp/ext.pcapng") <(decode "$tmp/ref.pcapng") | head -5)"
  else
    echo "note: $late records sent late by a preempted simulator: decodes not compared"
  fi
  # The same pcapng: interfaces described alike (the line settings), the same link type.
  for f in ref ext; do
    tshark -r "$tmp/$f.pcapng" -T fields -e frame.interface_description -e frame.encap_type \
      2>/dev/null | sort -u >"$tmp/$f.interfaces"
  done
  grep -q "19200 8E1" "$tmp/ext.interfaces" && cmp -s "$tmp/ref.interfaces" "$tmp/ext.interfaces" ||
    fail "interfaces differ: $(cat "$tmp/ext.interfaces") vs $(cat "$tmp/ref.interfaces")"
fi

# SIGTERM mid-run (Wireshark's stop): exit 0, nothing on stderr, the stream whole to its end; the
# control pipe carries the log and status-bar counts, at most two a second.
"${rt[@]}" "$simbus" --link "$tmp/term.tty" --serial "19200 8E1" --wait-ms 300 --duration 8 \
  2>/dev/null &
sim=$!
for _ in $(seq 50); do [ -e "$tmp/term.tty" ] && break; sleep 0.02; done
mkfifo "$tmp/term.fifo" "$tmp/control.out" "$tmp/control.in"
cat "$tmp/term.fifo" >"$tmp/term.pcapng" &
reader=$!
cat "$tmp/control.out" >"$tmp/control.bytes" &
control_reader=$!
"$drivetap" --capture --extcap-interface "$tmp/term.tty" --fifo "$tmp/term.fifo" --baud 19200 \
  --line-format 8E1 --extcap-control-out "$tmp/control.out" --extcap-control-in "$tmp/control.in" \
  2>"$tmp/term.err" &
cap=$!
started=$SECONDS
# Until the status bar has counted 30 frames (tshark reads more than 20 packets, below).
until_status 30 "$tmp/control.bytes" || fail "SIGTERM: 30 frames not counted in 20 s"
elapsed=$((SECONDS - started + 1))
stop_capture
[ "$rc" = 0 ] && [ ! -s "$tmp/term.err" ] || fail "SIGTERM: exit $rc, stderr: $(cat "$tmp/term.err")"
if [ "$have_tshark" = 1 ]; then
  packets=$(tshark -r "$tmp/term.pcapng" 2>"$tmp/term.tshark" | wc -l)
  complaint=$(grep -v "Running as user" "$tmp/term.tshark" | head -1)
  [ -z "$complaint" ] && [ "$packets" -gt 20 ] ||
    fail "SIGTERM: tshark reads $packets packets: $complaint"
  # drivetap reads the stream back to the same packets, every one whole.
  frames=$("$drivetap" read "$tmp/term.pcapng" -q 2>/dev/null | sed -n 's/^frames: *\([0-9]*\).*/\1/p')
  noise=$("$drivetap" read "$tmp/term.pcapng" -q 2>/dev/null | sed -n 's/.*noise: \([0-9]*\) records\?.*/\1/p')
  [ $((frames + ${noise:-0})) = "$packets" ] ||
    fail "SIGTERM: drivetap reads $frames frames and ${noise:-0} noise records, tshark $packets packets"
fi
python3 - "$tmp/control.bytes" "${packets:-0}" "$elapsed" <<'EOF' || fail "control pipe"
import re, sys
data = open(sys.argv[1], "rb").read()
messages, i = [], 0
while i < len(data):
    assert data[i:i + 1] == b"T", f"no sync pipe header at {i}"
    length = int.from_bytes(data[i + 1:i + 4], "big")
    control, command, payload = data[i + 4], data[i + 5], data[i + 6:i + 4 + length]
    messages.append((control, command, payload.decode()))
    i += 4 + length
assert i == len(data), "a message cut short"
log = [p for c, k, p in messages if k == 2]
status = [p for c, k, p in messages if k == 6]
assert log and log[0].startswith("capturing on ") and "19200 8E1" in log[0], log
seconds = int(sys.argv[3])
assert 1 <= len(status) <= 2 * seconds + 2, f"{len(status)} status messages in {seconds} s"
counts = [int(re.match(r"drivetap: (\d+) frames \(\d+ checksum ok\), \d+ findings, \d+ noise records$", s).group(1)) for s in status]
assert counts == sorted(counts) and counts[-1] > 0, counts
packets = int(sys.argv[2])
assert packets == 0 or counts[-1] <= packets, (counts, packets)
EOF

# Wireshark closing its end of the FIFO first (its reader gone): exit 0, nothing on stderr.
"$simbus" --link "$tmp/left.tty" --serial "19200 8E1" --wait-ms 300 --duration 8 2>/dev/null &
sim=$!
for _ in $(seq 50); do [ -e "$tmp/left.tty" ] && break; sleep 0.02; done
mkfifo "$tmp/left.fifo"
head -c 2000 <"$tmp/left.fifo" >/dev/null &
timeout 30 "$drivetap" --capture --extcap-interface "$tmp/left.tty" --fifo "$tmp/left.fifo" \
  --baud 19200 --line-format 8E1 2>"$tmp/left.err"
rc=$?
kill "$sim" 2>/dev/null
wait "$sim" 2>/dev/null
[ "$rc" = 0 ] && [ ! -s "$tmp/left.err" ] ||
  fail "reader gone: exit $rc, stderr: $(cat "$tmp/left.err")"

# --detect: the settings searched first as capture --scan does (on a pty every setting hears the
# traffic: this checks the mechanics, not the choice), then the capture with the one chosen.
"$simbus" --link "$tmp/detect.tty" --serial "19200 8E1" --wait-ms 300 --duration 25 2>/dev/null &
sim=$!
for _ in $(seq 50); do [ -e "$tmp/detect.tty" ] && break; sleep 0.02; done
mkfifo "$tmp/detect.fifo" "$tmp/detect.control"
cat "$tmp/detect.fifo" >"$tmp/detect.pcapng" &
reader=$!
cat "$tmp/detect.control" >"$tmp/detect.bytes" &
control_reader=$!
"$drivetap" --capture --extcap-interface "$tmp/detect.tty" --fifo "$tmp/detect.fifo" --detect \
  --protocol rtu --extcap-control-out "$tmp/detect.control" 2>"$tmp/detect.err" &
cap=$!
until_status 1 "$tmp/detect.bytes" || fail "--detect: no frame counted in 20 s"
stop_capture
[ "$rc" = 0 ] && [ ! -s "$tmp/detect.err" ] || fail "--detect: exit $rc: $(cat "$tmp/detect.err")"
detected=$(grep -ao "detected [0-9]* 8[NEO]1" "$tmp/detect.bytes")
[ "$(grep -ac "detecting the line settings: " "$tmp/detect.bytes")" -ge 1 ] && [ -n "$detected" ] &&
  grep -aq "capturing on $tmp/detect.tty at ${detected#detected }" "$tmp/detect.bytes" ||
  fail "--detect: no detection in the log: $(tr -c '[:print:]' ' ' <"$tmp/detect.bytes" | head -c 300)"
if [ "$have_tshark" = 1 ]; then
  packets=$(tshark -r "$tmp/detect.pcapng" 2>/dev/null | wc -l)
  [ "$packets" -gt 0 ] || fail "--detect: no packets after the detection"
  tshark -r "$tmp/detect.pcapng" -T fields -e frame.interface_description 2>/dev/null |
    grep -q "^${detected#detected }" || fail "--detect: the interface does not carry ${detected#detected }"
fi

# Bytes faster than the line settings (a pty at 19200 read as 1200): the warning goes to
# Wireshark's log through the control pipe, not to stderr, which Wireshark shows as an error.
"$simbus" --link "$tmp/fast.tty" --serial "19200 8N1" --wait-ms 300 --duration 25 2>/dev/null &
sim=$!
for _ in $(seq 50); do [ -e "$tmp/fast.tty" ] && break; sleep 0.02; done
mkfifo "$tmp/fast.fifo" "$tmp/fast.control"
cat "$tmp/fast.fifo" >/dev/null &
reader=$!
cat "$tmp/fast.control" >"$tmp/fast.bytes" &
control_reader=$!
"$drivetap" --capture --extcap-interface "$tmp/fast.tty" --fifo "$tmp/fast.fifo" --baud 1200 \
  --line-format 8N1 --extcap-control-out "$tmp/fast.control" 2>"$tmp/fast.err" &
cap=$!
end=$((SECONDS + 20))
until grep -aq "warning: $tmp/fast.tty: bytes come faster than 1200 8N1" "$tmp/fast.bytes" ||
  [ "$SECONDS" -ge "$end" ]; do sleep 0.05; done
stop_capture
[ "$rc" = 0 ] && [ ! -s "$tmp/fast.err" ] &&
  [ "$(grep -ac "bytes come faster than" "$tmp/fast.bytes")" = 1 ] ||
  fail "too fast: exit $rc, stderr: $(cat "$tmp/fast.err"), log: $(tr -c '[:print:]' ' ' <"$tmp/fast.bytes" | head -c 300)"

# The round trip through tshark: installed into a temporary HOME, listed by tshark -D, captured
# by tshark -i from the simulated bus behind the fake tree's ttyUSB0.
if [ "$have_tshark" = 1 ]; then
  home="$tmp/home"
  mkdir -p "$home"
  out=$(HOME=$home XDG_CONFIG_HOME= "$drivetap" wireshark --install); rc=$?
  [ "$rc" = 0 ] && [ -L "$home/.config/wireshark/extcap/drivetap-extcap" ] &&
    grep -q "^installed $home/.config/wireshark/extcap/drivetap-extcap -> " <<<"$out" ||
    fail "wireshark --install: exit $rc: $out"
  "${rt[@]}" "$simbus" --link "$tmp/ws.tty" --serial "19200 8E1" --wait-ms 300 --duration 12 \
    2>/dev/null &
  sim=$!
  for _ in $(seq 50); do [ -e "$tmp/ws.tty" ] && break; sleep 0.02; done
  rm "$root/dev/ttyUSB0"
  ln -s "$tmp/ws.tty" "$root/dev/ttyUSB0"
  listed=$(HOME=$home XDG_CONFIG_HOME= DRIVETAP_DEVICE_ROOT=$root tshark -D 2>/dev/null)
  grep -q '^[0-9]*\. /dev/ttyUSB2 (RS-485 tap /dev/ttyUSB2 (usb-FTDI_USB-RS485_Cable_FT1234-if00-port0))$' <<<"$listed" ||
    fail "tshark -D does not list the port: $listed"
  # tshark's own parse of the dialog's options: each is a preference of the interface.
  prefs=$(HOME=$home XDG_CONFIG_HOME= DRIVETAP_DEVICE_ROOT=$root tshark -G currentprefs 2>"$tmp/prefs.err")
  for pref in baud lineformat protocol drive t35 timeout secondport; do
    grep -q "^#extcap\._dev_ttyusb0\.$pref:" <<<"$prefs" || fail "tshark has no preference $pref"
  done
  grep -v "Running as user" "$tmp/prefs.err" | grep -q . &&
    fail "tshark complains about the config: $(grep -v "Running as user" "$tmp/prefs.err" | head -1)"
  HOME=$home XDG_CONFIG_HOME= DRIVETAP_DEVICE_ROOT=$root timeout 60 tshark -i /dev/ttyUSB0 \
    -o extcap._dev_ttyusb0.baud:19200 -o extcap._dev_ttyusb0.lineformat:8E1 -a duration:3 \
    -w "$tmp/ws.pcapng" >"$tmp/ws.out" 2>&1
  kill "$sim" 2>/dev/null
  wait "$sim" 2>/dev/null
  grep -q "Error by extcap" "$tmp/ws.out" && fail "tshark -i: $(grep "Error by extcap" "$tmp/ws.out")"
  packets=$(tshark -r "$tmp/ws.pcapng" 2>/dev/null | wc -l)
  rtu=$(tshark -r "$tmp/ws.pcapng" -Y mbrtu 2>/dev/null | wc -l)
  # (The capture starts inside a frame, whose tail is a noise packet, `data`; a simulator
  # preempted on this busy machine may split a few frames more.)
  [ "$packets" -gt 20 ] && [ $((rtu * 10)) -ge $((packets * 9)) ] ||
    fail "tshark -i through the extcap: $packets packets, $rtu Modbus RTU: $(tail -3 "$tmp/ws.out")"
  # An unplugged port (listed, gone when opened): tshark shows drivetap's one line, at once.
  rm "$root/dev/ttyUSB0"
  ln -s "$tmp/gone.tty" "$root/dev/ttyUSB0"
  HOME=$home XDG_CONFIG_HOME= DRIVETAP_DEVICE_ROOT=$root timeout 60 tshark -i /dev/ttyUSB0 \
    -a duration:2 -w "$tmp/gone.pcapng" >"$tmp/gone.out" 2>&1
  grep -q "Error by extcap pipe: drivetap: $root/dev/ttyUSB0: " "$tmp/gone.out" ||
    fail "tshark -i of a missing port: $(tail -3 "$tmp/gone.out")"
  out=$(HOME=$home XDG_CONFIG_HOME= "$drivetap" wireshark --uninstall); rc=$?
  [ "$rc" = 0 ] && [ ! -e "$home/.config/wireshark/extcap/drivetap-extcap" ] &&
    grep -q "^removed $home/.config/wireshark/extcap/drivetap-extcap$" <<<"$out" ||
    fail "wireshark --uninstall: exit $rc: $out"
  HOME=$home XDG_CONFIG_HOME= DRIVETAP_DEVICE_ROOT=$root tshark -D 2>/dev/null | grep -q "RS-485 tap" &&
    fail "tshark -D still lists the port after --uninstall"
fi
# XDG_CONFIG_HOME is honoured, a second --uninstall finds nothing, and --install needs a mode.
out=$(HOME=$tmp/nohome XDG_CONFIG_HOME=$tmp/xdg "$drivetap" wireshark --install) &&
  [ -L "$tmp/xdg/wireshark/extcap/drivetap-extcap" ] || fail "XDG_CONFIG_HOME: $out"
[ "$(readlink "$tmp/xdg/wireshark/extcap/drivetap-extcap")" = "$(readlink -f "$drivetap")" ] ||
  fail "the extcap links to $(readlink "$tmp/xdg/wireshark/extcap/drivetap-extcap")"
HOME=$tmp/nohome XDG_CONFIG_HOME=$tmp/xdg "$drivetap" wireshark --uninstall >/dev/null
out=$(HOME=$tmp/nohome XDG_CONFIG_HOME=$tmp/xdg "$drivetap" wireshark --uninstall)
grep -q "^nothing to remove" <<<"$out" || fail "second --uninstall: $out"
err=$("$drivetap" wireshark 2>&1); rc=$?
[ "$rc" = 2 ] && [ "$(wc -l <<<"$err")" = 1 ] || fail "wireshark without a mode: exit $rc: $err"

[ "$failed" = 0 ] && echo "ok extcap"
exit "$failed"
