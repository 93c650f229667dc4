#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang (ASan + UBSan) in build-fuzz/ and runs each
# for a while, from a seed corpus made of captures/ (docs/testing.md, "Fuzzing").
#
#   bash scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default 30 s, every target)
#   bash scripts/fuzz.sh 120 pcapng byte_log
#
# Targets: byte_log pcapng pcap rtu_framer modbus_pdu upper_pdu_link modbus_ascii danfoss_fc
# easydrive vcd sigrok profile toml_nesting hex_text display_filter report_timeline (the "fuzz_" prefix is
# optional). Per target: working corpus build-fuzz/corpus/<target> (kept between runs), seeds
# build-fuzz/seeds/<target> (remade each run), crash artifacts build-fuzz/artifacts/<target>/,
# libFuzzer's log build-fuzz/logs/<target>.log. Reproducers saved under
# captures/regressions/<bug>/input.<ext> (.log -> byte_log, .pcapng, .pcap, and .<target> for
# the others, e.g. input.rtu_framer) run first: one that still fails is reported and counts as
# a failure, one that passes joins the seeds. Reproduce a crash with
#   build-fuzz/fuzz/fuzz_<target> ARTIFACT
# A dictionary fuzz/fuzz_<target>.dict, when there is one, is passed with -dict.
# Environment: FUZZ_TIMEOUT (seconds one input may take before it counts as a hang, default 20);
# FUZZ_BUILD (the build directory, default build-fuzz; scripts/test.sh gives its sanitizer build); FUZZ_JOBS (targets run at once, default
# 1).
# Exit status 1 when any target found a crash, hang, leak or out-of-memory, or a regression
# reproducer still fails.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
root=$(pwd)

seconds=${1:-30}
[ $# -gt 0 ] && shift
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || [ "$seconds" -eq 0 ]; then
  echo "usage: bash scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]" >&2
  exit 2
fi
all_targets=(byte_log pcapng pcap rtu_framer modbus_pdu upper_pdu_link modbus_ascii danfoss_fc easydrive vcd
  sigrok profile toml_nesting hex_text display_filter report_timeline)
targets=()
for t in "$@"; do
  t=${t#fuzz_}
  if [[ " ${all_targets[*]} " != *" $t "* ]]; then
    echo "fuzz.sh: unknown target '$t' (one of: ${all_targets[*]})" >&2
    exit 2
  fi
  targets+=("$t")
done
[ ${#targets[@]} -gt 0 ] || targets=("${all_targets[@]}")
timeout=${FUZZ_TIMEOUT:-20}

# clang with its libFuzzer runtime, xxd and unzip for the seeds (scripts/install-deps.sh).
bash scripts/install-deps.sh clang libclang-rt-14-dev xxd unzip

build=${FUZZ_BUILD:-$root/build-fuzz}
jobs=$(nproc 2>/dev/null || echo 2)
mkdir -p "$build"
# A build configured with the targets already (scripts/test.sh's sanitizer build, whose objects
# they share) is built as it is; any other folder is configured for the targets alone.
if ! grep -qs '^DRIVETAP_FUZZ:BOOL=ON$' "$build/CMakeCache.txt"; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DDRIVETAP_FUZZ=ON \
    -DDRIVETAP_BUILD_TESTS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo > "$build/configure.log" 2>&1 || {
    cat "$build/configure.log" >&2
    exit 1
  }
fi
cmake --build "$build" -j "$jobs" --target fuzz

# ---- seeds ----

hex_to_file() {  # hex_to_file FILE HEX...   (spaces allowed)
  local out=$1
  shift
  printf '%s' "$*" | tr -d ' \n' | xxd -r -p > "$out"
}

# A byte log as fuzz_rtu_framer records (layout in fuzz/fuzz_rtu_framer.cpp): its line
# settings in the header, each byte's time as a delta from the previous byte's start.
byte_log_to_records() {
  awk '
    function bits() { return 1 + data + (parity == "N" ? 0 : 1) + stop }
    function hex16(v) { return sprintf("%02x%02x", v % 256, int(v / 256)) }
    function delta(us,   a) {
      if (us < 0) { a = int(-us + 0.5); if (a == 0) return hex16(16384); if (a > 16383) a = 16383; return hex16(49152 + a) }
      if (us < 16384) return hex16(16384 + int(us + 0.5))
      a = int(us / 1000 + 0.5); if (a > 16383) a = 16383
      return hex16(32768 + a)
    }
    BEGIN { baud = 9600; data = 8; parity = "N"; stop = 1; out = ""; started = 0; prev = 0 }
    /^[ \t]*#! *serial/ {
      for (i = 3; i <= NF; i++) {
        if ($i ~ /^[0-9]+$/) baud = $i
        else if ($i ~ /^[78][NnEeOo][12]$/) {
          data = substr($i, 1, 1); parity = toupper(substr($i, 2, 1)); stop = substr($i, 3, 1)
        }
      }
      next
    }
    /^[ \t]*#/ || NF < 3 { next }
    {
      ch = ($2 == "bus") ? 0 : ($2 == "m") ? 1 : ($2 == "s") ? 2 : 3
      t = $1 * 1e6                     # microseconds
      char_us = bits() * 1e6 / baud
      for (i = 3; i <= NF; i++) {
        if ($i ~ /^#/) break
        tok = $i; marks = ""
        if (index(tok, "!")) { marks = substr(tok, index(tok, "!") + 1); tok = substr(tok, 1, index(tok, "!") - 1) }
        flags = (marks ~ /p/ ? 1 : 0) + (marks ~ /f/ ? 2 : 0) + (marks ~ /b/ ? 4 : 0) + (marks ~ /o/ ? 8 : 0)
        for (k = 1; k + 1 <= length(tok); k += 2) {
          d = started ? t - prev : 0
          out = out delta(d) substr(tok, k, 2) sprintf("%02x", flags + 16 * ch)
          prev = t; started = 1; t += char_us
        }
      }
    }
    END {
      split("1200 2400 4800 9600 19200 38400 57600 115200", bauds, " ")
      b = 3
      for (i = 1; i <= 8; i++) if (bauds[i] == baud) b = i - 1
      p = (parity == "E") ? 1 : (parity == "O") ? 2 : 0
      line = b + 8 * p + (data == 7 ? 32 : 0) + (stop == 2 ? 64 : 0)
      printf "%02x0000%s", line, out
    }' "$1"
}

make_seeds() {
  local seeds=$build/seeds
  rm -rf "$seeds"
  for t in "${all_targets[@]}"; do mkdir -p "$seeds/$t"; done
  local f name
  for f in captures/*/input.*; do
    name=$(basename "$(dirname "$f")")
    case "$f" in
      *.log)
        cp "$f" "$seeds/byte_log/$name.log"
        byte_log_to_records "$f" | xxd -r -p > "$seeds/rtu_framer/$name"
        # Each telegram of the capture (one per line in these logs) as a modbus_pdu seed.
        grep -v '^[[:space:]]*#' "$f" | awk 'NF >= 3 { $1 = ""; $2 = ""; print }' |
          sed 's/#.*//; s/![a-z]*//g' | sort -u | awk 'NR <= 40' | {
          local n=0 line
          while read -r line; do
            [ -n "$line" ] || continue
            n=$((n + 1))
            hex_to_file "$seeds/modbus_pdu/$name-$n" "$line" 2> /dev/null || true
          done
        } || true
        ;;
      *.pcapng) cp "$f" "$seeds/pcapng/$name.pcapng" ;;
      *.pcap) cp "$f" "$seeds/pcap/$name.pcap" ;;
    esac
  done
  # sigrok-cli's VCD exports (captures/vcd/README.md) seed the VCD reader, with a simulator's
  # layout: multi-line sections, nested scopes, vectors, reals, $dumpvars/$dumpoff, 1 ps.
  cp captures/vcd/*.vcd "$seeds/vcd/"
  printf '%s\n' '$date' '  today' '$end' '$version Icarus Verilog $end' '$timescale' '  1ps' \
    '$end' '$scope module tb $end' '$var wire 1 ! clk $end' '$var reg 8 " data [7:0] $end' \
    '$scope module dut $end' '$var wire 1 #a tx $end' '$var real 1 $ v $end' \
    '$var wire 1 ! clk_alias $end' '$upscope $end' '$upscope $end' '$enddefinitions $end' \
    '$comment initial values $end' '#0' '$dumpvars' '0!' 'bxxxxxxxx "' 'z#a' 'r0.5 $' '$end' \
    '#1500' '1!' 'b1010 "' '1#a' '#3000' '0!' 'x#a' '$dumpoff' 'x!' '$end' '#4500' '$dumpon' \
    '1!' '0#a' '$end' '#6000' > "$seeds/vcd/simulator.vcd"
  # sigrok sessions as they are (a zip: first byte 'P', even, so read raw), and each as the
  # recipe fuzz/fuzz_sigrok.cpp zips itself: mode byte, metadata, NUL, the first 4 KiB of samples.
  local sr chunk
  for sr in $(find captures -name '*.sr' | sort); do
    name=$(basename "$sr" .sr)
    cp "$sr" "$seeds/sigrok/$name.sr"
    chunk=$(unzip -Z1 "$sr" 2> /dev/null | grep -E '^(logic|analog)-1' | sort -V | head -n 1 || true)
    [ -n "$chunk" ] || continue
    {
      case "$chunk" in analog-*) printf '\x05' ;; logic-1) printf '\x03' ;; *) printf '\x01' ;; esac
      unzip -p "$sr" metadata
      printf '\0'
      unzip -p "$sr" "$chunk" | head -c 4096
    } > "$seeds/sigrok/$name.recipe" 2> /dev/null || true
  done
  # Extreme headers: timescales of 1 s, sample rates of 1 and 3 Hz, a duplicate
  # samplerate, thousands of variables on one identifier, a byte order mark; the sigrok ones also
  # as recipes.
  python3 tests/hostile/make_inputs.py "$seeds/vcd" vcd-timescale-1s-sigfpe vcd-utf8-bom
  python3 tests/hostile/make_inputs.py "$seeds/sigrok" sigrok-1hz-sigfpe sigrok-3hz-sigfpe \
    sigrok-duplicate-samplerate-sigfpe
  python3 - "$seeds/vcd/many-variables-one-identifier.vcd" <<'PY'
import sys
with open(sys.argv[1], "w") as f:
    f.write("$timescale 1 us $end\n$scope module m $end\n")
    f.write("".join(f"$var wire 1 ! v{i} $end\n" for i in range(300)))
    f.write("$var wire 1 \" " + "n" * 5000 + " $end\n$upscope $end\n$enddefinitions $end\n")
    f.write("".join(f"#{t * 7} {t % 2}! {t % 2}\"\n" for t in range(400)))
PY
  for sr in "$seeds/sigrok/"sigrok-*.sr; do
    {
      printf '\x01'
      unzip -p "$sr" metadata
      printf '\0'
      unzip -p "$sr" logic-1-1 | head -c 4096
    } > "${sr%.sr}.recipe" 2> /dev/null || true
  done
  # TOML nesting programs (fuzz/fuzz_toml_nesting.cpp): deep arrays, deep inline tables, long
  # dotted keys and headers, strings and comments full of brackets.
  head -c 200 /dev/zero > "$seeds/toml_nesting/arrays"
  head -c 200 /dev/zero | tr '\0' ' ' > "$seeds/toml_nesting/tables"
  head -c 200 /dev/zero | tr '\0' '@' > "$seeds/toml_nesting/dotted"
  printf '\x00\x20\x40\x60\x80\xa0\xc0\xe0\xe7\xdf' > "$seeds/toml_nesting/mixed"
  # Drive profiles: each built-in one alone, and followed by a capture's bytes for its pipeline.
  local toml
  for toml in dissectors/profiles/*.toml; do
    name=$(basename "$toml" .toml)
    cp "$toml" "$seeds/profile/$name.toml"
    { cat "$toml"; printf '\0'; cat "$seeds/modbus_pdu/"seed-* 2> /dev/null | head -c 2048; } \
      > "$seeds/profile/$name-with-frames"
  done
  # `drivetap decode` text: the documentation's examples, and each telegram seed written as hex.
  grep -ho 'decode "[^"]*"' README.md docs/*.md tests/*.sh | sed 's/^decode "//; s/"$//' | sort -u |
    awk -v dir="$seeds/hex_text" '{ print > (dir "/example-" NR) }'
  printf '01 03 00 00 00 01 84 0A | 0x01,0x83;02 C0 F1\n:010300000001FB\\r\\n\n~010C00010FA0027C\\x0d\n' \
    > "$seeds/hex_text/mixed"
  for f in "$seeds/modbus_pdu/"*; do
    [ -f "$f" ] && xxd -p "$f" | tr -d '\n' > "$seeds/hex_text/hex-$(basename "$f")"
  done
  # Display filters: the tests' and the documentation's, and nesting near the limit (a first byte
  # 0xFF makes 2^(second byte % 18) parentheses, fuzz/fuzz_display_filter.cpp).
  python3 - "$seeds/display_filter" tests/display_filter.py <<'PY'
import re, sys
out, source = sys.argv[1], open(sys.argv[2]).read()
filters = set(re.findall(r'"((?:[^"\\]|\\.)*)"', source[source.index("STATIC_FILTERS"):source.index("def finding_filters")]))
for i, f in enumerate(sorted(filters)):
    open(f"{out}/static-{i}", "w").write(f.encode().decode("unicode_escape"))
open(f"{out}/deep-parentheses", "wb").write(b"\xff\x08addr == 1" + b")" * 256)
open(f"{out}/deep-not", "w").write("!" * 300 + "addr == 1")
open(f"{out}/long-chain", "w").write(" || ".join(["addr == 1"] * 2000))
open(f"{out}/huge-number", "w").write("n < " + "9" * 309)
PY
  # Report timelines (fuzz/fuzz_report_timeline.cpp: a header of character time and load
  # interval, then records of an operation byte, a time and their values): times and shifts next
  # to +-2^62 ns, the shortest load interval, records far apart and back in time.
  python3 - "$seeds/report_timeline" <<'PY'
import struct, sys
out = sys.argv[1]
def record(op, t, *rest):
    return bytes([op]) + struct.pack(">q", t) + b"".join(rest)
def frame(op, t, latency):
    return record(op, t, bytes([3, 8, 2, 1]), struct.pack(">q", latency))
edge = 1 << 62
seeds = {
    "span-of-2-62": bytes([0, 1, 0]) + record(0, 0, struct.pack(">q", -edge)) + frame(1, 0, 1000) + frame(5, 2 * edge - 1, -1),
    "shift-past-the-edge": bytes([0, 1, 0]) + record(0, 0, struct.pack(">q", edge)) + frame(2, edge, edge),
    "back-in-time": bytes([4, 0, 40]) + record(0, 0, struct.pack(">q", 0)) + b"".join(frame(1 + 4 * (k % 3), (10 - k) * 10**9, k) for k in range(10)),
    "stations": bytes([0, 104, 3]) + record(0, 0, struct.pack(">q", 0)) + b"".join(record(1, k * 10**6, bytes([0, 8, k % 256, k % 7]), struct.pack(">q", 5000)) for k in range(600)),
}
for name, data in seeds.items():
    open(f"{out}/{name}", "wb").write(data)
PY
  # Every telegram of the captures seeds the protocol-decoder targets too.
  for t in modbus_ascii danfoss_fc easydrive; do
    cp "$seeds/modbus_pdu/"* "$seeds/$t/" 2> /dev/null || true
  done
  # Files drivetap writes itself: its pcapng (exported PDU and user0 link types, with the
  # per-byte option) and classic pcap.
  local drivetap=$root/build/drivetap
  if [ -x "$drivetap" ]; then
    local c
    for c in seed-erman-e9 gap-inside-frame; do
      "$drivetap" read "captures/$c/input.log" -w "$seeds/pcapng/$c-upper-pdu.pcapng" \
        -o /dev/null > /dev/null 2>&1 || echo "fuzz.sh: note: $drivetap -w failed for $c" >&2
      "$drivetap" read "captures/$c/input.log" -w "$seeds/pcapng/$c-user0.pcapng" --dlt user0 \
        -o /dev/null > /dev/null 2>&1 || true
      "$drivetap" read "captures/$c/input.log" -w "$seeds/pcap/$c.pcap" --pcap \
        -o /dev/null > /dev/null 2>&1 || true
    done
    find "$seeds/pcapng" "$seeds/pcap" -type f -empty -delete
  else
    echo "fuzz.sh: no build/drivetap: no pcapng seeds written by drivetap" >&2
  fi
  # Packets of each link layer, around one Modbus request (02 03 00 00 00 04 44 3A).
  local frame="02 03 00 00 00 04 44 3A"
  hex_to_file "$seeds/upper_pdu_link/upper-pdu" \
    "000C 0008 6d62727475000000  0023 0004 00000000  0000 0000 $frame"
  hex_to_file "$seeds/upper_pdu_link/ethernet-ipv4-udp" \
    "020000000001 020000000002 0800" \
    "4500 0024 0000 4000 4011 0000 0a000001 0a000002" "0fa1 01f6 0010 0000 $frame"
  hex_to_file "$seeds/upper_pdu_link/rtac" "65000000 00000000 01 00 0000 $frame"
  hex_to_file "$seeds/upper_pdu_link/sll2-ipv6-tcp" \
    "86dd 0000 00000000 0001 00 06 0000000000000000" \
    "6000 0000 001c 06 40 20010db8000000000000000000000001 20010db8000000000000000000000002" \
    "0fa1 01f6 00000000 00000000 5018 ffff 0000 0000 $frame"
  # 9600 8N1; a burst of 4100 zero bytes with one timestamp (delta C000), then a request.
  hex_to_file "$seeds/rtu_framer/burst" "030000 00c00000" \
    "0040 0200  1244 0300  1244 0000  1244 0000  1244 0000  1244 0400  1244 4400  1244 3a00"
  hex_to_file "$seeds/modbus_pdu/exception" "01 83 02 C0 F1"
  hex_to_file "$seeds/modbus_pdu/device-id" "01 2B 0E 01 00 70 77"
}

# The regression reproducers of one target (captures/regressions/<bug>/input.<ext>).
regressions_of() {
  local r ext
  for r in captures/regressions/*/input.*; do
    [ -f "$r" ] || continue
    ext=${r##*.}
    [ "$ext" = log ] && ext=byte_log
    [ "$ext" = sr ] && ext=sigrok
    [ "$ext" = "$1" ] && echo "$r"
  done
  return 0
}

make_seeds

# ---- runs ----

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
mkdir -p "$build/logs"

# Runs one target: its regression reproducers, then the fuzzer. Writes its summary lines to
# build-fuzz/logs/<target>.result, and exits 1 when it found something.
run_target() {
  local t=$1
  local bin=$build/fuzz/fuzz_$t
  local corpus=$build/corpus/$t
  local artifacts=$build/artifacts/$t
  local log=$build/logs/$t.log
  local result_file=$build/logs/$t.result
  local failed=0 line
  : > "$result_file"
  mkdir -p "$corpus" "$artifacts"
  # Reproducers of known bugs first: one that still fails is reported (and kept out of the
  # seeds, so that fuzzing goes on); one that passes joins the seeds.
  while read -r r; do
    [ -n "$r" ] || continue
    if "$bin" -timeout="$timeout" -rss_limit_mb=2048 "$r" > "$build/logs/$t.regression.log" 2>&1; then
      cp "$r" "$build/seeds/$t/regression-$(basename "$(dirname "$r")")"
    else
      local where
      where=$(grep -m 1 -E 'runtime error|ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)' \
        "$build/logs/$t.regression.log" | sed "s|$root/||" || true)
      line=$(printf '%-15s regression %s STILL FAILS: %s' "$t" "$r" "${where:-see fuzz_$t $r}")
      echo "$line"
      echo "$line" >> "$result_file"
      failed=1
    fi
  done <<< "$(regressions_of "$t")"
  echo "== fuzz_$t: $seconds s (log: ${log#"$root"/})"
  local start rc=0 dict=()
  start=$(date +%s)
  [ -f "fuzz/fuzz_$t.dict" ] && dict=(-dict="fuzz/fuzz_$t.dict")
  "$bin" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout="$timeout" "${dict[@]}" \
    -print_final_stats=1 -artifact_prefix="$artifacts/" "$corpus" "$build/seeds/$t" \
    > "$log" 2>&1 || rc=$?
  local elapsed runs last cov ft files kib artifact result
  elapsed=$(($(date +%s) - start))
  runs=$(sed -n 's/^stat::number_of_executed_units: *\([0-9]*\).*/\1/p' "$log" | tail -n 1)
  [ -n "$runs" ] || runs=$(sed -n 's/^Done \([0-9]*\) runs.*/\1/p' "$log" | tail -n 1)
  [ -n "$runs" ] || runs=$(sed -n 's/^#\([0-9]*\)[[:space:]].*/\1/p' "$log" | tail -n 1)
  last=$(grep -E 'cov: [0-9]+ ft: [0-9]+' "$log" | tail -n 1 || true)
  cov=$(sed -n 's/.*cov: \([0-9]*\).*/\1/p' <<< "$last")
  ft=$(sed -n 's/.*ft: \([0-9]*\).*/\1/p' <<< "$last")
  files=$(find "$corpus" -type f | wc -l)
  kib=$(find "$corpus" -type f -printf '%s\n' | awk '{ n += $1 } END { printf "%.0f", n / 1024 }')
  artifact=$(sed -n 's/.*Test unit written to \(.*\)$/\1/p' "$log" | grep -v '/slow-unit-' |
    tail -n 1 || true)
  if [ -n "$artifact" ]; then
    result="CRASH $artifact"
    failed=1
  elif [ "$rc" -ne 0 ]; then
    result="CRASH (exit status $rc, no artifact: see ${log#"$root"/})"
    failed=1
  else
    result=ok
  fi
  line=$(printf '%-15s %5ss %10s runs  cov %-5s ft %-6s corpus %5s files %6s KiB  %s' \
    "$t" "$elapsed" "${runs:-?}" "${cov:-?}" "${ft:-?}" "$files" "$kib" "$result")
  echo "$line"
  echo "$line" >> "$result_file"
  return "$failed"
}

# FUZZ_JOBS targets at a time (default 1: each target gets a core of its own on a 2-core machine
# while the machine stays usable).
parallel=${FUZZ_JOBS:-1}
if ! [[ "$parallel" =~ ^[0-9]+$ ]] || [ "$parallel" -eq 0 ]; then
  echo "fuzz.sh: FUZZ_JOBS must be a positive number, not '$parallel'" >&2
  exit 2
fi
failed=0
for t in "${targets[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$parallel" ]; do wait -n || true; done
  run_target "$t" &
done
while [ "$(jobs -rp | wc -l)" -gt 0 ]; do wait -n || true; done

echo
echo "== summary (${seconds} s per target, $parallel at a time)"
for t in "${targets[@]}"; do
  cat "$build/logs/$t.result"
  # A target whose summary says it failed fails the run, however its job ended.
  grep -q 'STILL FAILS\|CRASH' "$build/logs/$t.result" && failed=1
done
exit "$failed"
