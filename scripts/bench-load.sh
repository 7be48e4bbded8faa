#!/usr/bin/env bash
# Load and latency of vpremesh-server, swept over worker counts, models and
# load (docs/benchmarks.md is made with it): for each --workers W a fresh
# server on a free loopback port, and for each MODEL:TARGET
#   closed loop: `vpremesh bench -c C -r REQUESTS` for each C in CLOSED,
#   open loop:   `vpremesh bench --rate F x capacity --duration OPEN_S` for each
#                F in OPEN_FACTORS, capacity being the best closed-loop throughput.
# Prints markdown tables on stdout; each run's JSON goes to $JSON_DIR.
#   scripts/bench-load.sh                       (CPU, build/release, horse and bunny)
#   BIN=.bundle/bin DEVICE=cuda WORKERS="1 2 4" MODELS=".bundle/models/igea.ply:10000" scripts/bench-load.sh
# Runs that would start after BUDGET_S seconds are skipped (and listed as such).
# ADDR=HOST:PORT loads a server that is already running (scripts/soak.sh)
# instead of starting one per worker count; WORKERS then only labels the rows.
set -uo pipefail
BIN=${BIN:-build/release}
SERVER=${SERVER:-$(ls "$BIN"/vpremesh-server "$BIN"/server/vpremesh-server 2>/dev/null | head -1)}
CLIENT=${CLIENT:-$(ls "$BIN"/vpremesh "$BIN"/client/vpremesh 2>/dev/null | head -1)}
DEVICE=${DEVICE:-cpu}
WORKERS=${WORKERS:-"1 2"}
MODELS=${MODELS:-"../shared/models/horse.ply:5000 ../shared/models/bunny.obj:3000"}
CLOSED=${CLOSED:-"1 2 4"}
REQUESTS=${REQUESTS:-12}
OPEN_FACTORS=${OPEN_FACTORS:-"0.9 1.5"}
OPEN_S=${OPEN_S:-30}
BUDGET_S=${BUDGET_S:-3600}
JSON_DIR=${JSON_DIR:-$(mktemp -d)}
ADDR=${ADDR:-}
[ -x "$CLIENT" ] && { [ -n "$ADDR" ] || [ -x "$SERVER" ]; } ||
  { echo "bench-load: no vpremesh-server / vpremesh under $BIN" >&2; exit 2; }
mkdir -p "$JSON_DIR"
t0=$SECONDS
server_pid=
stop_server() { [ -n "$server_pid" ] && kill "$server_pid" 2>/dev/null && wait "$server_pid" 2>/dev/null; server_pid=; }
trap stop_server EXIT

# One markdown row from a bench JSON file.
row() {
  python3 - "$@" <<'EOF'
import json, sys
workers, model, path = sys.argv[1], sys.argv[2], sys.argv[3]
j = json.load(open(path))
l, s = j["latency_ms"], j["split_ms"]
load = f"C={j['concurrency']}" if j["mode"] == "closed" else f"{j['rate_per_s']:.2f}/s x {j['duration_s']:g} s"
errors = ", ".join(f"{k} {v}" for k, v in j["errors_by_code"].items()) or "0"
if j.get("connection_errors"):
    errors += f"; connection {j['connection_errors']}"
cells = [workers, model, j["mode"], load, j["requests"], j["completed"], errors, f"{j['throughput_per_s']:.3f}"]
cells += [f"{l[k]:.0f}" for k in ("p50", "p90", "p99", "p99.9", "max", "mean")]
cells += [f"{s[k]:.0f}" for k in ("upload", "queue", "stages", "server_other", "transfer_other")]
print("| " + " | ".join(str(c) for c in cells) + " |")
EOF
}
# The per-stage means of the given runs (WORKERS MODEL JSON triples), one row each.
stage_table() {
  python3 - "$@" <<'EOF'
import json, sys
runs = [sys.argv[i:i + 3] for i in range(1, len(sys.argv), 3)]
order = json.load(open(runs[0][2]))["stage_order"]
print("| workers | model | " + " | ".join(order) + " |")
print("|---|---|" + "---|" * len(order))
for workers, model, path in runs:
    stages = json.load(open(path))["stages_ms"]
    print(f"| {workers} | {model} | " + " | ".join(f"{stages.get(n, 0):.0f}" for n in order) + " |")
EOF
}

echo "| workers | model | loop | load | requests | completed | errors | completed/s | p50 ms | p90 | p99 | p99.9 | max | mean | upload | queue | stages | decode+encode | transfer+other |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
stage_runs=()
skipped=()
for w in $WORKERS; do
  addr=$ADDR
  if [ -z "$addr" ]; then
    log="$JSON_DIR/server-w$w.log"
    # All the load comes from one address, and --max-jobs-per-client counts per address.
    "$SERVER" --listen 127.0.0.1:0 --max-jobs-per-client 4096 --workers "$w" --device "$DEVICE" >"$log" 2>&1 &
    server_pid=$!
    for _ in $(seq 600); do
      addr=$(grep -o 'listening on [0-9.]*:[0-9]*' "$log" | head -1 | cut -d' ' -f3)
      [ -n "$addr" ] && break
      kill -0 "$server_pid" 2>/dev/null || break
      sleep 0.1
    done
    [ -n "$addr" ] || { echo "bench-load: the server did not start:" >&2; cat "$log" >&2; exit 1; }
  fi
  for spec in $MODELS; do
    model=${spec%:*} target=${spec##*:} name=$(basename "${spec%:*}")
    capacity=0 warm=$w last_closed=
    for c in $CLOSED; do
      if [ $((SECONDS - t0)) -ge "$BUDGET_S" ]; then skipped+=("W=$w $name closed C=$c"); continue; fi
      out="$JSON_DIR/w$w-$name-c$c.json"
      "$CLIENT" bench --server "$addr" --input "$model" -n "$target" -c "$c" -r "$REQUESTS" --warmup "$warm" \
        --json >"$out" || { echo "bench-load: failed: W=$w $name C=$c" >&2; continue; }
      warm=0
      row "$w" "$name:$target" "$out"
      last_closed=$out
      capacity=$(python3 -c "import json,sys; print(max($capacity, json.load(open('$out'))['throughput_per_s']))")
    done
    [ -n "$last_closed" ] && stage_runs+=("$w" "$name:$target" "$last_closed")
    for f in $OPEN_FACTORS; do
      if [ $((SECONDS - t0)) -ge "$BUDGET_S" ] || [ "$capacity" = 0 ]; then
        skipped+=("W=$w $name open x$f")
        continue
      fi
      rate=$(python3 -c "print(round($f * $capacity, 3))")
      out="$JSON_DIR/w$w-$name-open$f.json"
      "$CLIENT" bench --server "$addr" --input "$model" -n "$target" --rate "$rate" --duration "$OPEN_S" \
        --json >"$out" || { echo "bench-load: failed: W=$w $name rate $rate" >&2; continue; }
      row "$w" "$name:$target" "$out"
    done
  done
  stop_server
done
echo
echo "Mean stage times (ms) at the largest closed-loop concurrency:"
echo
[ ${#stage_runs[@]} -eq 0 ] || stage_table "${stage_runs[@]}"
[ ${#skipped[@]} -eq 0 ] || printf '\nSkipped (over BUDGET_S=%s s): %s\n' "$BUDGET_S" "$(IFS=,; echo "${skipped[*]}")"
echo
echo "JSON of every run: $JSON_DIR; $((SECONDS - t0)) s in all."
