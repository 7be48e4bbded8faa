"""What a finished job gives back, put together from its events."""
from dataclasses import dataclass, field
from typing import Any, Dict, List

import grpc

from .errors import Error

try:  # NumPy is optional: without it the float arrays are lists.
    import numpy
except ImportError:
    numpy = None


@dataclass
class Stage:
    name: str    # views, render, image_saliency, ..., meshing
    ms: float    # wall time
    device: str  # "cpu", "cuda", "egl: ..."
    note: str    # e.g. why a stage fell back to the CPU
    level: int = 0            # a chain's stages: the level whose back half ran it
    front_half: bool = False  # a chain's stages every level shares (they ran once)


@dataclass
class Level:
    """One level of a level-of-detail chain (levels=[...])."""
    level: int
    mesh: bytes    # its Draco file
    saliency: Any  # one float per vertex of that mesh
    summary: Any   # its LevelSummary: target_vertices, output_vertices, ssim and tries for a visual target, ...


@dataclass
class Result:
    job_id: str
    mesh: bytes          # the output Draco file (b"" with return_mesh=False)
    saliency: Any        # one float per output vertex: numpy.float32 array, or a list without NumPy
    stages: List[Stage]  # in the order they ran
    summary: Any         # the Completed message: vertex and face counts, queue_ms, run_ms, total_ms, ...
    worker: str = ""
    device: str = ""
    input_saliency: Any = None   # with return_input_saliency=True: one float per input vertex
    saliency_points: Any = None  # with return_saliency_points=True: x, y, z per point, flat
    debug_images: Dict[str, bytes] = field(default_factory=dict)  # with return_debug_images=True: name -> PNG
    # A chain (levels=[...]): every level in order; mesh and saliency above are level 0's.
    levels: List[Level] = field(default_factory=list)

    @property
    def stage_ms(self) -> Dict[str, float]:
        """Stage name -> wall time in ms."""
        return {s.name: s.ms for s in self.stages}


def _floats(parts):
    """One flat array from the chunks' values."""
    if numpy is not None:
        arrays = [numpy.asarray(p, dtype=numpy.float32) for p in parts]
        return numpy.concatenate(arrays) if arrays else numpy.zeros(0, numpy.float32)
    return [v for p in parts for v in p]


class _Chunks:
    """A chunked payload: each chunk starts where the previous one ended, and
    every chunk agrees on the total."""

    def __init__(self, what, unit):
        self.what, self.unit, self.parts, self.size, self.total = what, unit, [], 0, None

    def add(self, chunk, payload, length):
        if chunk.offset != self.size:
            raise Error(grpc.StatusCode.INTERNAL, f"{self.what} chunk at offset {chunk.offset}, expected {self.size}")
        if chunk.total < chunk.offset + length or (self.total is not None and chunk.total != self.total):
            raise Error(grpc.StatusCode.INTERNAL, f"{self.what} chunk passes its total of {chunk.total}")
        self.total = chunk.total
        self.parts.append(payload)
        self.size += length

    def check_complete(self):
        if self.total is not None and self.size != self.total:
            raise Error(grpc.StatusCode.INTERNAL,
                        f"the server sent {self.size} of the {self.total} {self.unit} of the {self.what}")


class Assembler:
    """Takes a job's events in order; result() once `completed` came."""

    def __init__(self):
        self.job_id, self.worker, self.device = "", "", ""
        self.stages, self.debug_images = [], {}
        self.mesh = _Chunks("result", "bytes")
        self.floats = {k: _Chunks(k, "values") for k in ("saliency", "input_saliency", "saliency_points")}
        self.level_mesh, self.level_saliency = {0: self.mesh}, {0: self.floats["saliency"]}
        self.completed = None

    def add(self, event):
        self.job_id = self.job_id or event.job_id
        kind = event.WhichOneof("event")
        if kind == "started":
            self.worker, self.device = event.started.worker, event.started.device
        elif kind == "stage":
            s = event.stage
            self.stages.append(Stage(s.name, s.ms, s.device, s.note, s.level, s.front_half))
        elif kind == "result":
            c = event.result
            mesh = self.level_mesh.setdefault(c.level, _Chunks(f"result of level {c.level}", "bytes"))
            mesh.add(c, c.data, len(c.data))
        elif kind == "saliency":
            c = event.saliency
            values = self.level_saliency.setdefault(c.level, _Chunks(f"saliency of level {c.level}", "values"))
            values.add(c, c.values, len(c.values))
        elif kind in self.floats:
            chunk = getattr(event, kind)
            self.floats[kind].add(chunk, chunk.values, len(chunk.values))
        elif kind == "debug_image":
            self.debug_images[event.debug_image.name] = event.debug_image.png
        elif kind == "completed":
            self.completed = event.completed
        elif kind in ("failed", "cancelled"):
            raise Error.from_failure(getattr(event, kind), self.job_id)
        # Anything else (queued, an event a newer server sends) needs nothing.

    def result(self):
        for chunks in [*self.level_mesh.values(), *self.level_saliency.values(), *self.floats.values()]:
            chunks.check_complete()

        def floats(kind, absent):
            c = self.floats[kind]
            return _floats(c.parts) if c.total is not None else absent

        levels = []
        for summary in self.completed.levels if self.completed is not None else []:
            mesh = self.level_mesh.get(summary.level)
            values = self.level_saliency.get(summary.level)
            levels.append(Level(summary.level, b"".join(mesh.parts) if mesh else b"",
                                _floats(values.parts if values else []), summary))
        return Result(job_id=self.job_id, mesh=b"".join(self.mesh.parts), saliency=floats("saliency", _floats([])),
                      stages=self.stages, summary=self.completed, worker=self.worker, device=self.device,
                      input_saliency=floats("input_saliency", None), saliency_points=floats("saliency_points", None),
                      debug_images=self.debug_images, levels=levels)
