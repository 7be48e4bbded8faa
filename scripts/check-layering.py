#!/usr/bin/env python3
"""Checks that includes point down: no folder includes a higher one.

Reads every #include "..." line under worker/, server/ and client/, resolves it
the way the build does (beside the file, then from worker/, the repository
root and client/), and fails naming each include of a folder whose level is
not lower than the includer's own. Run by ctest (layering_test, label cpu)
from the repository root; with --graph it prints the folder graph it found.
"""
import os
import re
import sys

# The levels, lowest first. A file may include its own folder and folders of
# strictly lower level: never a higher one, and never a sibling of the same
# level (the three stage folders of level 3 stay independent of each other).
LEVELS = {
    "worker/core": 0,      # mesh, status, vec3, image, rng, exec context: used by everything
    "worker/gpu": 1,       # CUDA checks, stream, device buffer pool, uniform-grid k-NN
    "worker/io": 1,        # mesh and image file formats
    "worker/render": 2,    # stage 1: views, orientation, snapshots, GL loading
    "worker/saliency": 3,  # stages 2-4: image saliency, unprojection, saliency field
    "worker/resample": 3,  # stages 5-6: adaptive sampling, AWLOP
    "worker/surface": 3,   # stage 7: meshing, ordered heap
    "worker/eval": 4,      # metrics (renders, line drawings)
    "worker/peers": 4,     # peer remeshers
    "worker/pipeline": 5,  # orchestration: run_pipeline, job device, debug output
    "proto": 6,            # the gRPC API (generated vpremesh/v1/*.pb.h): nothing below knows of it
    "server": 7,           # the service
    "worker/service": 8,   # vpremesh-worker, on the server's queues
    "client": 8,           # the command line and benchmarks
}
SCANNED = ("worker", "server", "client")
SOURCE = re.compile(r"\.(h|hpp|cpp|cc|cu|cuh|inl)$")
INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"')
OUR_TOP = {p.split("/")[-1] for p in LEVELS} | {"worker"}


def folder_of(path):
    best = None
    for f in LEVELS:
        if (path == f or path.startswith(f + "/")) and (best is None or len(f) > len(best)):
            best = f
    return best


def resolve(includer, name):
    """The repository-relative path the include names, 'proto' for generated
    API headers, None for a header outside the repository."""
    for base in (os.path.dirname(includer), "worker", ".", "client"):
        candidate = os.path.normpath(os.path.join(base, name))
        if os.path.isfile(candidate):
            return candidate
    if name.startswith("vpremesh/v1/"):
        return "proto"
    return None


def main():
    graph = {}
    errors = []
    for top in SCANNED:
        for dirpath, _, files in os.walk(top):
            for fn in sorted(files):
                path = os.path.join(dirpath, fn)
                if not SOURCE.search(fn):
                    continue
                own = folder_of(path)
                if own is None:
                    errors.append(f"{path}: its folder has no level in scripts/check-layering.py")
                    continue
                with open(path, encoding="utf-8", errors="replace") as f:
                    for lineno, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        target = resolve(path, m.group(1))
                        if target is None:
                            if m.group(1).split("/")[0] in OUR_TOP and "/" in m.group(1):
                                errors.append(f"{path}:{lineno}: \"{m.group(1)}\" does not exist "
                                              "(a path from before the layout? scripts/rewrite-includes.py)")
                            continue
                        theirs = folder_of(target)
                        if theirs is None or theirs == own:
                            continue
                        graph.setdefault(own, set()).add(theirs)
                        if LEVELS[theirs] >= LEVELS[own]:
                            errors.append(f"{path}:{lineno}: {own} (level {LEVELS[own]}) includes "
                                          f"\"{m.group(1)}\" of {theirs} (level {LEVELS[theirs]})")
    if "--graph" in sys.argv:
        for own in sorted(graph, key=lambda f: (LEVELS[f], f)):
            print(f"{own} -> {', '.join(sorted(graph[own], key=lambda f: (LEVELS[f], f)))}")
    for e in errors:
        print(e, file=sys.stderr)
    if errors:
        print(f"check-layering: {len(errors)} include(s) point up or sideways", file=sys.stderr)
        return 1
    print("check-layering: every include points down")
    return 0


if __name__ == "__main__":
    os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    sys.exit(main())
