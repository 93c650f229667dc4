#!/usr/bin/env python3
"""`drivetap fields` against Wireshark 4.0 and against what drivetap prints.

    tests/fields.py DRIVETAP list      # the listing, and each id against `tshark -G fields`
    tests/fields.py DRIVETAP json      # every id `read -T json` prints is listed, values fit
    tests/fields.py DRIVETAP values    # values of shared ids equal tshark's on the same frames

1. list: `drivetap fields` prints P and F lines as tshark does (8 columns, each F after its
   layer's P line); every id once. An id Wireshark has is that field: a compatible type, the same
   protocol. An id Wireshark lacks uses no Wireshark protocol's prefix other than modbus/mbrtu (the
   layers drivetap shares with it), and a drivetap layer's filter name is a Wireshark protocol only
   when it is the same protocol.
2. json: every key of a `fields` object in `read -T json` of every capture in captures/ (and of
   generated traffic and one frame pair of each public Modbus function) is listed, and its values
   have the listed type: an integer within the width and bitmask, a hex string, a string; the
   record fields (layer `drivetap`) are frame records' keys, each with values of its type; each
   drive.* id is in one unit, the one listed (`drive.<id>.unit`), also as `-e drive.<id>.unit`.
3. values: the Modbus frames written as pcapng (`decode -w`) and read by tshark: for each frame,
   each id both print has the same values in both.

Exit 0 when all hold; 77 (skipped) when tshark is missing and DRIVETAP_REQUIRE_TSHARK is unset.
"""
import glob
import json
import os
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# Layers drivetap shares with Wireshark: their ids may be Wireshark's, or drivetap's own beside.
SHARED_LAYERS = {"modbus", "mbrtu"}
# drivetap's JSON record key `fc` (the function code) is Wireshark's protocol name of Fibre
# Channel, which drivetap never decodes; the key is a stable JSON contract, kept as it is.
RECORD_KEYS_ALLOWED_AS_PROTOCOL = {"fc"}

UINT = {"FT_UINT8": 8, "FT_UINT16": 16, "FT_UINT24": 24, "FT_UINT32": 32, "FT_UINT64": 64}
TYPE_CLASS = {
    **{t: "uint" for t in UINT},
    "FT_BOOLEAN": "boolean",
    "FT_BYTES": "bytes",
    "FT_UINT_BYTES": "bytes",
    "FT_STRING": "string",
    "FT_STRINGZ": "string",
    "FT_UINT_STRING": "string",
    "FT_STRINGZPAD": "string",
    "FT_STRINGZTRUNC": "string",
    "FT_NONE": "none",
    "FT_PROTOCOL": "none",
    "FT_DOUBLE": "real",
    "FT_FLOAT": "real",
}

failures = []


def fail(what):
    failures.append(what)
    if len(failures) <= 30:
        print("FAIL:", what)


def run(args, **kw):
    return subprocess.run(args, capture_output=True, text=True, check=True, **kw).stdout


def crc16(data):
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return bytes([crc & 0xFF, crc >> 8])


# A request and its reply for each public function (Modbus Application Protocol V1.1b3 §6, the
# spec's examples where it has one), station 1, and an exception reply.
MODBUS_PAIRS = [
    ("01 0000 000A", "01 02 FF03"),
    ("02 00C4 0016", "02 03 ACDB35"),
    ("03 006B 0003", "03 06 022B 0000 0064"),
    ("04 0008 0001", "04 02 000A"),
    ("05 00AC FF00", "05 00AC FF00"),
    ("06 0001 0003", "06 0001 0003"),
    ("07", "07 6D"),
    ("08 0000 A537", "08 0000 A537"),
    ("0B", "0B FFFF 0108"),
    ("0C", "0C 08 0000 0108 0121 2000"),
    ("0F 0013 000A 02 CD01", "0F 0013 000A"),
    ("10 0001 0002 04 000A 0102", "10 0001 0002"),
    ("11", "11 05 0102 03FF 00"),
    ("14 0E 06 0004 0001 0002 06 0003 0009 0002", "14 0C 05 06 0DFE 0020 05 06 33CD 0040"),
    ("15 0D 06 0004 0007 0003 06AF 04BE 100D", "15 0D 06 0004 0007 0003 06AF 04BE 100D"),
    ("16 0004 00F2 0025", "16 0004 00F2 0025"),
    ("17 0003 0006 000E 0003 06 00FF 00FF 00FF", "17 0C 00FE 0ACD 0001 0003 000D 00FF"),
    ("18 04DE", "18 0006 0002 01B8 1284"),
    ("2B 0E 01 00", "2B 0E 01 01 00 00 03 00 03 436F6D 01 02 4142 02 03 56312E"),
    ("03 0001 0001", "83 02"),
]


def modbus_hex():
    frames = []
    for pair in MODBUS_PAIRS:
        for pdu in pair:
            adu = bytes([1]) + bytes.fromhex(pdu.replace(" ", ""))
            frames.append((adu + crc16(adu)).hex().upper())
    return "|".join(frames)


def drivetap_fields(drivetap):
    """{id: (name, type, layer, base, bitmask, blurb)}, checking the listing's form."""
    fields, layers = {}, {}
    layer = None
    for line in run([drivetap, "fields"]).splitlines():
        cols = line.split("\t")
        if cols[0] == "P":
            if len(cols) != 3:
                fail(f"P line of {len(cols)} columns: {line!r}")
                continue
            layer = cols[2]
            if layer in layers:
                fail(f"layer {layer} twice")
            layers[layer] = cols[1]
        elif cols[0] == "F":
            if len(cols) != 8:
                fail(f"F line of {len(cols)} columns: {line!r}")
                continue
            _, name, fid, ftype, proto, base, bitmask, blurb = cols
            if fid in fields:
                fail(f"id {fid} listed twice")
            if proto != layer:
                fail(f"{fid}: protocol {proto} is not the layer above it ({layer})")
            if not name or ftype not in TYPE_CLASS:
                fail(f"{fid}: name {name!r}, type {ftype}")
            fields[fid] = (name, ftype, proto, base, int(bitmask, 16), blurb)
        else:
            fail(f"line neither P nor F: {line!r}")
    if len(fields) < 80 or len(layers) != 7:
        fail(f"{len(fields)} fields in {len(layers)} layers: too few")
    return fields, layers


def tshark_available():
    if shutil.which("tshark"):
        return True
    if os.environ.get("DRIVETAP_REQUIRE_TSHARK") == "1":
        fail("tshark is required but missing")
        return True
    print("tshark not installed: skipped")
    return False


def check_list(drivetap):
    fields, layers = drivetap_fields(drivetap)
    ws_fields, ws_protocols = {}, {}
    for line in run(["tshark", "-G", "fields"]).splitlines():
        cols = line.split("\t")
        if cols[0] == "F" and len(cols) >= 5:
            ws_fields[cols[2]] = (cols[3], cols[4])
        elif cols[0] == "P" and len(cols) >= 3:
            ws_protocols[cols[2]] = cols[1]
    if "modbus.func_code" not in ws_fields:
        fail("tshark -G fields lists no modbus.func_code: not Wireshark 4.0?")
    for layer, name in layers.items():
        if layer in ws_protocols and (layer not in SHARED_LAYERS or ws_protocols[layer] != name):
            fail(f"layer {layer} ({name}) is Wireshark's protocol {ws_protocols[layer]}")
    shared = 0
    for fid, (_, ftype, proto, _, _, _) in fields.items():
        if fid in ws_fields:
            ws_type, ws_proto = ws_fields[fid]
            shared += 1
            if TYPE_CLASS.get(ws_type) != TYPE_CLASS[ftype]:
                fail(f"{fid}: type {ftype}, Wireshark's {ws_type}")
            if ws_proto != proto:
                fail(f"{fid}: protocol {proto}, Wireshark's {ws_proto}")
            continue
        if fid in ws_protocols and fid not in RECORD_KEYS_ALLOWED_AS_PROTOCOL:
            fail(f"{fid} is Wireshark's protocol {ws_protocols[fid]}")
        # Each dotted prefix of the id ("danfoss_fc", "danfoss_fc.pke") is no Wireshark
        # protocol or field, but in the layers drivetap shares with Wireshark.
        parts = fid.split(".")
        for i in range(1, len(parts)):
            prefix = ".".join(parts[:i])
            if parts[0] in SHARED_LAYERS and (i == 1 or prefix not in ws_fields):
                continue
            if prefix in ws_protocols or prefix in ws_fields:
                fail(f"{fid}: its prefix {prefix} is Wireshark's")
    if shared < 30:
        fail(f"only {shared} ids are Wireshark's")
    print(f"list: {len(fields)} fields in {len(layers)} layers, {shared} of them Wireshark's")


def json_inputs(drivetap, work):
    """(label, command) for every capture, generated traffic and the Modbus pairs."""
    inputs = []
    for d in sorted(glob.glob(os.path.join(ROOT, "captures", "*")) +
                    glob.glob(os.path.join(ROOT, "captures", "regressions", "*"))):
        found = sorted(glob.glob(os.path.join(d, "input.*")))
        if not found:
            continue
        args = []
        if os.path.exists(os.path.join(d, "args")):
            args = open(os.path.join(d, "args")).read().split()
        path = found[0]
        if path.endswith(".hex"):
            inputs.append((path, [drivetap, "decode", "-T", "json", *args, "-"], path))
        else:
            inputs.append((path, [drivetap, "read", "-T", "json", *args, path], None))
    log = os.path.join(work, "generated.log")
    run([drivetap, "generate", "--frames", "20000", "-o", log])
    inputs.append(("generated", [drivetap, "read", "-T", "json", log], None))
    inputs.append(("modbus pairs", [drivetap, "decode", "-T", "json", modbus_hex()], None))
    return inputs


def value_fits(value, ftype, bitmask):
    cls = TYPE_CLASS[ftype]
    if cls == "uint":
        limit = 1 << UINT[ftype]
        if bitmask:
            limit = (bitmask >> ((bitmask & -bitmask).bit_length() - 1)) + 1
        return isinstance(value, int) and 0 <= value < limit
    if cls == "boolean":
        return value in (0, 1)
    if cls == "bytes":
        return isinstance(value, str) and all(c in "0123456789ABCDEF" for c in value) and \
            len(value) % 2 == 0
    if cls == "string":
        return isinstance(value, str)
    return False  # a group or a real number has no place in `fields`


def record_value_fits(value, ftype, bitmask):
    """A frame record's key: as a field, or null where the frame has none (no function code in
    a Danfoss FC telegram, no latency measured)."""
    if value is None:
        return True
    if TYPE_CLASS[ftype] == "real":
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    return value_fits(value, ftype, bitmask)


def check_json(drivetap):
    fields, _ = drivetap_fields(drivetap)
    record_keys = {fid for fid, f in fields.items() if f[2] == "drivetap"}
    seen, seen_keys, seen_drive = set(), set(), set()
    # One unit per drive.* id: the listing's (`drive.<id>.unit`, "Always U"), none when unlisted.
    listed_unit = {fid[:-len(".unit")]: f[5].removeprefix("Always ") for fid, f in fields.items()
                   if fid.startswith("drive.") and fid.endswith(".unit")}
    units_seen = {}
    with tempfile.TemporaryDirectory() as work:
        for label, command, stdin in json_inputs(drivetap, work):
            cwd = os.path.dirname(label) if os.path.isabs(label) else None
            out = subprocess.run(command, capture_output=True, text=True, cwd=cwd,
                                 stdin=open(stdin) if stdin else subprocess.DEVNULL).stdout
            for line in out.splitlines():
                record = json.loads(line)
                if record.get("type") == "frame":
                    for key in record_keys & record.keys():
                        seen_keys.add(key)
                        ftype, bitmask = fields[key][1], fields[key][4]
                        if not record_value_fits(record[key], ftype, bitmask):
                            fail(f"{label}: frame {record.get('n')}: {key} = {record[key]!r} "
                                 f"is no {ftype}")
                drive = record.get("drive")
                if isinstance(drive, dict):  # the drive values: drive.<id>, of their kind
                    for vid, v in drive.get("values", {}).items():
                        fid = "drive." + vid
                        seen_drive.add(fid)
                        if isinstance(v.get("value"), (int, float)) and "raw" in v:
                            units_seen.setdefault(fid, set()).add(v.get("unit", ""))
                        if fid not in fields:
                            fail(f"{label}: frame {record.get('n')}: {fid} is not listed")
                        elif fields[fid][1] != "FT_STRING" and not isinstance(v["value"], (int, float)):
                            fail(f"{label}: frame {record.get('n')}: {fid} = {v['value']!r} is no {fields[fid][1]}")
                for fid, value in record.get("fields", {}).items():
                    seen.add(fid)
                    if fid not in fields:
                        fail(f"{label}: frame {record.get('n')}: {fid} is not listed")
                        continue
                    for v in value if isinstance(value, list) else [value]:
                        ftype, bitmask = fields[fid][1], fields[fid][4]
                        if not value_fits(v, ftype, bitmask):
                            fail(f"{label}: frame {record.get('n')}: {fid} = {v!r} is no {ftype}")
    for fid, units in sorted(units_seen.items()):
        if units != {listed_unit.get(fid, "")}:
            fail(f"{fid}: units {sorted(units)} in the JSON, listed {listed_unit.get(fid, '')!r}")
    for fid, unit in (("drive.output_frequency", "Hz"), ("drive.output_frequency_pct", "%"),
                      ("drive.setpoint", "Hz"), ("drive.setpoint_pct", "%"),
                      ("drive.output_current", "A"), ("drive.output_voltage", "V")):
        if listed_unit.get(fid) != unit or fid not in units_seen:
            fail(f"{fid}: listed in {listed_unit.get(fid)!r}, not {unit!r}, or never printed")
    # -e drive.<id>.unit: the listed unit beside each value, in every session capture.
    for session in sorted(glob.glob(os.path.join(ROOT, "captures", "session-*", "input.*"))):
        ids = ["drive.output_frequency", "drive.output_frequency_pct", "drive.setpoint",
               "drive.setpoint_pct", "drive.output_current"]
        args = [a for i in ids for a in ("-e", i, "-e", i + ".unit")]
        out = run([drivetap, "read", session, "-T", "fields", "-E", "separator=/t", *args])
        rows = 0
        for line in out.splitlines():
            cols = line.split("\t")
            for k, fid in enumerate(ids):
                value, unit = cols[2 * k], cols[2 * k + 1]
                if value and unit != listed_unit[fid] or not value and unit:
                    fail(f"{session}: {fid} = {value!r}, {fid}.unit = {unit!r}")
                rows += bool(value)
        if rows == 0:
            fail(f"{session}: no shared quantity with its unit")
    print(f"units: {len(units_seen)} drive.* ids each in one unit, the listed one")
    if len(seen) < 60:
        fail(f"only {len(seen)} ids printed over all inputs")
    if seen_keys != record_keys:
        fail(f"record fields no frame record has: {sorted(record_keys - seen_keys)}")
    if len(seen_drive) < 20:
        fail(f"only {len(seen_drive)} drive.* ids printed over all inputs")
    print(f"json: {len(seen)} ids printed, all listed; {len(seen_keys)} record keys of their type; "
          f"{len(seen_drive)} drive.* ids, all listed")


def tshark_frames(pcapng):
    """Per packet, {id: [values]} of Wireshark's modbus and mbrtu fields."""
    pdml = run(["tshark", "-o", "mbrtu.tcp.port:0", "-r", pcapng, "-T", "pdml"])
    packets = []
    for packet in ET.fromstring(pdml).findall("packet"):
        values = {}

        def walk(node):
            for f in node.findall("field"):
                name = f.get("name", "")
                if name.split(".")[0] in SHARED_LAYERS:
                    values.setdefault(name, []).append(f.get("show"))
                walk(f)

        for proto in packet.findall("proto"):
            if proto.get("name") in SHARED_LAYERS:
                walk(proto)
        packets.append(values)
    return packets


def same_value(ours, theirs, ftype):
    cls = TYPE_CLASS[ftype]
    if cls == "uint":
        return ours == int(theirs, 0)
    if cls == "bytes":
        return ours == theirs.replace(":", "").upper()
    return ours == theirs


def check_values(drivetap):
    fields, _ = drivetap_fields(drivetap)
    compared = 0
    with tempfile.TemporaryDirectory() as work:
        pcapng = os.path.join(work, "modbus.pcapng")
        out = run([drivetap, "decode", "--drive", "none", "-T", "json", "-w", pcapng,
                   modbus_hex()])
        ours = [json.loads(l) for l in out.splitlines()]
        ours = [r for r in ours if r.get("type") == "frame"]
        theirs = tshark_frames(pcapng)
        if len(theirs) != len(ours):
            fail(f"{len(ours)} frames, tshark read {len(theirs)} packets")
            return
        for record, ws in zip(ours, theirs):
            for fid, value in record["fields"].items():
                if fid not in ws:
                    continue
                # Wireshark 4.0 takes each Read File Record sub-response's data to the end of
                # the PDU: a known fault of its dissector, not drivetap's.
                if fid == "modbus.data" and record["fc"] == 0x14 and record["dir"] == "response":
                    continue
                mine = value if isinstance(value, list) else [value]
                ftype = fields[fid][1]
                if len(mine) != len(ws[fid]) or not all(
                        same_value(a, b, ftype) for a, b in zip(mine, ws[fid])):
                    fail(f"frame {record['n']}: {fid} = {mine}, Wireshark: {ws[fid]}")
                compared += 1
    if compared < 60:
        fail(f"only {compared} values compared with Wireshark's")
    print(f"values: {compared} field values equal Wireshark's")


def main():
    if len(sys.argv) != 3 or sys.argv[2] not in ("list", "json", "values"):
        print(__doc__)
        return 2
    drivetap, what = os.path.abspath(sys.argv[1]), sys.argv[2]
    if what == "json":
        check_json(drivetap)
    elif not tshark_available():
        return 77
    elif what == "list":
        check_list(drivetap)
    else:
        check_values(drivetap)
    if failures:
        print(f"{len(failures)} failures")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
