#!/usr/bin/env python3
"""Rewrites #include "..." lines for the layout of issue 12.

The pipeline's files left worker/pipeline/ for one folder per library
(core/, render/, saliency/, resample/, surface/, and gpu/ for the shared
k-NN grid). This rewrites every include of a moved file, whether spelt
"pipeline/mesh.h" or bare "mesh.h" (as files inside worker/pipeline/ wrote
it), to its new path from worker/: "core/mesh.h". Nothing else on the line
changes; files that stayed in worker/pipeline/ (pipeline.h, debug_output.h,
job_device.h) are left alone. Running it twice changes nothing.

Usage: scripts/rewrite-includes.py [--also NAME=FOLDER ...] FILE...
Edits in place and names what it changed. --also adds a file moved out of
worker/pipeline/ later (--also surface_cvt.h=surface), treated like the others.
"""
import os
import re
import sys

# New folder (under worker/) of every file that left worker/pipeline/.
MOVED = {
    "core": "status.h mesh.h vec3.h image.h rng.h exec_context.h",
    "render": "views.h orientation.h snapshot.h gl_functions.h",
    "saliency": "median_filter.h inner_feature.h distance_transform.h silhouette_feature.h image_saliency.h "
                "image_saliency_device.cuh image_kernels.h gpu_saliency.h unproject.h saliency_field.h",
    "resample": "adaptive_sampling.h sampling_kernels.h awlop.h awlop_kernels.h",
    "surface": "meshing.h ordered_heap.h",
    "gpu": "knn_grid.cuh",
}
NEW_PATH = {name: f"{folder}/{name}" for folder, names in MOVED.items() for name in names.split()}

INCLUDE = re.compile(r'^(\s*#\s*include\s*")([^"]+)(".*)$')


def rewrite(path):
    here = os.path.dirname(os.path.abspath(path))
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    changed = 0
    for i, line in enumerate(lines):
        m = INCLUDE.match(line)
        if not m:
            continue
        name = m.group(2)
        if name.startswith("pipeline/") and name[len("pipeline/"):] in NEW_PATH:
            new = NEW_PATH[name[len("pipeline/"):]]
        elif name in NEW_PATH:
            # A bare name: rewrite unless a different file of that name sits
            # beside the includer (then the include means that one).
            local = os.path.join(here, name)
            if os.path.exists(local) and not local.endswith("/worker/" + NEW_PATH[name]):
                continue
            new = NEW_PATH[name]
        else:
            continue
        lines[i] = m.group(1) + new + m.group(3)
        changed += 1
    if changed:
        with open(path, "w", encoding="utf-8") as f:
            f.write("\n".join(lines))
        print(f"{path}: {changed} include(s) rewritten")


if __name__ == "__main__":
    args = sys.argv[1:]
    while len(args) >= 2 and args[0] == "--also":
        name, _, folder = args[1].partition("=")
        if not name or not folder:
            sys.exit(f"--also wants NAME=FOLDER, not {args[1]}")
        NEW_PATH[name] = f"{folder}/{name}"
        args = args[2:]
    if not args:
        sys.exit(__doc__)
    for p in args:
        rewrite(p)
