#!/usr/bin/env bash
# What the Redis Streams queue costs against the embedded one, and how jobs
# spread over worker processes (docs/scaling.md is made with it). Starts a
# throw-away redis-server (AOF, appendfsync always) on a free loopback port,
# then for each set-up a fresh server (and vpremesh-worker processes) and
# `vpremesh bench` closed loops over them. Prints one markdown table.
#   scripts/bench-queue.sh                               (build/release, suzanne -> 300)
#   MODEL=../shared/models/horse.ply TARGET=5000 REQUESTS=20 scripts/bench-queue.sh
#   BIN=.bundle/bin DEVICE=cuda RENDERER=egl PROCS="2 4" scripts/bench-queue.sh   (scripts/device-run.sh queue)
set -uo pipefail
BIN=${BIN:-build/release}
SERVER=${SERVER:-$(ls "$BIN"/vpremesh-server "$BIN"/server/vpremesh-server 2>/dev/null | head -1)}
WORKER=${WORKER:-$(ls "$BIN"/vpremesh-worker "$BIN"/worker/service/vpremesh-worker 2>/dev/null | head -1)}
CLIENT=${CLIENT:-$(ls "$BIN"/vpremesh "$BIN"/client/vpremesh 2>/dev/null | head -1)}
MODEL=${MODEL:-../shared/models/suzanne.obj}
TARGET=${TARGET:-300}
REQUESTS=${REQUESTS:-30}
RESOLUTION=${RESOLUTION:-256}
DEVICE=${DEVICE:-cpu}
RENDERER=${RENDERER:-auto}
PROCS=${PROCS:-2}  # worker-process counts after the first, each with as many clients
APPENDFSYNC=${APPENDFSYNC:-always}  # Redis AOF fsync: always (every write) or everysec
[ -x "$SERVER" ] && [ -x "$WORKER" ] && [ -x "$CLIENT" ] || { echo "bench-queue: binaries missing under $BIN" >&2; exit 2; }
command -v redis-server >/dev/null || { echo "bench-queue: redis-server not found: run scripts/install-deps.sh" >&2; exit 2; }
work=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; wait 2>/dev/null; rm -rf "$work"; }
trap cleanup EXIT

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
# Waits for a line in a log file; prints what follows `pattern`.
wait_line() {
  for _ in $(seq 600); do
    grep -o "$2.*" "$1" 2>/dev/null | head -1 | grep . && return 0
    sleep 0.1
  done
  echo "bench-queue: '$2' never appeared in $1" >&2; cat "$1" >&2; exit 1
}
start_server() {  # FLAGS... -> prints the address
  # All the load comes from one address, and --max-jobs-per-client counts per address.
  "$SERVER" --listen 127.0.0.1:0 --max-jobs-per-client 4096 --device "$DEVICE" --renderer "$RENDERER" "$@" >"$work/server.log" 2>&1 &
  pids+=($!)
  wait_line "$work/server.log" "listening on " | sed 's/listening on //'
}
start_workers() {  # URL N
  for i in $(seq "$2"); do
    "$WORKER" --queue "$1" --device "$DEVICE" --renderer "$RENDERER" >"$work/worker$i.log" 2>&1 &
    pids+=($!)
    wait_line "$work/worker$i.log" "vpremesh-worker ready" >/dev/null
  done
}
stop_all() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; wait 2>/dev/null; pids=(); }
bench() {  # LABEL ADDRESS CONCURRENCY
  "$CLIENT" bench --server "$2" -i "$MODEL" -n "$TARGET" --resolution "$RESOLUTION" -c "$3" -r "$REQUESTS" \
    --warmup 2 --json >"$work/bench.json" || { echo "bench-queue: bench failed ($1)" >&2; exit 1; }
  python3 - "$1" "$3" "$work/bench.json" <<'PY'
import json, sys
label, c, path = sys.argv[1], sys.argv[2], sys.argv[3]
j = json.load(open(path)); l, s = j["latency_ms"], j["split_ms"]
print(f"| {label} | {c} | {j['completed']}/{j['requests']} | {j['throughput_per_s']:.2f} | {l['p50']:.0f} | "
      f"{l['p99']:.0f} | {l['mean']:.0f} | {s['queue']:.1f} | {s['stages']:.0f} | {s['server_other']:.1f} |")
PY
}

port=$(free_port)
redis-server --port "$port" --bind 127.0.0.1 --dir "$work" --appendonly yes --appendfsync "$APPENDFSYNC" --save '' \
  --logfile "$work/redis.log" &
pids+=($!)
for _ in $(seq 100); do redis-cli -p "$port" ping 2>/dev/null | grep -q PONG && break; sleep 0.1; done
url="redis://127.0.0.1:$port"

echo "| queue | clients | done | jobs/s | p50 ms | p99 ms | mean ms | queue ms | stages ms | server other ms |"
echo "|---|---|---|---|---|---|---|---|---|---|"
addr=$(start_server --workers 1)
bench "embedded, 1 worker" "$addr" 1
stop_all
# The stop above also stopped Redis: start it again on the same port and dir.
redis-server --port "$port" --bind 127.0.0.1 --dir "$work" --appendonly yes --appendfsync "$APPENDFSYNC" --save '' \
  --logfile "$work/redis.log" &
pids+=($!)
for _ in $(seq 100); do redis-cli -p "$port" ping 2>/dev/null | grep -q PONG && break; sleep 0.1; done
addr=$(start_server --queue "$url")
start_workers "$url" 1
bench "redis ($APPENDFSYNC), 1 worker process" "$addr" 1
running=1
for n in $PROCS; do
  start_workers "$url" $((n - running))
  running=$n
  bench "redis ($APPENDFSYNC), $n worker processes" "$addr" "$n"
done
