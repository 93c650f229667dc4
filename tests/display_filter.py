#!/usr/bin/env python3
# Display filters (-Y) and -T fields checked against an independent evaluation: this script
# implements the filter language (docs/reference.md "Display filters") over the records of
# `drivetap read -T json` and compares the frames it selects with `drivetap read -Y F -T json`;
# it parses `-T fields -E separator=, -E quote=d` output with the csv module and compares it with
# the JSON records; bad filters must exit 2 with one line naming the column; a filtered --stats
# summary must count what the unfiltered one counts. A filter naming a finding reported after its
# frame (LATER) is also evaluated against each such finding's own record (late_records()).
# Usage: display_filter.py DRIVETAP SOURCE_DIR {filters|stats|fields}
import csv
import glob
import io
import json
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cases import Cases  # noqa: E402

DRIVETAP, SOURCE = sys.argv[1], sys.argv[2]
FAILURES = []

# Findings the pipeline reports after their frame was handed on: not the frame's for a filter;
# records of their own for a filter that names one.
LATER = {"unanswered_request", "unsolicited_response", "packet_split_frame", "packet_merged_frames"}
# A drive's timing-rule findings may come late too: held until the binder is sure of the family
# (the JSON record says "held").
MAY_BE_LATER = LATER | {"timing_rule"}


def later(r):
    return r["kind"] in LATER or r.get("held", False)


def fail(msg):
    FAILURES.append(msg)
    print("FAIL:", msg)


def run(args, stdin=None):
    p = subprocess.run([DRIVETAP] + args, capture_output=True, text=True, input=stdin)
    return p.returncode, p.stdout, p.stderr


# ---- the records: each frame/noise record with its values by name --------------------------


def records_of(json_text):
    out = []
    for line in json_text.splitlines():
        r = json.loads(line)
        if r["type"] in ("frame", "noise"):
            r["_findings"] = []
            out.append(r)
        elif r["type"] == "anomaly" and out and r["frame"] == out[-1]["n"] and not later(r):
            out[-1]["_findings"].append(r)
    return out


def late_records(lines):
    """Each late finding's own record: the finding, its n, t and channel, and its frame's protocol,
    addr and fc (from the frame record it names; none for noise)."""
    frames = {r["n"]: r for r in lines if r["type"] in ("frame", "noise")}
    out = []
    for i, r in enumerate(lines):
        if r["type"] != "anomaly" or not later(r):
            continue
        rec = {"type": "anomaly", "t": r["t"], "channel": r["channel"], "_findings": [r],
               "_line": i}
        if r["frame"] is not None:
            rec["n"] = r["frame"]
        f = frames.get(r["frame"])
        if f is not None and f["type"] == "frame":
            for k in ("protocol", "addr", "fc"):
                rec[k] = f.get(k)
        out.append(rec)
    return out


def names_later(expr):
    if expr[0] in ("and", "or"):
        return names_later(expr[1]) or names_later(expr[2])
    if expr[0] == "not":
        return names_later(expr[1])
    return expr[1] in MAY_BE_LATER


def values(rec, name):
    """The values of `name` in a record: a list of numbers (int/float) and strings."""
    if name == "finding":  # each finding's typed id (where it has one) and kind
        return [v for a in rec["_findings"] for v in ([a["finding"]] if "finding" in a else []) +
                [a["kind"]]]
    if name == "drive" or name.startswith("drive."):
        # The JSON `drive` object: `drive` is its text, `drive.<id>` its station, family or values.
        d = rec.get("drive")
        if not d:
            return []
        if name == "drive":
            return [d["text"]] if d["text"] else []
        key = name[len("drive."):]
        if key in ("station", "family"):
            return [d[key]] if key in d else []
        v = d["values"].get(key)
        return [] if v is None else [v["value"]]
    kinds = [a for a in rec["_findings"] if a["kind"] == name or a.get("finding") == name]
    if kinds:
        return [a["detail"] for a in kinds]
    if name in rec and not name.startswith("_") and name != "fields":
        v = rec[name]
        return [] if v is None else [v]
    v = rec.get("fields", {}).get(name)
    if v is None:
        return []
    return v if isinstance(v, list) else [v]


# ---- the filter language, independently -----------------------------------------------------

TOKEN = re.compile(
    r"\s*(?:(?P<str>\"(?:[^\"\\]|\\.)*\")|(?P<num>-?(?:0[xX][0-9a-fA-F]+|\d+(?:\.\d+(?!\.))?))"
    r"|(?P<op>==|!=|<=|>=|&&|\|\||\.\.|[<>!(){},])|(?P<word>[A-Za-z_][A-Za-z0-9_.\-]*))"
)
WORD_OPS = {"eq": "==", "ne": "!=", "lt": "<", "gt": ">", "le": "<=", "ge": ">=",
            "and": "&&", "or": "||", "not": "!"}


def tokens(text):
    pos, out = 0, []
    while pos < len(text):
        m = TOKEN.match(text, pos)
        if not m or m.end() == pos:
            if text[pos:].strip() == "":
                break
            raise ValueError("lex error at %d" % pos)
        pos = m.end()
        if m.group("str"):
            s = m.group("str")[1:-1]
            out.append(("str", re.sub(r"\\(.)", r"\1", s)))
        elif m.group("num"):
            t = m.group("num")
            neg = t.startswith("-")
            t = t.lstrip("-")
            v = int(t, 16) if t.lower().startswith("0x") else (float(t) if "." in t else int(t))
            out.append(("num", -v if neg else v))
        elif m.group("op"):
            out.append(("op", m.group("op")))
        else:
            w = m.group("word")
            out.append(("op", WORD_OPS[w]) if w in WORD_OPS else ("word", w))
    out.append(("end", None))
    return out


def parse(text):
    toks, i = tokens(text), [0]

    def peek():
        return toks[i[0]]

    def take():
        t = toks[i[0]]
        i[0] += 1
        return t

    def literal():
        k, v = take()
        if k == "num":
            return ("num", v)
        if k in ("str", "word"):
            return ("str", v)
        raise ValueError("value expected")

    def primary():
        if peek() == ("op", "("):
            take()
            e = orexpr()
            assert take() == ("op", ")")
            return e
        k, name = take()
        assert k == "word"
        t = peek()
        if t[0] == "op" and t[1] in ("==", "!=", "<", ">", "<=", ">="):
            take()
            return ("cmp", name, t[1], literal())
        if t == ("word", "contains"):
            take()
            return ("contains", name, literal()[1])
        neg = False
        if t == ("op", "!"):
            take()
            neg = True
            t = peek()
        if t == ("word", "in"):
            take()
            assert take() == ("op", "{")
            members = []
            while peek() != ("op", "}"):
                lo = literal()
                if peek() == ("op", ".."):
                    take()
                    hi = literal()
                    members.append(("range", lo[1], hi[1]))
                else:
                    members.append(lo)
                if peek() == ("op", ","):
                    take()
            take()
            e = ("in", name, members)
            return ("not", e) if neg else e
        return ("exists", name)

    def notexpr():
        if peek() == ("op", "!"):
            take()
            return ("not", notexpr())
        return primary()

    def andexpr():
        e = notexpr()
        while peek() == ("op", "&&"):
            take()
            e = ("and", e, notexpr())
        return e

    def orexpr():
        e = andexpr()
        while peek() == ("op", "||"):
            take()
            e = ("or", e, andexpr())
        return e

    e = orexpr()
    assert peek()[0] == "end"
    return e


def is_num(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def same_type(v, lit):
    return is_num(v) == (lit[0] == "num")


def evaluate(e, rec):
    op = e[0]
    if op == "and":
        return evaluate(e[1], rec) and evaluate(e[2], rec)
    if op == "or":
        return evaluate(e[1], rec) or evaluate(e[2], rec)
    if op == "not":
        return not evaluate(e[1], rec)
    vals = values(rec, e[1])
    if op == "exists":
        return len(vals) > 0
    if op == "contains":
        return any(isinstance(v, str) and e[2] in v for v in vals)
    if op == "in":
        def member(v, m):
            if m[0] == "range":
                return is_num(v) and m[1] <= v <= m[2]
            return same_type(v, m) and v == m[1]
        return any(member(v, m) for v in vals for m in e[2])
    _, _, rel, lit = e
    eq = [v for v in vals if same_type(v, lit) and v == lit[1]]
    if rel == "==":
        return len(eq) > 0
    if rel == "!=":
        return len(vals) > 0 and not eq
    cmp = {"<": lambda a, b: a < b, ">": lambda a, b: a > b,
           "<=": lambda a, b: a <= b, ">=": lambda a, b: a >= b}[rel]
    return any(same_type(v, lit) and cmp(v, lit[1]) for v in vals)


# ---- the inputs ----------------------------------------------------------------------------


def inputs(tmp):
    out = []
    for d in sorted(glob.glob(os.path.join(SOURCE, "captures", "*", ""))):
        found = [f for f in glob.glob(d + "input.*") if not f.endswith(".hex")]
        if not found:
            continue
        args = []
        if os.path.exists(d + "args"):
            args = open(d + "args").read().split()
        out.append((args, found[0]))
    for seed, mix in ((3, "all"), (5, "modbus-rtu")):
        path = os.path.join(tmp, "gen%d.pcapng" % seed)
        code, _, err = run(["generate", "--frames", "3000", "--seed", str(seed), "--mix", mix,
                            "-w", path])
        if code != 0:
            fail("generate: " + err)
            continue
        out.append(([], path))
    return out


STATIC_FILTERS = [
    "addr == 2", "addr != 2", "addr eq 1 or addr eq 3", "addr in {1 2 3}", "addr in {1..5}",
    "addr in {2, 4..6}", "addr not in {1 2}", "fc == 0x03", "fc >= 16", "fc lt 5", "fc le 3",
    "checksum == \"bad\"", "checksum == good", "checksum_bad", "addr == 2 && checksum_bad",
    "!checksum_bad", "not (addr == 1 or addr == 2)", "dir == \"response\" and latency_ms > 5",
    "latency_ms <= 12.5", "gap_before_ms > 50.0", "t > 0.5 && t < 2", "t_end >= 1.25",
    "summary contains \"exception\"", "hex contains \"0203\"", "drive contains \"fault\"",
    "drive", "finding == \"noise\"", "noise", "protocol == \"modbus-rtu\"",
    "protocol != modbus-rtu", "type == \"noise\"", "request_n", "exception", "exception == 2",
    "n in {1 3 5..9}", "addr == 1 || addr == 2 && fc == 3", "(addr == 1 || addr == 2) && fc == 3",
    "!addr == 1", "! ! checksum", "finding", "finding contains \"gap\"", "short_interframe_gap",
    "malformed || implausible", "channel == \"bus\"", "close == content", "checksum_stated",
    "n > 10 && n <= 40", "n >= -1", "checksum < \"good\"",
    # findings reported after their frame: their own records
    "unanswered_request", "unanswered_request && addr == 2", "unsolicited_response",
    "unanswered_request || unsolicited_response && fc == 3", "packet_split_frame",
    "packet_merged_frames || addr == 1", "!unanswered_request && n < 20",
    "unanswered_request contains \"function\" && protocol == \"modbus-rtu\"",
    "finding == \"unanswered_request\" || unanswered_request && t > 1",
]


def finding_filters(recs):
    """Filters on the typed finding ids the records' findings carry (JSON `finding`): bare, on a
    word of their detail, in `finding`, and with a key."""
    out, seen = [], set()
    for r in recs:
        for a in r["_findings"]:
            fid = a.get("finding")
            if not fid or fid in seen:
                continue
            seen.add(fid)
            word = a["detail"].split()[0] if a["detail"].split() else ""
            out += [fid, "%s contains %s" % (fid, json.dumps(word)), "finding == \"%s\"" % fid,
                    "!%s && addr == %d" % (fid, r.get("addr") if r.get("addr") is not None else 1)]
    return out


def tree_filters(recs):
    """Filters on field-tree ids seen in the records, values taken from them (generic: no id is
    named here)."""
    out, seen = [], set()
    for r in recs:
        for k, v in r.get("fields", {}).items():
            if k in seen:
                continue
            if isinstance(v, list) and len(v) > 1:
                seen.add(k)
                out += ["%s == %d" % (k, v[1]), "%s != %d" % (k, v[1]), "%s > %d" % (k, v[-1])]
            elif isinstance(v, int) and not isinstance(v, list):
                seen.add(k)
                out += [k, "%s == %d" % (k, v), "%s >= %d && addr != 1" % (k, v)]
            elif isinstance(v, str) and v:
                seen.add(k)
                out += ["%s == \"%s\"" % (k, v), "%s contains \"%s\"" % (k, v[:2])]
    return out[:45]


def drive_ids(recs):
    """The `drive.*` value ids the JSON records' drive objects carry, in order seen."""
    ids = []
    for r in recs:
        for k in (r.get("drive") or {}).get("values", {}):
            if k not in ids:
                ids.append(k)
    return ids


def drive_filters(recs):
    """Filters on the drive values seen in the records, values taken from them."""
    out, seen = [], set()
    for r in recs:
        for k, v in (r.get("drive") or {}).get("values", {}).items():
            if k in seen:
                continue
            seen.add(k)
            v = v["value"]
            if isinstance(v, str):
                out += ["drive.%s == \"%s\"" % (k, v)]
            else:
                out += ["drive.%s" % k, "drive.%s == %s" % (k, v), "drive.%s > %s" % (k, v)]
    if "running" in seen:
        out += ["drive.running == 1", "drive.running == 0 && drive.direction == \"forward\""]
    return out[:30]


def check_drive_fields(args, path, recs):
    """-T fields of the drive values against the JSON drive objects."""
    ids = drive_ids(recs)
    if not ids:
        return
    names = ["n"] + ["drive." + i for i in ["station", "family"] + ids]
    cmd = ["read"] + args + ["-T", "fields", "-E", "separator=,", "-E", "quote=d", "-E",
                             "occurrence=f"]
    for n in names:
        cmd += ["-e", n]
    code, out, err = run(cmd + [path])
    if code != 0:
        fail("%s -T fields drive.*: exit %d %s" % (path, code, err))
        return
    rows = list(csv.reader(io.StringIO(out)))
    if len(rows) != len(recs):
        fail("%s -T fields drive.*: %d lines for %d records" % (path, len(rows), len(recs)))
        return
    for row, r in zip(rows, recs):
        for name, cell in zip(names, row):
            want = values(r, name)
            if name in ("drive.station", "drive.family") and not r.get("drive"):
                continue  # a frame of a bound drive that says nothing: no JSON drive object
            got = [cell] if cell != "" else []
            ok = len(got) == len(want) and all(
                (float(g) == float(w)) if is_num(w) else g == str(w) for g, w in zip(got, want))
            if not ok:
                fail("%s -T fields n=%s %s: %r, JSON %r" % (path, r["n"], name, cell, want))
                return


def shown_besides_frames(expr, lines, picked):
    """The anomaly and transaction records -Y shows, in order: those of the selected frames; with a
    filter naming a late finding, each late finding whose own record it selects too, after the
    transaction that reported it (a timeout, an unsolicited reply)."""
    late = set()
    if names_later(expr):
        late = {r["_line"] for r in late_records(lines) if evaluate(expr, r)}
    out = []
    for i, r in enumerate(lines):
        if r["type"] == "anomaly" and (r["frame"] in picked or i in late):
            out.append(r)
        elif r["type"] == "transaction":
            if r["request_n"] in picked or r["response_n"] in picked:
                out.append(r)
            elif i + 1 in late and lines[i + 1]["frame"] in (r["request_n"], r["response_n"]):
                out.append(r)
    return out


def check_filters(args, path, recs, events, lines):
    filters = STATIC_FILTERS + finding_filters(recs) + tree_filters(recs) + drive_filters(recs)
    for f in filters:
        expr = parse(f)
        want = [r["n"] for r in recs if evaluate(expr, r)]
        code, out, err = run(["read"] + args + ["-T", "json", "-Y", f, path])
        if code != 0:
            fail("%s -Y %r: exit %d: %s" % (path, f, code, err.strip()))
            continue
        got = [json.loads(l) for l in out.splitlines()]
        got_n = [r["n"] for r in got if r["type"] in ("frame", "noise")]
        if got_n != want:
            fail("%s -Y %r: selected %s..., expected %s..." % (path, f, got_n[:8], want[:8]))
        # What belongs to the selected frames (and late findings selected), and nothing else.
        picked = set(got_n)
        for r in got:
            if r["type"] == "anomaly" and r["frame"] not in picked and \
                    not (names_later(expr) and later(r)):
                fail("%s -Y %r: anomaly of unselected frame %s" % (path, f, r["frame"]))
            if r["type"] == "transaction" and r["request_n"] not in picked and \
                    r["response_n"] not in picked and not names_later(expr):
                fail("%s -Y %r: transaction of unselected frames" % (path, f))
        got_besides = [r for r in got if r["type"] in ("anomaly", "transaction")]
        want_besides = shown_besides_frames(expr, lines, set(want))
        if got_besides != want_besides:
            fail("%s -Y %r: %d findings and transactions, expected %d" %
                 (path, f, len(got_besides), len(want_besides)))
        # The events read from the selected frames, every one of them.
        want_events = [e for e in events if e.get("frame") in set(want)]
        got_events = [r for r in got if r["type"] == "event"]
        if got_events != want_events:
            fail("%s -Y %r: %d events, expected %d" % (path, f, len(got_events), len(want_events)))
        summary = [r for r in got if r["type"] == "summary"]
        if not summary or summary[-1].get("filter", {}).get("matched") != len(want):
            fail("%s -Y %r: summary's filter count wrong: %s" % (path, f, summary[-1:]))
    return len(filters)


# Filters --stats -Y judges on a telegram's head where it can (the tree ids the head holds).
STATS_FILTERS = ["mbrtu.unit_id == 2 && modbus.func_code == 3", "modbus.func_code == 16",
                 "mbascii.unit_id || danfoss_fc.addr == 1", "mbrtu.unit_id", "!mbrtu.unit_id",
                 "modbus.func_code != 3 && addr <= 2"]


def every_tree_id_filters(recs):
    """For every field-tree id of the records: its presence and one of its values, which --stats
    -Y reads of each telegram's tree of the filter's ids alone (no head holds most ids)."""
    out, seen = [], set()
    for r in recs:
        for k, v in r.get("fields", {}).items():
            if k in seen:
                continue
            seen.add(k)
            v = v[-1] if isinstance(v, list) else v
            out += [k, "%s == %s" % (k, json.dumps(v, ensure_ascii=False))]
    return out


def check_stats(args, path, recs):
    # The count: what the JSON records select. Texts and typed finding ids are read of the
    # telegrams --stats -Y decodes for the filter, the others of their heads.
    for f in STATS_FILTERS + decoding_filters(recs) + every_tree_id_filters(recs):
        want = sum(1 for r in recs if evaluate(parse(f), r))
        code, out, err = run(["read"] + args + ["--stats", "-T", "json", "-Y", f, path])
        got = json.loads(out.splitlines()[-1]).get("filter", {}).get("matched") if code == 0 else None
        if got != want:
            fail("%s: --stats -Y %r matched %s, the JSON records %d (%s)" % (path, f, got, want, err.strip()))
    f = "addr == 2 && checksum_bad"
    _, plain, _ = run(["read"] + args + ["--stats", "-T", "json", path])
    code, filtered, err = run(["read"] + args + ["--stats", "-T", "json", "-Y", f, path])
    a, b = json.loads(plain.splitlines()[-1]), json.loads(filtered.splitlines()[-1])
    filt = b.pop("filter", None)
    if code != 0 or a != b or filt is None or filt["text"] != f:
        fail("%s: --stats -Y counts differ from --stats: %s / %s" % (path, a, b))
    _, text, _ = run(["read"] + args + ["--stats", "-Y", f, path])
    if "filter:       -Y 'addr == 2 && checksum_bad' matched" not in text:
        fail("%s: text summary has no filter line" % path)


def decoding_filters(recs):
    """Filters on findings (their presence the head's, their text and typed ids read of the
    telegram decoded) and on what no head holds (texts, stated checksums)."""
    kinds = ["malformed || implausible", "short_interframe_gap", "checksum_bad && addr == 1",
             "malformed contains \"byte\"", "!implausible && n > 3"]  # (presence, then text)
    return kinds + [f for f in STATIC_FILTERS + finding_filters(recs)
                    if re.search(r"summary|drive|finding|checksum_stated|[a-z_]\.[a-z_]", f)
                    and not names_later(parse(f))]


def check_fields_selected(args, path, recs):
    """-T fields -e n -Y of the filters on texts and findings: the frames the JSON records select.
    (-T fields asks the pipeline for no texts of its own: the filter's must still be there, for
    the telegrams it decodes itself and for those the pipeline decodes.)"""
    for f in decoding_filters(recs):
        want = [r["n"] for r in recs if evaluate(parse(f), r)]
        code, out, err = run(["read"] + args + ["-T", "fields", "-e", "n", "-Y", f, path])
        got = [int(l) for l in out.split()] if code == 0 else None
        if got != want:
            fail("%s -T fields -Y %r: selected %s..., expected %s... (%s)" %
                 (path, f, (got or [])[:8], want[:8], err.strip()))


def check_fields(args, path, recs):
    tree_ids = []
    for r in recs:
        for k in r.get("fields", {}):
            if k not in tree_ids:
                tree_ids.append(k)
    names = ["n", "t", "t_end", "channel", "dir", "protocol", "addr", "fc", "hex", "checksum",
             "exception", "drive", "latency_ms", "request_n", "gap_before_ms", "close", "summary",
             "finding"] + tree_ids[:12]
    cmd = ["read"] + args + ["-T", "fields", "-E", "separator=,", "-E", "quote=d", "-E",
                             "header=y", "-E", "aggregator=;"]
    for n in names:
        cmd += ["-e", n]
    code, out, err = run(cmd + [path])
    if code != 0:
        fail("%s -T fields: exit %d %s" % (path, code, err))
        return
    rows = list(csv.reader(io.StringIO(out)))
    if not rows:
        fail("%s -T fields: no output" % path)
        return
    if rows[0] != names:
        fail("%s -T fields header %s" % (path, rows[0]))
    if len(rows) - 1 != len(recs):
        fail("%s -T fields: %d lines for %d records" % (path, len(rows) - 1, len(recs)))
        return
    for row, r in zip(rows[1:], recs):
        for name, cell in zip(names, row):
            want = values(r, name)
            got = cell.split(";") if cell != "" else []
            ok = len(got) == len(want) and all(
                (float(g) == float(w)) if is_num(w) else g == w for g, w in zip(got, want))
            if name in ("summary", "drive") and len(want) == 1:
                ok = cell == want[0]  # may hold the aggregator
            if not ok:
                fail("%s -T fields n=%s %s: %r, JSON %r" % (path, r["n"], name, cell, want))
                return
    # occurrence=f / l on a multi-valued id, tab separator, no quotes
    multi = [k for r in recs for k, v in r.get("fields", {}).items() if isinstance(v, list)]
    if multi:
        k = multi[0]
        for occ, pick in (("f", 0), ("l", -1)):
            _, out, _ = run(["read"] + args + ["-T", "fields", "-e", "n", "-e", k, "-E",
                                              "occurrence=" + occ, path])
            for line, r in zip(out.splitlines(), recs):
                n, cell = line.split("\t")
                v = r.get("fields", {}).get(k)
                want = "" if v is None else str(v[pick] if isinstance(v, list) else v)
                if cell != want:
                    fail("%s occurrence=%s %s n=%s: %r, want %r" % (path, occ, k, n, cell, want))
                    break


BAD = [
    ("addr == && x", 9), ("addr ==", 8), ("(addr == 1", 11), ("nosuchfield == 1", 1),
    ("addr = 1", 6), ("addr == 1 &", 11), ("addr in {1 2", 13), ("summary contains 3", 18),
    ("addr == 1)", 10), ("\"unterminated", 1), ("addr == 0xZZ", 9),
    ("addr in {}", 9), ("addr in {\"a\"..3}", 13), ("addr matches \"x\"", 6),
    ("&& addr", 1), ("addr == 1 or", 13),
]


def check_bad(path):
    for f, column in BAD:
        code, out, err = run(["read", "-Y", f, path])
        lines = err.strip().splitlines()
        if code != 2 or len(lines) != 1 or not lines[0].startswith("drivetap: -Y: ") or \
                ("at column %d:" % column) not in lines[0] or out:
            fail("-Y %r: exit %d, stderr %r (want exit 2, one line, column %d)" %
                 (f, code, err, column))


PARTS = ("filters", "stats", "fields")


def main():
    """One part of the suite (ctest runs each as a test of its own): `filters` (-Y against the
    JSON records), `stats` (--stats -Y counts) or `fields` (-T fields against the JSON records,
    bad filters, the README's examples). Each input of a part is a case (tests/cases.py)."""
    part = sys.argv[3] if len(sys.argv) > 3 else None
    if part not in PARTS:
        print("usage: display_filter.py DRIVETAP SOURCE_DIR {%s}" % "|".join(PARTS))
        sys.exit(2)
    cases = Cases("display_filter." + part)
    total = 0
    with tempfile.TemporaryDirectory() as tmp:
        for args, path in inputs(tmp):
            if not cases.begin(case_name(path)):
                continue
            code, out, err = run(["read"] + args + ["-T", "json", path])
            if code != 0:
                continue  # (inputs that are refused are the golden tests' business)
            recs = records_of(out)
            if part == "filters":
                events = [json.loads(l) for l in out.splitlines() if l.startswith('{"type":"event"')]
                lines = [json.loads(l) for l in out.splitlines()]
                total += check_filters(args, path, recs, events, lines)
            elif part == "stats":
                check_stats(args, path, recs)
            else:
                check_fields(args, path, recs)
                check_fields_selected(args, path, recs)
                check_drive_fields(args, path, recs)
        if part == "fields" and cases.begin("bad-filters-and-examples"):
            check_bad(os.path.join(SOURCE, "captures", "seed-erman-e9", "input.log"))
            check_examples()
    for problem in cases.finish():
        fail(problem)
    print("%d filter runs compared, %d failures" % (total, len(FAILURES)))
    sys.exit(1 if FAILURES else 0)


def case_name(path):
    """An input's case: its capture folder, or the generated file's name."""
    folder = os.path.dirname(path)
    if os.path.dirname(folder) == os.path.join(SOURCE, "captures"):
        return os.path.basename(folder)
    return os.path.basename(path)


def check_examples():
    # The README's drive 2 frequency over time: a row for each frame that shows it.
    e9 = os.path.join(SOURCE, "captures", "session-e9", "input.log")
    code, out, err = run(["read", "--drive", "2=e9", "-T", "fields", "-e", "t", "-e",
                          "drive.output_frequency", "-e", "drive.output_frequency.unit", "-Y",
                          "drive.output_frequency", e9])
    rows = [l.split("\t") for l in out.splitlines()]
    if code != 0 or not rows or any(len(r) != 3 or "" in r or r[2] != "Hz" for r in rows):
        fail("README drive.output_frequency example: exit %d %r %s" % (code, out[:200], err))
    # A drive value no loaded profile gives is a filter error naming it.
    code, out, err = run(["read", "-Y", "drive.no_such_value > 1", e9])
    if code != 2 or "drive.no_such_value" not in err or len(err.splitlines()) != 1:
        fail("-Y drive.no_such_value: exit %d %r" % (code, err))
    # decode takes -Y too
    code, out, _ = run(["decode", "-T", "json", "-Y", "fc == 3",
                        "01 03 00 00 00 01 84 0A", "01 06 00 01 00 03 98 0B"])
    frames = [json.loads(l) for l in out.splitlines() if '"type":"frame"' in l]
    if code != 0 or [f["fc"] for f in frames] != [3]:
        fail("decode -Y: %s" % out)


main()
