#!/usr/bin/env python3
"""A Python client of vpremesh.v1.RemeshService, on stubs generated from
proto/vpremesh/v1/remesh.proto at build time (never committed).

Uploads a Draco file (spec first, then chunks of at most 1 MiB), follows the
job's events to `completed`, checks what came back, writes the result and
prints a JSON summary. Exit code 0 when every check holds, 1 otherwise.

    PYTHONPATH=build/.../python python3 python_client.py --server HOST:PORT \
        --mesh in.drc --target 300 --out result.drc
"""
import argparse
import json
import sys

import grpc
from vpremesh.v1 import remesh_pb2, remesh_pb2_grpc

CHUNK = 1 << 20  # remesh.proto: mesh_chunk is at most 1 MiB


def requests(spec, data):
    yield remesh_pb2.RemeshRequest(spec=spec)
    for offset in range(0, len(data), CHUNK):
        yield remesh_pb2.RemeshRequest(mesh_chunk=data[offset:offset + CHUNK])


def fail(message):
    print(f"python_client: {message}", file=sys.stderr)
    return 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--server", required=True)
    parser.add_argument("--mesh", required=True, help="a Draco (.drc) file")
    parser.add_argument("--target", type=int, required=True)
    parser.add_argument("--out", required=True, help="where the result (Draco) goes")
    args = parser.parse_args()

    with open(args.mesh, "rb") as f:
        data = f.read()
    # return_mesh and return_saliency are left unset: the result and its
    # saliency come back by default (remesh.proto).
    spec = remesh_pb2.JobSpec(target_vertices=args.target, mesh_size_bytes=len(data), label="python_client")
    kinds, result, saliency, completed, job_id = [], bytearray(), [], None, ""
    with grpc.insecure_channel(args.server) as channel:
        stub = remesh_pb2_grpc.RemeshServiceStub(channel)
        try:
            for event in stub.Remesh(requests(spec, data), timeout=300):
                kind = event.WhichOneof("event")
                kinds.append(kind)
                job_id = job_id or event.job_id
                if kind == "result":
                    if event.result.offset != len(result):
                        return fail(f"result chunk at {event.result.offset}, expected {len(result)}")
                    result += event.result.data
                elif kind == "saliency":
                    saliency.extend(event.saliency.values)
                elif kind == "completed":
                    completed = event.completed
                elif kind in ("failed", "cancelled"):
                    failure = getattr(event, kind)
                    return fail(f"job {kind}: code {failure.code}: {failure.message}")
        except grpc.RpcError as e:
            return fail(f"{e.code().name}: {e.details()}")

    if completed is None or kinds[-1] != "completed":
        return fail(f"the stream ended without `completed` (events: {kinds})")
    if kinds[0] != "queued" or "started" not in kinds:
        return fail(f"expected queued, started, ...: {kinds}")
    stages = kinds.count("stage")
    if stages < 7:
        return fail(f"only {stages} stage events")
    if abs(completed.output_vertices - args.target) > 0.02 * args.target:
        return fail(f"{completed.output_vertices} vertices for a target of {args.target}")
    if not result.startswith(b"DRACO") or (completed.result_bytes and len(result) != completed.result_bytes):
        return fail(f"result of {len(result)} bytes (summary says {completed.result_bytes})")
    if len(saliency) != completed.output_vertices:
        return fail(f"{len(saliency)} saliency values for {completed.output_vertices} vertices")
    with open(args.out, "wb") as f:
        f.write(result)
    print(json.dumps({"job_id": job_id, "output_vertices": completed.output_vertices,
                      "input_vertices": completed.input_vertices, "stages": stages, "result_bytes": len(result)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
