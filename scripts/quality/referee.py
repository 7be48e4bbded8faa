"""The issue-21 referee: every method on every case at the same vertex count,
judged alike. Driven by scripts/quality.sh (which makes the virtual
environment); see there for the knobs.

For each case (model, target) and method, one unit of work:
  1. remesh: ours (`vpremesh local --density MODE`; a variant
     `ours-MODE~flag=value~...` adds `--flag value` for each), a peer of `vpremesh
     compare` (`vpremesh peers --only SLUG`), or MeshLab's adaptive isotropic
     remeshing (meshlab_remesh.py, the edge length searched to land within 2%);
  2. judge: `vpremesh eval INPUT MESH --json --views-dir DIR` (SSIM of gray
     renderings over 14 views at 512 px, Hausdorff, angles, topology), then
     FLIP (flip-evaluator, LDR, 67 ppd) between the same reference and candidate
     PNGs, mean over the 14 views, whole images;
  3. write RUNS/<model>-<target>/<method>.json (the resume point: a unit whose
     JSON says ok, of the same commit, is skipped; a failed one is run again) and keep two views of the candidate for the
     contact sheet.
Every mesh is rendered by the same renderer (vpremesh's), so every method is
judged on the same pictures.
"""
import argparse
import concurrent.futures as cf
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
from PIL import Image
import flip_evaluator as flip

HERE = os.path.dirname(os.path.abspath(__file__))
OURS = ["perception", "curvature", "uniform", "paper"]
PEERS = {"openmesh-qem": "OpenMesh QEM", "cgal-isotropic": "CGAL isotropic", "meshoptimizer": "meshoptimizer"}
ALL_METHODS = [f"ours-{m}" for m in OURS] + ["meshlab-adaptive"] + list(PEERS)
SHEET_VIEWS = (4, 6)  # make_views' order: +z and +x+y+z of the aligned model, as compare's sheet
SHEET_PX = 256


def parse_cases(text):
    cases = []
    for line in text.strip().splitlines():
        model, *targets = line.split()
        cases += [(model, int(t)) for t in targets]
    return cases


def run(cmd, log, timeout):
    with open(log, "a") as err:
        err.write("$ " + " ".join(cmd) + "\n")
        err.flush()
        try:
            p = subprocess.run(["nice", "-n", "15"] + cmd, stdout=subprocess.PIPE, stderr=err, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"over {timeout:.0f} s: {' '.join(cmd[:3])}")
    if p.returncode != 0:
        raise RuntimeError(f"exit {p.returncode}: {' '.join(cmd[:3])} (see {log})")
    return p.stdout


def gray(path):
    return np.asarray(Image.open(path).convert("L"), dtype=np.float32) / 255.0


def flip_mean(reference, candidate, margin=32):
    """FLIP's mean over the whole image, computed on the crop around what either
    image draws (plus a margin wider than FLIP's filters): outside it both are
    black, FLIP is exactly 0 there, and the crop saves a third of the time."""
    drawn = (reference > 0) | (candidate > 0)
    if not drawn.any():
        return 0.0
    ys, xs = np.nonzero(drawn)
    y0, y1 = max(ys.min() - margin, 0), min(ys.max() + margin + 1, reference.shape[0])
    x0, x1 = max(xs.min() - margin, 0), min(xs.max() + margin + 1, reference.shape[1])
    rgb = lambda a: np.repeat(a[y0:y1, x0:x1, None], 3, axis=2)
    _, mean, _ = flip.evaluate(rgb(reference), rgb(candidate), "LDR", applyMagma=False)
    return float(mean) * (y1 - y0) * (x1 - x0) / reference.size


def remesh(args, model_path, target, method, mesh, log):
    if method.startswith("ours-"):
        # ours-MODE, or ours-MODE~flag=value~flag=value for a variant (`--flag value` each).
        mode, *extra = method[5:].split("~")
        flags = []
        for e in extra:
            k, _, v = e.partition("=")
            flags += [f"--{k}"] + ([v] if v else [])
        r = json.loads(run([args.bin, "local", model_path, "-o", mesh, "-n", str(target),
                            "--density", mode, "--json"] + flags, log, args.timeout))
        return {"time_ms": r.get("total_ms", 0), "note": ""}
    if method == "meshlab-adaptive":
        r = json.loads(run([sys.executable, os.path.join(HERE, "meshlab_remesh.py"), model_path, str(target), mesh], log, args.timeout))
        return {"time_ms": r["time_ms"], "note": r["note"], "search": r["tries"]}
    out = os.path.dirname(mesh)
    r = json.loads(run([args.bin, "peers", model_path, "-n", str(target), "--out", out, "--only", method], log, args.timeout))
    m = r["methods"][0]
    if not m["ok"]:
        raise RuntimeError(m["error"])
    os.replace(m["file"], mesh)
    return {"time_ms": m["time_ms"], "note": m["note"]}


def unit(args, model, target, method):
    name = model.rsplit(".", 1)[0]
    case = f"{name}-{target}"
    result_path = os.path.join(args.runs, case, method + ".json")
    if os.path.exists(result_path):
        kept = json.load(open(result_path))
        # A failed run is tried again, and so is one of other code than what is measured now.
        if kept.get("ok") and (kept.get("commit") == args.commit or args.any_commit):
            return result_path, "kept"
    work = os.path.join(args.work, case, method)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    log = os.path.join(work, "log.txt")
    model_path = os.path.join(args.models, model)
    mesh = os.path.join(work, "mesh.ply")
    rec = {"model": name, "target": target, "method": method, "commit": args.commit}
    start = time.monotonic()
    try:
        rec.update(remesh(args, model_path, target, method, mesh, log))
        views = os.path.join(work, "views")
        e = json.loads(run([args.bin, "eval", model_path, mesh, "--json", "--views-dir", views], log, args.timeout))
        c, ref, h, v = e["candidate"], e["reference"], e["hausdorff"], e["visual"]
        flips = []
        for i in range(len(v["per_view"])):
            flips.append(flip_mean(gray(f"{views}/reference-{i:02d}.png"), gray(f"{views}/candidate-{i:02d}.png")))
        rec.update({
            "ok": True, "vertices": c["vertices"], "faces": c["faces"],
            "ssim_mean": v["ssim_mean"], "ssim_worst": v["ssim_worst"],
            "ssim_per_view": [p["ssim"] for p in v["per_view"]],
            "flip_mean": sum(flips) / len(flips), "flip_worst": max(flips), "flip_per_view": flips,
            "hausdorff_mean": h["mean"], "hausdorff_max": h["max"],
            "share_angles_below_30": c["share_angles_below_30"], "min_angle_deg": c["min_angle_deg"],
            # Topology after merging vertices at exactly the same position, on
            # both sides: an input split at its seams (teapot.obj) has loops
            # and parts nobody sees, and a method that welds must not be
            # counted as closing them. Parts are sheets (faces joined across
            # edges): teapot's handle touches its body at vertices only, which
            # a 2-manifold remesh cannot keep joined.
            "loops_in": ref["welded"]["boundary_loops"], "loops_out": c["welded"]["boundary_loops"],
            "parts_in": ref["welded"]["sheets"], "parts_out": c["welded"]["sheets"],
            "closed_in": ref["welded"]["closed"], "closed_out": c["welded"]["closed"],
            "loops_in_unwelded": ref["boundary_loops"], "loops_out_unwelded": c["boundary_loops"],
            "boundary_edges_out": c["boundary_edges"],
            "non_manifold_edges": c["non_manifold_edges"], "non_manifold_vertices": c["non_manifold_vertices"],
        })
        sheet = os.path.join(args.runs, case, "views")
        os.makedirs(sheet, exist_ok=True)
        for i in SHEET_VIEWS:
            for who, dst in (("candidate", method), ("reference", "input")):
                img = Image.open(f"{views}/{who}-{i:02d}.png").convert("L").resize((SHEET_PX, SHEET_PX), Image.LANCZOS)
                img.save(os.path.join(sheet, f"{dst}-{i:02d}.png"), optimize=True)
        shutil.rmtree(views)
    except Exception as ex:  # a method that fails is a row that says so, not a lost run
        rec.update({"ok": False, "error": str(ex)})
    rec["unit_s"] = time.monotonic() - start
    os.makedirs(os.path.dirname(result_path), exist_ok=True)
    with open(result_path + ".tmp", "w") as f:
        json.dump(rec, f, indent=1)
    os.replace(result_path + ".tmp", result_path)  # complete or absent: what resume relies on
    if rec["ok"] and not args.keep_meshes:
        os.remove(mesh)
    return result_path, "ok" if rec["ok"] else "failed: " + rec["error"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--models", required=True)
    ap.add_argument("--cases", required=True, help="lines of 'model target target'")
    ap.add_argument("--methods", default=" ".join(ALL_METHODS))
    ap.add_argument("--runs", required=True, help="where the per-unit JSON goes")
    ap.add_argument("--work", required=True, help="scratch: meshes, renderings, logs")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--keep-meshes", action="store_true")
    ap.add_argument("--commit", default="unknown", help="what is measured, recorded in every run")
    ap.add_argument("--any-commit", action="store_true", help="keep earlier runs of any commit")
    ap.add_argument("--timeout", type=float, default=1800, help="seconds one step (remesh or eval) may take")
    args = ap.parse_args()
    methods = args.methods.split()
    for m in methods:
        if m.split("~")[0] not in ALL_METHODS:
            sys.exit(f"referee: unknown method {m} (one of {' '.join(ALL_METHODS)})")
    # Method by method in the order asked (the first ones matter most), case by
    # case within each: a run cut short has whole columns, not whole rows.
    units = [(model, t, m) for m in methods for model, t in parse_cases(args.cases)]
    t0 = time.monotonic()
    with cf.ProcessPoolExecutor(args.jobs) as pool:  # processes: FLIP holds the GIL
        futures = {pool.submit(unit, args, *u): u for u in units}
        for n, fut in enumerate(cf.as_completed(futures), 1):
            path, what = fut.result()
            print(f"[{n}/{len(units)} {time.monotonic() - t0:.0f}s] {path}: {what}", file=sys.stderr, flush=True)


if __name__ == "__main__":
    main()
