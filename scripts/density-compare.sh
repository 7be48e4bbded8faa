#!/usr/bin/env bash
# What each back half and density buys (docs/quality.md, "Density modes"):
# `vpremesh local --density MODE` on every shared model at two targets, each
# result judged by `vpremesh eval` against its input: SSIM of gray renderings
# (14 views), mean Hausdorff distance, angles under 30 degrees, boundary loops
# and parts (against the input's), non-manifold edges. Runs JOBS at a time.
# Prints a markdown table; the JSON of each run stays under $WORK.
#   scripts/density-compare.sh [VPREMESH]        (default build/release/client/vpremesh)
#   MODES="perception uniform" JOBS=8 MODELS=../shared/models scripts/density-compare.sh .bundle/bin/vpremesh
set -uo pipefail
BIN=${1:-build/release/client/vpremesh}
M=${MODELS:-../shared/models}
MODES=${MODES:-"perception curvature uniform paper"}
JOBS=${JOBS:-2}
WORK=${WORK:-$(mktemp -d)}
[ -x "$BIN" ] || { echo "density-compare: no vpremesh at $BIN" >&2; exit 2; }
mkdir -p "$WORK"
# model target target (the second about a third of the first, or 2x the input for small ones)
CASES=${CASES:-"igea.ply 10000 3000
nefertiti.obj 10000 3000
horse.ply 5000 2000
bunny.obj 5000 2000
beast.obj 5000 2000
kitten.obj 5000 2000
boot.obj 5000 2000
fish.obj 5000 2000
wingnut.obj 3000 1000
rocker-arm.obj 5000 2000
fandisk.obj 3000 1000
teapot.obj 2000 1000
spot.obj 2000 1000
suzanne.obj 600 300
cube_no_bottom.obj 500 200"}

run_one() {  # model target mode
  local name=${1%.*}
  local out="$WORK/$name-$2-$3"
  "$BIN" local "$M/$1" -o "$out.ply" -n "$2" --density "$3" --json >"$out.run.json" 2>"$out.err" &&
    "$BIN" eval "$M/$1" "$out.ply" --json >"$out.eval.json" 2>>"$out.err" || echo "failed" >"$out.failed"
}
export -f run_one
export BIN M WORK
while read -r model t1 t2; do
  for t in $t1 $t2; do for mode in $MODES; do echo "$model $t $mode"; done; done
done <<<"$CASES" | xargs -P "$JOBS" -L 1 bash -c 'run_one "$@"' _

python3 - "$WORK" "$MODES" <<'PY' "$CASES"
import json, os, sys
work, modes, cases = sys.argv[1], sys.argv[2].split(), sys.argv[3]
print("| model | target | density | vertices | SSIM | mean Hausdorff (% diag) | angles < 30° | min angle | loops in/out | parts in/out | nm edges | ms |")
print("|---|---:|---|---:|---:|---:|---:|---:|---|---|---:|---:|")
totals = {m: [] for m in modes}
for line in cases.strip().splitlines():
    model, *targets = line.split()
    name = model.rsplit(".", 1)[0]
    for t in targets:
        for mode in modes:
            base = f"{work}/{name}-{t}-{mode}"
            if os.path.exists(base + ".failed") or not os.path.exists(base + ".eval.json"):
                err = open(base + ".err").read().strip().splitlines()[-1:] if os.path.exists(base + ".err") else ["?"]
                print(f"| {name} | {t} | {mode} | failed: {err[0][:80]} | | | | | | | | |")
                continue
            e = json.load(open(base + ".eval.json")); r = json.load(open(base + ".run.json"))
            c, ref, h, v = e["candidate"], e["reference"], e["hausdorff"], e["visual"]
            totals[mode].append((v["ssim_mean"], 100 * h["mean"], c["share_angles_below_30"]))
            print(f"| {name} | {t} | {mode} | {c['vertices']} | {v['ssim_mean']:.4f} | {100 * h['mean']:.4f} | "
                  f"{100 * c['share_angles_below_30']:.2f}% | {c['min_angle_deg']:.1f} | {ref['boundary_loops']}/{c['boundary_loops']} | "
                  f"{ref['components']}/{c['components']} | {c['non_manifold_edges']} | {r.get('total_ms', 0):.0f} |")
print()
print("| density | runs | SSIM mean | mean Hausdorff mean (% diag) | angles < 30° mean |")
print("|---|---:|---:|---:|---:|")
for m in modes:
    t = totals[m]
    if t:
        print(f"| {m} | {len(t)} | {sum(x[0] for x in t) / len(t):.4f} | {sum(x[1] for x in t) / len(t):.4f} | {100 * sum(x[2] for x in t) / len(t):.2f}% |")
PY
