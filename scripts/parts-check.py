#!/usr/bin/env python3
"""Issue 19, part 3: a model made of many parts keeps every part.

Builds the issue's kit (spot placed 27 times on a 3 x 3 x 3 grid, nine copies
each at sizes 1, 0.3 and 0.08), remeshes it with `vpremesh local`, splits the
output into connected parts, matches each to the input part whose bounding box
holds its centre, and judges each pair with `vpremesh eval` (mean Hausdorff in
units of the input part's bounding-box diagonal). Prints one row per part and
a summary; exits 1 when a part is lost, open, or above the bound.

  scripts/parts-check.py [--vpremesh build/release/client/vpremesh]
                         [--model ../shared/models/spot.obj] [--target 10000]
                         [--bound 0.02] [--work /tmp/parts-check]
"""
import argparse
import json
import os
import subprocess
import sys

SIZES = (1.0, 0.3, 0.08)


def read_obj(path):
    verts, faces = [], []
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == "v":
                verts.append(tuple(float(x) for x in t[1:4]))
            elif t[0] == "f":
                idx = [int(s.split("/")[0]) for s in t[1:]]
                idx = [i - 1 if i > 0 else len(verts) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    faces.append((idx[0], idx[k], idx[k + 1]))
    return verts, faces


def write_obj(path, verts, faces):
    with open(path, "w") as f:
        for v in verts:
            f.write("v %.17g %.17g %.17g\n" % v)
        for a, b, c in faces:
            f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))


def parts(verts, faces):
    """Connected parts (through shared vertices): list of (vertex list, face list)."""
    parent = list(range(len(verts)))

    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b, c in faces:
        for u, w in ((a, b), (b, c)):
            ru, rw = find(u), find(w)
            if ru != rw:
                parent[max(ru, rw)] = min(ru, rw)
    groups = {}
    for fi, (a, b, c) in enumerate(faces):
        groups.setdefault(find(a), []).append(fi)
    out = []
    for root in sorted(groups):
        fs = groups[root]
        remap = {}
        pv, pf = [], []
        for fi in fs:
            tri = []
            for v in faces[fi]:
                if v not in remap:
                    remap[v] = len(pv)
                    pv.append(verts[v])
                tri.append(remap[v])
            pf.append(tuple(tri))
        out.append((pv, pf))
    return out


def boundary_edges(faces):
    count = {}
    for a, b, c in faces:
        for u, w in ((a, b), (b, c), (c, a)):
            e = (min(u, w), max(u, w))
            count[e] = count.get(e, 0) + 1
    return sum(1 for n in count.values() if n == 1)


def bbox(verts):
    lo = [min(v[i] for v in verts) for i in range(3)]
    hi = [max(v[i] for v in verts) for i in range(3)]
    return lo, hi


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--vpremesh", default="build/release/client/vpremesh")
    p.add_argument("--model", default="../shared/models/spot.obj")
    p.add_argument("--target", type=int, default=10000)
    p.add_argument("--bound", type=float, default=0.02)
    p.add_argument("--work", default="/tmp/parts-check")
    a = p.parse_args()
    os.makedirs(a.work, exist_ok=True)

    base, tris = read_obj(a.model)
    lo, hi = bbox(base)
    centre = [(lo[i] + hi[i]) / 2 for i in range(3)]
    extent = max(hi[i] - lo[i] for i in range(3))
    verts, faces = [], []
    inputs = []  # (size, part vertices, part faces)
    k = 0
    for i in range(3):
        for j in range(3):
            for l in range(3):
                s = SIZES[k % 3]
                k += 1
                at = (i * 1.5 * extent, j * 1.5 * extent, l * 1.5 * extent)
                pv = [tuple(at[d] + s * (v[d] - centre[d]) for d in range(3)) for v in base]
                first = len(verts)
                verts += pv
                faces += [(first + x, first + y, first + z) for x, y, z in tris]
                inputs.append((s, pv, tris))
    kit = os.path.join(a.work, "kit.obj")
    write_obj(kit, verts, faces)
    out = os.path.join(a.work, "kit-out.obj")
    run = subprocess.run([a.vpremesh, "local", kit, "-n", str(a.target), "-o", out],
                         capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit("vpremesh local failed: " + run.stderr)
    ov, of = read_obj(out)
    got = parts(ov, of)
    print("input: %d vertices, %d parts; output: %d vertices (target %d), %d parts"
          % (len(verts), len(inputs), len(ov), a.target, len(got)))

    matched = {}
    for pv, pf in got:
        plo, phi = bbox(pv)
        c = [(plo[d] + phi[d]) / 2 for d in range(3)]
        for n, (s, iv, _) in enumerate(inputs):
            ilo, ihi = bbox(iv)
            if all(ilo[d] <= c[d] <= ihi[d] for d in range(3)):
                matched.setdefault(n, []).append((pv, pf))
                break
    print("| part | size | output parts | vertices | boundary edges | mean Hausdorff (part diag) |")
    print("|---:|---:|---:|---:|---:|---:|")
    bad = 0
    worst = 0.0
    for n, (s, iv, itris) in enumerate(inputs):
        pieces = matched.get(n, [])
        if len(pieces) != 1:
            print("| %d | %g | %d | - | - | - |" % (n, s, len(pieces)))
            bad += 1
            continue
        pv, pf = pieces[0]
        ref = os.path.join(a.work, "in-%02d.obj" % n)
        cand = os.path.join(a.work, "out-%02d.obj" % n)
        write_obj(ref, iv, itris)
        write_obj(cand, pv, pf)
        e = subprocess.run([a.vpremesh, "eval", "--no-visual", "--json", ref, cand],
                           capture_output=True, text=True)
        if e.returncode != 0:
            sys.exit("vpremesh eval failed: " + e.stderr)
        mean = json.loads(e.stdout)["hausdorff"]["mean"]
        open_edges = boundary_edges(pf)
        worst = max(worst, mean)
        if open_edges or mean > a.bound:
            bad += 1
        print("| %d | %g | 1 | %d | %d | %.5f |" % (n, s, len(pv), open_edges, mean))
    print("\n%d of %d parts closed and within %.3g of their diagonal; worst mean Hausdorff %.5f"
          % (len(inputs) - bad, len(inputs), a.bound, worst))
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
