#!/usr/bin/env python3
"""The median of each step's time over runs, from the "steps <scope>: ..."
lines a job prints with VPREMESH_STEP_MARKS=1 (worker/core/step_marks.h).

    VPREMESH_STEP_MARKS=1 vpremesh-bench ... 2>marks.log
    scripts/step-marks.py marks.log [--skip N] [--label TEXT]

A step named more than once in a line (a loop's passes) counts as its sum
there. --skip N leaves out each scope's first N lines (a warm-up run).
Prints one Markdown table per scope: step, median ms, min-max, runs.
"""
import argparse
import collections
import statistics
import sys


def parse(lines):
    """Per scope, a list of {step: ms} (one per line)."""
    runs = collections.defaultdict(list)
    for line in lines:
        if not line.startswith("steps "):
            continue
        scope, _, rest = line[len("steps "):].partition(":")
        steps = collections.OrderedDict()
        for part in rest.split(";"):
            words = part.split()
            if len(words) != 2:
                continue
            try:
                ms = float(words[1])
            except ValueError:
                continue
            steps[words[0]] = steps.get(words[0], 0.0) + ms
        if steps:
            runs[scope.strip()].append(steps)
    return runs


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("log", nargs="?", default="-")
    ap.add_argument("--skip", type=int, default=0)
    ap.add_argument("--label", default="")
    args = ap.parse_args()
    stream = sys.stdin if args.log == "-" else open(args.log, errors="replace")
    runs = parse(stream)
    for scope, rows in runs.items():
        rows = rows[args.skip:]
        if not rows:
            continue
        order = []
        for r in rows:
            for step in r:
                if step not in order:
                    order.append(step)
        print(f"\n{args.label}{scope} ({len(rows)} runs)\n")
        print("| step | median ms | min-max |")
        print("|---|---:|---:|")
        total = []
        for step in order:
            values = [r.get(step, 0.0) for r in rows]
            print(f"| {step} | {statistics.median(values):.2f} | {min(values):.2f}-{max(values):.2f} |")
        for r in rows:
            total.append(sum(r.values()))
        print(f"| (sum) | {statistics.median(total):.2f} | {min(total):.2f}-{max(total):.2f} |")


if __name__ == "__main__":
    main()
