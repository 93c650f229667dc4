#!/usr/bin/env bash
# Generic Modbus slaves bind no drive family (docs/reference.md "Binding"): the corpus of
# tests/generic_slaves.py (mbpoll's defaults, libmodbus's unit-test addresses and values,
# pymodbus's example client over RTU and ASCII, a plant of random register maps: every reply made
# by pymodbus 3.0's own server code) and the captures of generic devices by other people in
# captures/ give no drive_bound event, no drive-level finding (timing rule), no `=` line and no
# drive value, and every station is summed up as generic; each read counted from -T json. About
# 5 s. Skipped (77) without Debian's python3-pymodbus, unless DRIVETAP_REQUIRE_PYMODBUS=1.
# Usage: tests/generic_slaves.sh DRIVETAP SOURCE_DIR
set -uo pipefail
drivetap=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
py=/usr/bin/python3
if ! "$py" -c 'import pymodbus' 2>/dev/null; then
  [ "${DRIVETAP_REQUIRE_PYMODBUS:-0}" = 1 ] && { echo "FAIL: python3-pymodbus is missing"; exit 1; }
  echo "skip: no python3-pymodbus"
  exit 77
fi
"$py" "$src/tests/generic_slaves.py" "$tmp/corpus" || { echo "FAIL: generic_slaves.py"; exit 1; }
failed=0
inputs=("$tmp"/corpus/*.log "$src"/captures/unbiased-rs485-modbus/input.*
        "$src"/captures/regressions/summary-station-let-go-keeps-profile/input.*)
[ "${#inputs[@]}" -ge 7 ] || { echo "FAIL: corpus incomplete: ${inputs[*]}"; exit 1; }
for input in "${inputs[@]}"; do
  "$drivetap" read "$input" -T json >"$tmp/out.json" 2>"$tmp/err" ||
    { echo "FAIL: $input: exit $?: $(cat "$tmp/err")"; failed=1; continue; }
  verdict=$("$py" - "$tmp/out.json" <<'PY'
import json, sys
frames = bound = timing = annotated = values = stations = generic = 0
for line in open(sys.argv[1]):
    r = json.loads(line)
    t = r.get("type")
    if t == "frame":
        frames += 1
        if r.get("drive"):
            annotated += 1
        if r.get("values"):
            values += 1
        timing += sum(1 for a in r.get("anomalies", []) if a.get("kind") == "timing_rule")
    elif t == "event" and r.get("kind") == "drive_bound":
        bound += 1
    elif t == "anomaly" and r.get("kind") == "timing_rule":
        timing += 1
    elif t == "summary":
        for d in r.get("drives", []):
            stations += 1
            generic += d.get("profile") == "generic"
ok = frames > 0 and stations > 0 and bound == annotated == values == timing == 0 and generic == stations
print(("ok" if ok else "bad") + f" frames {frames} stations {stations} generic {generic} "
      f"drive_bound {bound} annotated {annotated} with values {values} timing_rule {timing}")
PY
)
  case $verdict in
    ok*) echo "$(basename "$input"): $verdict" ;;
    *) echo "FAIL: $(basename "$input"): $verdict"; failed=1 ;;
  esac
done
[ "$failed" = 0 ] && echo "ok generic slaves"
exit "$failed"
