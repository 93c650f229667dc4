#!/usr/bin/env python3
"""A Modbus RTU pcapng written without drivetap: the second capture source of bench/.

Traffic as another capture tool records it on a busy plant bus: STATIONS stations (default 31)
polled in turn with Read Holding Registers (function 3) of random ranges, sometimes Write
Single/Multiple Registers, each answered at 9600 8N1 timing; a few exceptions and silent
stations. Registers and ranges are random, so no drive family fits most stations. The file is
pcapng, link type 252 (Wireshark upper PDU: a dissector-name tag "mbrtu" and the end tag before
the frame), one Enhanced Packet Block per frame with its direction in the EPB flags (outbound for
a request, inbound for a reply) and nanosecond timestamps (if_tsresol 9).

    bench/foreign_pcapng.py FRAMES OUT.pcapng [--seed N] [--stations N]

Written with the standard library only, block by block, so it is independent of drivetap's
writer (docs/formats.md describes what drivetap itself writes).
"""
import argparse
import random
import struct
import sys

BAUD = 9600
CHAR_NS = 10 * 1_000_000_000 // BAUD  # 8N1: 10 bits a character


def crc16(data: bytes) -> int:
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def rtu(payload: bytes) -> bytes:
    return payload + struct.pack("<H", crc16(payload))


def pad4(b: bytes) -> bytes:
    return b + b"\0" * (-len(b) % 4)


def option(code: int, value: bytes) -> bytes:
    return struct.pack("<HH", code, len(value)) + pad4(value)


def block(kind: int, body: bytes) -> bytes:
    total = 12 + len(body)
    return struct.pack("<II", kind, total) + body + struct.pack("<I", total)


def section_header() -> bytes:
    opts = option(4, b"bench/foreign_pcapng.py") + option(0, b"")
    return block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1) + opts)


def interface() -> bytes:
    opts = option(2, b"rs485") + option(9, bytes([9])) + option(0, b"")
    return block(0x00000001, struct.pack("<HHI", 252, 0, 0) + opts)


# Wireshark's exported-PDU tags: type and length big-endian, the length that of the padded value.
TAGS = struct.pack(">HH", 12, 8) + pad4(b"mbrtu") + struct.pack(">HH", 0, 0)
OUTBOUND, INBOUND = 2, 1


def packet(time_ns: int, frame: bytes, direction: int) -> bytes:
    data = TAGS + frame
    opts = option(2, struct.pack("<I", direction)) + option(0, b"")
    head = struct.pack("<IIIII", 0, time_ns >> 32, time_ns & 0xFFFFFFFF, len(data), len(data))
    return block(0x00000006, head + pad4(data) + opts)


def exchange(rng: random.Random, station: int):
    """A request and its reply (None: the station stays silent)."""
    roll = rng.random()
    if roll < 0.85:
        start = rng.randrange(0, 0x10000 - 125)
        count = rng.randint(1, 32)
        req = rtu(struct.pack(">BBHH", station, 3, start, count))
        if rng.random() < 0.01:
            return req, rtu(bytes([station, 0x83, 2]))
        values = b"".join(struct.pack(">H", rng.randrange(0x10000)) for _ in range(count))
        return req, rtu(bytes([station, 3, 2 * count]) + values)
    if roll < 0.93:
        addr, value = rng.randrange(0x10000), rng.randrange(0x10000)
        req = rtu(struct.pack(">BBHH", station, 6, addr, value))
        return req, req
    if roll < 0.99:
        start, count = rng.randrange(0, 0x10000 - 20), rng.randint(1, 8)
        values = b"".join(struct.pack(">H", rng.randrange(0x10000)) for _ in range(count))
        req = rtu(struct.pack(">BBHHB", station, 16, start, count, 2 * count) + values)
        return req, rtu(struct.pack(">BBHH", station, 16, start, count))
    return rtu(struct.pack(">BBHH", station, 3, rng.randrange(0x1000), 1)), None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("frames", type=int)
    ap.add_argument("out")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--stations", type=int, default=31)
    a = ap.parse_args()
    if a.frames < 1 or not 1 <= a.stations <= 247:
        print("foreign_pcapng.py: FRAMES must be positive and --stations 1..247", file=sys.stderr)
        return 2
    rng = random.Random(a.seed)
    t = 1_700_000_000 * 1_000_000_000
    written = 0
    station = 0
    with open(a.out, "wb") as f:
        f.write(section_header() + interface())
        chunk = []
        while written < a.frames:
            station = station % a.stations + 1
            req, rep = exchange(rng, station)
            # Stamped when the last byte arrived, as a capture tool stamps a packet it received.
            t += len(req) * CHAR_NS
            chunk.append(packet(t, req, OUTBOUND))
            written += 1
            t += rng.randint(4, 12) * CHAR_NS
            if rep is not None and written < a.frames:
                t += len(rep) * CHAR_NS
                chunk.append(packet(t, rep, INBOUND))
                written += 1
                t += rng.randint(4, 20) * CHAR_NS
            else:
                t += 200_000_000  # the master's reply timeout
            if len(chunk) >= 4096:
                f.write(b"".join(chunk))
                chunk.clear()
        f.write(b"".join(chunk))
    return 0


if __name__ == "__main__":
    sys.exit(main())
