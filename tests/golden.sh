#!/usr/bin/env bash
# Golden test: `drivetap read` of captures/<name>/input.* must print exactly expected.txt (text),
# expected.json (JSON lines) and expected.events.txt (`--events`: the drive-state timeline). Extra options for a capture go in captures/<name>/args.
# A logic-analyser capture (input.sr, input.vcd) is also diagnosed: `drivetap diagnose` must print
# expected.diagnose.txt and, with -T json, expected.diagnose.json (the line, per channel, and the
# verdicts).
# A capture that must fail (a damaged file) has expected.exit (the exit status) and
# expected.stderr (the one-line error); what was decoded before the damage is still compared.
# An input.hex is given to `drivetap decode -` on stdin instead (frames as pasted, one a line).
#
#   tests/golden.sh [--update-golden] [--drivetap BIN] CAPTURE_DIR...
#   tests/golden.sh --update-golden --drivetap build/drivetap captures/*     # rewrite all
set -euo pipefail

update=0
drivetap=""
dirs=()
while [ $# -gt 0 ]; do
  case "$1" in
    --update-golden) update=1 ;;
    --drivetap) drivetap="$2"; shift ;;
    *) dirs+=("$1") ;;
  esac
  shift
done
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
[ -n "$drivetap" ] || drivetap="$here/../build/drivetap"
drivetap="$(cd "$(dirname "$drivetap")" && pwd)/$(basename "$drivetap")"
[ "${#dirs[@]}" -gt 0 ] || { echo "usage: golden.sh [--update-golden] [--drivetap BIN] DIR..." >&2; exit 2; }

failed=0
for dir in "${dirs[@]}"; do
  [ -d "$dir" ] || continue
  input=$(cd "$dir" && ls input.* 2>/dev/null | head -n 1 || true)
  if [ -z "$input" ]; then continue; fi
  args=()
  if [ -f "$dir/args" ]; then read -r -a args < "$dir/args"; fi
  tmp=$(mktemp -d)
  want_exit=0
  [ -f "$dir/expected.exit" ] && want_exit=$(cat "$dir/expected.exit")
  text_exit=0
  json_exit=0
  command=(read); operand="$input"
  if [ "$input" = input.hex ]; then command=(decode); operand=-; fi
  (cd "$dir" && "$drivetap" "${command[@]}" "${args[@]}" "$operand" < "$input" > "$tmp/text" 2> "$tmp/text.err") || text_exit=$?
  (cd "$dir" && "$drivetap" "${command[@]}" -T json "${args[@]}" "$operand" < "$input" > "$tmp/json" 2> "$tmp/json.err") || json_exit=$?
  (cd "$dir" && "$drivetap" "${command[@]}" --events "${args[@]}" "$operand" < "$input" > "$tmp/events" 2> /dev/null) || true
  kinds=(txt json events.txt)
  case "$input" in
    *.sr | *.vcd)
      kinds+=(diagnose.txt diagnose.json)
      (cd "$dir" && "$drivetap" diagnose "${args[@]}" "$input" > "$tmp/diagnose.txt" 2> /dev/null) || true
      (cd "$dir" && "$drivetap" diagnose -T json "${args[@]}" "$input" > "$tmp/diagnose.json" 2> /dev/null) || true
      ;;
  esac
  if [ "$update" = 1 ]; then
    cp "$tmp/text" "$dir/expected.txt"
    cp "$tmp/json" "$dir/expected.json"
    cp "$tmp/events" "$dir/expected.events.txt"
    for kind in diagnose.txt diagnose.json; do
      if [ -f "$tmp/$kind" ]; then cp "$tmp/$kind" "$dir/expected.$kind"; fi
    done
    if [ "$text_exit" != 0 ]; then
      echo "$text_exit" > "$dir/expected.exit"
      cp "$tmp/text.err" "$dir/expected.stderr"
    else
      rm -f "$dir/expected.exit" "$dir/expected.stderr"
    fi
    echo "updated $dir (exit $text_exit)"
  else
    if [ "$text_exit" != "$want_exit" ] || [ "$json_exit" != "$want_exit" ]; then
      echo "FAIL $dir: drivetap read exited $text_exit (JSON: $json_exit), expected $want_exit"
      cat "$tmp/text.err"
      failed=1
    fi
    if [ -f "$dir/expected.stderr" ] && ! diff -u "$dir/expected.stderr" "$tmp/text.err"; then
      echo "FAIL $dir: error message differs from expected.stderr"
      failed=1
    fi
    for kind in "${kinds[@]}"; do
      case "$kind" in
        txt) got="$tmp/text" ;;
        json) got="$tmp/json" ;;
        events.txt) got="$tmp/events" ;;
        *) got="$tmp/$kind" ;;
      esac
      if ! diff -u "$dir/expected.$kind" "$got" > "$tmp/diff"; then
        echo "FAIL $dir: output differs from expected.$kind"
        head -n 60 "$tmp/diff"
        failed=1
      fi
    done
    [ "$failed" = 0 ] && echo "ok $dir"
  fi
  rm -rf "$tmp"
done
exit "$failed"
