#!/usr/bin/env bash
# What running jobs in supervised job processes costs (docs/isolation.md):
# two servers from the same binary, --isolation thread (the old way: jobs in
# the server's own threads) and --isolation process (the default), each with
# one warm worker, driven by `vpremesh bench -c 1` in alternating rounds so
# both see the same machine. Prints a markdown table of end-to-end latency.
#   scripts/bench-isolation.sh                                   (CPU, build/release, horse -> 5000)
#   BIN=.bundle/bin DEVICE=cuda MODEL=.bundle/models/igea.ply TARGET=10000 scripts/bench-isolation.sh
set -uo pipefail
BIN=${BIN:-build/release}
SERVER=${SERVER:-$(ls "$BIN"/vpremesh-server "$BIN"/server/vpremesh-server 2>/dev/null | head -1)}
CLIENT=${CLIENT:-$(ls "$BIN"/vpremesh "$BIN"/client/vpremesh 2>/dev/null | head -1)}
DEVICE=${DEVICE:-cpu}
MODEL=${MODEL:-../shared/models/horse.ply}
TARGET=${TARGET:-5000}
ROUNDS=${ROUNDS:-4}
REQUESTS=${REQUESTS:-5}
[ -x "$SERVER" ] && [ -x "$CLIENT" ] || { echo "bench-isolation: no vpremesh-server / vpremesh under $BIN" >&2; exit 2; }
dir=$(mktemp -d)
pids=()
trap 'kill "${pids[@]}" 2>/dev/null; wait 2>/dev/null; rm -rf "$dir"' EXIT

declare -A address
for mode in thread process; do
  # All the load comes from one address, and --max-jobs-per-client counts per address.
  "$SERVER" --listen 127.0.0.1:0 --max-jobs-per-client 4096 --workers 1 --device "$DEVICE" --isolation "$mode" >"$dir/$mode.log" 2>&1 &
  pids+=($!)
  for _ in $(seq 600); do
    address[$mode]=$(sed -n 's/^vpremesh-server listening on \([^ ]*\).*/\1/p' "$dir/$mode.log")
    [ -n "${address[$mode]}" ] && break
    sleep 0.1
  done
  [ -n "${address[$mode]}" ] || { echo "bench-isolation: the $mode server did not start" >&2; cat "$dir/$mode.log" >&2; exit 1; }
done

for round in $(seq "$ROUNDS"); do
  for mode in thread process; do
    "$CLIENT" bench --server "${address[$mode]}" -i "$MODEL" -n "$TARGET" -c 1 -r "$REQUESTS" --warmup 1 \
      --device "$([ "$DEVICE" = cuda ] && echo cuda || echo cpu)" --json >"$dir/$mode.$round.json" ||
      echo "bench-isolation: round $round ($mode) failed" >&2
  done
done

python3 - "$dir" "$ROUNDS" "$(basename "$MODEL")" "$TARGET" "$DEVICE" <<'PY'
import json, statistics, sys
d, rounds, model, target, device = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]
lat = {}
for mode in ("thread", "process"):
    runs = [json.load(open(f"{d}/{mode}.{r}.json")) for r in range(1, rounds + 1)]
    lat[mode] = [r["latency_ms"]["p50"] for r in runs]
    lat[mode + "_all"] = sum((r["latency_ms"]["mean"] * r["completed"] for r in runs), 0.0) / max(1, sum(r["completed"] for r in runs))
print(f"{model} -> {target} on {device}, one warm worker, `vpremesh bench -c 1`, {rounds} alternating rounds")
print()
print("| isolation | p50 per round (ms) | median of the p50s (ms) | mean of every request (ms) |")
print("|---|---|---|---|")
for mode in ("thread", "process"):
    print(f"| {mode} | {', '.join(f'{x:.0f}' for x in lat[mode])} | {statistics.median(lat[mode]):.1f} | {lat[mode + '_all']:.1f} |")
t, p = statistics.median(lat["thread"]), statistics.median(lat["process"])
print()
print(f"process - thread: {p - t:+.1f} ms ({100 * (p - t) / t:+.1f}%) on the median p50")
PY
