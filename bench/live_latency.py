#!/usr/bin/env python3
"""Live latency of `drivetap capture`: from the end of a frame's last byte on the (simulated) bus
to its JSON line reaching a reader. Runs tools/drivetap-simbus on a pty and the capture with
-T json, stamps each frame line as it arrives (wall clock) and compares it with the frame's t_end.

usage: bench/live_latency.py BUILD_DIR SERIAL SECONDS [SIMBUS ARGS...]
  e.g. build "9600 8E1" 10;  build "115200 8N1" 10 --gap 25,25  (above 19200 baud t3.5 is a
  fixed 1.75 ms: the simulator's default 5/10-character gaps are shorter, and frames then close
  by content when the next one starts, not by silence)
"""
import json, os, statistics, subprocess, sys, tempfile, time

build, serial, seconds = sys.argv[1], sys.argv[2], float(sys.argv[3])
extra = sys.argv[4:]
tmp = tempfile.mkdtemp()
link = os.path.join(tmp, "bus")
sim = subprocess.Popen([f"{build}/tools/drivetap-simbus", "--link", link, "--serial", serial,
                        "--duration", str(seconds), "--wait-ms", "500", *extra],
                       stderr=subprocess.DEVNULL)
while not os.path.exists(link):
    time.sleep(0.01)
cap = subprocess.Popen([f"{build}/drivetap", "capture", "-i", link, "-s", serial, "-P", "rtu",
                        "--drive", "none", "-T", "json", "--no-summary"],
                       stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, bufsize=1)
late = []
for line in cap.stdout:
    now = time.time()
    record = json.loads(line)
    if record.get("type") == "frame":
        late.append((now - float(record["t_end"])) * 1000)
sim.wait()
cap.wait()
late.sort()
n = len(late)
char_ms = 11 * 1000 / int(serial.split()[0]) if "N1" not in serial else 10 * 1000 / int(serial.split()[0])
t35 = 1.75 if int(serial.split()[0]) > 19200 else 3.5 * char_ms
print(f"{serial}: {n} frames; last byte -> line: median {statistics.median(late):.2f} ms, "
      f"p99 {late[int(n * 0.99) - 1]:.2f} ms, max {late[-1]:.2f} ms; t3.5 = {t35:.2f} ms, "
      f"so t3.5 + 5 ms = {t35 + 5:.2f} ms")
