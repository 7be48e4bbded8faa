#!/usr/bin/env bash
# What the Python package (client/python) costs against the C++ client: one
# local server (embedded queue, one warm worker), and in alternating rounds
#   vpremesh submit MODEL               (C++, converts the model to Draco)
#   vpremesh submit MODEL.drc           (C++, the same Draco file as Python)
#   python -c 'vpremesh.Client.remesh'  (a new interpreter each time, as a script would)
# each writing the result. Prints a markdown table of the median wall time of
# each process and of its client-side part (wall minus the server's
# submission-to-completion time, Completed.total_ms).
#   scripts/bench-python-client.sh            (CPU, build/release, horse -> 5000, 5 rounds)
#   MODEL=../shared/models/igea.ply TARGET=10000 ROUNDS=7 scripts/bench-python-client.sh
set -uo pipefail
BIN=${BIN:-build/release}
SERVER=${SERVER:-$BIN/server/vpremesh-server}
CLIENT=${CLIENT:-$BIN/client/vpremesh}
PYTHON=${PYTHON:-/usr/bin/python3}
DEVICE=${DEVICE:-cpu}
MODEL=${MODEL:-../shared/models/horse.ply}
TARGET=${TARGET:-5000}
ROUNDS=${ROUNDS:-5}
[ -x "$SERVER" ] && [ -x "$CLIENT" ] || { echo "bench-python-client: no vpremesh-server / vpremesh under $BIN" >&2; exit 2; }
dir=$(mktemp -d)
pid=
trap '[ -n "$pid" ] && kill "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$dir"' EXIT

# The package, as a user installs it (offline; the stubs are generated here).
"$PYTHON" -m venv --system-site-packages --without-pip "$dir/venv" &&
  "$PYTHON" -m pip --python "$dir/venv/bin/python" install --quiet --no-index --no-build-isolation ./client/python ||
  { echo "bench-python-client: installing client/python failed" >&2; exit 1; }

"$SERVER" --listen 127.0.0.1:0 --workers 1 --device "$DEVICE" >"$dir/server.log" 2>&1 &
pid=$!
address=
for _ in $(seq 600); do
  address=$(sed -n 's/^vpremesh-server listening on \([^ ]*\).*/\1/p' "$dir/server.log")
  [ -n "$address" ] && break
  sleep 0.1
done
[ -n "$address" ] || { echo "bench-python-client: the server did not start" >&2; cat "$dir/server.log" >&2; exit 1; }

# The Draco file both clients upload: the model as the server decoded it
# (--field-out writes it with its field), from a warm-up job.
"$CLIENT" submit "$MODEL" -o "$dir/warmup.drc" --field-out "$dir/model.drc" -n "$TARGET" --server "$address" \
  --device "$DEVICE" --json >/dev/null || { echo "bench-python-client: the warm-up job failed" >&2; exit 1; }

"$dir/venv/bin/python" - "$dir" "$address" "$CLIENT" "$MODEL" "$TARGET" "$ROUNDS" "$DEVICE" <<'PY'
import json, statistics, subprocess, sys, time
d, address, cli, model, target, rounds, device = sys.argv[1:8]
rounds = int(rounds)
python_job = ("import json, sys, time; t0 = time.perf_counter(); import vpremesh; t1 = time.perf_counter(); "
              "r = vpremesh.Client(sys.argv[1]).remesh(sys.argv[2], int(sys.argv[3]), device=sys.argv[5]); "
              "open(sys.argv[4], 'wb').write(r.mesh); "
              "print(json.dumps({'server_total_ms': r.summary.total_ms, 'import_ms': 1e3 * (t1 - t0), "
              "'call_ms': 1e3 * (time.perf_counter() - t1)}))")
clients = {
    f"C++ `vpremesh submit {model.rsplit('/', 1)[-1]}`":
        [cli, "submit", model, "-o", f"{d}/out.drc", "-n", target, "--server", address, "--device", device, "--json"],
    "C++ `vpremesh submit model.drc`":
        [cli, "submit", f"{d}/model.drc", "-o", f"{d}/out.drc", "-n", target, "--server", address, "--device", device,
         "--json"],
    "Python `vpremesh.Client.remesh(model.drc)`":
        [sys.executable, "-c", python_job, address, f"{d}/model.drc", target, f"{d}/out.drc", device],
}
runs = {name: [] for name in clients}
for _ in range(rounds):
    for name, command in clients.items():
        start = time.perf_counter()
        out = subprocess.run(command, check=True, capture_output=True, text=True).stdout
        wall_ms = 1e3 * (time.perf_counter() - start)
        report = json.loads(out)
        runs[name].append({"wall": wall_ms, "server": report["server_total_ms"],
                           "client": wall_ms - report["server_total_ms"],
                           "import": report.get("import_ms"), "call": report.get("call_ms"),
                           "in_call": report.get("call_ms", 0) - report["server_total_ms"]})
med = lambda name, key: statistics.median(r[key] for r in runs[name])
print(f"{model.rsplit('/', 1)[-1]} -> {target} on {device}, one warm worker, embedded queue; "
      f"median of {rounds} alternating rounds")
print()
print("| client | wall (ms) | server total (ms) | client side: wall - server total (ms) |")
print("|---|---|---|---|")
for name in clients:
    print(f"| {name} | {med(name, 'wall'):.0f} | {med(name, 'server'):.0f} | {med(name, 'client'):.0f} |")
py = list(clients)[2]
print()
for name in clients:
    print(f"{name}: server total per round (ms) " + ", ".join(f"{r['server']:.0f}" for r in runs[name]))
print(f"Python: `import vpremesh` (grpc, protobuf, NumPy) {med(py, 'import'):.0f} ms; the remesh call "
      f"{med(py, 'call'):.0f} ms, of which {med(py, 'in_call'):.0f} ms client side (upload, channel, result).")
PY
