#!/usr/bin/env python3
"""-z statistics recomputed from `drivetap read -T json` (docs/reference.md "Statistics (-z)").

    tests/stats_tables.py DRIVETAP CAPTURES_DIR

For every capture in CAPTURES_DIR and for `drivetap generate` traffic (several links and stations):
1. the stat records of `read -T json -z ...` equal what this script computes from the same run's
   frame, noise and transaction records: per-station counts, bytes and share, latency min/max
   (exact) and nearest-rank p50/p95/p99 (within the histogram's stated 1/128), poll interval
   mean and jitter, functions, the gap histogram, the load per interval;
2. `--stats -z` (no per-frame output: telegrams counted from their head) gives the same stat
   records, and so does `--drive none` (telegrams taken whole, handed over undecoded);
3. the text tables say what the JSON records say.
Unknown or malformed -z arguments: one line naming them, exit 2.
Each input is a case (tests/cases.py), which the sanitizer build samples.
"""
import json
import math
import os
import subprocess
import sys
import tempfile
from decimal import Decimal
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cases import Cases  # noqa: E402

DRIVETAP = sys.argv[1]
CAPTURES = sys.argv[2]
Z = ["-z", "stations", "-z", "functions", "-z", "gaps", "-z", "load", "-z", "load,0.25"]
failures = []


def fail(what):
    failures.append(what)
    print("FAIL:", what)


def run(args, check=True):
    p = subprocess.run([DRIVETAP] + args, capture_output=True, text=True)
    if check and p.returncode != 0:
        fail(f"drivetap {' '.join(args)}: exit {p.returncode}: {p.stderr.strip()}")
    return p


def ns(seconds_text):
    """A time printed as seconds with up to 9 decimals, in ns, exactly."""
    text = format(Decimal(seconds_text), "f") if not isinstance(seconds_text, str) else seconds_text
    whole, _, frac = text.partition(".")
    sign = -1 if whole.startswith("-") else 1
    return sign * (abs(int(whole)) * 1_000_000_000 + int((frac + "000000000")[:9]))


# Times are read exactly (Decimal), every other number as a float.
EXACT_KEYS = {"t", "t_end", "t0", "from_s", "to_s"}


def exact_times(record):
    for key, value in record.items():
        if isinstance(value, Decimal) and key not in EXACT_KEYS:
            record[key] = float(value)
        elif isinstance(value, dict):
            exact_times(value)
        elif isinstance(value, list):
            for item in value:
                if isinstance(item, dict):
                    exact_times(item)
    return record


def parse(text):
    return [exact_times(json.loads(line, parse_float=Decimal)) for line in text.splitlines()]


def nearest_rank(sorted_values, percent):
    rank = max(1, math.ceil(percent * len(sorted_values) / 100))
    return sorted_values[rank - 1]


def close(a, b, tolerance):
    return abs(a - b) <= tolerance + 1e-9


def check_records(name, records):
    frames = [r for r in records if r["type"] == "frame"]
    noise = [r for r in records if r["type"] == "noise"]
    transactions = [r for r in records if r["type"] == "transaction"]
    stats = [r for r in records if r["type"] == "stat"]

    # Stations.
    expected = defaultdict(lambda: defaultdict(int))
    latencies = defaultdict(list)
    requests_at = defaultdict(list)
    channel_bytes = defaultdict(int)
    for t in transactions:
        if t["addr"] < 0:
            continue
        s = expected[(t["channel"], t["protocol"], t["addr"])]
        s["requests"] += t["request_n"] is not None
        s["replies"] += t["response_n"] is not None
        s["exceptions"] += t["outcome"] == "exception"
        s["timeouts"] += t["outcome"] == "timeout"
        if t["latency_ms"] is not None:
            latencies[(t["channel"], t["protocol"], t["addr"])].append(t["latency_ms"])
    for f in frames + noise:
        channel_bytes[f["channel"]] += len(f["hex"]) // 2
    for f in frames:
        if f["addr"] is None:
            continue
        key = (f["channel"], f["protocol"], f["addr"])
        s = expected[key]
        s["bytes"] += len(f["hex"]) // 2
        s["bad_checksums"] += f["checksum"] in ("bad", "swapped")
        if f["dir"] == "request":
            requests_at[key].append(ns(f["t"]))
    got = {(r["channel"], r["protocol"], r["addr"]): r for r in stats if r["stat"] == "stations"}
    if set(got) != set(expected):
        fail(f"{name}: stations {sorted(got)} != recomputed {sorted(expected)}")
    for key, r in got.items():
        e = expected.get(key, {})
        for field in ("requests", "replies", "exceptions", "timeouts", "bad_checksums", "bytes"):
            if r[field] != e.get(field, 0):
                fail(f"{name} {key}: {field} {r[field]} != recomputed {e.get(field, 0)}")
        share = 100 * e.get("bytes", 0) / channel_bytes[key[0]] if channel_bytes[key[0]] else 0
        if not close(r["share_pct"], share, 0.0005):
            fail(f"{name} {key}: share {r['share_pct']} != recomputed {share:.3f}")
        values = sorted(latencies.get(key, []))
        if not values:
            if r["latency_ms"] is not None:
                fail(f"{name} {key}: latency {r['latency_ms']} without paired replies")
        elif r["latency_ms"] is None:
            fail(f"{name} {key}: no latency, {len(values)} recomputed")
        else:
            lat = r["latency_ms"]
            if lat["count"] != len(values):
                fail(f"{name} {key}: latency count {lat['count']} != {len(values)}")
            # min and max exact (both rounded to the us alike); percentiles within 1/128 of the
            # exact nearest-rank value, plus the us rounding of both sides.
            for field, exact, tolerance in (
                ("min", values[0], 0.0),
                ("max", values[-1], 0.0),
                ("p50", nearest_rank(values, 50), None),
                ("p95", nearest_rank(values, 95), None),
                ("p99", nearest_rank(values, 99), None),
            ):
                allowed = tolerance if tolerance is not None else exact / 128 + 0.001
                if not close(lat[field], exact, allowed):
                    fail(f"{name} {key}: latency {field} {lat[field]} != nearest rank {exact}")
        times = requests_at.get(key, [])
        intervals = [b - a for a, b in zip(times, times[1:])]
        if not intervals:
            if r["poll_ms"] is not None:
                fail(f"{name} {key}: poll interval with fewer than two requests")
        else:
            mean = sum(intervals) / len(intervals)
            jitter = math.sqrt(sum((i - mean) ** 2 for i in intervals) / len(intervals))
            poll = r["poll_ms"] or {}
            if poll.get("count") != len(intervals):
                fail(f"{name} {key}: poll count {poll.get('count')} != {len(intervals)}")
            if not close(poll.get("mean", -1), mean / 1e6, 0.0011) or not close(
                poll.get("jitter", -1), jitter / 1e6, 0.0011
            ):
                fail(f"{name} {key}: poll {poll} != mean {mean / 1e6:.4f}, jitter {jitter / 1e6:.4f}")

    # Functions.
    expected_fc = defaultdict(lambda: defaultdict(int))
    for t in transactions:
        f = expected_fc[(t["protocol"], None if t["fc"] < 0 else t["fc"])]
        f["requests"] += t["request_n"] is not None
        f["replies"] += t["response_n"] is not None
        f["exceptions"] += t["outcome"] == "exception"
    got_fc = {(r["protocol"], r["fc"]): r for r in stats if r["stat"] == "functions"}
    if set(got_fc) != set(expected_fc):
        fail(f"{name}: functions {sorted(got_fc, key=str)} != {sorted(expected_fc, key=str)}")
    for key, r in got_fc.items():
        for field in ("requests", "replies", "exceptions"):
            if r[field] != expected_fc[key][field]:
                fail(f"{name} {key}: function {field} {r[field]} != {expected_fc[key][field]}")
        if r["protocol"].startswith("modbus") and r["fc"] == 3 and r["name"] != "Read Holding Registers":
            fail(f"{name}: function 3 named {r['name']}")

    # Gaps: bins from t1.5 and t3.5; a gap within the us rounding of a bound may fall either side.
    gaps = [r for r in stats if r["stat"] == "gaps"]
    if len(gaps) != 1:
        fail(f"{name}: {len(gaps)} gap records")
    else:
        g = gaps[0]
        t15, t35 = g["t15_ms"], g["t35_ms"]
        # The bins' bounds as printed (t3.5 doublings, each rounded to the us), checked below
        # against t3.5; past the last bin shown, doublings of t3.5.
        ideal = [0, t15, t35] + [t35 * 2**k for k in range(1, 17)]
        bounds = [b["from_ms"] for b in g["bins"]] + ideal[len(g["bins"]) :]
        counts = [0] * 19
        loose = [0] * 19
        values = [f["gap_before_ms"] for f in frames if "gap_before_ms" in f]
        for v in values:
            b = 0
            while b + 1 < len(bounds) and v >= bounds[b + 1]:
                b += 1
            counts[b] += 1
            if any(abs(v - x) <= 0.0011 for x in bounds[1:]):
                loose[b] += 1
                if b + 1 < len(loose):
                    loose[b + 1] += 1
                if b > 0:
                    loose[b - 1] += 1
        if g["frames"] != len(values):
            fail(f"{name}: gaps over {g['frames']} frames, {len(values)} with gap_before_ms")
        for b, bin_ in enumerate(g["bins"]):
            if not close(bin_["from_ms"], ideal[b], 0.0006 * 2 ** max(0, b - 2)):
                fail(f"{name}: gap bin {b} from {bin_['from_ms']} != {ideal[b]}")
            if abs(bin_["count"] - counts[b]) > loose[b]:
                fail(f"{name}: gap bin {b} count {bin_['count']} != recomputed {counts[b]}")
        if sum(counts[len(g["bins"]):]) != 0:
            fail(f"{name}: gaps beyond the last bin shown")

    # Load: each frame and noise record busy bytes x character time from its first byte, split
    # over the intervals; counted (frames, bytes) in the interval it starts in.
    for interval_s in (1, 0.25):
        rows = [r for r in stats if r["stat"] == "load" and r["interval_s"] == interval_s]
        if not rows:
            if frames or noise:
                fail(f"{name}: no load rows for {interval_s} s")
            continue
        t0 = ns(rows[0]["t0"])
        c = rows[0]["character_time_ns"]
        interval = round(interval_s * 1e9)
        cells = defaultdict(lambda: [0, 0, 0])  # (interval, channel) -> frames, bytes, busy
        for f in frames + noise:
            start, size = ns(f["t"]), len(f["hex"]) // 2
            lo, hi = start - t0, start - t0 + size * c
            k0 = lo // interval
            cells[(k0, f["channel"])][0] += f["type"] == "frame"
            cells[(k0, f["channel"])][1] += size
            k = k0
            while k * interval < hi:
                cells[(k, f["channel"])][2] += min(hi, (k + 1) * interval) - max(lo, k * interval)
                k += 1
        first = min(frames + noise, key=lambda f: f["n"])
        if ns(first["t"]) != t0:
            fail(f"{name}: load t0 {rows[0]['t0']} is not the first record's time {first['t']}")
        shown = set()
        for r in rows:
            k_from = round(ns(r["from_s"]) / interval)
            k_to = round(ns(r["to_s"]) / interval)
            length = (k_to - k_from) * interval
            e = [0, 0, 0]
            for k in range(k_from, k_to):
                shown.add((k, r["channel"]))
                cell = cells.get((k, r["channel"]), [0, 0, 0])
                e = [a + b for a, b in zip(e, cell)]
            if [r["frames"], r["bytes"]] != e[:2] or not close(r["busy_pct"], 100 * e[2] / length, 0.0005):
                fail(f"{name}: load {r['from_s']}..{r['to_s']} {r['channel']}: {r} != recomputed {e}")
        missing = [k for k, v in cells.items() if k not in shown and v[1]]
        if missing:
            fail(f"{name}: load intervals with traffic not shown: {missing[:5]}")


def text_tables(text):
    """The -z blocks of a text run: {title word: [rows of fields]}."""
    tables = {}
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("=====") and i + 1 < len(lines) and not lines[i + 1].startswith("="):
            title = lines[i + 1].split(" ")[0]
            rows = []
            j = i + 3
            while j < len(lines) and not lines[j].startswith("====="):
                rows.append(lines[j])
                j += 1
            tables.setdefault(title, []).append(rows)
            i = j + 1
        else:
            i += 1
    return tables


def check_text(name, text, stats):
    tables = text_tables(text)
    json_stations = [r for r in stats if r["stat"] == "stations"]
    rows = [row.split() for row in tables.get("Stations", [[]])[0] if row != "(no stations)"]
    if len(rows) != len(json_stations):
        fail(f"{name}: text stations {len(rows)} rows, JSON {len(json_stations)}")
    for row, r in zip(rows, json_stations):
        lat = r["latency_ms"] or {}
        poll = r["poll_ms"] or {}
        want = [r["protocol"], str(r["addr"]), str(r["requests"]), str(r["replies"]),
                str(r["exceptions"]), str(r["timeouts"]), str(r["bad_checksums"])]
        want += [f"{lat[k]:.3f}" if lat else "-" for k in ("min", "p50", "p95", "p99", "max")]
        want += [f"{poll[k]:.3f}" if poll else "-" for k in ("mean", "jitter")]
        want += [str(r["bytes"])]
        if row[-16:-1] != want or not close(float(row[-1]), r["share_pct"], 0.05):
            fail(f"{name}: text station row {row} != JSON {r}")
    json_fc = [r for r in stats if r["stat"] == "functions"]
    rows = [row.split() for row in tables.get("Functions", [[]])[0] if row != "(no transactions)"]
    if len(rows) != len(json_fc):
        fail(f"{name}: text functions {len(rows)} rows, JSON {len(json_fc)}")
    for row, r in zip(rows, json_fc):
        want = [r["protocol"], "-" if r["fc"] is None else str(r["fc"])]
        counts = [str(r["requests"]), str(r["replies"]), str(r["exceptions"])]
        if row[:2] != want or row[-3:] != counts or " ".join(row[2:-3]) != (r["name"] or "-"):
            fail(f"{name}: text function row {row} != JSON {r}")
    gaps = [r for r in stats if r["stat"] == "gaps"]
    rows = tables.get("Gaps", [[]])[0]
    if gaps and [int(row.split()[-2]) for row in rows] != [b["count"] for b in gaps[0]["bins"]]:
        fail(f"{name}: text gap counts {rows} != JSON {gaps[0]['bins']}")
    for blocks_at, interval_s in ((0, 1), (1, 0.25)):
        json_load = [r for r in stats if r["stat"] == "load" and r["interval_s"] == interval_s]
        blocks = tables.get("Load", [])
        rows = [row.split() for row in blocks[blocks_at]] if len(blocks) > blocks_at else []
        rows = [row for row in rows if row != ["(no", "traffic)"]]
        if len(rows) != len(json_load):
            fail(f"{name}: text load,{interval_s} {len(rows)} rows, JSON {len(json_load)}")
            continue
        for row, r in zip(rows, json_load):
            if row[0] != f"{r['from_s']:.3f}" or row[2] != f"{r['to_s']:.3f}" or row[-3:-1] != [
                str(r["frames"]),
                str(r["bytes"]),
            ] or not close(float(row[-1]), r["busy_pct"], 0.05):
                fail(f"{name}: text load row {row} != JSON {r}")


def check_input(name, path):
    p = run(["read", path, "-T", "json"] + Z)
    if p.returncode != 0:
        return
    records = parse(p.stdout)
    stats = [r for r in records if r["type"] == "stat"]
    # The stat records come last, after the summary.
    kinds = [r["type"] for r in records]
    if "summary" not in kinds or kinds.index("summary") > len(kinds) - len(stats) - 1:
        fail(f"{name}: stat records do not follow the summary")
    check_records(name, records)
    for variant in (["--stats"], ["--drive", "none"], ["--stats", "--drive", "none"]):
        q = run(["read", path, "-T", "json"] + variant + Z)
        other = parse(q.stdout)
        if [r for r in other if r["type"] == "stat"] != stats:
            fail(f"{name}: stat records with {' '.join(variant)} differ")
        if variant == ["--drive", "none"]:
            check_records(name + " --drive none", other)
    t = run(["read", path] + Z)
    check_text(name, t.stdout, stats)


def main():
    inputs = []
    for d in sorted(os.listdir(CAPTURES)):
        for f in sorted(os.listdir(os.path.join(CAPTURES, d))) if os.path.isdir(os.path.join(CAPTURES, d)) else []:
            if f.startswith("input."):
                inputs.append((d, os.path.join(CAPTURES, d, f)))
    with tempfile.TemporaryDirectory() as work:
        for seed in (3, 11):
            log = os.path.join(work, f"generated-{seed}.log")
            run(["generate", "--frames", "20000", "--seed", str(seed), "-o", log])
            inputs.append((f"generate --seed {seed}", log))
        cases = Cases("stats_tables")
        for name, path in inputs:
            if cases.begin(name):
                check_input(name, path)
        cases.end()  # (what follows always runs)
        p = run(["read", inputs[-1][1], "-T", "json", "--stats", "-z", "stations"])
        stations_seen = sum('"stat":"stations"' in line for line in p.stdout.splitlines())
        if stations_seen < 4:
            fail(f"generated traffic: only {stations_seen} stations")
        # --stats --no-summary -z: the statistics alone (what -q -z prints).
        p = run(["read", inputs[-1][1], "--stats", "--no-summary", "-z", "functions"])
        lines = p.stdout.splitlines()
        if not lines or lines[0] != "=" * 83 or lines[1] != "Functions (-z functions)" or "summary" in p.stdout:
            fail(f"--stats --no-summary -z: {p.stdout[:200]!r}")
        # decode: counts, no times.
        p = run(["decode", "-z", "stations", "-z", "gaps", "-T", "json", "01 03 00 00 00 01 84 0A"])
        if '"stat":"stations"' not in p.stdout or '"stat":"gaps"' in p.stdout:
            fail(f"decode -z: {p.stdout}")
        # Refused arguments: one line, exit 2.
        for bad, message in (
            ("x", "drivetap: -z: unknown statistic 'x' (stations, functions, gaps, load)"),
            ("load,0", "drivetap: -z load,0: the interval must be seconds from 0.001 to 86400, e.g. load,1"),
            ("stations,2", "drivetap: -z stations,2: takes no argument"),
        ):
            for command in (["read", inputs[0][1]], ["decode", "01 03 00 00 00 01 84 0A"]):
                p = run(command[:1] + ["-z", bad] + command[1:], check=False)
                if p.returncode != 2 or p.stderr.strip() != message or p.stdout:
                    fail(f"-z {bad}: exit {p.returncode}, stderr {p.stderr!r}, stdout {p.stdout[:80]!r}")
    for problem in cases.finish():
        fail(problem)
    print(f"{len(inputs)} inputs checked, {len(failures)} failures")
    return 1 if failures else 0


sys.exit(main())
