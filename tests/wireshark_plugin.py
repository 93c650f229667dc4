#!/usr/bin/env python3
"""drivetap's Wireshark plugin against tshark 4.0 on a capture of all four protocols.

    tests/wireshark_plugin.py DRIVETAP

Generated traffic (Modbus RTU, Danfoss FC, Easydrive, Modbus ASCII, with bad checksums) written
with `read -w`, the plugin installed with `drivetap wireshark --install` into a temporary HOME
(and equal to `--print-plugin`), then with tshark:
1. each protocol's filter selects exactly the frames drivetap says are that protocol;
2. every field id that occurs (fields of the tree, drive.*) has in `tshark -T fields -e ID` the
   values `drivetap read -T fields -e ID` gives (numbers compared as numbers: Wireshark spells a
   hex field 0x.., a double without trailing zeros);
3. bad checksums are expert errors (`_ws.expert.severity`) and `drivetap.checksum_bad`;
4. a Danfoss FC packet is its telegram and at most 32 bytes of tags; its tree has drivetap's
   shape, and its AK is labelled by the telegram's direction;
5. without the plugin (empty HOME) the file opens and each packet comment starts with the decode;
6. `--dlt user0` on a Danfoss FC bus is refused with one line, exit 2;
7. findings held while a drive's family was not yet sure (captures/session-e9) reach the pcapng:
   each of the text output's held lines is in the comment of a packet written at or after the
   frame it names (its own packet was written before the finding was handed on).

Exit 0 when all hold; 77 (skipped) when tshark is missing and DRIVETAP_REQUIRE_TSHARK is unset.
"""
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
failures = []

PROTOCOLS = {"modbus-rtu": "mbrtu", "danfoss-fc": "danfoss_fc", "easydrive": "easydrive",
             "modbus-ascii": "mbascii"}
NUMERIC = ("FT_UINT", "FT_INT", "FT_BOOLEAN", "FT_DOUBLE")


def fail(what):
    failures.append(what)
    print("FAIL:", what)


def run(args, env=None, check=True):
    p = subprocess.run(args, capture_output=True, text=True, env=env)
    if check and p.returncode != 0:
        raise SystemExit(f"{' '.join(args)}: exit {p.returncode}: {p.stderr.strip()}")
    return p


def tshark(home, capture, *args):
    env = dict(os.environ, HOME=home)
    env.pop("XDG_CONFIG_HOME", None)
    return run(["tshark", "-r", capture, *args], env=env).stdout


def rows(text):
    return [line.split("\t") for line in text.splitlines()]


def number(text):
    try:
        return int(text, 0)
    except ValueError:
        return float(text)


def same(mine, theirs, ftype):
    if mine == theirs:
        return True
    a, b = mine.split(","), theirs.split(",")
    if len(a) != len(b):
        return False
    if ftype.startswith(NUMERIC):
        try:
            return all(abs(number(x) - number(y)) <= 1e-9 * max(1, abs(number(x)))
                       for x, y in zip(a, b))
        except ValueError:
            return False
    if ftype == "FT_BYTES":
        return all(x.replace(":", "").lower() == y.replace(":", "").lower() for x, y in zip(a, b))
    return False


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    drivetap = os.path.abspath(sys.argv[1])
    if not shutil.which("tshark"):
        if os.environ.get("DRIVETAP_REQUIRE_TSHARK"):
            print("tshark is missing")
            return 1
        return 77
    with tempfile.TemporaryDirectory() as work:
        home, empty = os.path.join(work, "home"), os.path.join(work, "empty")
        os.makedirs(home)
        os.makedirs(empty)
        log, capture = os.path.join(work, "bus.log"), os.path.join(work, "bus.pcapng")
        run([drivetap, "generate", "--frames", "3000", "--seed", "5", "-o", log])
        run([drivetap, "read", log, "-q", "-w", capture])

        # The plugin: installed = printed, both generated from the tables.
        env = dict(os.environ, HOME=home)
        installed = run([drivetap, "wireshark", "--install"], env=env).stdout
        printed = run([drivetap, "wireshark", "--print-plugin"]).stdout
        want = os.path.join(home, ".local/lib/wireshark/plugins/drivetap.lua")
        if f"installed {want}\n" not in installed or open(want).read() != printed:
            fail(f"--install said {installed!r}, not --print-plugin's text at {want}")
        err = run(["tshark", "-G", "protocols"], env=env).stderr
        if "Lua" in err or "error" in err.lower():
            fail(f"the plugin does not load: {err.strip()}")

        # drivetap's view of the capture, read back.
        listing = run([drivetap, "fields"]).stdout
        ftypes = {c[2]: c[3] for c in rows(listing) if c[0] == "F"}
        json_lines = run([drivetap, "read", capture, "-T", "json", "--no-summary"]).stdout
        import json
        records = [json.loads(l) for l in json_lines.splitlines()]
        frames = [r for r in records if r.get("type") == "frame"]
        ids = set()
        for r in frames:
            if PROTOCOLS.get(r["protocol"]) != "mbrtu":  # Wireshark's own dissector: fields.py
                ids.update(r.get("fields", {}).keys())
            drive = r.get("drive")
            if isinstance(drive, dict):
                ids.update("drive." + k for k in drive.get("values", {}))
                ids.update("drive." + k for k in ("station", "family") if k in drive)
        for k in list(ids):
            if k.startswith("drive.") and k not in ftypes:
                ftypes[k] = "FT_STRING" if k in ("drive.family", "drive.direction",
                                                 "drive.fault_name") else "FT_DOUBLE"

        # 1. each protocol's filter selects drivetap's frames of it.
        packets = rows(tshark(home, capture, "-T", "fields", "-e", "frame.number", "-e",
                              "frame.comment"))
        for proto_id, name in PROTOCOLS.items():
            ours = {r["n"] for r in frames if r["protocol"] == proto_id}
            numbers = run([drivetap, "read", capture, "-Y", f'protocol == "{proto_id}"', "-T",
                           "fields", "-e", "n"]).stdout.split()
            if {int(n) for n in numbers} != ours or not ours:
                fail(f"{proto_id}: -Y protocol gives other frames than the JSON")
            theirs = tshark(home, capture, "-Y", name, "-T", "fields", "-e",
                            "frame.number").split()
            # (Packet numbers are drivetap's frame numbers: one packet per frame or noise.)
            if {int(n) for n in theirs} != ours:
                fail(f"tshark -Y {name}: {len(theirs)} packets, drivetap: {len(ours)} frames "
                     f"(first differing: {sorted(set(map(int, theirs)) ^ ours)[:5]})")
        print(f"protocols: {len(frames)} frames of {len(PROTOCOLS)} protocols, "
              f"{len(packets)} packets")

        # 2. every id's values, frame by frame.
        ordered = sorted(ids)
        protocol_of = {r["n"]: r["protocol"] for r in frames}
        compared = 0
        for at in range(0, len(ordered), 40):
            chunk = ordered[at:at + 40]
            args = ["-T", "fields", "-E", "separator=/t", "-E", "aggregator=,"]
            fields_args = [a for i in chunk for a in ("-e", i)]
            mine = rows(run([drivetap, "read", capture, *args, "-e", "n", *fields_args]).stdout)
            theirs = {int(r[0]): r[1:] for r in rows(
                tshark(home, capture, *args, "-e", "frame.number", *fields_args))}
            for row in mine:
                n = int(row[0])
                rtu = protocol_of.get(n) == "modbus-rtu"
                if n not in theirs:
                    fail(f"frame {n}: no packet in tshark's output")
                    continue
                for i, fid in enumerate(chunk):
                    a, b = row[1 + i], theirs[n][i]
                    if not a and not b:
                        continue
                    if rtu and not fid.startswith("drive."):
                        continue  # Wireshark's own mbrtu and modbus: tests/fields.py
                    if not same(a, b, ftypes.get(fid, "FT_STRING")):
                        fail(f"frame {n}: {fid} = {a!r}, tshark: {b!r}")
                    compared += 1
        if compared < 1000 or len(ids) < 20:
            fail(f"only {compared} values of {len(ids)} ids compared")
        print(f"fields: {compared} values of {len(ids)} ids equal")

        # 3. bad checksums: expert errors.
        bad = {int(n) for n in run([drivetap, "read", capture, "-Y", "checksum_bad", "-T",
                                    "fields", "-e", "n"]).stdout.split()}
        flagged = {int(r[0]): r[1] for r in rows(tshark(
            home, capture, "-Y", "drivetap.checksum_bad", "-T", "fields", "-e", "frame.number",
            "-e", "_ws.expert.severity"))}
        if set(flagged) != bad or not bad:
            fail(f"bad checksums: drivetap {len(bad)} frames, tshark {len(flagged)} packets")
        error = str(8388608)  # PI_ERROR
        if any(error not in s.split(",") for s in flagged.values()):
            fail("a bad checksum is not an expert error")
        print(f"checksums: {len(bad)} bad, each an expert error")

        # 4. lean packets: a Danfoss FC packet is its telegram and a few bytes of tags.
        sizes = rows(tshark(home, capture, "-Y", "danfoss_fc", "-T", "fields", "-e", "frame.len",
                            "-e", "exported_pdu.exported_pdu"))
        tags = {int(length) - len(payload.replace(":", "")) // 2 for length, payload in sizes}
        if not tags or max(tags) > 32:
            fail(f"Danfoss FC packets carry {sorted(tags)} bytes of tags (at most 32 expected)")
        print(f"packet size: a Danfoss FC packet is its telegram + {sorted(tags)} bytes of tags")

        # 4b. the field tree has drivetap's shape (-V's indentation): each field under its parent.
        import re
        import xml.etree.ElementTree as ET
        plugin_protos = {name for proto_id, name in PROTOCOLS.items() if name != "mbrtu"}
        shapes = {}  # frame number -> [(id, depth)] of drivetap -V
        current = None
        for line in run([drivetap, "read", capture, "-V"]).stdout.splitlines():
            head = re.match(r"^ *(\d+) +\d+\.\d+ ", line)
            if head:
                current = shapes.setdefault(int(head.group(1)), [])
                continue
            node = re.match(r"^        \[[^\]]*\]( +)(\S+)", line)
            if node and current is not None:
                current.append((node.group(2), node.start(2)))
        for n, nodes in shapes.items():
            if nodes:
                top = min(col for _, col in nodes)
                shapes[n] = [(fid, (col - top) // 2) for fid, col in nodes]
        pdml = tshark(home, capture, "-Y", " || ".join(sorted(plugin_protos)), "-T", "pdml")
        checked = nested = 0
        for packet in ET.fromstring(pdml).iter("packet"):
            number = int(next(f.get("show") for f in packet.iter("field")
                              if f.get("name") == "frame.number"))
            theirs = []

            def walk(element, depth):
                for child in element.findall("field"):
                    theirs.append((child.get("name"), depth))
                    walk(child, depth + 1)
            for proto in packet.findall("proto"):
                if proto.get("name") in plugin_protos:
                    walk(proto, 0)
            if theirs != shapes.get(number):
                fail(f"packet {number}: tree {theirs[:6]}..., drivetap -V {shapes.get(number, [])[:6]}...")
                break
            checked += 1
            nested += any(depth > 0 for _, depth in theirs)
        if checked < 100 or nested == 0:
            fail(f"tree shape: only {checked} packets ({nested} with nested fields) compared")
        print(f"tree: {checked} packets have drivetap's field tree ({nested} nested)")

        # 4c. a field whose meaning depends on the direction (Danfoss FC's AK) is labelled by the
        # telegram's direction: "Request (AK)" on a request, "Response (AK)" on a reply.
        direction = {r["n"]: r.get("dir") for r in frames}
        labels = {"request": "Request (AK)", "response": "Response (AK)"}
        seen = {}
        for packet in ET.fromstring(pdml).iter("packet"):
            number = int(next(f.get("show") for f in packet.iter("field")
                              if f.get("name") == "frame.number"))
            for f in packet.iter("field"):
                if f.get("name") != "danfoss_fc.pke.ak":
                    continue
                want = labels.get(direction.get(number))
                label = f.get("showname", "")
                seen[direction.get(number)] = seen.get(direction.get(number), 0) + 1
                if not want or want not in label:
                    fail(f"packet {number} ({direction.get(number)}): AK labelled {label!r}")
        if not seen.get("request") or not seen.get("response"):
            fail(f"AK labels: only {seen} packets with an AK")
        print(f"AK: labelled by direction on {seen} packets")

        # 5. without the plugin: opens, each comment starts with the decode.
        stock = rows(tshark(empty, capture, "-T", "fields", "-e", "frame.number", "-e",
                            "frame.comment"))
        summaries = run([drivetap, "read", capture, "-T", "fields", "-E", "separator=/t", "-e",
                         "n", "-e", "summary"]).stdout
        decode = {int(r[0]): r[1] for r in rows(summaries)}
        if len(stock) != len(packets):
            fail(f"without the plugin tshark reads {len(stock)} packets, not {len(packets)}")
        for number_text, comment in stock:
            n = int(number_text)
            if n in decode and not comment.startswith(decode[n]):
                fail(f"packet {n} without the plugin: comment {comment[:60]!r}")
                break
        print(f"without the plugin: {len(stock)} packets, comments carry the decode")

        # 6. --dlt user0 on a Danfoss FC bus: one line, exit 2.
        fc = os.path.join(ROOT, "captures", "seed-danfoss-fc", "input.log")
        for extra in ([], ["-P", "fc"]):
            out = os.path.join(work, "user0.pcapng")
            p = run([drivetap, "read", fc, "-q", "--dlt", "user0", "-w", out, *extra],
                    check=False)
            lines = p.stderr.strip().splitlines()
            if p.returncode != 2 or len(lines) != 1 or "--dlt user0" not in lines[0] \
                    or "Danfoss FC" not in lines[0]:
                fail(f"--dlt user0 {extra}: exit {p.returncode}, stderr {p.stderr!r}")
            if extra and os.path.exists(out):
                fail("--dlt user0 -P fc: the file was made before the refusal")
            if os.path.exists(out):
                os.remove(out)
        print("--dlt user0: refused")

        # 7. held findings in the pcapng, as in the text.
        e9 = os.path.join(ROOT, "captures", "session-e9", "input.log")
        held_pcapng = os.path.join(work, "held.pcapng")
        text = run([drivetap, "read", e9, "-w", held_pcapng]).stdout
        held = [line.split("!!!  ", 1)[1] for line in text.splitlines()
                if "!!!  " in line and "held while drive" in line]
        comments = rows(tshark(empty, held_pcapng, "-T", "fields", "-e", "frame.number", "-e",
                               "frame.comment"))
        if not held:
            fail("session-e9: no held finding in the text: the check proves nothing")
        for finding in held:
            frame = int(finding.split("(#", 1)[1].split(",", 1)[0])
            carriers = [int(n) for n, c in comments if finding in c]
            if not carriers or carriers[0] < frame:
                fail(f"held finding {finding[:70]!r}: in packets {carriers}, frame #{frame}")
        print(f"held findings: {len(held)} in the text, each in a packet comment")
    if failures:
        print(f"{len(failures)} failures")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
