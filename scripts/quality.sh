#!/usr/bin/env bash
# The issue-21 referee (docs/quality.md, "Side by side at equal vertex counts"):
# every shared model at the two targets of scripts/density-compare.sh, by our
# pipeline at four densities (perception, curvature, uniform, paper), MeshLab's
# adaptive isotropic remeshing (pymeshlab, edge length searched to within 2% of
# the vertex count) and the peers of `vpremesh compare` (OpenMesh QEM, CGAL
# isotropic, meshoptimizer); each result judged by `vpremesh eval` (SSIM over 14
# views, Hausdorff, angles, topology) and by FLIP on the same renderings.
# Writes $OUT/runs/<model>-<target>/<method>.json (one per run: the resume
# point), $OUT/{summary.md,summary.json,results.json,results.csv}, a contact
# sheet per case, and the referee part of docs/quality.md.
#   scripts/quality.sh [VPREMESH]                   (default build/release/client/vpremesh)
#   CASES="horse.ply 5000
#   fandisk.obj 3000" METHODS="ours-perception meshlab-adaptive" scripts/quality.sh
#   JOBS=2 (runs at a time)  FRESH=1 (drop earlier runs first)  DOC= (leave docs/quality.md alone)
#   ANY_COMMIT=1 (keep earlier runs even where the code has changed since)
#   STEP_TIMEOUT=1800 (seconds a remeshing or an evaluation may take; past it the run is a failure)
# Methods: ours-perception ours-curvature ours-uniform ours-paper meshlab-adaptive
#          openmesh-qem cgal-isotropic meshoptimizer
#          and variants of ours: ours-MODE~flag=value~... (e.g. ours-curvature~anisotropy=0)
# pymeshlab, flip-evaluator, numpy and pillow come from a virtual environment
# made on first use ($VENV); the service never needs them.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${1:-build/release/client/vpremesh}
M=${MODELS:-../shared/models}
OUT=${OUT:-docs/images/quality/issue21}
WORK=${WORK:-build/quality-work}
VENV=${VENV:-build/quality-venv}
JOBS=${JOBS:-2}
DOC=${DOC-docs/quality.md}
# Default cases: density-compare.sh's list, so that both scripts measure the same runs.
DEFAULT_CASES=$(sed -n '/^CASES=\${CASES:-"/,/"}$/p' scripts/density-compare.sh | sed -e 's/^CASES=\${CASES:-"//' -e 's/"}$//')
CASES=${CASES:-$DEFAULT_CASES}
# In order of what the goals need first: a run cut short still has whole columns.
METHODS=${METHODS:-"ours-curvature meshlab-adaptive cgal-isotropic openmesh-qem ours-uniform ours-perception ours-paper meshoptimizer"}
[ -x "$BIN" ] || { echo "quality.sh: no vpremesh binary at $BIN (make build, or pass its path)" >&2; exit 2; }
[ -n "$CASES" ] || { echo "quality.sh: no cases (could not read density-compare.sh's list)" >&2; exit 2; }

# scipy: scripts/gaze-score.py's k-d tree (without it the fixation-weighted
# error of a 10,000-vertex remesh takes minutes instead of a second).
if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -c 'import pymeshlab, flip_evaluator, numpy, PIL, scipy' 2>/dev/null; then
  echo "quality.sh: making $VENV (pymeshlab flip-evaluator numpy pillow scipy)" >&2
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install -q pymeshlab flip-evaluator numpy pillow scipy
fi
PY="$VENV/bin/python"

# What is measured: the last commit that changed the code vpremesh is built from
# (docs and scripts do not count). Earlier runs of other code are measured again.
CODE="worker client proto server cmake CMakeLists.txt"
COMMIT=$(git log -1 --format=%h HEAD -- $CODE 2>/dev/null || echo unknown)
git diff --quiet HEAD -- $CODE 2>/dev/null || COMMIT="$COMMIT+local-changes"
[ "${FRESH:-0}" = 1 ] && rm -rf "$OUT/runs" "$WORK"
mkdir -p "$OUT/runs" "$WORK"

start=$(date +%s)
"$PY" scripts/quality/referee.py --bin "$BIN" --models "$M" --cases "$CASES" --methods "$METHODS" \
  --runs "$OUT/runs" --work "$WORK" --jobs "$JOBS" --commit "$COMMIT" ${ANY_COMMIT:+--any-commit} \
  --timeout "${STEP_TIMEOUT:-1800}"
echo "quality.sh: runs took $(($(date +%s) - start)) s" >&2
"$PY" scripts/quality/report.py --runs "$OUT/runs" --out "$OUT" ${DOC:+--doc "$DOC"} \
  --note "Machine: $(nproc) cores, $(uname -m); runs $JOBS at a time."
echo "$OUT/summary.md" >&2
