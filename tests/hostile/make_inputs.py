#!/usr/bin/env python3
"""Hostile inputs for tests/hostile.sh, made on the fly: the large ones are not worth
committing, and each is named after the bug it reproduces.

    make_inputs.py DIR NAME...     writes DIR/NAME.<ext> for each NAME below
"""
import random
import struct
import sys
import zipfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
from wire import crc16  # noqa: E402  (the Modbus RTU CRC the capture generators share)


def pcapng_block(kind, body):
    body += b"\0" * (-len(body) % 4)
    length = 12 + len(body)
    return struct.pack("<II", kind, length) + body + struct.pack("<I", length)


def pcapng_option(code, value):
    return struct.pack("<HH", code, len(value)) + value + b"\0" * (-len(value) % 4)


def pcapng(path, packets, link_type=147, if_name=None, tsresol=None, tsoffset=None):
    """packets: (time_us, bytes); one interface."""
    out = pcapng_block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))
    options = b""
    if if_name is not None:
        options += pcapng_option(2, if_name)
    if tsresol is not None:
        options += pcapng_option(9, bytes([tsresol]))
    if tsoffset is not None:
        options += pcapng_option(14, struct.pack("<q", tsoffset))
    if options:
        options += pcapng_option(0, b"")
    blocks = [out, pcapng_block(1, struct.pack("<HHI", link_type, 0, 0) + options)]
    # (blocks joined once: appending each to one bytes object copies the whole file every time)
    for t, data in packets:
        blocks.append(pcapng_block(6, struct.pack("<IIIII", 0, t >> 32, t & 0xFFFFFFFF, len(data),
                                                  len(data)) + data))
    with open(path, "wb") as f:
        f.write(b"".join(blocks))


def pcapng_interfaces(path, interfaces, packets, link_type=147):
    """packets: (time_us, interface, bytes) on `interfaces` interfaces."""
    blocks = [pcapng_block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))]
    for k in range(interfaces):
        name = f"bus{k}".encode()
        blocks.append(pcapng_block(1, struct.pack("<HHI", link_type, 0, 0) +
                                   pcapng_option(2, name) + pcapng_option(0, b"")))
    for t, interface, data in packets:
        blocks.append(pcapng_block(6, struct.pack("<IIIII", interface, t >> 32, t & 0xFFFFFFFF,
                                                  len(data), len(data)) + data))
    with open(path, "wb") as f:
        f.write(b"".join(blocks))


def many_stations(path, interfaces):
    """Every Modbus address 1..247 polled once on each of `interfaces` buses, one bus after the
    other, each request answered 20 ms later; then station 1 of each bus polled 8 times more:
    247 x `interfaces` stations."""
    packets = []
    t = 0
    for address in list(range(1, 248)) + [1] * 8:
        for interface in range(interfaces):
            packets.append((t, interface, bytes([address, 3, 0, 0, 0, 1] + crc16([address, 3, 0, 0, 0, 1]))))
            packets.append((t + 20000, interface, bytes([address, 3, 2, 0, address] + crc16([address, 3, 2, 0, address]))))
            t += 25000
    pcapng_interfaces(path, interfaces, packets)


def random_packets(path, megabytes):
    """Random bytes in packets of 1..64 bytes, 5 ms apart: no protocol at all."""
    r = random.Random(36)
    packets, total, t = [], 0, 0
    while total < megabytes << 20:
        data = bytes(r.getrandbits(8) for _ in range(r.randint(1, 64)))
        packets.append((t, data))
        total += len(data)
        t += 5000
    pcapng(path, packets)


def toggles(count, seed):
    """Level-run lengths of a line that toggles irregularly (3..30 samples)."""
    r = random.Random(seed)
    return [r.choice([3, 3, 6, 9, 3, 12, 30]) for _ in range(count)]


def vcd(path, timescale, variables=1, shared=False, changes=200, bom=False):
    with open(path, "wb") as f:
        if bom:
            f.write(b"\xef\xbb\xbf")
        f.write(f"$timescale {timescale} $end\n$scope module m $end\n".encode())
        for i in range(variables):
            ident = "!" if shared else chr(33 + i)
            f.write(f"$var wire 1 {ident} line{i} $end\n".encode())
        f.write(b"$upscope $end\n$enddefinitions $end\n#0 1!\n")
        t, level = 0, 1
        for width in toggles(changes, 1):
            t += width
            level ^= 1
            f.write(f"#{t} {level}!\n".encode())


def sigrok(path, rate, samples, extra_metadata=""):
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("version", "2")
        z.writestr("metadata",
                   "[global]\nsigrok version=0.5.2\n[device 1]\ncapturefile=logic-1\n"
                   f"total probes=1\nsamplerate={rate}\nunitsize=1\nprobe1=RX\n{extra_metadata}")
        z.writestr("logic-1-1", samples)


def toggling_samples():
    out, level = bytearray(), 1
    for width in toggles(300, 2):
        out += bytes([level]) * width
        level ^= 1
    return bytes(out)


def uart_samples(text, samples_per_bit, idle_bits=40):
    """8N1 characters of `text`, upright, as one sample byte per sample (bit 0 = the line)."""
    bits = [1] * idle_bits
    for c in text:
        bits += [0] + [(c >> k) & 1 for k in range(8)] + [1] + [1] * 3
    bits += [1] * idle_bits
    return bytes(b for bit in bits for b in [bit] * samples_per_bit)


def streamed_sigrok(path, rate, head, idle_mib16):
    """A one-channel session: `head` samples, then idle_mib16 x 16 MiB of idle line, written
    piece by piece (the whole would not fit in memory)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("version", "2")
        z.writestr("metadata",
                   "[global]\nsigrok version=0.5.2\n[device 1]\ncapturefile=logic-1\n"
                   f"total probes=1\nsamplerate={rate}\nunitsize=1\nprobe1=RX\n")
        with z.open("logic-1-1", "w", force_zip64=True) as f:
            f.write(head)
            idle = b"\x01" * (1 << 24)
            for _ in range(idle_mib16):
                f.write(idle)


def make(directory, name):
    at = f"{directory}/{name}"
    if name == "vcd-timescale-1s-sigfpe":
        vcd(at + ".vcd", "1 s")
    elif name == "sigrok-1hz-sigfpe":
        sigrok(at + ".sr", "1 Hz", toggling_samples())
    elif name == "sigrok-3hz-sigfpe":
        sigrok(at + ".sr", "3 Hz", toggling_samples())
    elif name == "sigrok-duplicate-samplerate-sigfpe":
        sigrok(at + ".sr", "1 MHz", toggling_samples(), "samplerate=1 Hz\n")
    elif name == "vcd-4096-variables-one-identifier":
        vcd(at + ".vcd", "1 us", variables=4096, shared=True, changes=40000)
    elif name == "vcd-utf8-bom":
        vcd(at + ".vcd", "1 us", bom=True)
    elif name == "sigrok-zip-bomb":
        # 64 characters of traffic, then an idle line: 64 MiB of samples in about 64 KB, four
        # times the 16 MiB limit the test gives (--logic-max 16M); more only costs the making.
        streamed_sigrok(at + ".sr", "1 MHz",
                        uart_samples(b"\x01\x03\x00\x00\x00\x01\x84\x0a" * 8, 104), 4)
    elif name == "random-packets":
        random_packets(at + ".pcapng", 2)
    elif name == "pcapng-64k-interface-name":
        frame = bytes.fromhex("0203000000043a44")
        pcapng(at + ".pcapng", [(k * 100000, frame) for k in range(50)],
               if_name=b"A" * 65000 + b"\x1b[2J\n\xff")
    elif name == "pcapng-negative-tsoffset":
        frame = bytes.fromhex("020300000004443a")
        pcapng(at + ".pcapng", [(k * 100000, frame) for k in range(3)], tsoffset=-1000)
    elif name == "pcapng-first-packet-at-zero":
        frame = bytes.fromhex("020300000004443a")
        pcapng(at + ".pcapng", [(k * 100000, frame) for k in range(3)])
    elif name == "pcapng-span-9e9-seconds":
        # Times from -4611686000 s to +4611686000 s (if_tsoffset): next to the +-2^62 ns limit, a
        # span of nearly 2^63 ns.
        pcapng(at + ".pcapng", [(0, bytes.fromhex("020300000004443a")),
                                (9_223_372_000 * 1_000_000,
                                 bytes.fromhex("0203080001000200030004" "0d14"))],
               tsoffset=-4_611_686_000)
    elif name == "pcapng-formula-interface-name":
        # A spreadsheet formula as the interface (channel) name.
        frame = bytes.fromhex("020300000004443a")
        pcapng(at + ".pcapng", [(k * 100000, frame) for k in range(3)],
               if_name=b"=HYPERLINK(\"http://x\")")
    elif name == "pcapng-63232-stations":
        many_stations(at + ".pcapng", 256)
    elif name == "logic-long-idle":
        # 60 s of idle line at 10 MHz after 32 characters: decoding takes seconds of idle runs.
        streamed_sigrok(at + ".sr", "10 MHz",
                        uart_samples(b"\x02\x03\x00\x00\x00\x04\x44\x3a" * 4, 1042), 36)
    else:
        sys.exit(f"make_inputs.py: unknown input '{name}'")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit("usage: make_inputs.py DIR NAME...")
    for n in sys.argv[2:]:
        make(sys.argv[1], n)
