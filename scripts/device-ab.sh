#!/usr/bin/env bash
# Runs ON the device machine, after scripts/device-run.sh has unpacked the new
# bundle and the GL loaders: the baseline bundle and the new one alternating,
# ROUNDS rounds a side, each round one warm vpremesh-bench process per
# argument set (the before-and-after tables of docs/performance.md).
#   scripts/device-ab.sh ROUNDS "BENCH ARGS" ["BENCH ARGS" ...]
# Carry .pack/bundle.tar.xz (the new bundle, scripts/device-bundle.sh) and
# .pack/base.tar.xz (the baseline commit's .bundle/bin/vpremesh-bench and
# .bundle/commit alone, packed the same way: two whole packs pass the tool's
# 64 MiB; the libraries are the new bundle's, the same Debian packages).
# Appends every table to $OUT/ab.md (each line marked side, round and set;
# the device tool brings back 8 files at most) and prints them; with
# VPREMESH_STEP_MARKS=1, the step medians per side and set to $OUT/steps.md.
set -uo pipefail
rounds=${1:?rounds}
shift
OUT=${OUT:-/tmp/out}
mkdir -p "$OUT" .base
if [ ! -d .base/.bundle ] || [ .pack/base.tar.xz -nt .base/.bundle ]; then
  rm -rf .base/.bundle
  tar -xJf .pack/base.tar.xz -C .base
  touch .base/.bundle
fi
[ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] &&
  export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
echo "base: $(cat .base/.bundle/commit)  new: $(cat .bundle/commit)"
for r in $(seq 1 "$rounds"); do
  for side in base new; do
    dir=.bundle
    [ $side = base ] && dir=.base/.bundle
    set_no=0
    for args in "$@"; do
      set_no=$((set_no + 1))
      # shellcheck disable=SC2086  # each set is a word list on purpose
      LD_LIBRARY_PATH=$PWD/.bundle/lib $dir/bin/vpremesh-bench $args 2>"$OUT/run.err" |
        sed "s/^/$side r$r s$set_no: /" | tee -a "$OUT/ab.md"
      sed "s/^/$side s$set_no /" "$OUT/run.err" >>"$OUT/ab.err"
    done
  done
done
rm -f "$OUT/run.err"
# With VPREMESH_STEP_MARKS=1 set, each side's and set's step medians
# (scripts/step-marks.py: medians over every run of the process).
if grep -q "^[a-z]* s[0-9]* steps " "$OUT/ab.err" 2>/dev/null; then
  for set_no in $(seq 1 $#); do
    for side in base new; do
      grep "^$side s$set_no steps " "$OUT/ab.err" | cut -d' ' -f3- |
        python3 scripts/step-marks.py --label "$side s$set_no " >>"$OUT/steps.md"
    done
  done
  grep -v "^[a-z]* s[0-9]* steps " "$OUT/ab.err" >"$OUT/ab.err.tmp" && mv "$OUT/ab.err.tmp" "$OUT/ab.err"
fi
