#!/usr/bin/env bash
# Negative corpus: lines that carry no drive protocol — captures/negative-*/ (made by
# scripts/make_negative_captures.py) and the public foreign-line recordings in captures/foreign-*/
# (sigrok-dumps, public domain) — must give no good drive telegram and bind no drive, whatever
# line settings decode them. Checked from the JSON output: the summary's good_telegrams and
# drives, every protocol_detected and drive_bound event.
#   tests/negative.sh DRIVETAP_BIN CAPTURES_DIR
set -euo pipefail
drivetap="$1"
captures="$2"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failed=0
runs=0

check() {  # check LABEL FILE [OPTIONS...]
  local label="$1" file="$2"
  shift 2
  runs=$((runs + 1))
  if ! "$drivetap" read -T json "$@" "$file" > "$tmp/out.json" 2> "$tmp/err.txt"; then
    # Every recording is readable (the MIDI one in sigrok 0.2's format too): a refusal fails.
    if [ -s "$tmp/out.json" ]; then :; else echo "FAIL $label: not read ($(head -n 1 "$tmp/err.txt"))"; failed=1; return 0; fi
  fi
  if ! python3 - "$label" "$tmp/out.json" <<'PY'
import json, sys
label, path = sys.argv[1], sys.argv[2]
problems, summary, detected = [], None, 0
for n, line in enumerate(open(path), 1):
    r = json.loads(line)
    if r.get("type") == "event" and r.get("kind") == "protocol_detected":
        detected += 1
        if r.get("protocol") != "unknown" or r.get("confidence") != "none":
            problems.append(f"line {n}: {r.get('detail')}")
    if r.get("type") == "event" and r.get("kind") == "drive_bound" and r.get("profile") != "generic":
        problems.append(f"line {n}: {r.get('detail')}")
    if r.get("type") == "summary":
        summary = r
if summary is None:
    problems.append("no summary line")
else:
    # (good_telegrams: checksum and plausibility; older outputs had only the checksum count)
    good = summary.get("good_telegrams", summary["checksum"]["good"])
    if good != 0:
        problems.append(f"{good} good telegram(s)")
    for d in summary["drives"]:
        if d["profile"] != "generic":
            problems.append(f"drive {d['address']} bound to {d['profile_name']}")
if detected == 0 and summary is not None and summary["frames"] > 0:
    problems.append("frames decoded with no detection")
for p in problems:
    print(f"FAIL {label}: {p}")
sys.exit(1 if problems else 0)
PY
  then
    failed=1
  fi
}

for dir in "$captures"/negative-*/; do
  input=$(cd "$dir" && ls input.* | head -n 1)
  check "$(basename "$dir")" "$dir/$input"
done
# The recordings, with the line detected from the samples and with settings forced (the rules
# must hold whatever the line settings: the 9600 8N1 hello-world decodes as ASCII text then).
for file in "$captures"/foreign-*/input.sr; do
  name=$(basename "$(dirname "$file")")
  check "$name" "$file"
  for settings in "9600 8N1" "9600 8E1" "19200 8N1" "115200 8E1" "250000 8N2"; do
    check "$name -s '$settings'" "$file" -s "$settings"
  done
done
[ "$runs" -ge 53 ] || { echo "FAIL: only $runs runs (corpus missing?)"; exit 1; }
[ "$failed" = 0 ] && echo "ok: $runs runs, no good drive telegram, no drive bound"
exit "$failed"
