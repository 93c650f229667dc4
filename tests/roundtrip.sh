#!/usr/bin/env bash
# Lossless pcapng: `drivetap read` of a file drivetap wrote must print exactly what the writing
# run printed (text and JSON), and `-w -` must stream the same file to stdout.
#   tests/roundtrip.sh --drivetap BIN CAPTURE_DIR
set -euo pipefail
drivetap="$2"
dir="$3"
input=$(cd "$dir" && ls input.* | head -n 1)
args=()
if [ -f "$dir/args" ]; then read -r -a args < "$dir/args"; fi
# The pcapng carries the line settings, not a binding by hand: --drive goes with every reading.
drive_args=()
for ((k = 0; k < ${#args[@]}; k++)); do
  case ${args[k]} in
    --drive) drive_args+=(--drive "${args[k + 1]}"); k=$((k + 1)) ;;
    --drive=*) drive_args+=("${args[k]}") ;;
  esac
done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$dir"
"$drivetap" read "${args[@]}" "$input" -w "$tmp/out.pcapng" > "$tmp/first.txt"
"$drivetap" read "${drive_args[@]}" "$tmp/out.pcapng" > "$tmp/second.txt"
diff -u "$tmp/first.txt" "$tmp/second.txt" || { echo "FAIL $dir: text differs after pcapng round trip"; exit 1; }
"$drivetap" read -T json "${args[@]}" "$input" > "$tmp/first.json"
"$drivetap" read -T json "${drive_args[@]}" "$tmp/out.pcapng" > "$tmp/second.json"
diff -u "$tmp/first.json" "$tmp/second.json" || { echo "FAIL $dir: JSON differs after pcapng round trip"; exit 1; }
"$drivetap" read "${args[@]}" "$input" -w - 2> "$tmp/stderr.txt" > "$tmp/stdout.pcapng"
cmp "$tmp/out.pcapng" "$tmp/stdout.pcapng" || { echo "FAIL $dir: -w - differs from -w FILE"; exit 1; }
grep -q -- "--- summary ---" "$tmp/stderr.txt" || { echo "FAIL $dir: no summary on stderr with -w -"; exit 1; }
"$drivetap" read "${drive_args[@]}" - < "$tmp/out.pcapng" > "$tmp/third.txt"
diff -u "$tmp/first.txt" "$tmp/third.txt" || { echo "FAIL $dir: reading the pcapng from stdin differs"; exit 1; }
echo "ok $dir"
