"""The referee's report: reads RUNS/<case>/<method>.json (referee.py) and writes
  OUT/summary.md    per-method means, the issue-21 goal checks, what the
                    guidance buys, one table per case with its contact sheet
  OUT/results.json  every unit's record
  OUT/results.csv   the same, one row per unit (no per-view lists)
  OUT/<case>/contact_sheet.png  rows: two views; columns: input, then each method
and, with --doc, replaces the text between the referee markers of that file
(docs/quality.md) with summary.md.
"""
import argparse
import csv
import glob
import json
import os
import re

from PIL import Image

OURS = "ours-curvature"  # the default density (PipelineOptions::density): the one the goals judge
WELL_SHAPED = ["meshlab-adaptive", "cgal-isotropic"]
QEM = "openmesh-qem"
ORDER = ["ours-curvature", "ours-perception", "ours-uniform", "ours-paper", "meshlab-adaptive",
         "openmesh-qem", "cgal-isotropic", "meshoptimizer"]
LABEL = {"ours-perception": "vpremesh perception", "ours-curvature": "vpremesh curvature (default)",
         "ours-uniform": "vpremesh uniform", "ours-paper": "vpremesh paper",
         "meshlab-adaptive": "MeshLab adaptive isotropic", "openmesh-qem": "OpenMesh QEM",
         "cgal-isotropic": "CGAL isotropic", "meshoptimizer": "meshoptimizer"}
BEGIN, END = "<!-- referee:begin (scripts/quality.sh writes this part) -->", "<!-- referee:end -->"


def load(runs):
    recs = []
    for p in glob.glob(os.path.join(runs, "*", "*.json")):
        recs.append(json.load(open(p)))
    return recs


def case_key(c):
    name, t = c.rsplit("-", 1)
    return name, -int(t)


def mean(xs):
    xs = [x for x in xs if x is not None]
    return sum(xs) / len(xs) if xs else float("nan")


def pct(x, d=2):
    return f"{100 * x:.{d}f}%"


def broken(r):
    """What is broken in a result, as short words (empty when nothing)."""
    out = []
    if r["closed_in"] and not r["closed_out"]:
        out.append(f"open ({r['boundary_edges_out']} boundary edges)")
    if r["loops_in"] != r["loops_out"]:
        out.append(f"loops {r['loops_in']}→{r['loops_out']}")
    if r["parts_in"] != r["parts_out"]:
        out.append(f"parts {r['parts_in']}→{r['parts_out']}")
    if r["non_manifold_edges"] or r["non_manifold_vertices"]:
        out.append(f"non-manifold {r['non_manifold_edges']} edges / {r['non_manifold_vertices']} vertices")
    return out


def contact_sheet(runs, out, case, methods):
    src = os.path.join(runs, case, "views")
    if not os.path.isdir(src):
        return None
    views = sorted({f.rsplit("-", 1)[1] for f in os.listdir(src) if f.startswith("input-")})
    cols = ["input"] + [m for m in methods if os.path.exists(os.path.join(src, f"{m}-{views[0]}"))] if views else []
    if not views or len(cols) < 2:
        return None
    px, gutter = 256, 2
    sheet = Image.new("L", (len(cols) * (px + gutter) + gutter, len(views) * (px + gutter) + gutter), 64)
    for r, v in enumerate(views):
        for c, m in enumerate(cols):
            sheet.paste(Image.open(os.path.join(src, f"{m}-{v}")), (gutter + c * (px + gutter), gutter + r * (px + gutter)))
    os.makedirs(os.path.join(out, case), exist_ok=True)
    path = os.path.join(out, case, "contact_sheet.png")
    sheet.save(path, optimize=True)
    return cols


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--doc")
    ap.add_argument("--note", default="", help="a line about the machine and the run, quoted in the header")
    args = ap.parse_args()
    # Variants of ours (ours-MODE~flag=value) are for variants.py, not the goals' tables.
    recs = [r for r in load(args.runs) if r["method"] in ORDER]
    by = {}
    for r in recs:
        by.setdefault(f"{r['model']}-{r['target']}", {})[r["method"]] = r
    cases = sorted(by, key=case_key)
    methods = [m for m in ORDER if any(m in by[c] for c in cases)]
    ok = lambda c, m: m in by[c] and by[c][m].get("ok")

    json.dump(sorted(recs, key=lambda r: (case_key(f"{r['model']}-{r['target']}"), ORDER.index(r["method"]))),
              open(os.path.join(args.out, "results.json"), "w"), indent=1)
    fields = ["model", "target", "method", "ok", "error", "vertices", "faces", "time_ms", "ssim_mean", "ssim_worst",
              "flip_mean", "flip_worst", "hausdorff_mean", "hausdorff_max", "share_angles_below_30", "min_angle_deg",
              "loops_in", "loops_out", "parts_in", "parts_out", "closed_in", "closed_out", "non_manifold_edges",
              "non_manifold_vertices", "commit", "note"]
    with open(os.path.join(args.out, "results.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fields, extrasaction="ignore")
        w.writeheader()
        for c in cases:
            for m in methods:
                if m in by[c]:
                    w.writerow(by[c][m])

    commits = sorted({r.get("commit", "?") for r in recs})
    n_units = sum(len(by[c]) for c in cases)
    L = [f"Generated by `scripts/quality.sh` from {n_units} runs ({len(cases)} cases × up to {len(methods)} methods) "
         f"of commit{'s' if len(commits) > 1 else ''} {', '.join(commits)}. {args.note}".rstrip(), "",
         "Every mesh is judged by `vpremesh eval` against its input, with the same renderer and cameras: SSIM of "
         "gray renderings (14 views, 512 px, windows that see surface; higher is better), FLIP "
         "(`flip-evaluator`, LDR, 67 ppd, mean over the same 14 renderings, whole images; lower is better), mean "
         "symmetric Hausdorff distance (200k samples a side, % of the input's bounding-box diagonal), the share "
         "of angles under 30° and the smallest angle, boundary loops, parts (faces joined across edges) and "
         "non-manifold edges/vertices against the input's; loops, parts and closedness counted after merging "
         "vertices at exactly the same position on both sides (an exporter's seams are not holes). MeshLab is `meshing_isotropic_explicit_remeshing(adaptive=True)` "
         "with defaults otherwise, its target edge length searched to land within 2% of the vertex count (the "
         "count reached is in each table). `time` is one run's wall time on a loaded 2-core machine, not a "
         "benchmark.", ""]

    # Per-method means over the cases where both that method and ours finished,
    # with ours on the same cases beside them: a run cut short compares like with like.
    L += ["### Means per method", "",
          f"Each row: the mean over the cases where that method and `{OURS}` both finished, and `{OURS}` on "
          "those same cases in the last two columns.", "",
          "| method | cases | SSIM | FLIP | mean Hausdorff (% diag) | angles < 30° | smallest angle | vertices off target (worst) | runs with something broken | failed runs | ours SSIM, same cases | ours FLIP, same cases |",
          "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    summary = {}
    for m in methods:
        same = [c for c in cases if ok(c, m) and ok(c, OURS)]
        rs = [by[c][m] for c in same]
        allr = [by[c][m] for c in cases if ok(c, m)]
        failed = sum(1 for c in cases if m in by[c] and not by[c][m].get("ok"))
        s = {k: mean(r[k] for r in rs) for k in ("ssim_mean", "flip_mean", "hausdorff_mean", "share_angles_below_30")}
        s["cases"] = len(same)
        s["min_angle"] = min((r["min_angle_deg"] for r in allr), default=float("nan"))
        s["off"] = max((abs(r["vertices"] / r["target"] - 1) for r in allr), default=float("nan"))
        s["broken"] = sum(1 for r in allr if broken(r))
        s["ours_ssim"] = mean(by[c][OURS]["ssim_mean"] for c in same)
        s["ours_flip"] = mean(by[c][OURS]["flip_mean"] for c in same)
        summary[m] = s
        L.append(f"| {LABEL[m]} | {len(same)} | {s['ssim_mean']:.4f} | {s['flip_mean']:.4f} | {100 * s['hausdorff_mean']:.4f} | "
                 f"{pct(s['share_angles_below_30'])} | {s['min_angle']:.1f}° | {pct(s['off'], 1)} | "
                 f"{s['broken']}/{len(allr)} | {failed} | {s['ours_ssim']:.4f} | {s['ours_flip']:.4f} |")
    L.append("")

    # Goal checks (issue 21, "Goals, measured side by side").
    def per_case(pred):
        met, missed, tied = [], [], []
        for c in cases:
            v = pred(c)
            if v is None:
                continue
            {True: met, False: missed, "tie": tied}[v[0]].append((c, v[1]))
        return met, missed, tied

    def line(title, met, missed, tied=(), limit=60):
        n = len(met) + len(missed) + len(tied)
        status = "**met**" if not missed and n else ("**missed**" if n else "not measured")
        s = f"- {title}: {status}, {len(met)}/{n} cases"
        s += f" (and {len(tied)} level: {', '.join(c for c, _ in tied)})." if tied else "."
        if missed:
            s += " Missed on: " + "; ".join(f"{c} ({w})" for c, w in missed[:limit]) + (" …" if len(missed) > limit else "") + "."
        return s

    def peer_text(c, m, value):
        r = by[c][m]
        off = r["vertices"] / r["target"] - 1
        return f"{LABEL[m]} {value}" + (f" at {r['vertices']} vertices" if abs(off) > 0.02 else "")

    goals = ["### The goals, one by one", "", f"Judged on `{OURS}` (the default density).", ""]
    if any(OURS in by[c] for c in cases):
        for metric, better, fmt in (("ssim_mean", max, "{:.4f}"), ("flip_mean", min, "{:.4f}")):
            def pred(c, metric=metric, better=better, fmt=fmt):
                peers = [m for m in WELL_SHAPED if ok(c, m)]
                if not ok(c, OURS) or not peers:
                    return None
                o = by[c][OURS][metric]
                bm = better(peers, key=lambda m: by[c][m][metric])
                best = by[c][bm][metric]
                if abs(o - best) < 1e-4:  # level, as far as the measure tells (cube_no_bottom: both exact)
                    return "tie", ""
                beats = o > best if better is max else o < best
                return beats, f"ours {fmt.format(o)}, {peer_text(c, bm, fmt.format(best))}"
            goals.append(line(f"{'SSIM' if metric == 'ssim_mean' else 'FLIP'} better than every well-shaped peer "
                              "(MeshLab adaptive, CGAL isotropic)", *per_case(pred)))
        both = [c for c in cases if ok(c, OURS) and ok(c, QEM)]
        if both:
            o, q = mean(by[c][OURS]["ssim_mean"] for c in both), mean(by[c][QEM]["ssim_mean"] for c in both)
            goals.append(f"- Mean SSIM within 0.01 of OpenMesh QEM's: {'**met**' if o >= q - 0.01 else '**missed**'}, "
                         f"ours {o:.4f}, QEM {q:.4f} ({o - q:+.4f}) over {len(both)} cases.")
        if ok("horse-5000", OURS) if "horse-5000" in by else False:
            f = by["horse-5000"][OURS]["flip_mean"]
            goals.append(f"- Horse → 5,000 at FLIP ≤ 0.0125: {'**met**' if f <= 0.0125 else '**missed**'}, {f:.4f}"
                         + (f" (MeshLab {by['horse-5000']['meshlab-adaptive']['flip_mean']:.4f}, QEM "
                            f"{by['horse-5000'][QEM]['flip_mean']:.4f})" if ok("horse-5000", "meshlab-adaptive")
                            and ok("horse-5000", QEM) else "") + ".")
            if ok("horse-5000", QEM):
                # The issue measured QEM at 0.0102 with its own renderer; FLIP's scale follows the renderer.
                q = by["horse-5000"][QEM]["flip_mean"]
                goals.append(f"  On this renderer's scale (the issue's 0.0125 is 1.23× the 0.0102 it measured for QEM; "
                             f"QEM here {q:.4f}, so ≤ {1.2255 * q:.4f}): {'**met**' if f <= 1.2255 * q else '**missed**'}, "
                             f"ours {f / q:.2f}× QEM's.")

        def haus_peers(c):
            peers = [m for m in WELL_SHAPED if ok(c, m)]
            if not ok(c, OURS) or not peers:
                return None
            bm = min(peers, key=lambda m: by[c][m]["hausdorff_mean"])
            o, best = by[c][OURS]["hausdorff_mean"], by[c][bm]["hausdorff_mean"]
            if abs(o - best) < 1e-7:  # 1e-5 % of the diagonal: both exact
                return "tie", ""
            return o <= best, f"ours {100 * o:.4f}%, {peer_text(c, bm, f'{100 * best:.4f}%')}"
        goals.append(line("Mean Hausdorff no larger than the well-shaped peers'", *per_case(haus_peers)))

        def haus_qem(c):
            if not ok(c, OURS) or not ok(c, QEM):
                return None
            o, q = by[c][OURS]["hausdorff_mean"], by[c][QEM]["hausdorff_mean"]
            return o <= 1.5 * q, f"{o / q:.2f}× QEM's"
        goals.append(line("Mean Hausdorff at most 1.5× QEM's", *per_case(haus_qem)))

        def angles(c):
            if not ok(c, OURS):
                return None
            a = by[c][OURS]["share_angles_below_30"]
            return a < 0.01, pct(a)
        goals.append(line("Under 1% of angles below 30°", *per_case(angles)))

        def min_angle(c):
            if not ok(c, OURS):
                return None
            a = by[c][OURS]["min_angle_deg"]
            return a >= 10, f"{a:.1f}°"
        goals.append(line("No angle under 10° (measured over the whole mesh: whether a small angle sits at an input "
                          "corner is not told apart)", *per_case(min_angle)))

        def intact(c):
            if not ok(c, OURS):
                return None
            b = broken(by[c][OURS])
            return not b, ", ".join(b)
        goals.append(line("Nothing broken (closed stays closed, as many boundary loops and parts as the input, no "
                          "non-manifold edge or vertex)", *per_case(intact)))

        def count(c):
            if not ok(c, OURS):
                return None
            r = by[c][OURS]
            return abs(r["vertices"] / r["target"] - 1) <= 0.02, f"{r['vertices']} for {r['target']}"
        goals.append(line("Vertex count within 2% of the target", *per_case(count)))
        failed = [c for c in cases if OURS in by[c] and not by[c][OURS].get("ok")]
        if failed:
            goals.append(f"- Runs of `{OURS}` that failed: " + "; ".join(f"{c} ({by[c][OURS]['error'][:80]})" for c in failed) + ".")
    L += goals + [""]

    # What the guidance buys.
    dens = [m for m in ("ours-perception", "ours-curvature", "ours-uniform", "ours-paper") if m in methods]
    if len(dens) > 1:
        L += ["### What the guidance buys", "",
              "SSIM (higher is better) and FLIP (lower is better) of each density of our pipeline on every case; "
              "`paper` is the paper's whole back half (adaptive sampling, AWLOP, advancing front).", "",
              "| case | " + " | ".join(f"SSIM {d[5:]}" for d in dens) + " | " + " | ".join(f"FLIP {d[5:]}" for d in dens) + " |",
              "|---|" + "---:|" * (2 * len(dens))]
        for c in cases:
            cell = lambda d, k, f: f.format(by[c][d][k]) if ok(c, d) else "–"
            L.append(f"| {c} | " + " | ".join(cell(d, "ssim_mean", "{:.4f}") for d in dens) + " | "
                     + " | ".join(cell(d, "flip_mean", "{:.4f}") for d in dens) + " |")
        core = [d for d in dens if d != "ours-paper"]  # the guidance proper; the paper's back half may lag
        cs = [c for c in cases if all(ok(c, d) for d in core)]
        if cs:
            def col_mean(d, k):
                cd = [c for c in cs if ok(c, d)]
                v = f"{mean(by[c][d][k] for c in cd):.4f}" if cd else "–"
                return v + (f" ({len(cd)} cases)" if cd and len(cd) < len(cs) else "")
            L.append(f"| **mean of {len(cs)}** | " + " | ".join(col_mean(d, "ssim_mean") for d in dens)
                     + " | " + " | ".join(col_mean(d, "flip_mean") for d in dens) + " |")
            L.append("")
            if "ours-uniform" in dens:
                for d in dens:
                    if d == "ours-uniform":
                        continue
                    cd = [c for c in cases if ok(c, d) and ok(c, "ours-uniform")]
                    if not cd:
                        continue
                    wins = sum(1 for c in cd if by[c][d]["flip_mean"] < by[c]["ours-uniform"]["flip_mean"])
                    swins = sum(1 for c in cd if by[c][d]["ssim_mean"] > by[c]["ours-uniform"]["ssim_mean"])
                    gain = 1 - mean(by[c][d]["flip_mean"] for c in cd) / mean(by[c]["ours-uniform"]["flip_mean"] for c in cd)
                    L.append(f"- `{d[5:]}` against `uniform` ({len(cd)} cases): SSIM higher on {swins}, FLIP lower on "
                             f"{wins}; mean FLIP {100 * abs(gain):.1f}% {'lower' if gain >= 0 else 'higher'}.")
        L.append("")

    # Per case.
    L += ["### Every case", ""]
    for c in cases:
        cols = contact_sheet(args.runs, args.out, c, methods)
        first = next(iter(by[c].values()))
        L += [f"#### {c}", ""]
        intro = [r for r in by[c].values() if r.get("ok")]
        if intro:
            r0 = intro[0]
            L += [f"Input: {r0['loops_in']} boundary loops, {r0['parts_in']} parts, {'closed' if r0['closed_in'] else 'open'}. "
                  f"Target {first['target']} vertices.", ""]
        L += ["| method | vertices | SSIM | FLIP | mean Hausdorff % | angles < 30° | min angle | loops out | parts out | nm edges | broken | time ms | note |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---|"]
        for m in methods:
            if m not in by[c]:
                continue
            r = by[c][m]
            if not r.get("ok"):
                L.append(f"| {LABEL[m]} | failed: {r['error'][:100]} |" + " |" * 11)
                continue
            L.append(f"| {LABEL[m]} | {r['vertices']} | {r['ssim_mean']:.4f} | {r['flip_mean']:.4f} | "
                     f"{100 * r['hausdorff_mean']:.4f} | {pct(r['share_angles_below_30'])} | {r['min_angle_deg']:.1f} | "
                     f"{r['loops_out']} | {r['parts_out']} | {r['non_manifold_edges']} | {', '.join(broken(r)) or '–'} | "
                     f"{r['time_ms']:.0f} | {r.get('note', '')} |")
        if cols:
            rel = os.path.relpath(os.path.join(args.out, c, "contact_sheet.png"),
                                  os.path.dirname(args.doc) if args.doc else args.out)
            L += ["", f"![{c}: {', '.join(cols)}]({rel})", "", f"Columns: {', '.join(cols)}; rows: views +z and +x+y+z."]
        L.append("")

    text = "\n".join(L) + "\n"
    open(os.path.join(args.out, "summary.md"), "w").write(text)
    json.dump(summary, open(os.path.join(args.out, "summary.json"), "w"), indent=1)
    if args.doc:
        doc = open(args.doc).read()
        if BEGIN in doc and END in doc:
            doc = doc[:doc.index(BEGIN) + len(BEGIN)] + "\n" + text + doc[doc.index(END):]
        else:
            doc += f"\n{BEGIN}\n{text}{END}\n"
        open(args.doc, "w").write(doc)


if __name__ == "__main__":
    main()
