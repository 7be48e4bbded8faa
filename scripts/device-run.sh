#!/usr/bin/env bash
# Runs ON the device machine (NVIDIA H100), from the repository root, with
# .bundle/ (scripts/device-bundle.sh) and .gl/ (the GL loader debs) carried:
#   scripts/device-run.sh [tests|bench|all] [bench arguments...]
# Writes under $OUT: device.txt, gpu-tests.log, bench.md.
set -uo pipefail
mode=${1:-all}
shift || true
OUT=${OUT:-/tmp/out}
mkdir -p "$OUT"
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
  git log -1 --format=%h 2>/dev/null || true; } >"$OUT/device.txt" 2>&1
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
