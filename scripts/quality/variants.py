"""Side by side: two or more methods of the referee (scripts/quality.sh), case by
case, from the per-run JSON it writes. Made for variants of ours
(`ours-MODE~flag=value`), which report.py's goal tables do not know:

  python3 scripts/quality/variants.py RUNS BASE OTHER [OTHER...]

Prints a markdown table per case (SSIM, FLIP, mean Hausdorff in % of the
diagonal, angles under 30 degrees, smallest angle, what broke), then the
means over the cases every method finished and, for each OTHER, on how many
cases it beats BASE in each measure.
"""
import json
import os
import sys


def broken(r):
    bad = []
    if r["closed_in"] and not r["closed_out"]:
        bad.append("opened")
    if r["loops_out"] != r["loops_in"]:
        bad.append(f"loops {r['loops_in']}->{r['loops_out']}")
    if r["parts_out"] != r["parts_in"]:
        bad.append(f"parts {r['parts_in']}->{r['parts_out']}")
    if r["non_manifold_edges"] or r["non_manifold_vertices"]:
        bad.append("non-manifold")
    return ", ".join(bad) or "-"


# (key, label, higher is better, format)
MEASURES = [("ssim_mean", "SSIM", True, "{:.4f}"), ("flip_mean", "FLIP", False, "{:.4f}"),
            ("hausdorff_mean", "mean H %", False, "{:.4f}"), ("share_angles_below_30", "<30°", False, "{:.2%}"),
            ("min_angle_deg", "min °", True, "{:.1f}")]


def value(r, key):
    return 100 * r[key] if key == "hausdorff_mean" else r[key]


def main():
    runs, methods = sys.argv[1], sys.argv[2:]
    if len(methods) < 2:
        sys.exit(__doc__)
    rows = {}
    for case in sorted(os.listdir(runs)):
        recs = {}
        for m in methods:
            p = os.path.join(runs, case, m + ".json")
            if os.path.exists(p):
                r = json.load(open(p))
                if r.get("ok"):
                    recs[m] = r
        if len(recs) == len(methods):
            rows[case] = recs
    head = "| case | method | vertices | " + " | ".join(l for _, l, _, _ in MEASURES) + " | broken |"
    print(head)
    print("|---|---|---:|" + "---:|" * len(MEASURES) + "---|")
    for case, recs in rows.items():
        for m in methods:
            r = recs[m]
            cells = " | ".join(f.format(value(r, k)) for k, _, _, f in MEASURES)
            print(f"| {case} | {m} | {r['vertices']} | {cells} | {broken(r)} |")
    print()
    print(f"Means over {len(rows)} cases:\n")
    print("| method | " + " | ".join(l for _, l, _, _ in MEASURES) + " | runs broken |")
    print("|---|" + "---:|" * len(MEASURES) + "---:|")
    for m in methods:
        means = [sum(value(recs[m], k) for recs in rows.values()) / max(len(rows), 1) for k, _, _, _ in MEASURES]
        nbroken = sum(broken(recs[m]) != "-" for recs in rows.values())
        cells = " | ".join(f.format(x) for x, (_, _, _, f) in zip(means, MEASURES))
        print(f"| {m} | {cells} | {nbroken} |")
    base = methods[0]
    for m in methods[1:]:
        wins = []
        for k, label, higher, _ in MEASURES:
            better = sum((value(recs[m], k) > value(recs[base], k)) if higher else (value(recs[m], k) < value(recs[base], k))
                         for recs in rows.values())
            worse = sum((value(recs[m], k) < value(recs[base], k)) if higher else (value(recs[m], k) > value(recs[base], k))
                        for recs in rows.values())
            wins.append(f"{label} better on {better}, worse on {worse}")
        print(f"\n{m} against {base}: " + "; ".join(wins) + ".")


if __name__ == "__main__":
    main()
