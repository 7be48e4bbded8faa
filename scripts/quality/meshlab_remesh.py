"""MeshLab's adaptive isotropic explicit remeshing (pymeshlab) to a vertex count.

    python meshlab_remesh.py INPUT TARGET OUTPUT.ply  ->  prints one JSON object

The filter takes a target edge length, not a vertex count, so the length is
searched: L0 from the area (an equilateral mesh of V vertices and 2V faces
covers A = V sqrt(3)/2 L^2), then secant steps on log V(log L) (slope -2 until
two tries give a measured one), switching to bisection of log L once the
target is bracketed. Each try starts from the input. Stops within 2% of the
target, after MAX_TRIES, or when two tries land on the same count (MeshLab
keeps feature and boundary vertices, so on some inputs, beast's UV seams, the
count stops falling); the try closest to the target is written. Every
other parameter keeps MeshLab's default (10 iterations, features at 30°,
surface distance check at 1%), adaptive=True.
"""
import json
import math
import sys
import time

import pymeshlab

TOLERANCE = 0.02
MAX_TRIES = 8


def remesh(ms, length):
    ms.set_current_mesh(0)
    ms.add_mesh(ms.current_mesh(), "try")  # a copy of the input; the filter works on the current mesh
    ms.meshing_isotropic_explicit_remeshing(adaptive=True, targetlen=pymeshlab.PureValue(length))
    n = ms.current_mesh().vertex_number()
    return n, ms.current_mesh_id()


def main():
    path, target, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    start = time.monotonic()
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(path)
    ms.meshing_remove_duplicate_vertices()
    area = ms.get_geometric_measures()["surface_area"]
    length = math.sqrt(2 * area / (math.sqrt(3) * target))
    tries, best = [], None
    lo = hi = None  # (log L, log V) with V above / below the target
    for _ in range(MAX_TRIES):
        n, mesh_id = remesh(ms, length)
        tries.append({"length": length, "vertices": n})
        miss = abs(n - target) / target
        if best is None or miss < best[0]:
            if best is not None:
                ms.set_current_mesh(best[2])
                ms.delete_current_mesh()
            best = (miss, n, mesh_id, length)
        else:
            ms.set_current_mesh(mesh_id)
            ms.delete_current_mesh()
        if miss <= TOLERANCE:
            break
        if len(tries) >= 2 and abs(tries[-1]["vertices"] - tries[-2]["vertices"]) <= 0.005 * target:
            break  # saturated: features and boundaries keep the count where it is, whatever the length
        point = (math.log(length), math.log(max(n, 1)))
        if n > target:
            lo = point  # too many vertices: edges too short
        else:
            hi = point
        if lo and hi:  # bracketed: interpolate log V linearly in log L, kept inside the bracket
            t = (math.log(target) - lo[1]) / (hi[1] - lo[1]) if hi[1] != lo[1] else 0.5
            t = min(max(t, 0.1), 0.9)
            length = math.exp(lo[0] + t * (hi[0] - lo[0]))
        else:
            slope = -2.0
            if len(tries) >= 2:
                a, b = tries[-2], tries[-1]
                if a["length"] != b["length"] and a["vertices"] > 0 and b["vertices"] > 0 and a["vertices"] != b["vertices"]:
                    slope = (math.log(b["vertices"]) - math.log(a["vertices"])) / (math.log(b["length"]) - math.log(a["length"]))
                    slope = min(max(slope, -4.0), -0.5)
            length = math.exp(math.log(length) + (math.log(target) - math.log(max(n, 1))) / slope)
    ms.set_current_mesh(best[2])
    ms.save_current_mesh(out, save_vertex_color=False, save_vertex_quality=False, save_face_color=False)
    print(json.dumps({"vertices": best[1], "miss": best[0], "length": best[3], "tries": tries,
                      "time_ms": 1000 * (time.monotonic() - start),
                      "note": f"L={best[3]:.5g} after {len(tries)} tries, {100 * (best[1] / target - 1):+.1f}% off"}))


if __name__ == "__main__":
    main()
