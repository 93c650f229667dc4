#!/usr/bin/env python3
"""Command-line conventions a tshark user expects, each checked against an independent computation.

    tests/conventions.py DRIVETAP

1. -c N: exactly the first N frames of the full output, and the summary counts N.
2. -q: no line per frame, the summary alone (the same as --stats).
3. -t: every frame's time column recomputed from `-T json` times (r: since the first byte of a
   pcap, d/dd: since the previous frame, e/a/ad/u/ud: calendar times by Python, local ones in
   TZ=Asia/Tokyo and TZ=America/New_York); tshark's -t ad and -t e of the pcap's first packet equal
   drivetap's of its first frame; a byte log has no wall clock: said once, shown relative.
4. `drivetap -r FILE` is `drivetap read FILE`; `-D` lists a made-up /dev (DRIVETAP_DEVICE_ROOT)
   with /dev/serial/by-id names; a misspelt command names the closest one.
5. Refused options: each is one line starting `drivetap:` and exit 2 (table REFUSED).
6. --color: always colours findings, events, noise and diagnose's verdicts (stripped of its
   escapes, the output is the plain one); auto colours a terminal (a pty) unless NO_COLOR is set,
   never a pipe.
7. Progress: on a terminal stderr (a pty), lines of frames and % of the file, erased at the end;
   none with -q, --no-progress or a stderr that is no terminal.
8. Long lines: a noise record shows its first 64 bytes of hex (those of `-T json`) and how many
   more; -x dumps every frame and noise record as tshark -x dumps the packets drivetap writes of
   them (`-w --plain --dlt user0`: a packet's bytes are the record's).
"""
import datetime
import json
import os
import pty
import re
import shutil
import subprocess
import sys
import tempfile
import zoneinfo

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DRIVETAP = sys.argv[1]
PCAP = os.path.join(ROOT, "captures/dlt147-split-and-merged/input.pcap")
LOG = os.path.join(ROOT, "captures/session-e9/input.log")
SR = os.path.join(ROOT, "captures/sigrok-brainchild-io-16do/brainchild-io-16do.sr")
failed = []


def fail(message):
    failed.append(message)
    print("FAIL:", message)


def run(args, env=None, stdin=None):
    e = dict(os.environ)
    e.update(env or {})
    return subprocess.run([DRIVETAP] + args, capture_output=True, text=True, env=e, input=stdin)


FRAME_LINE = re.compile(r"^ {0,4}(\d+) ")


def frame_lines(text):
    return [line for line in text.splitlines() if FRAME_LINE.match(line)]


# 1. -c N
full = run(["read", "--no-summary", LOG]).stdout
for n in (1, 5, 12):
    r = run(["read", "-c", str(n), LOG])
    got = frame_lines(r.stdout)
    if r.returncode != 0 or got != frame_lines(full)[:n]:
        fail(f"-c {n}: exit {r.returncode}, frame lines {len(got)}")
    if not re.search(rf"^frames: +{n} ", r.stdout, re.M):
        fail(f"-c {n}: summary does not count {n} frames")
r = run(["read", "-c", "3", "-T", "json", PCAP])
if sum(1 for line in r.stdout.splitlines() if json.loads(line)["type"] == "frame") != 3:
    fail("-c 3 -T json of a pcap: not 3 frame records")
r = run(["decode", "-c", "1", "01 03 00 00 00 01 84 0A | 01 03 00 00 00 01 84 0A"])
if len(frame_lines(r.stdout)) != 1:
    fail(f"decode -c 1: {r.stdout}")

# 2. -q
q = run(["read", "-q", LOG])
stats = run(["read", "--stats", LOG])
if q.returncode != 0 or q.stdout != stats.stdout or frame_lines(q.stdout):
    fail(f"-q: not the summary alone: {q.stdout[:200]}")

# 3. -t
records = [json.loads(line) for line in run(["read", "-T", "json", PCAP]).stdout.splitlines()]
frames = [rec for rec in records if rec["type"] == "frame"]


def ns(rec):
    whole, _, fraction = f"{rec['t']:.9f}".partition(".")
    return int(whole) * 10**9 + int(fraction)


def json_ns_exact(line):
    # The JSON time as written (9 decimals), not through a float.
    m = re.search(r'"t":(-?\d+)\.(\d{9})', line)
    return int(m.group(1)) * 10**9 + int(m.group(2))


frame_ns = [json_ns_exact(line) for line in run(["read", "-T", "json", PCAP]).stdout.splitlines()
            if '"type":"frame"' in line]
first_byte = frame_ns[0]  # the pcap's first byte starts its first frame


def seconds(t):
    sign = "-" if t < 0 else ""
    t = abs(t)
    return f"{sign}{t // 10**9}.{(t % 10**9) // 1000:06d}"


def calendar(t, tz, date):
    when = datetime.datetime.fromtimestamp(t // 10**9, tz) + datetime.timedelta(
        microseconds=(t % 10**9) // 1000)
    return when.strftime("%Y-%m-%d %H:%M:%S.%f" if date else "%H:%M:%S.%f")


def shown_times(fmt, env=None):
    out = run(["read", "--no-summary", "-t", fmt, PCAP], env=env).stdout
    times = []
    for line in frame_lines(out):
        # number, then the time (one or two words), then the channel
        words = line.split()
        times.append(" ".join(words[1:3]) if fmt in ("ad", "ud") else words[1])
    return times


expect = {
    "r": [seconds(t - first_byte) for t in frame_ns],
    "e": [seconds(t) for t in frame_ns],
    "d": [seconds(t - p) for t, p in zip(frame_ns, [frame_ns[0]] + frame_ns)],
    "dd": [seconds(t - p) for t, p in zip(frame_ns, [frame_ns[0]] + frame_ns)],
    "u": [calendar(t, datetime.timezone.utc, False) for t in frame_ns],
    "ud": [calendar(t, datetime.timezone.utc, True) for t in frame_ns],
}
for fmt, want in expect.items():
    got = shown_times(fmt)
    if got != want:
        fail(f"-t {fmt}: {got[:3]} ..., expected {want[:3]} ...")
# -T fields' t follows -t as the text column does.
for fmt, want in expect.items():
    got = run(["read", "-T", "fields", "-e", "t", "-Y", 'type == "frame"', "-t", fmt,
               PCAP]).stdout.splitlines()
    if got != want:
        fail(f"-T fields -e t -t {fmt}: {got[:3]} ..., expected {want[:3]} ...")
if shown_times("r") != [seconds(t - first_byte) for t in frame_ns]:
    fail("default time column is not -t r")
for tz in ("Asia/Tokyo", "America/New_York"):
    zone = zoneinfo.ZoneInfo(tz)
    for fmt, date in (("a", False), ("ad", True)):
        got = shown_times(fmt, env={"TZ": tz})
        want = [calendar(t, zone, date) for t in frame_ns]
        if got != want:
            fail(f"TZ={tz} -t {fmt}: {got[:2]}, expected {want[:2]}")
# The reference above agrees with tshark's -t a, ad, u, ud of the pcap's packets (tshark gives 9
# decimals: cut to 6), their instants from tshark's -t e.
if shutil.which("tshark"):
    def tshark_times(fmt):
        return subprocess.run(["tshark", "-r", PCAP, "-t", fmt, "-T", "fields", "-e",
                               "_ws.col.Time"], capture_output=True, text=True,
                              env=dict(os.environ, TZ="Asia/Tokyo")).stdout.split("\n")[:-1]
    instants = [int(e.replace(".", "")) for e in tshark_times("e")]
    zone = zoneinfo.ZoneInfo("Asia/Tokyo")
    for fmt, tz, date in (("a", zone, False), ("ad", zone, True),
                          ("u", datetime.timezone.utc, False), ("ud", datetime.timezone.utc, True)):
        theirs = [t[:-3] for t in tshark_times(fmt)]
        ours = [calendar(t, tz, date) for t in instants]
        if not instants or theirs != ours:
            fail(f"reference -t {fmt} differs from tshark's: {ours[:2]} / {theirs[:2]}")
# A byte log has no wall clock: one line on stderr, times relative.
r = run(["read", "--no-summary", "-t", "ad", LOG])
lines = r.stderr.splitlines()
if r.returncode != 0 or len(lines) != 1 or "no wall-clock time" not in lines[0]:
    fail(f"-t ad of a byte log: stderr {r.stderr!r}")
if frame_lines(r.stdout) != frame_lines(full):
    fail("-t ad of a byte log: not shown relative")

# 4. -r, -D, a misspelt command
if run(["-r", LOG]).stdout != run(["read", LOG]).stdout:
    fail("drivetap -r FILE differs from drivetap read FILE")
if run(["read", "-r", LOG, "-c", "2"]).stdout != run(["read", "-c", "2", LOG]).stdout:
    fail("read -r FILE differs from read FILE")
with tempfile.TemporaryDirectory() as root:
    os.makedirs(f"{root}/dev/serial/by-id")
    os.makedirs(f"{root}/sys/class/tty/ttyS0")
    os.makedirs(f"{root}/sys/class/tty/ttyS1")
    for name in ("ttyUSB10", "ttyUSB2", "ttyACM0", "ttyS0", "ttyS1", "tty0", "null"):
        open(f"{root}/dev/{name}", "w").close()
    with open(f"{root}/sys/class/tty/ttyS0/type", "w") as f:
        f.write("4\n")  # a 16550A
    with open(f"{root}/sys/class/tty/ttyS1/type", "w") as f:
        f.write("0\n")  # no UART behind it
    os.symlink("../../ttyUSB2", f"{root}/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A10K1234-if00-port0")
    r = run(["-D"], env={"DRIVETAP_DEVICE_ROOT": root})
    want = ("1. /dev/ttyACM0\n2. /dev/ttyS0\n"
            "3. /dev/ttyUSB2 (usb-FTDI_FT232R_USB_UART_A10K1234-if00-port0)\n4. /dev/ttyUSB10\n")
    if r.returncode != 0 or r.stdout != want:
        fail(f"-D: exit {r.returncode}, printed {r.stdout!r}")
    os.makedirs(f"{root}/empty/dev")
    r = run(["-D"], env={"DRIVETAP_DEVICE_ROOT": f"{root}/empty"})
    if r.returncode != 1 or not r.stderr.startswith("drivetap: no serial ports found"):
        fail(f"-D with no ports: exit {r.returncode}, {r.stderr!r}")

# 5. Refused: (arguments, the start of the one line on stderr). Each exits 2.
REFUSED = [
    (["reed", LOG], "drivetap: unknown command 'reed' (did you mean read?)"),
    (["dcode", "0102"], "drivetap: unknown command 'dcode' (did you mean decode?)"),
    (["frobnicate"], "drivetap: unknown command 'frobnicate' (commands: decode, read"),
    (["read"], "drivetap: read: give a capture file"),
    (["read", "--bogus", LOG], "drivetap: read: unknown option --bogus"),
    (["read", "-c", "x", LOG], "drivetap: read: "),
    (["read", "-t", "zz", LOG], "drivetap: read: -t: zz not in"),
    (["read", "--color=sometimes", LOG], "drivetap: read: --color: sometimes not in"),
    (["diagnose", "-w", "x.pcapng", LOG], "drivetap: diagnose: -w does not apply to diagnose"),
    (["diagnose", "-c", "5", LOG], "drivetap: diagnose: -c does not apply to diagnose"),
    (["diagnose", "-q", LOG], "drivetap: diagnose: -q does not apply to diagnose"),
    (["diagnose", "-t", "e", LOG], "drivetap: diagnose: -t does not apply to diagnose"),
    (["diagnose", "-V", LOG], "drivetap: diagnose: -V does not apply to diagnose"),
    (["diagnose", "--events", LOG], "drivetap: diagnose: --events does not apply to diagnose"),
    (["diagnose", "--stats", LOG], "drivetap: diagnose: --stats does not apply to diagnose"),
    (["diagnose", "-o", "x.txt", LOG], "drivetap: diagnose: -o does not apply to diagnose"),
    (["diagnose", "-x", LOG], "drivetap: diagnose: -x does not apply to diagnose"),
    (["decode", "--channels", "RX", "0102"], "drivetap: decode: --channels does not apply"),
    (["decode", "--invert", "0102"], "drivetap: decode: --invert does not apply to decode"),
    (["decode", "--logic-max", "1G", "0102"], "drivetap: decode: --logic-max does not apply"),
    (["decode", "-t", "e", "0102"], "drivetap: decode: -t does not apply to decode"),
    (["decode", "--timeout", "2s", "0102"], "drivetap: decode: --timeout does not apply"),
    (["decode", "--no-progress", "0102"], "drivetap: decode: --no-progress does not apply"),
    (["capture", "--channels", "RX", "-i", "/dev/null"], "drivetap: capture: --channels does not"),
    (["capture", "--no-progress", "-i", "/dev/null"], "drivetap: capture: --no-progress does not"),
    (["read", "--pcap", LOG], "drivetap: --pcap: only with -w FILE"),
    (["read", "--dlt", "user0", LOG], "drivetap: --dlt: only with -w FILE"),
    (["read", "--plain", LOG], "drivetap: --plain: only with -w FILE"),
    (["decode", "--pcap", "0102"], "drivetap: --pcap: only with -w FILE"),
    (["read", "--channels", "RX", LOG], "drivetap: --channels: only for logic-analyser captures"),
    (["read", "--invert", "-s", "9600 8N1", PCAP], "drivetap: --invert: only for logic-analyser"),
    (["read", "--logic-max", "2G", LOG], "drivetap: --logic-max: only for logic-analyser"),
    (["read", "-T", "json", "-t", "e", LOG], "drivetap: -t: only for the text output"),
    (["read", "-T", "json", "-x", LOG], "drivetap: -x: only for the text output"),
    (["read", "-T", "json", "-V", LOG], "drivetap: -V: only for the text output"),
    (["read", "-q", "--events", LOG], "drivetap: -q and --events"),
    (["read", "-q", "-x", LOG], "drivetap: -q and -x"),
    (["read", "-q", "-V", LOG], "drivetap: -q and -V"),
    (["read", "-q", "--no-summary", LOG], "drivetap: -q and --no-summary leave nothing to print"),
    (["read", "--stats", "--events", LOG], "drivetap: --stats and --events"),
    (["read", "--stats", "-x", LOG], "drivetap: --stats and -x"),
    (["read", "--events", "-V", LOG], "drivetap: --events and -V"),
    (["read", "--events", "-x", LOG], "drivetap: --events and -x"),
    (["read", "-T", "json", "--color=always", LOG], "drivetap: --color: only for the text output"),
    (["diagnose", "-T", "json", "--color=never", LOG], "drivetap: --color: only for the text"),
    (["capture", "--scan-time", "3", "-i", "/dev/null"], "drivetap: --scan-time: only with --scan"),
    (["capture", "--scan", "-w", "x.pcapng", "-i", "/dev/null"], "drivetap: -w: not with --scan"),
    (["capture", "--scan", "-c", "5", "-i", "/dev/null"], "drivetap: -c: not with --scan"),
    (["capture", "--scan", "-b", "files:3", "-i", "/dev/null"], "drivetap: -b: not with --scan"),
]
for args, start in REFUSED:
    r = run(args)
    lines = r.stderr.splitlines()
    if r.returncode != 2 or len(lines) != 1 or not lines[0].startswith(start):
        fail(f"{' '.join(args)}: exit {r.returncode}, stderr {r.stderr!r}, expected {start!r}")

# Each command's --help lists only the options it takes.
for command, absent in (("diagnose", ["-w,", "-c,", "-q,", "--events", "-x,", " -t "]),
                        ("decode", ["--channels", "--invert", "--logic-max", " -t ", "--timeout"]),
                        ("capture", ["--channels", "--invert", "--logic-max", "--no-progress"])):
    text = run([command, "--help"]).stdout
    for option in absent:
        if option in text:
            fail(f"{command} --help lists {option.strip()}")

# 6. --color
ESCAPE = re.compile(r"\x1b\[[0-9;]*m")
BAD = os.path.join(ROOT, "captures/gap-inside-frame/input.log")  # bad checksums, noise
for path in (LOG, BAD, PCAP):
    plain = run(["read", path]).stdout
    colored = run(["read", "--color=always", path]).stdout
    if ESCAPE.sub("", colored) != plain:
        fail(f"--color=always {path}: not the plain output once its escapes are stripped")
    for line in colored.splitlines():
        bare = ESCAPE.sub("", line)
        finding = re.match(r"^ {8}! |^ *(\d+|-) +\S+ \S+ +(!!!|\*\*\*|---)  ", bare)
        if finding and "\x1b[" not in line:
            fail(f"--color=always: finding, event or noise line not coloured: {bare[:80]}")
        if not finding and "\x1b[" in line and not re.search(r"(BAD|SWAPPED) \(wire", bare):
            fail(f"--color=always: a line coloured that is no finding: {bare[:80]}")
if "\x1b[" in run(["read", "--color=auto", LOG]).stdout:
    fail("--color=auto coloured a pipe")
if "\x1b[" in run(["read", "--color=never", LOG], env={"NO_COLOR": ""}).stdout:
    fail("--color=never coloured")
if "\x1b[" not in run(["read", "--color=always", LOG], env={"NO_COLOR": "1"}).stdout:
    fail("--color=always with NO_COLOR: not coloured (the option says always)")
diag = run(["diagnose", "--color=always", SR]).stdout
if "\x1b[31m[inverted-line]" not in diag or ESCAPE.sub("", diag) != run(["diagnose", SR]).stdout:
    fail(f"diagnose --color=always: {diag[:300]!r}")


def on_terminal(args, env=None, stream="stdout"):
    """Runs drivetap with `stream` on a pty (the other to a pipe); returns (pty text, pipe text)."""
    master, slave = pty.openpty()
    e = dict(os.environ)
    e.update(env or {})
    kw = {"stdout": slave, "stderr": subprocess.PIPE} if stream == "stdout" else \
         {"stdout": subprocess.PIPE, "stderr": slave}
    p = subprocess.Popen([DRIVETAP] + args, env=e, **kw)
    os.close(slave)
    seen = b""
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:
            break
        if not chunk:
            break
        seen += chunk
    other = (p.stderr if stream == "stdout" else p.stdout).read()
    p.wait()
    os.close(master)
    return seen.decode(), other.decode()


if "\x1b[" not in on_terminal(["read", LOG])[0]:
    fail("--color=auto did not colour a terminal")
if "\x1b[" in on_terminal(["read", LOG], env={"NO_COLOR": "1"})[0]:
    fail("--color=auto coloured a terminal with NO_COLOR set")

# 7. Progress on a terminal stderr (DRIVETAP_PROGRESS_MS=0: a line at every batch).
with tempfile.TemporaryDirectory() as work:
    big = os.path.join(work, "big.log")
    subprocess.run([DRIVETAP, "generate", "--frames", "20000", "-o", big], check=True,
                   capture_output=True)
    fast = {"DRIVETAP_PROGRESS_MS": "0"}
    err, out = on_terminal(["read", "--stats", big], env=fast, stream="stderr")
    lines = re.findall(r"\rdrivetap: [^\r]*? (\d+) frames, (\d+) %, \d+ frames/s\x1b\[K", err)
    if len(lines) < 2 or not err.endswith("\r\x1b[K") or "frames:" not in out:
        fail(f"progress: {err[-300:]!r}")
    else:
        counts = [int(n) for n, _ in lines]
        percents = [int(p) for _, p in lines]
        if counts != sorted(counts) or percents != sorted(percents) or percents[-1] > 100:
            fail(f"progress: counts or percentages go backwards: {lines[:3]} ... {lines[-3:]}")
    for args in (["read", "-q", big], ["read", "--stats", "--no-progress", big]):
        err, _ = on_terminal(args, env=fast, stream="stderr")
        if err:
            fail(f"progress shown with {args[1:-1]}: {err[:100]!r}")
    r = run(["read", "--stats", big], env=fast)
    if r.stderr:
        fail(f"progress shown on a stderr that is no terminal: {r.stderr[:100]!r}")

# 8. Long lines and -x
DMX = os.path.join(ROOT, "captures/negative-dmx/input.log")
text = run(["read", DMX]).stdout
noise_json = [json.loads(line) for line in run(["read", "-T", "json", DMX]).stdout.splitlines()
              if '"type":"noise"' in line]
noise_text = [line for line in text.splitlines() if "---  noise:" in line]
if len(noise_json) != len(noise_text) or not noise_json:
    fail("noise records: text and JSON count differ")
for rec, line in zip(noise_json, noise_text):
    data = bytes.fromhex(rec["hex"])
    shown = " ".join(f"{b:02X}" for b in data[:64])
    want = f"noise: {len(data)} bytes {shown}" + (f" … (+{len(data) - 64} bytes)" if len(data) > 64 else "")
    if not line.endswith(want):
        fail(f"noise line: {line[:120]} ..., expected ... {want[-60:]}")
if shutil.which("tshark"):
    with tempfile.TemporaryDirectory() as work:
        for path in (LOG, DMX, BAD):
            written = os.path.join(work, "x.pcapng")
            dumped = run(["read", "-x", path, "-w", written, "--plain", "--dlt", "user0"]).stdout
            ours = [line[8:] for line in dumped.splitlines() if re.match(r"^ {8}[0-9a-f]{4}  ", line)]
            theirs = subprocess.run(["tshark", "-x", "-r", written], capture_output=True,
                                    text=True).stdout.splitlines()
            theirs = [line for line in theirs if line]
            if not ours or ours != theirs:
                fail(f"-x {path}: {len(ours)} dump lines, tshark's {len(theirs)}: "
                     f"{ours[:2]} / {theirs[:2]}")

print("conventions: " + ("FAILED" if failed else "all checks pass"))
sys.exit(1 if failed else 0)
