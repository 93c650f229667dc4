#!/usr/bin/env python3
"""Writes captures/dlt147-split-and-merged/input.pcap: a classic pcap with link type 147 (USER0),
as modbus-sniffer or SerialPCAP write it, where the capture tool cut frames badly:
  packets 1+2: one request split over two packets (5 + 3 bytes, the second 1 ms late)
  packet 3:    its reply, whole
  packet 4:    a request and its reply together in one packet
  packet 5:    an FC 06 request, whole;  packet 6: its echo, whole
Each packet is stamped when its last byte has arrived (9600 8N1: 1.041667 ms a character)."""
import os
import struct

from wire import with_crc


CHAR_NS = round(10 * 1e9 / 9600)
req1 = with_crc([0x01, 0x03, 0x00, 0x00, 0x00, 0x02])
rsp1 = with_crc([0x01, 0x03, 0x04, 0x00, 0x0A, 0x01, 0xF4])
req2 = with_crc([0x02, 0x04, 0x00, 0x10, 0x00, 0x01])
rsp2 = with_crc([0x02, 0x04, 0x02, 0x12, 0x34])
req3 = with_crc([0x01, 0x06, 0x00, 0x01, 0x01, 0x1D])
base = 1_700_000_000 * 1_000_000_000
packets = [
    (base + 5 * CHAR_NS, req1[:5]),
    (base + 8 * CHAR_NS + 1_000_000, req1[5:]),
    (base + 8 * CHAR_NS + 10_000_000 + 9 * CHAR_NS, rsp1),
    (base + 200_000_000 + 15 * CHAR_NS, req2 + rsp2),
    (base + 400_000_000 + 8 * CHAR_NS, req3),
    (base + 400_000_000 + 16 * CHAR_NS + 10_000_000, req3),
]
out = struct.pack("<IHHiIII", 0xA1B23C4D, 2, 4, 0, 0, 65535, 147)  # nanosecond pcap
for ts, data in packets:
    out += struct.pack("<IIII", ts // 1_000_000_000, ts % 1_000_000_000, len(data), len(data)) + data
path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "captures",
                    "dlt147-split-and-merged", "input.pcap")
os.makedirs(os.path.dirname(path), exist_ok=True)
open(path, "wb").write(out)
