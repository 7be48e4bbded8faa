#!/usr/bin/env bash
# The demo: remesh a bundled model with `vpremesh local` and print the stage table.
# Usage: scripts/demo.sh BUILD_DIR MODEL TARGET OUT_DIR
set -euo pipefail
build=$1 model=$2 target=$3 out=$4
mkdir -p "$out"
name=$(basename "${model%.*}")
echo "vpremesh demo: $model -> $target vertices"
"$build/client/vpremesh" local "$model" -o "$out/$name-remeshed.ply" --target-vertices "$target" \
  --field-out "$out/$name-saliency.ply" --debug-dir "$out/debug"
echo
"$build/client/vpremesh" eval "$model" "$out/$name-remeshed.ply"
echo
echo "wrote $out/$name-remeshed.ply (mesh + saliency), $out/$name-saliency.ply (field on the input),"
echo "      $out/debug/ (per-view snapshots, feature images, saliency points)"
