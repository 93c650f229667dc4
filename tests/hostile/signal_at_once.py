#!/usr/bin/env python3
"""Starts a command and sends it SIGINT the moment it has caught SIGINT and SIGTERM (polling its
/proc status without sleeping), then waits for it; exits with the command's status as a shell
would (128 + signal when it died of one). Its standard error goes to ERRFILE.
  signal_at_once.py ERRFILE COMMAND [ARG...]"""
import signal
import subprocess
import sys
import time

errfile, command = sys.argv[1], sys.argv[2:]
with open(errfile, "wb") as err:
    child = subprocess.Popen(command, stderr=err)
    deadline = time.monotonic() + 20
    while child.poll() is None and time.monotonic() < deadline:
        try:
            with open(f"/proc/{child.pid}/status") as status:
                caught = next((int(line.split()[1], 16) for line in status
                               if line.startswith("SigCgt:")), 0)
        except OSError:
            caught = 0
        # SIGINT is bit 1, SIGTERM bit 14 of the mask.
        if caught & 0x4002 == 0x4002:
            child.send_signal(signal.SIGINT)
            break
    try:
        rc = child.wait(timeout=20)
    except subprocess.TimeoutExpired:
        child.kill()
        sys.exit("signal_at_once.py: the command did not end 20 s after the signal")
sys.exit(128 - rc if rc < 0 else rc)
