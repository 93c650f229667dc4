#!/usr/bin/env python3
"""Converts sigrok ground-truth frame lists (*.frames.csv from ../shared/captures-external) into a
drivetap byte log: one line per frame at its exact start time (start_sample / sample rate), the
frame's bytes back to back.

usage: frames_csv_to_bytelog.py --serial "9600 8N1" --rate 4000000 [--note TEXT] \
           CSV:CHANNEL [CSV:CHANNEL ...] > input.log
"""
import argparse
import csv


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--serial", required=True)
    ap.add_argument("--rate", type=int, required=True, help="logic analyser sample rate, Hz")
    ap.add_argument("--note", action="append", default=[])
    ap.add_argument("inputs", nargs="+", help="CSV:CHANNEL")
    args = ap.parse_args()
    rows = []
    for spec in args.inputs:
        path, channel = spec.rsplit(":", 1)
        with open(path, newline="") as f:
            for r in csv.DictReader(f):
                ns = int(r["start_sample"]) * 1_000_000_000 // args.rate
                rows.append((ns, channel, r["hex"].upper()))
    rows.sort()
    for note in args.note:
        print(f"# {note}")
    print(f"#! serial {args.serial}")
    for ns, channel, hexstr in rows:
        spaced = " ".join(hexstr[i:i + 2] for i in range(0, len(hexstr), 2))
        print(f"{ns // 1_000_000_000}.{ns % 1_000_000_000:09d} {channel} {spaced}")


if __name__ == "__main__":
    main()
