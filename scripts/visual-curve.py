#!/usr/bin/env python3
"""A model's SSIM against its output vertex count, the curve a visual target searches.

    scripts/visual-curve.py MODEL [--near N] [--bin build/release/client/vpremesh] [--flags "--threads 2"]

Counts: 100 x 1.2^k up to the input's vertex count and that count, and, with --near N, every
1% from 0.85 N to 1.15 N (where the bound is crossed, the score's noise
between close counts is what a search meets). The levels run as chains of at
most 16 (`vpremesh local --lod`, the front half shared: each level is the
same as a job at its count), each judged as the search judges a try:
`vpremesh eval --views 6` (the job's six 512-px views, mean SSIM of the
shaded renderings). Prints one line per count: `count ssim seconds`, the
last the back half's wall time per level (the chain's time over its levels'
counts, split in proportion to count). scripts/visual-search-sim.py replays
search policies on such curves.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def input_vertices(binary, model, flags):
    out = subprocess.run([binary, "local", model, "-n", "100", "-o", os.devnull + ".ply", "--json", *flags],
                         capture_output=True, text=True)
    try:
        return json.loads(out.stdout[out.stdout.index("{"):])["input"]["vertices"]
    except (ValueError, KeyError):
        sys.exit(f"cannot read the input's vertex count: {out.stderr.strip()}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model")
    ap.add_argument("--near", type=int, default=0, help="a count near where the bound is crossed")
    ap.add_argument("--bin", default="build/release/client/vpremesh")
    ap.add_argument("--flags", default="", help="extra flags for every vpremesh local")
    a = ap.parse_args()
    flags = a.flags.split()
    top = input_vertices(a.bin, a.model, flags)
    counts = set()
    c = 100.0
    while c <= top:
        counts.add(int(c))
        c *= 1.2
    if a.near:
        for i in range(-15, 16):
            counts.add(int(round(a.near * (1 + 0.01 * i))))
    counts.add(top)  # the search's top: a visual target never asks for more than the input has
    counts = sorted(n for n in counts if 100 <= n <= top)
    with tempfile.TemporaryDirectory() as work:
        for start in range(0, len(counts), 16):
            batch = counts[start:start + 16]
            out = os.path.join(work, "level.ply")
            t0 = time.time()
            subprocess.run([a.bin, "local", a.model, "--lod", ",".join(map(str, batch)), "-o", out, "--json", *flags],
                           check=True, capture_output=True)
            seconds = time.time() - t0
            for i, n in enumerate(batch):
                level = os.path.join(work, f"level.lod{i}.ply") if len(batch) > 1 else out
                ev = subprocess.run([a.bin, "eval", a.model, level, "--views", "6", "--samples", "1000", "--json"],
                                    check=True, capture_output=True, text=True)
                ssim = json.loads(ev.stdout)["visual"]["ssim_mean"]
                print(f"{n} {ssim:.6f} {seconds * n / sum(batch):.3f}", flush=True)


if __name__ == "__main__":
    main()
