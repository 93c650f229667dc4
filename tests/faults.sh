#!/usr/bin/env bash
# Fault tests: outputs that cannot be created or fill the disk, inputs that are cut
# short, directories, devices, missing profiles. Each must give one error line naming the file
# or option, a non-zero exit, and leave what was already written valid.
#   bash tests/faults.sh BUILD/drivetap
set -uo pipefail
drivetap=$1
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# shellcheck source=tests/expect.sh
source "$root/tests/expect.sh"
log=$root/captures/session-e9/input.log

# Outputs.
expect "-o in a missing directory" 2 '^drivetap: -o /nonexistent/x.txt: cannot create: No such file' -- \
  "$drivetap" read "$log" -o /nonexistent/x.txt
expect "-w in a missing directory" 2 '^drivetap: -w /nonexistent/x.pcapng: cannot create' -- \
  "$drivetap" read "$log" -w /nonexistent/x.pcapng -o /dev/null
expect "-o on a full disk" 1 '^drivetap: -o /dev/full: write failed: No space left on device$' -- \
  "$drivetap" read "$log" -o /dev/full
expect "-w on a full disk" 1 '^drivetap: -w /dev/full: write failed: No space left on device$' -- \
  "$drivetap" read "$log" -w /dev/full -o /dev/null
expect "-w --pcap on a full disk" 1 '^drivetap: -w /dev/full: write failed: No space left on device$' -- \
  "$drivetap" read "$log" --pcap -w /dev/full -o /dev/null
# A capture that fills the limit long before its end: the failed write happens on the writer
# thread, mid-run, and its reason must still be the one reported.
"$drivetap" generate --frames 2000 --seed 1 --mix modbus-rtu -w "$work/big.pcapng" 2>/dev/null ||
  fail "generate for the mid-run limit failed"
for format in pcapng pcap; do
  flag=()
  [ "$format" = pcap ] && flag=(--pcap)
  expect "-w $format past a file size limit mid-run" 1 \
    "^drivetap: -w $work/mid.$format: write failed: File too large\$" -- \
    bash -c 'ulimit -f 4; exec "$@"' _ "$drivetap" read "$work/big.pcapng" "${flag[@]}" \
    -w "$work/mid.$format" -o /dev/null
done
# The same with --stats (its -w file is also written on the writer thread).
expect "-w past a file size limit mid-run, --stats" 1 \
  "^drivetap: -w $work/mid-stats.pcapng: write failed: File too large\$" -- \
  bash -c 'ulimit -f 4; exec "$@"' _ "$drivetap" read --stats "$work/big.pcapng" \
  -w "$work/mid-stats.pcapng" -o /dev/null
expect "stdout on a full disk" 1 '^drivetap: standard output: write failed: No space left on device$' -- \
  sh -c '"$0" read "$1" > /dev/full' "$drivetap" "$log"
expect "JSON to a full disk" 1 '^drivetap: standard output: write failed: No space left on device$' -- \
  sh -c '"$0" read -T json "$1" > /dev/full' "$drivetap" "$log"
# A disk that fills mid-write, as a file size limit (ulimit -f 4: 4 KiB, the first stdio buffer
# reach the disk, then EFBIG): the -w file is cut back to its last whole block or record and
# reads back with the packets that fitted. (The generated capture: session-e9's lean Modbus RTU
# packets fit in 4 KiB as classic pcap.)
for format in pcapng pcap; do
  flag=()
  [ "$format" = pcap ] && flag=(--pcap)
  out=$work/limited.$format
  expect "-w $format past a file size limit" 1 "^drivetap: -w $out: write failed: File too large\$" -- \
    bash -c 'ulimit -f 4; exec "$@"' _ "$drivetap" read "$work/big.pcapng" "${flag[@]}" -w "$out" \
    -o /dev/null
  size=$(stat -c %s "$out")
  { [ "$size" -gt 0 ] && [ "$size" -le 4096 ]; } || fail "limited.$format: $size bytes"
  "$drivetap" read "$out" -o "$work/limited.txt" 2> "$work/reread.err" ||
    fail "limited.$format does not read back: $(cat "$work/reread.err")"
  grep -qE '^frames: +[1-9]' "$work/limited.txt" || fail "limited.$format: no frames kept"
  if command -v tshark > /dev/null; then
    tshark -r "$out" > /dev/null 2> "$work/tshark.err" ||
      fail "limited.$format: tshark rejects it: $(cat "$work/tshark.err")"
  fi
done
# The same for -o: text and JSON Lines are cut back after their last whole line.
for format in text json; do
  out=$work/limited.$format
  expect "-o $format past a file size limit" 1 "^drivetap: -o $out: write failed: File too large\$" -- \
    bash -c 'ulimit -f 4; exec "$@"' _ "$drivetap" read -T "$format" "$log" -o "$out"
  size=$(stat -c %s "$out")
  { [ "$size" -gt 0 ] && [ "$size" -le 4096 ]; } || fail "limited.$format: $size bytes"
  [ "$(tail -c 1 "$out" | od -An -c | tr -d ' ')" = '\n' ] || fail "limited.$format: ends inside a line"
  if [ "$format" = json ] && grep -qvE '^\{.*\}$' "$out"; then
    fail "limited.json: a line that is no whole record: $(grep -vE '^\{.*\}$' "$out" | head -n 1)"
  fi
done

# Inputs that are no capture file.
expect "input is a directory" 1 "^drivetap: $work: is a directory" -- "$drivetap" read "$work"
expect "input is /dev/null" 1 '^drivetap: /dev/null: empty file$' -- "$drivetap" read /dev/null
expect "input is /dev/zero" 1 '^drivetap: /dev/zero: offset 0: not a recognised capture format' -- \
  timeout 20 "$drivetap" read /dev/zero
# Random bytes: usually no format, or a byte log when they happen to start with a digit or blank
# (then the line and column of the first bad token are named).
expect "input is /dev/urandom" 1 '^drivetap: /dev/urandom(:[0-9]+:[0-9]+)?: ' -- \
  timeout 20 "$drivetap" read /dev/urandom -o /dev/null
"$drivetap" read "$log" -w "$work/whole.pcapng" -o /dev/null 2> /dev/null || fail "writing whole.pcapng"
mkfifo "$work/fifo"
head -c 10000 "$work/whole.pcapng" > "$work/fifo" &
expect "input is a FIFO, cut short" 1 "^drivetap: $work/fifo: offset [0-9]+: truncated block" -- \
  timeout 20 "$drivetap" read "$work/fifo" -o /dev/null
wait
expect "standard input cut short" 1 '^drivetap: <stdin>: offset [0-9]+: truncated block' -- \
  sh -c 'head -c 10000 "$1" | timeout 20 "$0" read - -o /dev/null' "$drivetap" "$work/whole.pcapng"
expect "input missing" 1 '^drivetap: /nonexistent.log: cannot open: No such file' -- \
  "$drivetap" read /nonexistent.log

# Profiles.
expect "--drive names no profile" 2 "^drivetap: --drive 2=nope: no profile .nope." -- "$drivetap" read --drive 2=nope "$log" -o /dev/null
expect "--profile file missing" 1 '^drivetap: profile /nonexistent.toml: cannot open' -- \
  "$drivetap" read --profile /nonexistent.toml "$log" -o /dev/null
expect "--profile-dir missing" 1 '/nonexistent' -- \
  "$drivetap" read --profile-dir /nonexistent "$log" -o /dev/null
expect "--profile is /dev/zero" 1 '^drivetap: profile /dev/zero: is not a regular file \(a FIFO, socket or device\), not a profile file$' -- \
  timeout 20 "$drivetap" read --profile /dev/zero "$log" -o /dev/null
expect "--profile is a directory" 1 "^drivetap: profile $work: is a directory, not a profile file\$" -- \
  "$drivetap" read --profile "$work" "$log" -o /dev/null
expect "profiles FILE missing" 1 '^drivetap: /nonexistent.toml: cannot open the profile file: No such file or directory$' -- \
  "$drivetap" profiles /nonexistent.toml

# Inputs cut short: one error line, exit 1, and the outputs hold everything before the cut,
# valid (drivetap reads its pcapng back; so does tshark when installed).
cut_half() { head -c $(($(stat -c %s "$1") / 2 + 3)) "$1" > "$2"; }
"$drivetap" read "$log" -w "$work/full.pcapng" -o /dev/null 2> /dev/null || fail "writing full.pcapng"
"$drivetap" read "$log" --pcap -w "$work/full.pcap" -o /dev/null 2> /dev/null || fail "writing full.pcap"
cut_half "$work/full.pcapng" "$work/cut.pcapng"
cut_half "$work/full.pcap" "$work/cut.pcap"
cut_half "$log" "$work/cut.log"
cut_half "$root/captures/uart-phy/from_analog_uart_analog_10700_8n2.sr" "$work/cut.sr"
vcd=$(ls "$root"/captures/vcd/*.vcd | head -n 1)
cut_half "$vcd" "$work/cut.vcd"
check_cut() {  # check_cut FILE PATTERN
  local f=$1 pattern=$2
  expect "$(basename "$f") cut short" 1 "$pattern" -- \
    "$drivetap" read "$f" -w "$work/out.pcapng" -o "$work/out.txt"
  grep -q '^--- summary ---' "$work/out.txt" || fail "$(basename "$f"): text output lacks the summary"
  "$drivetap" read "$work/out.pcapng" -o "$work/reread.txt" 2> "$work/reread.err" ||
    fail "$(basename "$f"): the -w output does not read back: $(cat "$work/reread.err")"
  if command -v tshark > /dev/null; then
    tshark -r "$work/out.pcapng" > /dev/null 2> "$work/tshark.err" ||
      fail "$(basename "$f"): tshark rejects the -w output: $(cat "$work/tshark.err")"
  fi
}
check_cut "$work/cut.pcapng" "^drivetap: $work/cut.pcapng: offset [0-9]+: truncated block"
check_cut "$work/cut.pcap" "^drivetap: $work/cut.pcap: offset [0-9]+: packet [0-9]+: truncated"
check_cut "$work/cut.log" "^drivetap: $work/cut.log:[0-9]+:[0-9]+: (last line cut short|bad byte|expected)"
# A zip without its central directory cannot be opened at all; a VCD names the line.
expect "cut.sr cut short" 1 "^drivetap: $work/cut.sr: not a readable zip" -- \
  "$drivetap" read "$work/cut.sr" -o /dev/null
"$drivetap" read "$work/cut.vcd" -o "$work/out.txt" > /dev/null 2> "$work/err"
rc=$?
[ "$rc" -ne 0 ] || fail "cut.vcd: exit 0"
tail -n 1 "$work/err" | grep -qE "^drivetap: $work/cut.vcd: line [0-9]+: " ||
  fail "cut.vcd: last stderr line '$(tail -n 1 "$work/err")' does not name the line"

# Inputs that would grow memory without bound (resource limits): refused with their position,
# what came before decoded.
for i in $(seq 0 300); do printf '%d.0 ch%d 01 03 00 00 00 01 84 0A\n' "$i" "$i"; done > "$work/many.log"
expect "byte log with 301 channels" 1 "^drivetap: $work/many.log:257:[0-9]+: more than 256 channels" -- \
  "$drivetap" read "$work/many.log" -o "$work/out.txt"
[ "$(grep -c 'ch255' "$work/out.txt")" -ge 1 ] || fail "many.log: channels before the limit not decoded"
grep -q '^--- summary ---' "$work/out.txt" || fail "many.log: text output lacks the summary"
head -c 20000000 /dev/zero | tr '\0' '0' > "$work/long.log"
expect "byte log line of 20 MB" 1 "^drivetap: $work/long.log:1:.*line longer than 16777216 bytes" -- \
  "$drivetap" read "$work/long.log" -o /dev/null
expect "decode: stdin line of 2 MB" 2 '^drivetap: standard input: line 2: longer than 1048576 bytes' -- \
  sh -c '{ echo "01 03 00 00 00 01 84 0A"; head -c 2000000 /dev/zero | tr "\0" "0"; } |
    "$0" decode -o "$1"' "$drivetap" "$work/decoded.txt"
grep -q 'addr 1  Read Holding Registers 0x0000  crc ok' "$work/decoded.txt" ||
  fail "decode: the frame before the long line was not written: $(head -c 300 "$work/decoded.txt")"
expect "decode: hex then ASCII" 2 '^drivetap: standard input: line 2 \(":010300000001FB"\): give frames of one kind' -- \
  sh -c 'printf "01 03 00 00 00 01 84 0A\n:010300000001FB\n" | "$0" decode' "$drivetap"

if [ "$failures" -ne 0 ]; then
  echo "$failures fault test(s) failed" >&2
  exit 1
fi
echo "fault tests: all passed"
