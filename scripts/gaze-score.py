#!/usr/bin/env python3
"""How well a perception field predicts where people look, and what a remesh
keeps there (docs/perception.md; the measures of ../shared/gaze/README.md).

  gaze-score.py field GAZE.ply FIELD.ply [...]   AUC for top5, CC with fixation
  gaze-score.py curvature GAZE.ply [...]          the same for |mean curvature|
  gaze-score.py share FIELD.ply [...]             share of vertices at the field's maximum
  gaze-score.py error GAZE.ply REMESH.ply         fixation-weighted and plain error
  gaze-score.py fixation-field GAZE.ply OUT.ply   the fixation as a field, for vpremesh field-sheet
                                                  (and vpremesh local --attention-map: an oracle)
  gaze-score.py blend GAZE.ply FIELD.ply T OUT.ply
                                                  T x fixation-field + (1 - T) x the field's rank in
                                                  [0, 1]: predictors between ours (T = 0) and the
                                                  measured fixation (T = 1), for --attention-map

GAZE.ply: a mesh of ../shared/gaze/ (vertex properties x y z fixation top5).
FIELD.ply: the same mesh written by `vpremesh local --field-out`, vertices in
the same order (property "saliency"). REMESH.ply: any triangle mesh in PLY.
Errors are distances from each gaze vertex to the remeshed surface, in units
of the gaze mesh's bounding-box diagonal. numpy only, plus scipy's k-d tree
for the error when it is installed (a brute-force fallback otherwise).
"""
import sys

import numpy as np

PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def read_ply(path):
    """Binary little-endian PLY -> (dict of vertex properties, faces #F x 3 int)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header") + len(b"end_header")
    end = data.index(b"\n", end) + 1
    elements = []
    for line in data[:end].decode("ascii", "replace").splitlines():
        tok = line.split()
        if not tok:
            continue
        if tok[0] == "format" and tok[1] != "binary_little_endian":
            sys.exit(f"gaze-score: {path}: only binary_little_endian PLY is read")
        if tok[0] == "element":
            elements.append((tok[1], int(tok[2]), []))
        elif tok[0] == "property":
            if tok[1] == "list":
                elements[-1][2].append((tok[4], "<" + PLY_TYPES[tok[2]], "<" + PLY_TYPES[tok[3]]))
            else:
                elements[-1][2].append((tok[2], "<" + PLY_TYPES[tok[1]], None))
    offset, vertices, faces = end, {}, None
    for name, count, props in elements:
        if all(p[2] is None for p in props):
            dt = np.dtype([(p[0], p[1]) for p in props])
            arr = np.frombuffer(data, dt, count, offset)
            offset += dt.itemsize * count
            if name == "vertex":
                vertices = {p[0]: arr[p[0]].astype(np.float64) for p in props}
        else:
            # Triangles only: a list of 3 indices as the element's single property.
            (pname, ctype, itype), = props
            dt = np.dtype([("n", ctype), ("i", itype, 3)])
            arr = np.frombuffer(data, dt, count, offset)
            if np.any(arr["n"] != 3):
                sys.exit(f"gaze-score: {path}: only triangle faces are read")
            offset += dt.itemsize * count
            if name == "face":
                faces = arr["i"].astype(np.int64)
    return vertices, faces


def positions(v):
    return np.stack([v["x"], v["y"], v["z"]], axis=1)


def auc(score, positive):
    """Area under the ROC curve of `score` for the boolean `positive` (ties count half)."""
    score = np.asarray(score, np.float64)
    positive = np.asarray(positive, bool)
    order = np.argsort(score, kind="mergesort")
    ranks = np.empty(len(score))
    sorted_scores = score[order]
    # Average rank over ties.
    _, first, counts = np.unique(sorted_scores, return_index=True, return_counts=True)
    avg = first + (counts - 1) / 2.0 + 1.0
    ranks[order] = np.repeat(avg, counts)
    npos, nneg = positive.sum(), (~positive).sum()
    if npos == 0 or nneg == 0:
        return float("nan")
    return float((ranks[positive].sum() - npos * (npos + 1) / 2.0) / (npos * nneg))


def cc(a, b):
    a = np.asarray(a, np.float64) - np.mean(a)
    b = np.asarray(b, np.float64) - np.mean(b)
    den = np.sqrt((a * a).sum() * (b * b).sum())
    return float((a * b).sum() / den) if den > 0 else 0.0


def share_at_max(field):
    field = np.asarray(field, np.float64)
    return float(np.mean(field >= field.max() - 1e-6))


def mean_curvature(p, f):
    """|H| per vertex as worker/surface/surface_density.cpp computes it: 1/4 sum of
    |dihedral angle| x edge length over the vertex's edges, over a third of its faces' area."""
    n = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
    length = np.linalg.norm(n, axis=1)
    area = np.zeros(len(p))
    for k in range(3):
        np.add.at(area, f[:, k], length / 6.0)
    n = n / np.maximum(length, 1e-300)[:, None]
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    face = np.tile(np.arange(len(f)), 3)
    e.sort(axis=1)
    key = e[:, 0] * (len(p) + 1) + e[:, 1]
    order = np.argsort(key, kind="mergesort")
    key, face, e = key[order], face[order], e[order]
    pair = np.nonzero(key[1:] == key[:-1])[0]  # manifold edges: two consecutive entries
    cosang = np.clip((n[face[pair]] * n[face[pair + 1]]).sum(1), -1, 1)
    angle = np.arccos(cosang)
    u, w = e[pair, 0], e[pair, 1]
    contrib = 0.25 * angle * np.linalg.norm(p[u] - p[w], axis=1)
    integral = np.zeros(len(p))
    np.add.at(integral, u, contrib)
    np.add.at(integral, w, contrib)
    return np.where(area > 0, integral / np.maximum(area, 1e-300), 0.0)


def point_triangle_distance(q, a, b, c):
    """Distance from points q (#N x 3) to triangles (a, b, c) (#N x 3 each), row by row
    (Ericson, Real-Time Collision Detection, 5.1.5)."""
    ab, ac, ap = b - a, c - a, q - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = q - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = q - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    denom = va + vb + vc
    denom = np.where(np.abs(denom) > 1e-300, denom, 1e-300)
    v = vb / denom
    w = vc / denom
    closest = a + ab * v[:, None] + ac * w[:, None]  # inside the face
    # Regions, most specific last so that they override.
    def pick(mask, point):
        closest[mask] = point[mask]
    t = np.clip(d1 / np.where(d1 - d3 != 0, d1 - d3, 1e-300), 0, 1)
    pick((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * t[:, None])
    t = np.clip(d2 / np.where(d2 - d6 != 0, d2 - d6, 1e-300), 0, 1)
    pick((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * t[:, None])
    t = np.clip((d4 - d3) / np.where((d4 - d3) + (d5 - d6) != 0, (d4 - d3) + (d5 - d6), 1e-300), 0, 1)
    pick((va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), b + (c - b) * t[:, None])
    pick((d1 <= 0) & (d2 <= 0), a)
    pick((d3 >= 0) & (d4 <= d3), b)
    pick((d6 >= 0) & (d5 <= d6), c)
    return np.linalg.norm(q - closest, axis=1)


def surface_distance(q, p, f):
    """Exact distance from each point of q to the triangle mesh (p, f)."""
    a, b, c = p[f[:, 0]], p[f[:, 1]], p[f[:, 2]]
    centroid = (a + b + c) / 3.0
    reach = np.max(np.linalg.norm(np.stack([a, b, c]) - centroid[None], axis=2))
    out = np.empty(len(q))
    try:
        from scipy.spatial import cKDTree
    except ImportError:
        cKDTree = None
    if cKDTree is not None:
        tree = cKDTree(centroid)
        nearest, _ = tree.query(q)
        # Any triangle holding the closest point has its centroid within
        # (distance to the nearest centroid) + reach.
        for i, cand in enumerate(tree.query_ball_point(q, nearest + reach + 1e-12)):
            cand = np.asarray(cand)
            qi = np.repeat(q[i:i + 1], len(cand), 0)
            out[i] = point_triangle_distance(qi, a[cand], b[cand], c[cand]).min()
        return out
    for i in range(len(q)):
        qi = np.repeat(q[i:i + 1], len(f), 0)
        out[i] = point_triangle_distance(qi, a, b, c).min()
    return out


def rank01(values):
    """Each value's rank over n - 1, in [0, 1]; ties share their mean rank."""
    values = np.asarray(values, np.float64)
    n = len(values)
    if n < 2:
        return np.zeros(n)
    order = np.argsort(values, kind="mergesort")
    sorted_values = values[order]
    ranks = np.empty(n)
    i = 0
    while i < n:
        j = i
        while j < n and sorted_values[j] == sorted_values[i]:
            j += 1
        ranks[order[i:j]] = 0.5 * (i + j - 1)
        i = j
    return ranks / (n - 1)


def fixation_field(fixation):
    """Fixation time as a field in [0, 1] drawn on the same ramp as ours: 0 where
    nobody looked (blue), else 0.2 + 0.8 x its rank among the looked-at
    vertices, the attention field's own floor and rank normalization (so the
    two pictures compare orderings, not units; ties share their mean rank)."""
    fixation = np.asarray(fixation, np.float64)
    out = np.zeros(len(fixation))
    seen = fixation > 0
    n = int(seen.sum())
    if n == 1:
        out[seen] = 1.0
    elif n > 1:
        out[seen] = 0.2 + 0.8 * rank01(fixation[seen])
    return out


def blend(fixation, field, t):
    """t x fixation_field + (1 - t) x rank01(field): a predictor of attention
    between the field (t = 0) and the measured fixation (t = 1), whose AUC
    rises with t (docs/perception.md: what a better predictor would buy)."""
    return t * fixation_field(fixation) + (1.0 - t) * rank01(field)


def write_field_ply(path, p, f, field):
    """Binary PLY with x y z saliency and the triangles (the property vpremesh reads as a field)."""
    v = np.zeros(len(p), np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("saliency", "<f4")]))
    v["x"], v["y"], v["z"], v["saliency"] = p[:, 0], p[:, 1], p[:, 2], field
    t = np.zeros(len(f), np.dtype([("n", "u1"), ("i", "<i4", 3)]))
    t["n"], t["i"] = 3, f
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(p)}\n"
              "property float x\nproperty float y\nproperty float z\nproperty float saliency\n"
              f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(path, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(v.tobytes())
        out.write(t.tobytes())


def gaze_of(path):
    v, f = read_ply(path)
    if "fixation" not in v or "top5" not in v:
        sys.exit(f"gaze-score: {path} has no fixation/top5 vertex properties")
    return v, f


def main(argv):
    if len(argv) < 2:
        sys.exit(__doc__)
    cmd, args = argv[1], argv[2:]
    if cmd == "field" and len(args) >= 2 and len(args) % 2 == 0:
        print("| gaze mesh | field | AUC | CC | share at max |")
        print("|---|---|---|---|---|")
        for gaze_path, field_path in zip(args[::2], args[1::2]):
            g, _ = gaze_of(gaze_path)
            fv, _ = read_ply(field_path)
            if len(fv["x"]) != len(g["x"]) or np.max(np.abs(positions(fv) - positions(g))) > 1e-4:
                sys.exit(f"gaze-score: {field_path} does not hold {gaze_path}'s vertices in its order")
            s = fv["saliency"]
            print(f"| {gaze_path} | {field_path} | {auc(s, g['top5'] > 0):.3f} | {cc(s, g['fixation']):.3f} "
                  f"| {share_at_max(s):.1%} |")
    elif cmd == "curvature" and args:
        print("| gaze mesh | AUC of abs(H) | CC of abs(H) |")
        print("|---|---|---|")
        for gaze_path in args:
            g, f = gaze_of(gaze_path)
            h = mean_curvature(positions(g), f)
            print(f"| {gaze_path} | {auc(h, g['top5'] > 0):.3f} | {cc(h, g['fixation']):.3f} |")
    elif cmd == "share" and args:
        print("| field | vertices | share at max |")
        print("|---|---|---|")
        for field_path in args:
            fv, _ = read_ply(field_path)
            print(f"| {field_path} | {len(fv['x'])} | {share_at_max(fv['saliency']):.1%} |")
    elif cmd == "error" and len(args) == 2:
        g, _ = gaze_of(args[0])
        rv, rf = read_ply(args[1])
        q = positions(g)
        diag = np.linalg.norm(q.max(0) - q.min(0))
        d = surface_distance(q, positions(rv), rf) / diag
        w = g["fixation"]
        print(f"weighted {np.sum(w * d) / np.sum(w):.6g} plain {np.mean(d):.6g} vertices {len(rv['x'])}")
    elif cmd == "blend" and len(args) == 4:
        g, f = gaze_of(args[0])
        fv, _ = read_ply(args[1])
        if len(fv["x"]) != len(g["x"]) or np.max(np.abs(positions(fv) - positions(g))) > 1e-4:
            sys.exit(f"gaze-score: {args[1]} does not hold {args[0]}'s vertices in its order")
        t = float(args[2])
        if not 0.0 <= t <= 1.0:
            sys.exit(f"gaze-score: blend weight {t} is not in [0, 1]")
        b = blend(g["fixation"], fv["saliency"], t)
        write_field_ply(args[3], positions(g), f, b)
        print(f"blend {t:g}: AUC {auc(b, g['top5'] > 0):.3f} CC {cc(b, g['fixation']):.3f}")
    elif cmd == "fixation-field" and len(args) == 2:
        g, f = gaze_of(args[0])
        write_field_ply(args[1], positions(g), f, fixation_field(g["fixation"]))
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv)
