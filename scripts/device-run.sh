#!/usr/bin/env bash
# Runs ON the device machine (NVIDIA H100), from the repository root, with
# .pack/ (scripts/device-bundle.sh) and .gl/ (the GL loader debs) carried:
#   scripts/device-run.sh [tests|bench|all|suite|load|queue|isolation|density|targets|field|lod|visual] [bench arguments...]
# Writes under $OUT: device.txt, gpu-tests.log, bench.md; `load` (not part of
# all) writes load.md: vpremesh-server with --device cuda and 1, 2, 4 workers,
# driven by `vpremesh bench` closed and open loop (scripts/bench-load.sh);
# `queue` writes queue.md: the embedded queue against Redis Streams with 1, 2
# and 4 vpremesh-worker processes on the GPU (scripts/bench-queue.sh).
set -uo pipefail
mode=${1:-all}
shift || true
OUT=${OUT:-/tmp/out}
mkdir -p "$OUT"
# A warm machine keeps the last call's .bundle: unpack again when the pack is newer.
# (Python's lzma where the image has no xz.)
if [ ! -d .bundle ] || [ .pack/bundle.tar.xz -nt .bundle ]; then
  rm -rf .bundle
  if command -v xz >/dev/null; then tar -xJf .pack/bundle.tar.xz
  else python3 -c 'import tarfile; tarfile.open(".pack/bundle.tar.xz").extractall()'; fi
  touch .bundle
fi
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
export LD_LIBRARY_PATH=$PWD/.bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] &&
  export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json

# The build tree's ctest files name /work/main/build/device and the tests read
# ../shared/models: recreate those paths here.
mkdir -p /work/shared build
[ "$PWD" = /work/main ] || ln -sfn "$PWD" /work/main
ln -sfn "$PWD/.bundle/models" /work/shared/models
ln -sfn "$PWD/.bundle/build" build/device

{ date -u +%FT%TZ; nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader; nproc;
  echo "bundle built at $(cat .bundle/commit 2>/dev/null || echo 'an unknown commit')"; } >"$OUT/device.txt" 2>&1
cat "$OUT/device.txt"

if [ "$mode" = tests ] || [ "$mode" = all ]; then
  (cd build/device && ctest -L gpu --output-on-failure --timeout 300) 2>&1 | tee "$OUT/gpu-tests.log"
fi
if [ "$mode" = bench ] || [ "$mode" = all ]; then
  M=.bundle/models
  args=("$@")
  [ ${#args[@]} -gt 0 ] || args=("$M/igea.ply:10000" "$M/horse.ply:5000" "$M/bunny.obj:5000" "$M/kitten.obj:5000")
  .bundle/bin/vpremesh-bench "${args[@]}" 2>"$OUT/bench.err" | tee "$OUT/bench.md"
  tail -5 "$OUT/bench.err"
fi
if [ "$mode" = suite ]; then
  # The measurements in docs/performance.md (GPU section), in one warm process each.
  B=.bundle/bin/vpremesh-bench
  M=.bundle/models
  $B --device both --repeat 5 --peers all "$M/igea.ply:10000" "$M/horse.ply:5000" "$M/bunny.obj:5000" \
    "$M/kitten.obj:5000" 2>>"$OUT/bench.err" | tee "$OUT/bench-models.md"
  $B --device both --repeat 3 --peers "OpenMesh QEM,meshoptimizer" "$M/igea.ply@1M:20000" 2>>"$OUT/bench.err" |
    tee "$OUT/bench-1m.md"
  $B --device cuda --repeat 3 --peers none --concurrency 8 --jobs 32 "$M/horse.ply:5000" 2>>"$OUT/bench.err" |
    tee "$OUT/bench-concurrency.md"
  grep -v '\.\.\.$' "$OUT/bench.err" | tail -30
fi
if [ "$mode" = lod ]; then
  # Issue 20's chain and a visual target (scripts/bench-lod.sh): the GPU path,
  # then the CPUs only (16 threads). Visual-target models as arguments
  # (default kitten), SWEEP counts below each (default 0).
  M=.bundle/models
  visual=("$@")
  [ ${#visual[@]} -gt 0 ] || visual=("$M/kitten.obj")
  ROUNDS=${ROUNDS:-2} SWEEP=${SWEEP:-0} bash scripts/bench-lod.sh .bundle/bin/vpremesh "$M/igea.ply" \
    50000,20000,5000,1000 "${visual[@]}" | tee "$OUT/lod-gpu.md"
  CUDA_VISIBLE_DEVICES= ROUNDS=${ROUNDS:-2} SWEEP=${SWEEP:-0} bash scripts/bench-lod.sh \
    .bundle/bin/vpremesh "$M/igea.ply" 50000,20000,5000,1000 "${visual[@]}" | tee "$OUT/lod-cpu.md"
fi
if [ "$mode" = visual ]; then
  # Issue 20's visual targets with the search's tries made ahead after a
  # pass, after either outcome, and without (scripts/bench-lod.sh, CHAIN=0;
  # AHEADS picks), on the GPU path, ROUNDS times. Models as arguments.
  M=.bundle/models
  visual=("$@")
  [ ${#visual[@]} -gt 0 ] || visual=("$M/kitten.obj" "$M/fish.obj" "$M/fandisk.obj" "$M/horse.ply")
  for round in $(seq "${ROUNDS:-1}"); do
    for ahead in ${AHEADS:-on both off}; do
      echo "round $round, --tries-ahead $ahead" | tee -a "$OUT/visual.md"
      CHAIN=0 ROUNDS=1 SWEEP=${SWEEP:-0} FLAGS="--tries-ahead $ahead" bash scripts/bench-lod.sh \
        .bundle/bin/vpremesh "$M/igea.ply" 50000 "${visual[@]}" | tee -a "$OUT/visual.md"
    done
  done
fi
if [ "$mode" = load ]; then
  # About 3 minutes: runs that would start after BUDGET_S are skipped and listed.
  BIN=.bundle/bin DEVICE=cuda WORKERS="${WORKERS:-1 2 4}" CLOSED="${CLOSED:-1 4 8}" REQUESTS=${REQUESTS:-16} \
    OPEN_FACTORS="${OPEN_FACTORS:-0.9 1.5}" OPEN_S=${OPEN_S:-8} BUDGET_S=${BUDGET_S:-160} JSON_DIR="${JSON_DIR:-/tmp/load-json}" \
    MODELS="${MODELS:-.bundle/models/igea.ply:10000 .bundle/models/horse.ply:5000}" \
    bash scripts/bench-load.sh 2>"$OUT/load.err" | tee "$OUT/load.md"
  tail -5 "$OUT/load.err"
fi
if [ "$mode" = isolation ]; then
  # Job processes against jobs in the server's threads (docs/isolation.md), CPU and GPU.
  BIN=.bundle/bin DEVICE=cpu MODEL=.bundle/models/horse.ply TARGET=5000 ROUNDS=${ROUNDS:-4} REQUESTS=${REQUESTS:-5} \
    bash scripts/bench-isolation.sh 2>"$OUT/isolation.err" | tee "$OUT/isolation.md"
  BIN=.bundle/bin DEVICE=cuda MODEL=.bundle/models/igea.ply TARGET=10000 ROUNDS=${ROUNDS:-4} REQUESTS=${REQUESTS:-5} \
    bash scripts/bench-isolation.sh 2>>"$OUT/isolation.err" | tee -a "$OUT/isolation.md"
  tail -5 "$OUT/isolation.err"
fi
if [ "$mode" = density ]; then
  # Every back half and density on every bundled model (docs/quality.md), JOBS at a time.
  MODELS=.bundle/models JOBS=${JOBS:-12} WORK=/tmp/density bash scripts/density-compare.sh .bundle/bin/vpremesh |
    tee "$OUT/density.md"
fi
if [ "$mode" = targets ]; then
  # Issue 23's goal: every bundled model at 1,000, 5,000 and twice its vertex count, no crash.
  for m in .bundle/models/*; do
    v=$(.bundle/bin/vpremesh eval "$m" "$m" --no-visual --json 2>/dev/null | python3 -c 'import json,sys; print(json.load(sys.stdin)["reference"]["vertices"])')
    for t in 1000 5000 $((2 * v)); do echo "$m $t"; done
  done | xargs -P "${JOBS:-12}" -L 1 sh -c '.bundle/bin/vpremesh local "$0" -o /tmp/t-$(basename "$0")-$1.ply -n "$1" >/dev/null 2>/tmp/t-$(basename "$0")-$1.err; echo "$(basename "$0") $1 exit $?"' |
    sort | tee "$OUT/targets.txt"
fi
if [ "$mode" = field ]; then
  # Issue 24's speed goal, paired: ROUNDS fresh processes each way, alternating,
  # the attention field (the default) against the paper's (--density paper);
  # the field's stages summed per run (views, image_saliency, unproject,
  # visibility, saliency_field: the render, the same work either way and
  # carrying the GL start-up, left out). Medians, ms, to field.md.
  M=${MODEL:-.bundle/models/igea.ply} T=${TARGET:-10000} R=${ROUNDS:-7}
  stage_ms() { awk -v want="$2" '/"ms":/ {gsub(/[",]/, "", $2); ms = $2}
    /"name":/ {gsub(/[",]/, "", $2); if ($2 == want && !done) {print ms; done = 1}}' "$1"; }
  median() { sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)]}'; }
  for r in $(seq "$R"); do
    for f in attention paper; do
      extra=(); [ $f = paper ] && extra=(--density paper)
      .bundle/bin/vpremesh local "$M" -n "$T" -o /tmp/field-$f.ply --json "${extra[@]}" >/tmp/field-$f-$r.json 2>/dev/null
    done
  done
  {
    echo "| field | views | image_saliency | unproject | visibility | saliency_field | sum without render | render |"
    echo "|---|---:|---:|---:|---:|---:|---:|---:|"
    for f in attention paper; do
      row="| $f |"
      for s in views image_saliency unproject visibility saliency_field sum render; do
        m=$(for r in $(seq "$R"); do
          j=/tmp/field-$f-$r.json
          if [ $s = sum ]; then
            for t in views image_saliency unproject visibility saliency_field; do stage_ms "$j" $t; done |
              awk '{s += $1} END {printf "%.2f\n", s}'
          else
            v=$(stage_ms "$j" $s)
            echo "${v:-0}"
          fi
        done | median)
        row="$row $m |"
      done
      echo "$row"
    done
    grep -o '"note": "[^"]*waiting[^"]*"' /tmp/field-attention-1.json || true
  } | tee "$OUT/field.md"
fi
if [ "$mode" = queue ]; then
  PATH=$PWD/.bundle/bin:$PATH BIN=.bundle/bin DEVICE=cuda RENDERER=egl PROCS="${PROCS:-2 4}" \
    MODEL="${MODEL:-.bundle/models/igea.ply}" TARGET=${TARGET:-10000} RESOLUTION=${RESOLUTION:-512} \
    REQUESTS=${REQUESTS:-24} bash scripts/bench-queue.sh 2>"$OUT/queue.err" | tee "$OUT/queue.md"
  tail -5 "$OUT/queue.err"
fi
