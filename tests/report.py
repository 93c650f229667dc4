#!/usr/bin/env python3
# `drivetap report` (docs/reference.md "Report"), in two parts:
#   data     the data embedded in the page of bundled captures against `drivetap read -T json` of
#            the same captures, recomputed here (counts per station, latency percentiles,
#            findings, drive values, events, state bands at the events' frames, load); several
#            captures on one timeline; the page fetches nothing; bad input: read's one-line error
#            and exit status, and no page or temporary file left behind (also when stopped by a
#            signal);
#   browser  the page rendered in headless Chromium: no script error, every chart drawn and not
#            blank (the canvas pixels the page counts, and the screenshot's pixels in each chart's
#            region). Skipped (77) without chromium unless DRIVETAP_REQUIRE_CHROMIUM=1 (CI).
# usage: report.py DRIVETAP SOURCE_DIR data|browser [--screenshot docs/report.png]
import json
import math
import os
import re
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import zlib

drivetap, root, part = sys.argv[1], sys.argv[2], sys.argv[3]
screenshot_out = sys.argv[5] if len(sys.argv) > 5 and sys.argv[4] == "--screenshot" else None
failures = []

SHARED_IDS = {"station", "family", "setpoint", "setpoint_pct", "output_frequency", "output_frequency_pct",
              "output_current", "output_voltage", "running", "direction", "fault", "fault_name", "status_word", "control_word"}


def register_field_id(name):
    """A register's drive.* id made from its name, as the profile loader makes it."""
    return "_".join(w.lower() for w in re.split(r"[^A-Za-z0-9]+", name) if w)


def not_quantities():
    """Per profile id: the register ids the report does not draw (a role not under a shared id,
    bits, an enum or no unit), read from the profiles themselves (dissectors/profiles/*.toml)."""
    import tomllib
    out = {}
    folder = os.path.join(root, "dissectors", "profiles")
    for name in sorted(os.listdir(folder)):
        if not name.endswith(".toml"):
            continue
        with open(os.path.join(folder, name), "rb") as f:
            profile = tomllib.load(f)
        ids, skipped = [], set()
        for kind in ("register", "parameter"):
            for r in profile.get(kind, []):
                rid = r.get("id") or register_field_id(r["name"])
                if rid in ids:  # a name twice: told apart by its number or address
                    rid += "_" + (register_field_id(r["number"]) if kind == "parameter" else "%04x" % r["address"])
                ids.append(rid)
                role = r.get("role", "") and rid not in SHARED_IDS
                if role or r.get("bits") or r.get("enum") or not r.get("unit"):
                    skipped.add(rid)
        out[profile["drive"]["id"]] = skipped
    return out


NOT_QUANTITIES = not_quantities()


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAIL:", what)


def run(args, **kw):
    return subprocess.run([drivetap] + args, capture_output=True, text=True, **kw)


def page_data(path):
    text = open(path, encoding="utf-8").read()
    m = re.search(r'<script type="application/json" id="report-data">(.*?)</script>', text, re.S)
    assert m, f"{path}: no report data"
    return json.loads(m.group(1)), text


def records(capture, *extra):
    out = run(["read", "-T", "json", "--no-summary", *extra, capture])
    assert out.returncode == 0, out.stderr
    return [json.loads(line) for line in out.stdout.splitlines() if line.strip()]


def nearest_rank(values, percent):
    values = sorted(values)
    rank = max(1, math.ceil(percent * len(values) / 100))
    return values[rank - 1]


def check_capture_data(capture, tmp):
    page = os.path.join(tmp, "page.html")
    out = run(["report", capture, "-o", page])
    check(out.returncode == 0, f"{capture}: report exit {out.returncode}: {out.stderr}")
    data, text = page_data(page)
    recs = records(capture)
    name = os.path.relpath(capture, root)
    frames = [r for r in recs if r["type"] == "frame"]
    check(data["captures"][0]["frames"] == len(frames),
          f"{name}: {data['captures'][0]['frames']} frames in the page, {len(frames)} in read -T json")
    check(data["summary"]["frames"] == len(frames), f"{name}: summary frames")

    # Stations: requests, replies, timeouts, exceptions and latency percentiles from the
    # transactions (the LogHistogram's percentiles are within 1/128 of the nearest-rank value).
    stations = {}
    for r in recs:
        if r["type"] != "transaction" or r.get("addr") is None or r["addr"] < 0:
            continue
        s = stations.setdefault((r["channel"], r["protocol"], r["addr"]),
                                {"requests": 0, "replies": 0, "timeouts": 0, "exceptions": 0, "lat": []})
        s["requests"] += r.get("request_n") is not None
        s["replies"] += r.get("response_n") is not None
        s["timeouts"] += r["outcome"] == "timeout"
        s["exceptions"] += r["outcome"] == "exception"
        if r.get("latency_ms") is not None:
            s["lat"].append(r["latency_ms"])
    page_stations = {(l["channel"], l["protocol"], l["addr"]): l for l in data["latency"]}
    table = {(r["channel"], r["protocol"], r["addr"]): r
             for r in data["captures"][0]["stats"] if r["stat"] == "stations"}
    check(set(page_stations) == set(stations), f"{name}: stations {sorted(page_stations)} vs {sorted(stations)}")
    for key, s in stations.items():
        p = page_stations.get(key, {})
        t = table.get(key, {})
        for k in ("requests", "replies", "timeouts", "exceptions"):
            check(p.get(k) == s[k], f"{name}: station {key} {k}: page {p.get(k)}, JSON {s[k]}")
        check(t.get("timeouts") == s["timeouts"] and t.get("requests") == s["requests"],
              f"{name}: station {key}: -z stations table differs from the transactions")
        if s["lat"]:
            for pct in (50, 95, 99):
                want = nearest_rank(s["lat"], pct)
                got = p.get(f"p{pct}_ms")
                check(got is not None and abs(got - want) <= want / 128 + 0.0011,
                      f"{name}: station {key} p{pct}: page {got}, recomputed {want}")
                check(t["latency_ms"][f"p{pct}"] == got, f"{name}: station {key} p{pct}: table and chart differ")
            check(sum(p["bins"]) == len(s["lat"]), f"{name}: station {key}: histogram holds {sum(p['bins'])} of {len(s['lat'])}")

    # Findings: counts per kind and station (a finding's station: its frame's address).
    address = {r["n"]: r.get("addr", -1) for r in recs if r["type"] == "frame"}
    want = {}
    for r in recs:
        if r["type"] != "anomaly":
            continue
        station = address.get(r.get("frame"), -1) if r.get("frame") else -1
        if station is None:
            station = -1
        want[(r["kind"], station)] = want.get((r["kind"], station), 0) + 1
    got = {(row["kind"], row["station"]): row["count"] for row in data["findings"]["rows"]}
    check(got == want, f"{name}: findings {sorted(got.items())} vs {sorted(want.items())}")
    for row in data["findings"]["rows"]:
        check(sum(c[1] for c in row["cells"]) == row["count"], f"{name}: heatmap cells of {row['kind']}")

    # Drive values: each series' extremes and count are those of the frames' drive values that are
    # quantities: numbers, and a register's own id only when its profile gives it a unit and no
    # role, bits or enum (a role's value is drawn under its shared id or as states and events).
    values = {}
    for f in frames:
        d = f.get("drive")
        if not d:
            continue
        not_drawn = NOT_QUANTITIES.get(d["family"], set())
        for vid, v in d.get("values", {}).items():
            if vid in ("running", "fault", "status_word", "control_word") or not isinstance(v.get("value"), (int, float)):
                continue
            if vid in not_drawn or ("raw" in v and "unit" not in v):
                continue
            values.setdefault((d["station"], vid), []).append(v["value"])
    series = {}
    for drive in data["drives"]:
        for sr in drive["series"]:
            series[(drive["addr"], sr["id"])] = sr
    check(set(series) == set(values), f"{name}: drive series {sorted(series)} vs {sorted(values)}")
    for key, vs in values.items():
        sr = series.get(key)
        if not sr:
            continue
        check(sr["values"] == len(vs), f"{name}: {key}: {sr['values']} values, JSON {len(vs)}")
        lo, hi = min(p[1] for p in sr["points"]), max(p[2] for p in sr["points"])
        check(abs(lo - min(vs)) <= 1e-3 * max(1, abs(min(vs))) and abs(hi - max(vs)) <= 1e-3 * max(1, abs(max(vs))),
              f"{name}: {key}: min/max {lo}/{hi}, JSON {min(vs)}/{max(vs)}")
    # Events: those of read --events, by drive and kind.
    ev = records(capture, "--events")
    want_events = {}
    for e in ev:
        if e["type"] == "event" and e["kind"] in ("command", "running", "direction", "setpoint", "fault", "warning"):
            want_events[(e["address"], e["kind"])] = want_events.get((e["address"], e["kind"]), 0) + 1
    got_events = {}
    for drive in data["drives"]:
        for e in drive["events"]:
            got_events[(drive["addr"], e[1])] = got_events.get((drive["addr"], e[1]), 0) + 1
    check(got_events == want_events, f"{name}: events {got_events} vs {want_events}")

    # State bands change at the frame whose event changed the state: each column's last state
    # (what holds until the next column drawn) is the state after the events before the column's
    # end, recomputed from --events (running: its `to`; a fault: the status word's or the code's).
    width = data["column_s"]
    colour = lambda bits: 4 if bits & 4 else 1 if bits & 1 else 2 if bits & 2 else 8
    bands_checked = 0
    for drive in data["drives"]:
        if drive["events_left_out"]:
            continue
        mine = [e for e in ev if e["type"] == "event" and e.get("address") == drive["addr"]
                and e["kind"] in ("running", "fault")]
        times = [e[0] for e in drive["events"] if e[1] in ("running", "fault")]
        check(len(times) == len(mine), f"{name}: drive {drive['addr']}: state events differ")
        after = []  # (time on the page's timeline, state bits after the event)
        running, fault_word, fault_code = None, False, False
        for t, e in zip(times, mine):
            if e["kind"] == "running":
                running = e["to"] == "running"
            elif "status word" in e["detail"]:
                fault_word = e["to"] != ""
            else:
                fault_code = e["to"] != ""
            bits = (4 if fault_word or fault_code else 0) | (0 if running is None else 1 if running else 2)
            after.append((t, bits or 8))
        for mid, bits, last in drive["states"]:
            end = mid + width / 2
            if any(abs(t - end) < 1e-6 for t, _ in after):
                continue  # an event on the column's edge: either side is right
            state = 8
            for t, b in after:
                if t < end:
                    state = b
            check(colour(last) == colour(state),
                  f"{name}: drive {drive['addr']}: the band after {mid:.3f} s is {colour(last)}, "
                  f"the events say {colour(state)}")
            bands_checked += 1
        # A transition is drawn at its event: the column holding it ends in the new state.
        for t, b in after:
            col = [c for c in drive["states"] if c[0] - width / 2 <= t < c[0] + width / 2]
            check(bool(col), f"{name}: drive {drive['addr']}: no state column at the event at {t}")
    check(bands_checked > 0 or not any(d["events"] for d in data["drives"]),
          f"{name}: no state band checked")

    # Load: the busy time of all columns adds up to bytes x character time.
    char_ms = data["captures"][0]["character_ms"]
    busy = sum(p[1] / 100 * data["column_s"] for l in data["load"] for p in l["points"])
    total_bytes = sum(len(f["hex"]) // 2 for f in frames) + sum(
        len(r["hex"]) // 2 for r in recs if r["type"] == "noise")
    check(abs(busy - total_bytes * char_ms / 1000) <= 0.002 * max(busy, 1e-3) + 1e-4,
          f"{name}: load adds up to {busy} s busy, bytes x character time {total_bytes * char_ms / 1000}")

    # Self-contained: nothing fetched when viewed.
    check(not re.search(r'<script[^>]+src=|<link[^>]+href=|<img[^>]+src=|@import|url\(', text),
          f"{name}: the page refers to something outside it")
    return data


def check_data():
    with tempfile.TemporaryDirectory() as tmp:
        for capture in ("session-e9/input.log", "seed-erman-e9/input.log", "session-vlt-aqua-modbus/input.log",
                        "session-eds1000/input.log", "dlt147-split-and-merged/input.pcap"):
            check_capture_data(os.path.join(root, "captures", capture), tmp)

        # Several captures: one timeline, the second (no wall-clock time) a second after the first.
        a, b = (os.path.join(root, "captures", c) for c in ("session-e9/input.log", "seed-erman-e9/input.log"))
        page = os.path.join(tmp, "two.html")
        out = run(["report", a, b, "-o", page])
        check(out.returncode == 0, f"two captures: exit {out.returncode} {out.stderr}")
        data, _ = page_data(page)
        c0, c1 = data["captures"]
        check(abs(c1["from_s"] - (c0["to_s"] + 1)) < 1e-6, f"two captures: second starts at {c1['from_s']}, first ends {c0['to_s']}")
        check(data["summary"]["frames"] == c0["frames"] + c1["frames"], "two captures: frames add up")
        check(data["to_s"] == c1["to_s"], "two captures: the timeline ends with the second")

        # Captures whose stations share addresses (the same Modbus station 2 twice, a Danfoss FC and
        # a Modbus station 1): each capture's stations, drives and findings are its own, their
        # counts those of `read -T json` of that file alone.
        copy = os.path.join(tmp, "again.log")
        shutil.copy(a, copy)
        files = [a, copy, os.path.join(root, "captures", "session-vlt-aqua-fc", "input.log"),
                 os.path.join(root, "captures", "session-vlt-aqua-modbus", "input.log")]
        page = os.path.join(tmp, "four.html")
        out = run(["report", *files, "-o", page])
        check(out.returncode == 0, f"four captures: exit {out.returncode} {out.stderr}")
        data, _ = page_data(page)
        for i, f in enumerate(files):
            recs = records(f)
            want = {}
            for r in recs:
                if r["type"] == "transaction" and r.get("addr") is not None and r["addr"] >= 0:
                    w = want.setdefault((r["channel"], r["protocol"], r["addr"]), [0, 0, 0])
                    w[0] += r.get("request_n") is not None
                    w[1] += r.get("response_n") is not None
                    w[2] += r["outcome"] == "timeout"
            got = {(l["channel"], l["protocol"], l["addr"]): [l["requests"], l["replies"], l["timeouts"]]
                   for l in data["latency"] if l["capture"] == i}
            check(got == want, f"four captures: capture {i + 1} stations {got}, its own JSON {want}")
            drives = {fr["addr"] for fr in recs if fr["type"] == "frame" and fr.get("drive")}
            charted = {d["addr"] for d in data["drives"] if d["capture"] == i}
            check(charted == drives, f"four captures: capture {i + 1} drives {charted}, its JSON {drives}")
            address = {r["n"]: r.get("addr", -1) for r in recs if r["type"] == "frame"}
            findings = {}
            for r in recs:
                if r["type"] == "anomaly":
                    station = address.get(r.get("frame"), -1) if r.get("frame") else -1
                    key = (r["kind"], -1 if station is None else station)
                    findings[key] = findings.get(key, 0) + 1
            rows = {(row["kind"], row["station"]): row["count"] for row in data["findings"]["rows"]
                    if row["capture"] == i}
            check(rows == findings, f"four captures: capture {i + 1} findings {rows}, its JSON {findings}")
        check(len([d for d in data["drives"] if d["addr"] == 2]) == 2,
              "four captures: the two files' drive 2 are not two drives")

        # Each capture diagnosed alone: a healthy session and one with gaps inside its frames get
        # what `drivetap diagnose -T json` says of each file alone, not one verdict over both.
        files = [a, os.path.join(root, "captures", "gap-inside-frame", "input.log"), copy]
        page = os.path.join(tmp, "diagnoses.html")
        out = run(["report", *files, "-o", page])
        check(out.returncode == 0, f"diagnoses: exit {out.returncode} {out.stderr}")
        data, _ = page_data(page)
        got = [(d["capture"], d["line"], [(v["id"], v["evidence"]) for v in d["verdicts"]]) for d in data["diagnosis"]]
        want = []
        for i, f in enumerate(files):
            alone = json.loads(run(["diagnose", f, "-T", "json"]).stdout)
            want.append((i, alone["line"], [(v["id"], v["evidence"]) for v in alone["verdicts"]]))
        check(got == want, f"diagnoses: the page's {got}, each file's diagnose {want}")
        check(got[0][2] != got[1][2], "diagnoses: the two files' verdicts are alike: the test proves nothing")

        # 63 232 stations (256 buses x 247 addresses): the page keeps the 64 busiest stations' rows and
        # sums the rest in one, the 48 busiest latency charts, the 16 busiest channels' load, the
        # first 128 drives; every request is still counted once.
        subprocess.run([sys.executable, os.path.join(root, "tests", "hostile", "make_inputs.py"), tmp,
                        "pcapng-63232-stations"], check=True)
        page = os.path.join(tmp, "stations.html")
        out = run(["report", os.path.join(tmp, "pcapng-63232-stations.pcapng"), "-o", page])
        check(out.returncode == 0, f"63232 stations: exit {out.returncode} {out.stderr}")
        data, text = page_data(page)
        rows = [r for r in data["captures"][0]["stats"] if r["stat"] == "stations"]
        others = [r for r in rows if r.get("other_stations")]
        check(len(rows) == 65 and len(others) == 1 and others[0]["other_stations"] == 63232 - 64,
              f"63232 stations: {len(rows)} rows, others {others[:1]}")
        check(sum(r["requests"] for r in rows) == 247 * 256 + 8 * 256, "63232 stations: requests lost or counted twice")
        busiest = [r for r in rows if not r.get("other_stations")]
        check(all(r["addr"] == 1 and r["requests"] == 9 for r in busiest[:64]),
              "63232 stations: the listed rows are not the busiest (address 1 of each bus, 9 polls)")
        check(data["latency_stations"] == 63232 and len(data["latency"]) == 48,
              f"63232 stations: latency {data['latency_stations']}, {len(data['latency'])} charts")
        check(data["load_channels"] == 256 and len(data["load"]) == 16,
              f"63232 stations: load {data['load_channels']} channels, {len(data['load'])} drawn")
        read_drives = {(f["channel"], f["addr"]) for f in records(os.path.join(tmp, "pcapng-63232-stations.pcapng"))
                       if f["type"] == "frame" and f.get("drive")}
        check(len(data["drives"]) == 128 and len(data["drives"]) + data["drives_left_out"] == len(read_drives),
              f"63232 stations: {len(data['drives'])} drives charted, {data['drives_left_out']} left out, "
              f"{len(read_drives)} read")
        check(len(text) < 2_000_000, f"63232 stations: a page of {len(text)} bytes")

        # Wall-clock time from a pcap.
        data = check_capture_data(os.path.join(root, "captures/dlt147-split-and-merged/input.pcap"), tmp)
        check(data["wall_clock"] and data["origin_s"] > 1e9, "a pcap: wall-clock times")

        # Bad input: read's one-line error and exit status, and nothing left in the directory.
        empty = os.path.join(tmp, "empty.log")
        open(empty, "w").close()
        text = os.path.join(tmp, "text.txt")
        open(text, "w").write("hello\n")
        out_dir = os.path.join(tmp, "out")
        os.mkdir(out_dir)
        bad = [os.path.join(tmp, "missing.pcapng"), empty, text]
        for reg in ("byte-log-time-max-overflow/input.log", "pcapng-time-max-overflow/input.pcapng",
                    "vcd-timescale-1s-sigfpe/input.vcd", "sigrok-1hz-sigfpe/input.sr"):
            bad.append(os.path.join(root, "captures/regressions", reg))
        for path in bad:
            read = run(["read", path])
            rep = run(["report", path, "-o", os.path.join(out_dir, "r.html")])
            read_last = read.stderr.strip().splitlines()[-1]
            rep_last = rep.stderr.strip().splitlines()[-1] if rep.stderr.strip() else ""
            check(rep.returncode == read.returncode and rep.returncode != 0,
                  f"{path}: report exit {rep.returncode}, read {read.returncode}")
            check(rep_last == read_last and rep_last.startswith("drivetap: "),
                  f"{path}: report says {rep_last!r}, read {read_last!r}")
            check(os.listdir(out_dir) == [], f"{path}: left behind {os.listdir(out_dir)}")
        # A good capture after a bad one: still no page (a page of part of the captures would pass
        # for all of them).
        rep = run(["report", a, bad[3], "-o", os.path.join(out_dir, "r.html")])
        check(rep.returncode == 1 and os.listdir(out_dir) == [], "a bad second capture: no page")
        # Usage errors: exit 2, one line.
        for args, pattern in (([a], "give the page's file"), ([a, "-o", os.path.join(tmp, "no/dir/r.html")], "-o .*cannot create"),
                              ([a, "-T", "json", "-o", "x.html"], "-T"), ([a, "-Y", "addr ==", "-o", "x.html"], "-Y"),
                              ([a, "-o", a], "same file")):
            rep = run(["report", *args])
            check(rep.returncode == 2 and len(rep.stderr.strip().splitlines()) == 1 and re.search(pattern, rep.stderr),
                  f"report {args}: exit {rep.returncode}, {rep.stderr!r}")
        # An existing page is replaced whole, only at the end.
        target = os.path.join(out_dir, "keep.html")
        open(target, "w").write("old")
        run(["report", bad[3], "-o", target])
        check(open(target).read() == "old" and os.listdir(out_dir) == ["keep.html"], "a failed run kept the old page")
        os.unlink(target)
        # SIGTERM while reading (a FIFO that delivers part of a capture and waits): exit 130,
        # nothing left.
        big = os.path.join(tmp, "big.log")
        subprocess.run([drivetap, "generate", "--frames", "20000", "-o", big], capture_output=True, check=True)
        fifo = os.path.join(tmp, "fifo.log")
        os.mkfifo(fifo)
        proc = subprocess.Popen([drivetap, "report", fifo, "-o", os.path.join(out_dir, "r.html")],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        writer = open(fifo, "wb")
        content = open(big, "rb").read()
        writer.write(content[:len(content) // 2])
        writer.flush()
        # (The write returned: drivetap has read all but a pipe's worth; it is reading, its signal
        # handlers set, no fixed wait needed.)
        proc.send_signal(signal.SIGTERM)
        try:
            _, err = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
        writer.close()
        check(proc.returncode == 130 and "interrupted" in err, f"SIGTERM: exit {proc.returncode}, {err!r}")
        check(os.listdir(out_dir) == [], f"SIGTERM: left behind {os.listdir(out_dir)}")


# --- browser ---

def png_pixels(path):
    """Width, height and rows of RGB(A) bytes of a PNG (8-bit RGB or RGBA, not interlaced)."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width = 8, [], 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and colour in (2, 6) and interlace == 0, "unexpected PNG format"
            bpp = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat.append(body)
        pos += 12 + length
    raw = zlib.decompress(b"".join(idat))
    stride = width * bpp
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if f == 1:
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 255
        elif f == 2:
            line = bytearray((a + b) & 255 for a, b in zip(line, prev))
        elif f == 3:
            for i in range(stride):
                left = line[i - bpp] if i >= bpp else 0
                line[i] = (line[i] + ((left + prev[i]) >> 1)) & 255
        elif f == 4:
            for i in range(stride):
                a = line[i - bpp] if i >= bpp else 0
                b, c = prev[i], prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return width, height, bpp, rows


def chromium_binary():
    for name in ("chromium", "chromium-browser"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def chromium(args, profile):
    return subprocess.run([chromium_binary(), "--headless", "--disable-gpu", "--no-sandbox", "--hide-scrollbars",
                           "--no-first-run", f"--user-data-dir={profile}", "--force-device-scale-factor=1",
                           "--virtual-time-budget=10000", *args],
                          capture_output=True, text=True, timeout=180)


def check_browser():
    if not chromium_binary():
        if os.environ.get("DRIVETAP_REQUIRE_CHROMIUM") == "1":
            print("FAIL: chromium not installed (scripts/install-deps.sh installs it)")
            sys.exit(1)
        print("SKIP: chromium not installed")
        sys.exit(77)
    with tempfile.TemporaryDirectory() as tmp:
        # A capture whose file and channel are named to end the page's script ("<!--<script>" once
        # made the data element swallow it: no chart drawn, no error shown).
        hostile = os.path.join(tmp, "<!--<script>x.log")
        with open(os.path.join(root, "captures", "session-e9", "input.log")) as f, open(hostile, "w") as h:
            for line in f:
                h.write(line if line.startswith("#") else line.replace(" bus ", " <!--<script></script>& ", 1))
        # The third route: a drive profile's name (the e9 profile under a name that ends scripts).
        profile = os.path.join(tmp, "e9-hostile.toml")
        with open(os.path.join(root, "dissectors", "profiles", "e9.toml")) as f, open(profile, "w") as copy:
            named = False
            for line in f:
                if not named and line.startswith("name ="):
                    line = 'name = "E-9 <!--<script></script>&"\n'
                    named = True
                copy.write(line)
        for capture, expected, extra in (
                ("session-e9/input.log", ["drive-", "latency-", "load", "gaps-", "findings-heatmap"], []),
                ("seed-danfoss-fc/input.log", ["latency-", "load", "gaps-"], []),  # (no finding: its last request is pending)
                (hostile, ["drive-", "latency-", "load", "gaps-", "findings-heatmap"], []),
                ("session-e9/input.log", ["drive-", "latency-", "load", "gaps-", "findings-heatmap"],
                 ["--profile", profile, "--drive", "2=e9"])):
            page = os.path.join(tmp, "page.html")
            out = run(["report", os.path.join(root, "captures", capture), "-o", page, *extra])
            if extra:
                check("E-9 <!--<script></script>&" in page_data(page)[0]["drives"][0]["name"],
                      f"{capture} {extra}: the profile's name is not the page's")
            check(out.returncode == 0, f"{capture}: report exit {out.returncode}")
            # (The same width as the screenshot below: the chart regions are where it shows them.)
            dom = chromium(["--dump-dom", "--window-size=1400,1000", "file://" + page],
                           os.path.join(tmp, "profile")).stdout
            body = re.search(r"<body([^>]*)>", dom)
            check(body and 'data-ok="1"' in body.group(1), f"{capture}: the page did not finish drawing")
            check(body and "data-errors" not in body.group(1), f"{capture}: script errors")
            errors = re.search(r'<pre id="errors">(.*?)</pre>', dom, re.S)
            check(errors is not None and errors.group(1).strip() == "", f"{capture}: {errors and errors.group(1)}")
            canvases = re.findall(r"<canvas([^>]*)>", dom)
            count = re.search(r'data-charts="(\d+)"', body.group(1) if body else "")
            check(count and int(count.group(1)) == len(canvases) and canvases, f"{capture}: {len(canvases)} canvases")
            names = [re.search(r'data-chart="([^"]+)"', c).group(1) for c in canvases]
            for prefix in expected:
                check(any(n.startswith(prefix) for n in names), f"{capture}: no chart {prefix}* among {names}")
            rects = {}
            for c in canvases:
                name = re.search(r'data-chart="([^"]+)"', c).group(1)
                coloured = re.search(r'data-plot-coloured="(\d+)"', c)
                check(coloured and int(coloured.group(1)) >= 50, f"{capture}: chart {name} is blank ({coloured and coloured.group(1)} coloured pixels)")
                rect = re.search(r'data-rect="([\d.,-]+)"', c)
                if rect:
                    rects[name] = [float(v) for v in rect.group(1).split(",")]
            height = re.search(r'data-height="(\d+)"', body.group(1) if body else "")
            # The screenshot: every chart's region holds coloured pixels.
            shot = os.path.join(tmp, "shot.png")
            h = int(height.group(1)) if height else 4000
            chromium([f"--screenshot={shot}", f"--window-size=1400,{h}", "file://" + page], os.path.join(tmp, "profile"))
            check(os.path.exists(shot), f"{capture}: no screenshot")
            if not os.path.exists(shot):
                continue
            width, sh, bpp, rows = png_pixels(shot)
            check(rects.keys() == set(names), f"{capture}: chart regions missing")
            for name, (x, y, w, hh) in rects.items():
                coloured = 0
                for yy in range(int(y), min(sh, int(y + hh))):
                    row = rows[yy]
                    for xx in range(int(x), min(width, int(x + w))):
                        r, g, b = row[xx * bpp], row[xx * bpp + 1], row[xx * bpp + 2]
                        if max(r, g, b) - min(r, g, b) > 40:
                            coloured += 1
                check(coloured >= 50, f"{capture}: chart {name} blank in the screenshot ({coloured} coloured pixels)")
        # 63 232 stations: the page draws (before, 43 MB of it took Chromium 130 s), its stations
        # table holds 65 rows, the last the other stations' sum.
        subprocess.run([sys.executable, os.path.join(root, "tests", "hostile", "make_inputs.py"), tmp,
                        "pcapng-63232-stations"], check=True)
        page = os.path.join(tmp, "stations.html")
        run(["report", os.path.join(tmp, "pcapng-63232-stations.pcapng"), "-o", page])
        dom = chromium(["--dump-dom", "--window-size=1400,1000", "file://" + page], os.path.join(tmp, "profile")).stdout
        body = re.search(r"<body([^>]*)>", dom)
        check(body and 'data-ok="1"' in body.group(1) and "data-errors" not in body.group(1),
              "63232 stations: the page did not finish drawing")
        table = re.search(r'<table[^>]*data-table="stations"[^>]*>(.*?)</table>', dom, re.S)
        rows = re.findall(r"<tr>", table.group(1)) if table else []
        check(table and len(rows) == 66 and "(63168 other stations)" in table.group(1),
              f"63232 stations: the stations table has {len(rows)} rows (a head and 65)")
        check("the 48 busiest of 63232 stations" in dom and "the 16 busiest of 256 channels" in dom and
              "128 more not charted" in dom, "63232 stations: the headings do not say what is left out")
        if screenshot_out:
            # The README's picture: the top of the session-e9 page, small.
            page = os.path.join(tmp, "shot.html")
            run(["report", "captures/session-e9/input.log", "-o", page], cwd=root)
            chromium([f"--screenshot={screenshot_out}", "--window-size=1000,1250", "file://" + page], os.path.join(tmp, "profile"))
            print("wrote", screenshot_out, os.path.getsize(screenshot_out), "bytes")


if part == "data":
    check_data()
elif part == "browser":
    check_browser()
else:
    sys.exit(f"usage: {sys.argv[0]} DRIVETAP SOURCE_DIR data|browser")
if failures:
    print(f"{len(failures)} failures")
    sys.exit(1)
print("ok")
