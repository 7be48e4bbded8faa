#!/usr/bin/env python3
"""Generated shapes that real assets resemble at their worst, remeshed and judged.

Each shape is written as an OBJ, remeshed with `vpremesh local` at a few
targets, and judged with `vpremesh eval --no-visual`: the output must keep
the input's topology after welding (closed stays closed, as many boundary
loops and sheets), be 2-manifold, have the asked vertex count within 2%, and
lie within BOUND of the input's bounding-box diagonal (mean Hausdorff).
Prints one row per case; exits 1 when any case fails.

  scripts/stress-shapes.py [--vpremesh build/release/client/vpremesh]
                           [--targets 300,3000] [--work /tmp/stress-shapes]
                           [--only NAME,...] [--bound 0.01]
"""
import argparse
import json
import math
import os
import subprocess
import sys

import numpy as np


def grid_sphere(n=48, r=1.0):
    """UV sphere, closed, poles welded."""
    verts = [(0.0, 0.0, r)]
    for i in range(1, n):
        t = math.pi * i / n
        for j in range(2 * n):
            p = 2 * math.pi * j / (2 * n)
            verts.append((r * math.sin(t) * math.cos(p), r * math.sin(t) * math.sin(p), r * math.cos(t)))
    verts.append((0.0, 0.0, -r))
    m = 2 * n
    idx = lambda i, j: 1 + (i - 1) * m + (j % m)
    faces = []
    for j in range(m):
        faces.append((0, idx(1, j), idx(1, j + 1)))
    for i in range(1, n - 1):
        for j in range(m):
            a, b, c, d = idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1)
            faces += [(a, c, b), (b, c, d)]
    last = len(verts) - 1
    for j in range(m):
        faces.append((idx(n - 1, j), last, idx(n - 1, j + 1)))
    return np.array(verts), np.array(faces)


def box(sx, sy, sz, n=40):
    """Closed box made of n x n quads per side (split), sizes sx, sy, sz."""
    verts, faces, key = [], [], {}

    def vid(p):
        k = tuple(round(c, 9) for c in p)
        if k not in key:
            key[k] = len(verts)
            verts.append(k)
        return key[k]

    for axis in range(3):
        for side in (-1, 1):
            u, v = [a for a in range(3) if a != axis]
            for i in range(n):
                for j in range(n):
                    quad = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = side * 0.5
                        p[u] = -0.5 + (i + di) / n
                        p[v] = -0.5 + (j + dj) / n
                        quad.append(vid(p))
                    if side < 0:
                        quad.reverse()
                    a, b, c, d = quad
                    faces += [(a, b, c), (a, c, d)]
    v = np.array(verts) * np.array([sx, sy, sz])
    f = np.array(faces)
    # Orient outward: the normal of each face against its centre.
    p = v[f]
    nrm = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flip = (nrm * p.mean(axis=1)).sum(axis=1) < 0
    f[flip] = f[flip][:, ::-1]
    return v, f


def torus(R=1.0, r=0.3, nu=96, nv=32):
    verts = []
    for i in range(nu):
        u = 2 * math.pi * i / nu
        for j in range(nv):
            w = 2 * math.pi * j / nv
            verts.append(((R + r * math.cos(w)) * math.cos(u), (R + r * math.cos(w)) * math.sin(u), r * math.sin(w)))
    faces = []
    for i in range(nu):
        for j in range(nv):
            a, b = i * nv + j, ((i + 1) % nu) * nv + j
            c, d = i * nv + (j + 1) % nv, ((i + 1) % nu) * nv + (j + 1) % nv
            faces += [(a, b, d), (a, d, c)]
    return np.array(verts), np.array(faces)


def cylinder(length, radius, nu=32, nl=400):
    """Closed thin rod along x, capped with fans."""
    verts = []
    for i in range(nl + 1):
        x = -length / 2 + length * i / nl
        for j in range(nu):
            w = 2 * math.pi * j / nu
            verts.append((x, radius * math.cos(w), radius * math.sin(w)))
    faces = []
    for i in range(nl):
        for j in range(nu):
            a, b = i * nu + j, i * nu + (j + 1) % nu
            c, d = (i + 1) * nu + j, (i + 1) * nu + (j + 1) % nu
            faces += [(a, c, d), (a, d, b)]
    c0 = len(verts)
    verts.append((-length / 2, 0, 0))
    c1 = len(verts)
    verts.append((length / 2, 0, 0))
    for j in range(nu):
        faces.append((c0, j, (j + 1) % nu))
        a, b = nl * nu + j, nl * nu + (j + 1) % nu
        faces.append((c1, b, a))
    return np.array(verts), np.array(faces)


def revolve(profile, nu=96):
    """Closed surface of revolution about z: profile is (radius, z) from the bottom
    pole to the top pole (radius 0 at both ends)."""
    prof = list(profile)
    verts = [(0.0, 0.0, prof[0][1])]
    for r, z in prof[1:-1]:
        for j in range(nu):
            a = 2 * math.pi * j / nu
            verts.append((r * math.cos(a), r * math.sin(a), z))
    verts.append((0.0, 0.0, prof[-1][1]))
    rings = len(prof) - 2
    ring = lambda i, j: 1 + i * nu + (j % nu)
    faces = [(0, ring(0, j + 1), ring(0, j)) for j in range(nu)]
    for i in range(rings - 1):
        for j in range(nu):
            a, b, c, d = ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1)
            faces += [(a, b, d), (a, d, c)]
    top = len(verts) - 1
    faces += [(top, ring(rings - 1, j), ring(rings - 1, j + 1)) for j in range(nu)]
    return np.array(verts), np.array(faces)


def cup(wall=0.02, n=60):
    """A closed cup (a solid of revolution with thin walls): outer bottom, outer
    wall, rim, inner wall, inner bottom; height 1, radius 0.4."""
    pts = [(0.0, 0.0)]
    pts += [(0.4 * i / n, 0.0) for i in range(1, n)]
    pts += [(0.4, 1.0 * i / n) for i in range(n + 1)]
    pts += [(0.4 - wall * 0.5 * (1 - math.cos(math.pi * i / 8)), 1.0 + wall * 0.5 * math.sin(math.pi * i / 8))
            for i in range(1, 8)]
    pts += [(0.4 - wall, 1.0 - (1.0 - wall) * i / n) for i in range(n + 1)]
    pts += [((0.4 - wall) * (1 - i / n), wall) for i in range(1, n)]
    pts += [(0.0, wall)]
    # The profile runs bottom pole -> rim -> inner bottom pole: z is not monotone,
    # so the inner pole sits above the outer one at height `wall`.
    return revolve(pts)


def dumbbell(neck=0.01, n=200):
    """Two balls of radius 0.25 joined by a neck of radius `neck`, length 2."""
    pts = []
    for i in range(n + 1):
        z = -1.0 + 2.0 * i / n
        d = min(abs(z + 0.75), abs(z - 0.75))
        ball = math.sqrt(max(0.0, 0.25 ** 2 - d * d)) if d < 0.25 else 0.0
        r = max(ball, neck) if -1.0 < z < 1.0 and not (abs(z) > 0.75 and d >= 0.25) else ball
        pts.append((r, z))
    pts[0] = (0.0, -1.0)
    pts[-1] = (0.0, 1.0)
    return revolve(pts)


def holes(v, f, count, radius, seed):
    """Cuts `count` round holes: faces with a corner within radius of a random vertex go."""
    rng = np.random.default_rng(seed)
    centres = v[rng.choice(len(v), count, replace=False)]
    d = np.min(np.linalg.norm(v[:, None, :] - centres[None, :, :], axis=2), axis=1)
    keep = ~(d[f] < radius).any(axis=1)
    return v, f[keep]


def concat(*meshes):
    vs, fs, off = [], [], 0
    for v, f in meshes:
        vs.append(v)
        fs.append(f + off)
        off += len(v)
    return np.vstack(vs), np.vstack(fs)


def plane(n=100):
    xs = np.linspace(-1, 1, n + 1)
    v = np.array([(x, y, 0.05 * math.sin(3 * x) * math.cos(2 * y)) for y in xs for x in xs])
    f = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            f += [(a, a + 1, a + n + 2), (a, a + n + 2, a + n + 1)]
    return v, np.array(f)


def shapes():
    s, sf = grid_sphere()
    yield "thin-slab", box(1.0, 1.0, 0.004, n=40)       # two sheets 0.4% of the size apart
    yield "rod", cylinder(20.0, 0.05)                    # aspect 200:1
    yield "torus", torus()
    yield "thin-torus", torus(1.0, 0.02, 128, 12)       # a wire ring
    yield "sphere-20-holes", holes(s, sf, 20, 0.12, 1)  # an open scan
    yield "height-field", plane()                       # one sheet, one loop
    yield "nested-spheres", concat((s, sf), (s * 0.9, sf[:, ::-1]))  # a hollow shell
    b, bf = box(1, 1, 1, 20)
    yield "two-boxes-close", concat((b, bf), (b + [1.0005, 0, 0], bf))  # two parts 0.05% apart
    yield "spheres-many-sizes", concat(*[(s * r + [4 * i, 0, 0], sf) for i, r in enumerate((1, 0.3, 0.1, 0.03))])
    yield "cup", cup()                                  # thin walls, a rim, an opening that is not a hole
    yield "dumbbell", dumbbell()                        # a neck 1% of the length
    top, topf = box(1.0, 1.0, 0.05, n=20)
    legs = [cylinder(1.0, 0.03, nu=8, nl=10) for _ in range(4)]
    legs = [(np.c_[v[:, 1], v[:, 2], v[:, 0]] + [x, y, -0.5], f) for (v, f), (x, y) in
            zip(legs, ((-0.4, -0.4), (0.4, -0.4), (-0.4, 0.4), (0.4, 0.4)))]
    yield "low-poly-table", concat((top + [0, 0, 0.025], topf), *legs)  # octagonal legs as separate parts
    yield "far-small", ((s * 1e-3) + [1e5, -2e5, 3e4], sf)
    # Edges of more than two faces: two boxes that share an edge, and a fin
    # (a strip of faces) standing on a box's top along a line of its grid.
    b, bf = box(1, 1, 1, 20)
    yield "boxes-sharing-an-edge", concat((b, bf), (b + [1, 1, 0], bf))
    fin = [(x / 20 - 0.5, 0.0, 0.5 + z * 0.05) for z in range(7) for x in range(21)]
    finf = [(z * 21 + x, z * 21 + x + 1, (z + 1) * 21 + x + 1) for z in range(6) for x in range(20)]
    finf += [(z * 21 + x, (z + 1) * 21 + x + 1, (z + 1) * 21 + x) for z in range(6) for x in range(20)]
    yield "fin-on-a-box", concat((b, bf), (np.array(fin), np.array(finf)))
    # Two boxes side by side, each with its own wall where they touch: after
    # the weld a double-sided wall inside one box (every wall edge in four
    # faces, two lying on top of two), and a double-sided card on its own.
    yield "boxes-sharing-a-face", concat((b, bf), (b + [1, 0, 0], bf))
    card, cardf = plane(40)
    yield "double-sided-card", (card, np.concatenate([cardf, cardf[:, ::-1]]))
    # Foliage: a sphere and 30 small one-sided leaves (each 1/15 of the sphere's
    # size, 8 x 8 quads) scattered round it: at low counts each leaf gets a
    # few cells, too few for a dual triangle, and must not vanish.
    rng = np.random.default_rng(1)
    leaf, leaff = plane(8)
    leaves = [((leaf * 0.075) + rng.uniform(-2, 2, 3), leaff) for _ in range(30)]
    yield "sphere-with-30-leaves", concat((s, sf), *leaves)


# What a shape's output should have where the input's own count is not it:
# an edge of more than two faces joins sheets that no 2-manifold can keep
# joined, so they come apart there (surface/pinch_split.h).
EXPECTED_SHEETS = {"boxes-sharing-an-edge": 2, "fin-on-a-box": 2, "boxes-sharing-a-face": 2}


def write_obj(path, v, f):
    with open(path, "w") as out:
        for p in v:
            out.write(f"v {p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n")
        for t in f:
            out.write(f"f {t[0] + 1} {t[1] + 1} {t[2] + 1}\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vpremesh", default="build/release/client/vpremesh")
    ap.add_argument("--targets", default="300,3000")
    ap.add_argument("--work", default="/tmp/stress-shapes")
    ap.add_argument("--only", default="")
    ap.add_argument("--bound", type=float, default=0.01)
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    only = set(filter(None, args.only.split(",")))
    failures = 0
    print(f"{'shape':22} {'target':>6} {'out':>6} {'closed':>9} {'loops':>7} {'sheets':>7} {'nm e/v':>7} "
          f"{'haus':>8} {'ms':>6}  verdict")
    for name, (v, f) in shapes():
        if only and name not in only:
            continue
        src = os.path.join(args.work, name + ".obj")
        write_obj(src, v, f)
        for target in (int(t) for t in args.targets.split(",")):
            out = os.path.join(args.work, f"{name}-{target}.ply")
            r = subprocess.run([args.vpremesh, "local", src, "-o", out, "-n", str(target), "--json"],
                               capture_output=True, text=True, timeout=600)
            if r.returncode != 0:
                print(f"{name:22} {target:>6} {'':>6} remesh failed (exit {r.returncode}): "
                      f"{(r.stderr or r.stdout).strip().splitlines()[-1:]}")
                failures += 1
                continue
            ms = json.loads(r.stdout).get("total_ms", 0)
            e = subprocess.run([args.vpremesh, "eval", src, out, "--json", "--no-visual"], capture_output=True,
                               text=True, timeout=600)
            j = json.loads(e.stdout)
            ci, co = j["reference"], j["candidate"]
            wi, wo = ci["welded"], co["welded"]
            problems = []
            if wi["closed"] and not wo["closed"]:
                problems.append("opened")
            if wi["boundary_loops"] != wo["boundary_loops"]:
                problems.append("loops")
            if EXPECTED_SHEETS.get(name, wi["sheets"]) != wo["sheets"]:
                problems.append("sheets")
            if co["non_manifold_edges"] or co["non_manifold_vertices"]:
                problems.append("non-manifold")
            if abs(co["vertices"] - target) > 0.02 * target:
                problems.append("count")
            if j["hausdorff"]["mean"] > args.bound:
                problems.append("far")
            failures += bool(problems)
            print(f"{name:22} {target:>6} {co['vertices']:>6} {str(wi['closed'])[0]}->{str(wo['closed'])[0]:>6} "
                  f"{wi['boundary_loops']:>3}->{wo['boundary_loops']:<3} {wi['sheets']:>3}->{wo['sheets']:<3} "
                  f"{co['non_manifold_edges']}/{co['non_manifold_vertices']:>5} {j['hausdorff']['mean']:8.5f} "
                  f"{ms:6.0f}  {'ok' if not problems else 'FAIL: ' + ', '.join(problems)}", flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
