#!/usr/bin/env python3
"""An RS-485 pair without fail-safe bias, as a logic probe on it records it.

A Modbus RTU master polls slave 1 (function 3, 2 registers) at 9600 8N1 and the slave answers:
44 transactions, 88 frames, every CRC good. Each transmitter drives the pair only while it
sends: it enables its driver 1.5 bit times (mark) before the first start bit and lets go 1 bit
time after the last stop bit. Nobody drives the pair in between, and the unbiased pair floats to
about 0 V, which the probe reads as low: the line rests "low" for most of the capture although
every character on it is upright. Written as a sigrok-style VCD at 1 MHz.

    python3 scripts/make_unbiased_capture.py captures/unbiased-rs485-modbus/input.vcd
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from wire import with_crc  # noqa: E402

RATE = 1_000_000
BAUD = 9600
BIT = RATE / BAUD


def main(path):
    changes = [(0, 0)]  # (time in samples, level); the pair floats low at the start
    t = 2000.0

    def level(at, value):
        at = int(round(at))
        if changes[-1][1] != value:
            changes.append((at, value))

    def transmit(data):
        nonlocal t
        level(t, 1)  # driver enabled: mark
        t += 1.5 * BIT
        for byte in data:
            bits = [0] + [(byte >> i) & 1 for i in range(8)] + [1]
            for b in bits:
                level(t, b)
                t += BIT
        t += 1.0 * BIT
        level(t, 0)  # driver released: the pair floats low

    for n in range(44):
        register = 0x0100 + 2 * (n % 8)
        transmit(with_crc(bytes([0x01, 0x03, register >> 8, register & 0xFF, 0x00, 0x02])))
        t += 3.5e-3 * RATE  # the slave's turnaround
        value = (1500 + 7 * n) & 0xFFFF
        transmit(with_crc(bytes([0x01, 0x03, 0x04, value >> 8, value & 0xFF, 0x00, n & 0xFF])))
        t += 40e-3 * RATE  # the master's poll interval
    end = int(t)
    with open(path, "w") as out:
        out.write("$date drivetap make_unbiased_capture.py $end\n")
        out.write("$timescale 1 us $end\n$scope module drivetap $end\n")
        out.write("$var wire 1 ! RS485 $end\n$upscope $end\n$enddefinitions $end\n")
        for at, value in changes:
            out.write(f"#{at} {value}!\n")
        out.write(f"#{end}\n")


if __name__ == "__main__":
    main(sys.argv[1])
