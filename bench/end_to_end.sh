#!/usr/bin/env bash
# End to end against tshark, on Modbus RTU pcapng from two writers: drivetap's generator and
# bench/foreign_pcapng.py (another writer: 31 stations, random registers no drive family fits,
# direction flags on every packet). Each file goes through tshark (text, -T fields, -q -z
# io,stat,0) and through `drivetap read` in text, JSON and --stats, in the default mode (drive
# profiles on: the headline) and with --drive none beside it: seconds, packets/s, drivetap's ratio
# to tshark, peak RSS; `cat` of the file as the floor of any reader (its ratio to io,stat bounds
# what --stats can reach) and drivetap_floor (bench/floor.cpp: the file read with drivetap's
# reader and each packet's CRC checked, on one thread) as the floor of a --stats pass. Then
# drivetap alone on the generated traffic as its own full pcapng and on the mix of the five drive
# families (tshark decodes neither the FC nor the '~' protocol); the peak RSS across the sizes;
# and drivetap's peak RSS on a noisy bus seen by a logic analyser (every byte stamped on its own:
# the frames whose storage is largest). Writes bench/RESULTS.md (or $RESULTS).
#
#   bench/end_to_end.sh [BUILD_DIR] [FRAMES...]     default: build 1000000 10000000
#   REPEAT=N bench/end_to_end.sh ...                  each tshark and drivetap row the best of N
#                                                     runs (default 1; generation runs once)
#   NOISE_BYTES=N bench/end_to_end.sh ...             bytes of the noisy capture (default 6000000)
#   RESULTS=FILE bench/end_to_end.sh ...              the report there instead of bench/RESULTS.md
#
# Needs tshark, python3 and GNU time's /usr/bin/time (Debian: apt-get install tshark time).
#
# The generated capture is `drivetap generate --seed 1 --mix modbus-rtu --plain` (the frames
# alone, 80 bytes a packet, as another capture tool writes them); the foreign one
# `bench/foreign_pcapng.py FRAMES --seed 1` (82 bytes a packet). A 10 M run needs about 5.5 GB
# in $TMPDIR and some 3 minutes of Python; tshark needs about 1.5 GB of memory for it.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$root/build}
shift || true
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(1000000 10000000)
drivetap="$build/drivetap"
floor="$build/bench/drivetap_floor"
results=${RESULTS:-$root/bench/RESULTS.md}
repeat=${REPEAT:-1}
noise_bytes=${NOISE_BYTES:-6000000}
# Every argument and tool checked before the first run (a 10 M run takes a quarter of an hour).
die() { echo "end_to_end.sh: $*" >&2; exit 2; }
[ -x "$drivetap" ] || die "$drivetap: no drivetap there (first argument: the build directory)"
[ -x "$floor" ] || echo "end_to_end.sh: no $floor (a build without Google Benchmark): no floor row" >&2
for frames in "${sizes[@]}"; do
  [[ $frames =~ ^[1-9][0-9]*$ ]] || die "FRAMES $frames: not a positive number of frames"
done
[[ $repeat =~ ^[1-9][0-9]*$ ]] || die "REPEAT=$repeat: not a positive number of runs"
[[ $noise_bytes =~ ^[1-9][0-9]*$ ]] || die "NOISE_BYTES=$noise_bytes: not a positive number of bytes"
command -v tshark >/dev/null || die "tshark is not installed (Debian: apt-get install tshark)"
command -v python3 >/dev/null || die "python3 is not installed (Debian: apt-get install python3)"
[ -x /usr/bin/time ] || die "/usr/bin/time is not installed (Debian: apt-get install time)"
[ -d "$(dirname "$results")" ] || die "RESULTS=$results: no directory $(dirname "$results")"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

rows=()
# min_of A B: the smaller of two decimal numbers, B when A is empty.
min_of() { awk -v a="$1" -v b="$2" 'BEGIN { print (a == "" || b + 0 < a + 0) ? b : a }'; }
# measure NAME COMMAND...: wall seconds (the best of $runs runs, default $repeat), CPU seconds
# (user + system, all threads; the least of the runs) and peak RSS (the largest), output to
# /dev/null.
measure() {
  local name=$1 best="" least="" peak=0 k seconds rss user sys cpu
  shift
  for ((k = 0; k < ${runs:-$repeat}; k++)); do
    # (the wall clock from bash's EPOCHREALTIME, in us, read without a fork: /usr/bin/time's %e
    # has 10 ms steps, too coarse for `cat`)
    local start end
    start=${EPOCHREALTIME/[.,]/}
    /usr/bin/time -f "%M %U %S" -o "$work/time" "$@" >/dev/null 2>"$work/stderr" || {
      echo "$name failed: $(tail -1 "$work/stderr")" >&2
      exit 1
    }
    end=${EPOCHREALTIME/[.,]/}
    seconds=$(awk -v us=$((end - start)) 'BEGIN { printf "%.3f", us / 1e6 }')
    read -r rss user sys <"$work/time"
    cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }')
    best=$(min_of "$best" "$seconds")
    least=$(min_of "$least" "$cpu")
    ((rss > peak)) && peak=$rss
  done
  rows+=("$name|$best|$peak|$least|$*")
  echo "$name: $best s (best of ${runs:-$repeat}), CPU $least s, $((peak / 1024)) MB" >&2
}
seconds_of() { for r in "${rows[@]}"; do [ "${r%%|*}" != "$1" ] || cut -d'|' -f2 <<<"$r"; done; }
rss_of() { for r in "${rows[@]}"; do [ "${r%%|*}" != "$1" ] || cut -d'|' -f3 <<<"$r"; done; }
# Packets of a generated pcapng: one per frame and one per noise record (its --truth file).
packets_of() {
  local total
  total=$(grep '^"total"' "$1")
  echo $(($(grep -o '"frames":[0-9]*' <<<"$total" | cut -d: -f2) +
          $(grep -o '"noise_records":[0-9]*' <<<"$total" | cut -d: -f2)))
}

report="$work/RESULTS.md"
{
  echo "# End-to-end results (bench/end_to_end.sh)"
  echo
  echo "Machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) cores;"
  echo "$(date -u +%Y-%m-%d); drivetap $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '(not a git checkout)'). Two sources of"
  echo "Modbus RTU pcapng, both read by tshark and drivetap: \`drivetap generate --seed 1 --mix modbus-rtu"
  echo "--plain\` (drivetap's generator: a few drives of the built-in families) and"
  echo "\`bench/foreign_pcapng.py --seed 1\` (another writer: 31 stations polled for random registers, no"
  echo "family fitting them, link type 252 with the direction in each packet's flags). drivetap runs in"
  echo "its default mode (drive profiles on) and with \`--drive none\` beside it."
  echo "Each tshark and drivetap row is the best of $repeat run(s) (REPEAT), its memory the largest."
  echo "CPU s: user + system seconds of all the run's threads (drivetap reads ahead, decodes and"
  echo "writes on three; tshark decodes on one), the least of the runs, in /usr/bin/time's 10 ms"
  echo "steps: the work done, which this VM's neighbours disturb less than the wall clock."
} >"$report"

# table TITLE PACKETS: the rows measured since the last table, with packets/s and each drivetap
# row's ratio to the tshark run of the same output.
table() {
  local title=$1 packets=$2 r name seconds rss cpu cmd rate ratio against unit
  {
    echo
    echo "$title"
    echo
    echo "| run | seconds | CPU s | packets/s | peak RSS MB | vs tshark | command |"
    echo "|---|---|---|---|---|---|---|"
    for r in "${rows[@]}"; do
      IFS='|' read -r name seconds rss cpu cmd <<<"$r"
      rate=$(awk -v p="$packets" -v s="$seconds" 'BEGIN { printf "%.0f", (s > 0 ? p / s : 0) }')
      against=""
      case $name in
        "drivetap text"*) against="tshark text" unit=text ;;
        "drivetap -T json"*) against="tshark -T fields" unit=fields ;;
        "drivetap --stats"* | "cat (no decoding)" | "floor: read + CRC, one thread") against="tshark io,stat" unit=io,stat ;;
      esac
      ratio=""
      [ -z "$against" ] || ratio=$(awk -v a="$(seconds_of "$against")" -v b="$seconds" -v u="$unit" 'BEGIN { printf "%.1fx %s", a / b, u }')
      echo "| $name | $seconds | $cpu | $rate | $((rss / 1024)) | $ratio | \`${cmd//$work\//}\` |"
    done
  } >>"$report"
}

# compare FILE: tshark and drivetap on FILE, default mode and --drive none (the rows of a table).
compare() {
  local file=$1
  measure "tshark text" tshark -r "$file"
  measure "tshark -T fields" tshark -r "$file" -T fields -e modbus.func_code
  measure "tshark io,stat" tshark -r "$file" -q -z io,stat,0
  # The floor of any reader: the file's bytes copied out of the page cache once, nothing decoded.
  measure "cat (no decoding)" cat "$file"
  # The floor of --stats: reading and CRC-checking every packet on one thread, nothing else.
  [ ! -x "$floor" ] || measure "floor: read + CRC, one thread" "$floor" "$file"
  measure "drivetap text" "$drivetap" read "$file"
  measure "drivetap -T json" "$drivetap" read -T json "$file"
  measure "drivetap --stats" "$drivetap" read --stats "$file"
  measure "drivetap text, --drive none" "$drivetap" read --drive none "$file"
  measure "drivetap -T json, --drive none" "$drivetap" read --drive none -T json "$file"
  measure "drivetap --stats, --drive none" "$drivetap" read --drive none --stats "$file"
}

memory=()
for frames in "${sizes[@]}"; do
  echo "== $frames frames" >&2
  # drivetap's generator.
  rows=()
  runs=1 measure "generate --mix modbus-rtu --plain" "$drivetap" generate --mix modbus-rtu \
    --frames "$frames" --plain -w "$work/bus.pcapng" --truth "$work/bus.json"
  packets=$(packets_of "$work/bus.json")
  size_mb=$(du -m "$work/bus.pcapng" | cut -f1)
  compare "$work/bus.pcapng"
  rm -f "$work/bus.pcapng"
  generated=("${rows[@]}")
  # Another writer.
  rows=()
  runs=1 measure "bench/foreign_pcapng.py" python3 "$root/bench/foreign_pcapng.py" "$frames" \
    "$work/foreign.pcapng" --seed 1
  foreign_mb=$(du -m "$work/foreign.pcapng" | cut -f1)
  compare "$work/foreign.pcapng"
  rm -f "$work/foreign.pcapng"
  foreign=("${rows[@]}")
  # drivetap alone: the same traffic as its own full pcapng, and all links.
  rows=()
  runs=1 measure "generate --mix modbus-rtu (full)" "$drivetap" generate --mix modbus-rtu \
    --frames "$frames" -w "$work/full.pcapng"
  full_mb=$(du -m "$work/full.pcapng" | cut -f1)
  measure "cat, full pcapng" cat "$work/full.pcapng"
  measure "drivetap --stats, full pcapng" "$drivetap" read --drive none --stats "$work/full.pcapng"
  measure "drivetap text, full pcapng" "$drivetap" read --drive none "$work/full.pcapng"
  rm -f "$work/full.pcapng"
  runs=1 measure "generate --mix all" "$drivetap" generate --frames "$frames" -w "$work/mix.pcapng" \
    --truth "$work/mix.json"
  mix_packets=$(packets_of "$work/mix.json")
  mix_mb=$(du -m "$work/mix.pcapng" | cut -f1)
  measure "drivetap text, mix, drives" "$drivetap" read "$work/mix.pcapng"
  rm -f "$work/mix.pcapng"
  alone=("${rows[@]}")

  # The headline: drivetap's default mode against tshark on both sources, --drive none beside it.
  ratio_in() {  # ratio_in ROWS-NAME DRIVETAP-ROW TSHARK-ROW
    local -n chosen=$1
    rows=("${chosen[@]}")
    awk -v a="$(seconds_of "$3")" -v b="$(seconds_of "$2")" 'BEGIN { printf "%.1fx", a / b }'
  }
  {
    echo
    echo "## $frames frames"
    echo
    echo "drivetap's speed as a multiple of tshark's on the same file (wall seconds), default mode /"
    echo "\`--drive none\`:"
    echo
    echo "| output (against tshark's) | generated: default | generated: --drive none | foreign: default | foreign: --drive none |"
    echo "|---|---|---|---|---|"
    for mode in "text|tshark text" "-T json|tshark -T fields" "--stats|tshark io,stat"; do
      IFS='|' read -r out against <<<"$mode"
      echo "| $out ($against) | $(ratio_in generated "drivetap $out" "$against") | $(ratio_in generated "drivetap $out, --drive none" "$against") | $(ratio_in foreign "drivetap $out" "$against") | $(ratio_in foreign "drivetap $out, --drive none" "$against") |"
    done
  } >>"$report"
  rows=("${generated[@]}")
  table "### Generated: $packets packets, $size_mb MB of plain pcapng" "$packets"
  rss_generated="$(rss_of 'drivetap --stats'):$(rss_of 'drivetap text'):$(rss_of 'tshark text')"
  rows=("${foreign[@]}")
  table "### Foreign: $frames packets, $foreign_mb MB of pcapng (bench/foreign_pcapng.py)" "$frames"
  memory+=("$frames:$rss_generated:$(rss_of 'drivetap --stats'):$(rss_of 'drivetap text'):$(rss_of 'tshark text')")
  rows=("${alone[@]}")
  {
    echo
    echo "### drivetap alone: the generated traffic as its full pcapng ($full_mb MB), all links ($mix_packets packets, $mix_mb MB)"
    echo
    echo "| run | seconds | CPU s | peak RSS MB | command |"
    echo "|---|---|---|---|---|"
    for r in "${rows[@]}"; do
      IFS='|' read -r name seconds rss cpu cmd <<<"$r"
      echo "| $name | $seconds | $cpu | $((rss / 1024)) | \`${cmd//$work\//}\` |"
    done
  } >>"$report"
done

{
  echo
  echo "## Memory across sizes"
  echo
  echo "Peak RSS in MB, drivetap read --stats / drivetap read (text) / tshark text, default mode:"
  echo
  for s in "${memory[@]}"; do
    IFS=: read -r frames a b c d e f <<<"$s"
    echo "- $frames frames: generated $((a / 1024)) / $((b / 1024)) / $((c / 1024)); foreign $((d / 1024)) / $((e / 1024)) / $((f / 1024))"
  done
} >>"$report"

# A bus of noise only, as a logic analyser decodes it: one byte a line, each 1.0 to 1.4 character
# times after the one before (no silence long enough to end a frame, no two gaps alike), so that
# every frame is a noise record of the longest kind with a time stamp per byte (some 17 bytes of
# storage a byte). A Park-Miller generator (exact in awk's doubles): the same file everywhere.
echo "== $noise_bytes noise bytes" >&2
awk -v n="$noise_bytes" 'BEGIN {
  print "#! serial 19200 8E1"; x = 1; t = 1; ct = 11 / 19200
  for (i = 0; i < n; i++) {
    x = (x * 16807) % 2147483647; t += ct * (1 + (x % 400) / 1000)
    x = (x * 16807) % 2147483647; printf "%.9f rtu %02X\n", t, x % 256
  }
}' >"$work/noise.log"
"$drivetap" read --stats -w "$work/noise.pcapng" "$work/noise.log" >/dev/null
rows=()
measure "drivetap --stats, noise log" "$drivetap" read --drive none --stats "$work/noise.log"
measure "drivetap -T json, noise log" "$drivetap" read --drive none -T json "$work/noise.log"
measure "drivetap --stats, noise pcapng" "$drivetap" read --drive none --stats "$work/noise.pcapng"
measure "drivetap -T json, noise pcapng" "$drivetap" read --drive none -T json "$work/noise.pcapng"
measure "drivetap text, noise pcapng" "$drivetap" read --drive none "$work/noise.pcapng"
{
  echo
  echo "## Memory on a noisy bus, stamped byte by byte"
  echo
  echo "$noise_bytes bytes of noise, one a line of a byte log, 1.0 to 1.4 character times apart;"
  echo "the same as drivetap's pcapng (per-byte times). Peak RSS:"
  echo
  echo "| run | seconds | CPU s | peak RSS MB | command |"
  echo "|---|---|---|---|---|"
  for r in "${rows[@]}"; do
    IFS='|' read -r name seconds rss cpu cmd <<<"$r"
    echo "| $name | $seconds | $cpu | $((rss / 1024)) | \`${cmd//$work\//}\` |"
  done
} >>"$report"

cp "$report" "$results"
cat "$results"
