#!/usr/bin/env bash
# Builds the GPU bundle on this (GPU-less) machine for the device machine:
# nvcc for sm_90, EGL only (OSMesa's LLVM is too big to carry), Release. Writes
# .bundle/ (ignored by git, carried by the device tool):
#   bin/     vpremesh, vpremesh-bench, vpremesh-server, vpremesh-worker (stripped),
#            and this machine's redis-server and redis-cli for the queue benchmark
#   lib/     the non-system shared libraries they need (from ldd)
#   build/   a pruned copy of the build tree that `ctest -L gpu` can run
#   models/  the shared models the GPU tests and the benchmark read
# and packs it into .pack/bundle.tar.xz, which is what the device tool carries
# (xz: with gzip the pack and the tree passed the tool's 64 MiB).
# Then scripts/device-run.sh runs on the device. Usage: scripts/device-bundle.sh
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=build/device
MODELS=${MODELS:-"igea.ply horse.ply bunny.obj kitten.obj"}

cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DVPR_CUDA="${CUDA:-ON}" -DVPR_OSMESA=OFF \
  -DCMAKE_CUDA_ARCHITECTURES=90 >/dev/null
targets=(vpremesh vpremesh-bench)
# The list once, then grep it: `ninja ... | grep -q` under pipefail fails
# whenever grep stops reading early and ninja dies of SIGPIPE.
known=$(ninja -C "$BUILD" -t targets all 2>/dev/null || true)
for t in ${EXTRA_TARGETS-vpremesh-server vpremesh-worker image_saliency_gpu_test attention_field_gpu_test geometry_gpu_test staged_upload_gpu_test mesh_edges_gpu_test mean_curvature_gpu_test cvt_sweeps_gpu_test offset_match_gpu_test dual_projection_gpu_test drawn_geometry_gpu_test device_snapshots_gpu_test pipeline_gpu_test job_device_test}; do
  if grep -q "^$t:" <<<"$known"; then targets+=("$t"); fi
done
cmake --build "$BUILD" -j"$(nproc)" --target "${targets[@]}"

rm -rf .bundle && mkdir -p .bundle/bin .bundle/lib .bundle/build .bundle/models
bins=()
for t in vpremesh vpremesh-bench vpremesh-server vpremesh-worker; do
  f=$(find "$BUILD" -maxdepth 3 -type f -name "$t" -perm -u+x | head -1)
  [ -n "$f" ] && cp "$f" .bundle/bin/ && bins+=(".bundle/bin/$t")
done
for t in redis-server redis-cli; do
  if command -v "$t" >/dev/null; then cp "$(command -v "$t")" .bundle/bin/ && bins+=(".bundle/bin/$t"); fi
done
# The ctest tree: every CTestTestfile and discovered-test list, and the test
# executables at their paths relative to the build folder.
(cd "$BUILD" && find . \( -name CTestTestfile.cmake -o -name '*_include.cmake' -o -name '*_tests.cmake' \
  -o -name '*_labels.cmake' \) \
  -exec cp --parents {} ../../.bundle/build/ \;)
for t in "${targets[@]}"; do
  case "$t" in *_test)
    rel=$(cd "$BUILD" && find tests -maxdepth 2 -type f -name "$t" | head -1)
    [ -n "$rel" ] || continue
    mkdir -p ".bundle/build/$(dirname "$rel")"
    cp "$BUILD/$rel" ".bundle/build/$rel"
    bins+=(".bundle/build/$rel") ;;
  esac
done
strip --strip-unneeded "${bins[@]}"

# Libraries the device image lacks: everything ldd finds except the C/C++
# runtime, the CUDA driver and the GL loaders (the .gl/ debs bring those).
skip='^(linux-vdso|ld-linux|libc\.|libm\.|libstdc\+\+|libgcc_s|libpthread|libdl\.|librt\.|libcuda\.|libEGL|libGL|libOpenGL|libGLX|libGLdispatch)'
for b in "${bins[@]}"; do ldd "$b"; done | awk '/=> \//{print $1, $3}' | sort -u |
  while read -r name path; do
    [[ "$name" =~ $skip ]] || cp -L "$path" .bundle/lib/
  done
for m in $MODELS; do cp "../shared/models/$m" .bundle/models/; done
# The commit the binaries were built from (the device's copy of the tree may
# name another): "+" when the tree had changes not committed.
{ git rev-parse --short HEAD; git diff --quiet HEAD -- . ':!.pack' ':!.gl' || echo "+"; } | paste -sd '' >.bundle/commit
# The tool carries at most 64 MiB with the working tree: send it compressed.
mkdir -p .pack && rm -f .pack/bundle.tar.gz && tar -cf - .bundle | xz -T0 -6 >.pack/bundle.tar.xz
du -sh .bundle .pack/bundle.tar.xz | sed 's/^/device-bundle: /'
