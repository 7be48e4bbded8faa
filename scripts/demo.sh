#!/usr/bin/env bash
# The demo, through the service: start vpremesh-server on a free loopback port,
# remesh a bundled model with `vpremesh submit` (upload, live progress, result,
# stage table with the queue time), compare it with the input, stop the server.
# Usage: scripts/demo.sh BUILD_DIR MODEL TARGET OUT_DIR
set -euo pipefail
build=$1 model=$2 target=$3 out=$4
mkdir -p "$out"
name=$(basename "${model%.*}")
log="$out/server.log"

# Port 0: the server picks a free port and prints
# "vpremesh-server listening on 127.0.0.1:PORT" once it accepts calls.
"$build/server/vpremesh-server" --listen 127.0.0.1:0 >"$log" 2>&1 &
server=$!
# SIGTERM drains the server (no job is left by then); on any exit.
trap 'kill "$server" 2>/dev/null && wait "$server" 2>/dev/null; true' EXIT

address=""
for _ in $(seq 600); do  # up to a minute
  address=$(sed -n 's/^vpremesh-server listening on \([^ ]*\)$/\1/p' "$log" | head -n 1)
  [[ -n $address ]] && break
  if ! kill -0 "$server" 2>/dev/null; then
    cat "$log" >&2
    echo "vpremesh demo: vpremesh-server exited before it listened" >&2
    exit 1
  fi
  sleep 0.1
done
if [[ -z $address ]]; then
  cat "$log" >&2
  echo "vpremesh demo: vpremesh-server did not listen within a minute" >&2
  exit 1
fi

echo "vpremesh demo: $model -> $target vertices on vpremesh-server at $address"
"$build/client/vpremesh" submit "$model" -o "$out/$name-remeshed.ply" --target-vertices "$target" \
  --server "$address"
echo
"$build/client/vpremesh" eval "$model" "$out/$name-remeshed.ply"
echo
echo "wrote $out/$name-remeshed.ply (mesh + saliency); server log in $log"
