#!/usr/bin/env python3
"""Writes captures/seed-*/input.log: the Modbus RTU worked examples of the drive manuals
(../shared/specs/seeds, transcribed and checked in docs/protocols.md §2/§6) laid out as a byte log.

Each example is a request followed by its reply 5 ms (at least 6 characters) after the request's
last character; the next request comes 100 ms after the reply. The manuals print an error reply as an alternative answer to
the same request, so the request is repeated before it. Bytes are exactly as printed (wrong CRCs
included); the Danfoss examples (002 §7.10) print no CRC, so ours is appended there.
Re-run from the repository root: python3 scripts/make_seed_captures.py
"""
import os

from wire import ts

SEEDS = {
    "seed-erman-e9": {
        "serial": "4800 8N1",
        "source": "000_83f94d0f1b288c77.txt §6 (ERMAN E-9 RS-485 card; 4800 8N1 is the F180 default)",
        "frames": [
            ("§6 example 1: read 0x0000-0x0003 of drive 2", "req", "02 03 00 00 00 04 3A 44"),
            ("§6 example 1: reply", "rsp", "02 03 08 00 03 13 88 13 88 01 7C 80 48"),
            ("§6 example 1 (repeated for the error reply)", "req", "02 03 00 00 00 04 3A 44"),
            ("§6 example 1: error reply", "rsp", "02 83 03 F1 31"),
            ("§6 example 2: write 0x0010-0x0011", "req", "02 10 00 10 00 02 04 00 01 13 88 EB FC"),
            ("§6 example 2: reply", "rsp", "02 10 00 10 00 02 F1 E1"),
            ("§6 example 2 (repeated for the error reply)", "req", "02 10 00 10 00 02 04 00 01 13 88 EB FC"),
            ("§6 example 2: error reply", "rsp", "02 90 02 CD C1"),
            ("§6 example 3: diagnostics, return query data", "req", "01 08 00 00 A5 37 DA 8D"),
            ("§6 example 3: echo reply", "rsp", "01 08 00 00 A5 37 DA 8D"),
            ("§6 example 3 (repeated for the error reply)", "req", "01 08 00 00 A5 37 DA 8D"),
            ("§6 example 3: error reply (prints FC 0x89, not 0x88)", "rsp", "01 89 01 86 50"),
        ],
    },
    "seed-erman-erg": {
        "serial": "38400 8N1",
        "source": "003_1fff8d2f1b2134c5.txt §6-§8 (ERMAN ER-G; 38400 8N1)",
        "frames": [
            ("§6 FC 01 read coils 0-11", "req", "01 01 00 00 00 0C 3C 0F"),
            ("§6 FC 01 reply", "rsp", "01 01 02 00 01 78 3C"),
            ("§6 FC 01 (repeated for the error reply)", "req", "01 01 00 00 00 0C 3C 0F"),
            ("§6 FC 01 error reply", "rsp", "01 81 03 00 51"),
            ("§6 FC 03 read holding registers 1-4", "req", "01 03 00 01 00 04 15 C9"),
            ("§6 FC 03 reply", "rsp", "01 03 08 01 00 01 F4 01 F4 00 32 25 C4"),
            ("§6 FC 03 (repeated for the error reply)", "req", "01 03 00 01 00 04 15 C9"),
            ("§6 FC 03 error reply", "rsp", "01 83 03 01 31"),
            ("§6 FC 04 read input registers 1-5 (CRC reused from FC 03)", "req", "01 04 00 01 00 05 15 C9"),
            ("§6 FC 04 reply (byte count 0x10 but 10 data bytes)", "rsp", "01 04 10 01 F4 00 00 00 D6 00 00 02 32 0A 03"),
            ("§6 FC 04 (repeated for the error reply)", "req", "01 04 00 01 00 05 15 C9"),
            ("§6 FC 04 error reply", "rsp", "01 84 03 03 01"),
            ("§7 FC 05 write coil 0 (START)", "req", "01 05 00 00 FF 00 8C 3A"),
            ("§7 FC 05 echo reply", "rsp", "01 05 00 00 FF 00 8C 3A"),
            ("§7 FC 05 (repeated for the error reply)", "req", "01 05 00 00 FF 00 8C 3A"),
            ("§7 FC 05 error reply", "rsp", "01 85 03 02 91"),
            ("§7 FC 06 write register 1 = 285 (28.5 Hz)", "req", "01 06 00 01 01 1D 19 93"),
            ("§7 FC 06 echo reply", "rsp", "01 06 00 01 01 1D 19 93"),
            ("§7 FC 06 (repeated for the error reply)", "req", "01 06 00 01 01 1D 19 93"),
            ("§7 FC 06 error reply", "rsp", "01 86 03 02 61"),
            ("§7 FC 0F write coils 0-8 (FAULT RESET + START)", "req", "01 0F 00 00 00 09 02 01 01 25 2C"),
            ("§7 FC 0F reply", "rsp", "01 0F 00 00 00 09 95 CD"),
            ("§7 FC 0F (repeated for the error reply)", "req", "01 0F 00 00 00 09 02 01 01 25 2C"),
            ("§7 FC 0F error reply", "rsp", "01 8F 03 04 31"),
            ("§7 FC 10 write registers 12-13 (accel 20.0 s, decel 40.0 s)", "req", "01 10 00 0C 00 02 04 00 C8 01 90 73 F8"),
            ("§7 FC 10 reply", "rsp", "01 10 00 0C 00 02 81 CB"),
            ("§7 FC 10 (repeated for the error reply)", "req", "01 10 00 0C 00 02 04 00 C8 01 90 73 F8"),
            ("§7 FC 10 error reply", "rsp", "01 90 03 0C 01"),
            ("§8 FC 08 diagnostics", "req", "01 08 00 00 A5 37 DA 8D"),
            ("§8 FC 08 echo reply", "rsp", "01 08 00 00 A5 37 DA 8D"),
            ("§8 FC 08 (repeated for the error reply)", "req", "01 08 00 00 A5 37 DA 8D"),
            ("§8 FC 08 error reply (prints FC 0x89, not 0x88)", "rsp", "01 89 01 86 50"),
        ],
    },
    "seed-e5-8200": {
        "serial": "19200 8E1",
        "source": "004_b52caedc7a1dba3d.txt RTU examples (E5-8200; 19200 8E1 is one of its settings)",
        "frames": [
            ("error-code table: exception reply of drive 2 (no request printed)", "rsp", "02 83 52 C0 CD"),
            ("FC 03 read 0x2523 (frequency setpoint)", "req", "01 03 25 23 00 01 7E CC"),
            ("FC 03 reply: 2000 = 20.00 Hz", "rsp", "01 03 02 07 D0 BB E8"),
            ("FC 03 (repeated for the error reply)", "req", "01 03 25 23 00 01 7E CC"),
            ("FC 03 error reply: vendor code 0x52 (address error)", "rsp", "01 83 52 C0 CD"),
            ("FC 08 loop-back", "req", "01 08 00 00 A5 37 DA 8D"),
            ("FC 08 echo reply", "rsp", "01 08 00 00 A5 37 DA 8D"),
            ("FC 08 (repeated for the error reply)", "req", "01 08 00 00 A5 37 DA 8D"),
            ("FC 08 error reply: code 0x20 (neither standard nor E5)", "rsp", "01 88 20 47 D8"),
            ("FC 06 write 0x2502 = 6000 (60.00 Hz)", "req", "01 06 25 02 17 70 2D 12"),
            ("FC 06 echo reply", "rsp", "01 06 25 02 17 70 2D 12"),
            ("FC 06 (repeated for the error reply)", "req", "01 06 25 02 17 70 2D 12"),
            ("FC 06 error reply: vendor code 0x52", "rsp", "01 86 52 C3 9D"),
            ("FC 10 write 0x2501-0x2502: run forward, 60.00 Hz", "req", "01 10 25 01 00 02 04 00 01 17 70 CB 26"),
            ("FC 10 reply", "rsp", "01 10 25 01 00 02 1B 04"),
            ("FC 10 (repeated for the error reply)", "req", "01 10 25 01 00 02 04 00 01 17 70 CB 26"),
            ("FC 10 error reply: vendor code 0x52", "rsp", "01 90 52 CD FD"),
        ],
    },
    "seed-danfoss-modbus": {
        "serial": "19200 8E1",
        "source": "002_03ee24b95404293a.txt §7.10 (Danfoss VLT AQUA, Modbus RTU; CRCs appended by us: the manual prints none)",
        "frames": [
            ("§7.10.1 FC 01 read coils 33-48 (status word)", "req", "01 01 00 20 00 10 3C 0C"),
            ("§7.10.1 reply", "rsp", "01 01 02 07 06 3B CE"),
            ("§7.10.2 FC 05 force coil 65 (write to EEPROM) ON", "req", "01 05 00 40 FF 00 8D EE"),
            ("§7.10.2 reply as printed (not the echo the text describes)", "rsp", "01 05 FF 00 00 01 3C 1E"),
            ("§7.10.3 FC 0F force coils 17-32 (reference)", "req", "01 0F 00 10 00 10 02 20 00 F9 70"),
            ("§7.10.3 reply", "rsp", "01 0F 00 10 00 10 55 C2"),
            ("§7.10.4 FC 03 read holding registers 0-2", "req", "01 03 00 00 00 03 05 CB"),
            ("§7.10.4 reply", "rsp", "01 03 06 55 AA 55 AA 55 AA BB AB"),
            ("§7.10.5 FC 06 preset register 1 = 3", "req", "01 06 00 01 00 03 98 0B"),
            ("§7.10.5 echo reply", "rsp", "01 06 00 01 00 03 98 0B"),
            ("§7.10.6 FC 10 preset registers 0x0419-0x041A: parameter 1-05 = 738", "req", "01 10 04 19 00 02 04 00 00 02 E2 81 20"),
            ("§7.10.6 reply", "rsp", "01 10 04 19 00 02 91 3F"),
        ],
    },
}

REPLY_DELAY_NS = 5_000_000
NEXT_REQUEST_NS = 100_000_000


def char_ns(serial):
    baud, fmt = serial.split()
    bits = 1 + int(fmt[0]) + (0 if fmt[1] == "N" else 1) + int(fmt[2])
    return round(bits * 1e9 / int(baud))


def main():
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "captures")
    for name, seed in SEEDS.items():
        ct = char_ns(seed["serial"])
        lines = [
            f"# Modbus RTU worked examples from {seed['source']}",
            "# Generated by scripts/make_seed_captures.py; bytes exactly as printed in the manual.",
            f"#! serial {seed['serial']}",
        ]
        t = 0
        for label, kind, hex_bytes in seed["frames"]:
            n = len(hex_bytes.split())
            lines.append(f"# {label}")
            lines.append(f"{ts(t)} bus {hex_bytes}")
            end = t + n * ct
            t = end + (max(REPLY_DELAY_NS, 6 * ct) if kind == "req" else NEXT_REQUEST_NS)
        os.makedirs(os.path.join(root, name), exist_ok=True)
        with open(os.path.join(root, name, "input.log"), "w") as f:
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
