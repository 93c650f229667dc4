#!/usr/bin/env bash
# A family's timing-rule findings are held while the binder is not sure of the family, and leave
# with a binding that is let go (docs/reference.md "Drive binding"), in every output: the summary,
# -T json, diagnose, the report and -Y. A binding that stands hands its held findings on, each
# named with its drive. About 1 s.
# Usage: tests/binding_let_go.sh DRIVETAP SOURCE_DIR
set -uo pipefail
drivetap=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failed=0
fail() { echo "FAIL: $*"; failed=1; }
ok() { echo "ok $*"; }
stands=$src/captures/seed-e5-8200/input.log

# timing_rule findings in -T json (on frames and handed on after them), the summary's count,
# the drive's profile at the end and the let-go event's word on what it dropped.
count() {
  python3 - "$1" <<'PY'
import json, sys
on_frames = late = summed = 0
late_stations, profile, dropped = set(), "", ""
for line in open(sys.argv[1]):
    r = json.loads(line)
    t = r.get("type")
    if t == "frame":
        on_frames += sum(a.get("kind") == "timing_rule" for a in r.get("anomalies", []))
    elif t == "anomaly" and r.get("kind") == "timing_rule":
        late += 1
    elif t == "event" and r.get("kind") == "drive_bound" and r.get("profile") == "generic":
        dropped = r["detail"].split("; ")[-1]
    elif t == "summary":
        summed = r["anomalies"].get("timing_rule", 0)
        profile = ",".join(d["profile"] for d in r.get("drives", []))
print(on_frames + late, summed, profile, dropped, sep="|")
PY
}
report_data() {  # report_data PAGE: kind:station of each findings row, and the drives' addresses
  python3 - "$1" <<'PY'
import json, re, sys
page = open(sys.argv[1]).read()
d = json.loads(re.search(r'<script type="application/json" id="report-data">(.*?)</script>', page, re.S).group(1))
rows = sorted(f'{r["kind"]}:{r["station"]}:{r["count"]}' for r in d["findings"]["rows"] if r["kind"] == "timing_rule")
print(" ".join(rows), "|", " ".join(str(x["addr"]) for x in d["drives"]))
PY
}
let_go_checks() {  # let_go_checks INPUT FRAMES WITHDRAWN SHOWN (lines -Y wrote before the let-go)
local let_go=$1 frames=$2 withdrawn=$3 shown=$4 got name
name=$(basename "$(dirname "$let_go")")
"$drivetap" read -T json "$let_go" > "$tmp/let_go.json" 2> "$tmp/err" || fail "read: $(cat "$tmp/err")"
got=$(count "$tmp/let_go.json")
[ "$got" = "$shown|0|generic|$withdrawn timing-rule findings made under it withdrawn" ] &&
  ok "$name: -T json: $shown timing-rule findings written before the let-go, which withdraws $withdrawn; none in the summary" ||
  fail "$name: -T json: $got"
"$drivetap" read -Y timing_rule "$let_go" > "$tmp/y.txt" 2>&1
if [ "$shown" = 0 ]; then
  grep -q "^filter: *-Y 'timing_rule' matched 0 of $frames frames$" "$tmp/y.txt" &&
    ! grep -q "timing rule broken" "$tmp/y.txt" && ok "$name: -Y timing_rule selects nothing" ||
    fail "$name: -Y timing_rule: $(grep -E 'filter:|timing' "$tmp/y.txt")"
else
  # A stream cannot take back a line: those it wrote while the binding was sure, then the event.
  [ "$(grep -c "timing rule broken" "$tmp/y.txt")" = "$shown" ] &&
    tail -n +"$(grep -n "timing rule broken" "$tmp/y.txt" | tail -1 | cut -d: -f1)" "$tmp/y.txt" |
    grep -q "\*\*\*  drive [0-9]* let go: .*; $withdrawn timing-rule findings made under it withdrawn$" &&
    ok "$name: -Y timing_rule: the $shown it wrote, then the let-go event withdrawing them" ||
    fail "$name: -Y timing_rule: $(grep -E 'let go|timing' "$tmp/y.txt")"
fi
"$drivetap" diagnose "$let_go" > "$tmp/diagnose.txt" 2>&1
! grep -qi "timing" "$tmp/diagnose.txt" && ok "$name: diagnose gives no timing verdict" ||
  fail "$name: diagnose: $(grep -i timing "$tmp/diagnose.txt")"
"$drivetap" report "$let_go" -o "$tmp/let_go.html" 2> "$tmp/err" || fail "report: $(cat "$tmp/err")"
got=$(report_data "$tmp/let_go.html")
[ "$got" = " | " ] && ok "$name: the report has no timing-rule row and no drive" ||
  fail "$name: report: $got"
}
# Let go while medium (its findings held, dropped), and after it was sure (handed on, withdrawn).
let_go_checks "$src/captures/regressions/binding-let-go-drops-held-findings/input.log" 41 3 0
let_go_checks "$src/captures/regressions/binding-let-go-withdraws-findings/input.log" 60 2 2

# The same traffic without the reads that let the binding go: it stands (medium) to the end, and
# its three held findings are handed on then, each with its station.
"$drivetap" read -T json "$stands" > "$tmp/stands.json" 2> "$tmp/err" || fail "read: $(cat "$tmp/err")"
got=$(count "$tmp/stands.json")
[ "$got" = "3|3|e5-8200|" ] && ok "stands: 3 timing-rule findings handed on and summed" ||
  fail "stands: -T json: $got"
"$drivetap" read -Y timing_rule "$stands" > "$tmp/y.txt" 2>&1
[ "$(grep -c "timing rule broken (#1[357], held while drive 1's family was not yet sure)" "$tmp/y.txt")" = 3 ] &&
  grep -q "and 3 findings reported after their frame" "$tmp/y.txt" &&
  ok "stands: -Y timing_rule shows and counts the 3, each with its frame and drive" ||
  fail "stands: -Y timing_rule: $(cat "$tmp/y.txt")"
"$drivetap" diagnose "$stands" > "$tmp/diagnose.txt" 2>&1
grep -q "\[timing-rule\].*keeps at least 10 ms (E5-8200" "$tmp/diagnose.txt" &&
  ok "stands: diagnose's timing-rule verdict" || fail "stands: diagnose: $(cat "$tmp/diagnose.txt")"
"$drivetap" report "$stands" -o "$tmp/stands.html" 2> "$tmp/err" || fail "report: $(cat "$tmp/err")"
got=$(report_data "$tmp/stands.html")
[ "$got" = "timing_rule:1:3 | 1" ] && ok "stands: the report's timing-rule row is drive 1's" ||
  fail "stands: report: $got"
[ "$failed" = 0 ] && echo "ok binding let go"
[ "$failed" = 0 ]
