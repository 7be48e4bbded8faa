#!/usr/bin/env bash
# Soak: the closed- and open-loop sweep of scripts/bench-load.sh, run round
# after round against ONE server, so that connection set-up, reconnects and
# the server's long-lived state are exercised the way a user's benchmark
# exercises them. Fails (exit 1) on any request that did not complete for a
# reason other than a refusal by a limit (RESOURCE_EXHAUSTED): a connection
# error, UNAVAILABLE, INTERNAL, a failed job, a bench run that crashed.
#   scripts/soak.sh                                   (CPU, 10 rounds)
#   DURATION_S=600 scripts/soak.sh                    (rounds until 10 minutes are up)
#   BIN=.bundle/bin DEVICE=cuda WORKERS=2 MODELS=".bundle/models/igea.ply:10000" CLOSED="1 4 8" scripts/soak.sh
# Prints one markdown table (requests, completed, errors by code, p99 per
# model and load, over every round) on stdout; each run's JSON goes to
# $JSON_DIR/round-N.
set -uo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-build/release}
SERVER=${SERVER:-$(ls "$BIN"/vpremesh-server "$BIN"/server/vpremesh-server 2>/dev/null | head -1)}
CLIENT=${CLIENT:-$(ls "$BIN"/vpremesh "$BIN"/client/vpremesh 2>/dev/null | head -1)}
DEVICE=${DEVICE:-cpu}
WORKERS=${WORKERS:-2}
ROUNDS=${ROUNDS:-10}
DURATION_S=${DURATION_S:-0}  # > 0: rounds until this many seconds passed (ROUNDS ignored)
JSON_DIR=${JSON_DIR:-$(mktemp -d)}
export BIN DEVICE CLIENT SERVER
export MODELS=${MODELS:-"../shared/models/suzanne.obj:300"}
export CLOSED=${CLOSED:-"1 4 8"}
export REQUESTS=${REQUESTS:-16}
export OPEN_FACTORS=${OPEN_FACTORS:-"0.9 1.5"}
export OPEN_S=${OPEN_S:-10}
[ -x "$SERVER" ] && [ -x "$CLIENT" ] || { echo "soak: no vpremesh-server / vpremesh under $BIN" >&2; exit 2; }
mkdir -p "$JSON_DIR"
t0=$SECONDS
log="$JSON_DIR/server.log"
"$SERVER" --listen 127.0.0.1:0 --workers "$WORKERS" --device "$DEVICE" >"$log" 2>&1 &
server_pid=$!
trap 'kill "$server_pid" 2>/dev/null; wait "$server_pid" 2>/dev/null' EXIT
addr=
for _ in $(seq 600); do
  addr=$(grep -o 'listening on [0-9.]*:[0-9]*' "$log" | head -1 | cut -d' ' -f3)
  [ -n "$addr" ] && break
  kill -0 "$server_pid" 2>/dev/null || break
  sleep 0.1
done
[ -n "$addr" ] || { echo "soak: the server did not start:" >&2; cat "$log" >&2; exit 1; }

round=0
while :; do
  if [ "$DURATION_S" -gt 0 ]; then [ $((SECONDS - t0)) -lt "$DURATION_S" ] || break
  else [ "$round" -lt "$ROUNDS" ] || break; fi
  round=$((round + 1))
  dir="$JSON_DIR/round-$round"
  ADDR=$addr WORKERS=$WORKERS JSON_DIR=$dir scripts/bench-load.sh >"$dir.md" 2>"$dir.err"
  echo "soak: round $round done at $((SECONDS - t0)) s" >&2
  kill -0 "$server_pid" 2>/dev/null || { echo "soak: the server died in round $round" >&2; cat "$log" >&2; exit 1; }
done

# Every run of every round: one row per model and load, and the verdict.
python3 - "$JSON_DIR" "$round" "$((SECONDS - t0))" <<'EOF'
import glob, json, os, sys
root, rounds, seconds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rows, bad = {}, []
rdirs = [d for d in glob.glob(os.path.join(root, "round-*")) if os.path.isdir(d)]
for rdir in sorted(rdirs, key=lambda d: int(d.rsplit("-", 1)[1])):
    for path in sorted(glob.glob(os.path.join(rdir, "*.json"))):
        try:
            j = json.load(open(path))
        except ValueError:
            bad.append(f"{path}: not a bench report (the client crashed?)")
            continue
        name = os.path.basename(j["input"])
        load = f"C={j['concurrency']}" if j["mode"] == "closed" else f"open x{path.rsplit('open', 1)[1][:-5]}"
        key = (f"{name}:{j['target_vertices']}", j["mode"], load)
        r = rows.setdefault(key, {"runs": 0, "requests": 0, "completed": 0, "codes": {}, "p99": []})
        r["runs"] += 1
        r["requests"] += j["requests"]
        r["completed"] += j["completed"]
        codes = dict(j["errors_by_code"])
        if j.get("connection_errors"):
            codes["connection"] = j["connection_errors"]
        for code, n in codes.items():
            r["codes"][code] = r["codes"].get(code, 0) + n
            if code != "RESOURCE_EXHAUSTED":
                example = j.get("error_examples", {}).get(code) or j.get("connection_error_example", "")
                bad.append(f"{path}: {n} x {code}: {example}")
        if j["completed"]:
            r["p99"].append(j["latency_ms"]["p99"])
print(f"{rounds} rounds in {seconds} s against one server\n")
print("| model | loop | load | runs | requests | completed | errors by code | p99 ms (median run) | p99 ms (worst run) |")
print("|---|---|---|---|---|---|---|---|---|")
total = {"runs": 0, "requests": 0, "completed": 0, "codes": {}}
for (model, mode, load), r in sorted(rows.items()):
    codes = ", ".join(f"{c} {n}" for c, n in sorted(r["codes"].items())) or "0"
    p = sorted(r["p99"])
    med = f"{p[len(p) // 2]:.0f}" if p else "-"
    worst = f"{p[-1]:.0f}" if p else "-"
    print(f"| {model} | {mode} | {load} | {r['runs']} | {r['requests']} | {r['completed']} | {codes} | {med} | {worst} |")
    for k in ("runs", "requests", "completed"):
        total[k] += r[k]
    for c, n in r["codes"].items():
        total["codes"][c] = total["codes"].get(c, 0) + n
codes = ", ".join(f"{c} {n}" for c, n in sorted(total["codes"].items())) or "0"
print(f"| all | | | {total['runs']} | {total['requests']} | {total['completed']} | {codes} | | |")
if not rows:
    bad.append("no bench run finished")
if bad:
    print("\nsoak: FAILED, errors that are not a refusal by a limit:", file=sys.stderr)
    for line in bad[:20]:
        print("  " + line, file=sys.stderr)
    sys.exit(1)
print(f"\nsoak: OK: every request completed or was refused by a limit (RESOURCE_EXHAUSTED); JSON in {root}",
      file=sys.stderr)
EOF
