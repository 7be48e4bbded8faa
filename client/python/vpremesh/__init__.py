"""A Python client of the vpremesh remeshing service.

    import vpremesh
    with vpremesh.Client("localhost:50051") as client:
        result = client.remesh("horse.drc", 5000, progress=print)
    open("out.drc", "wb").write(result.mesh)
    result.saliency      # one float per output vertex (NumPy when installed)
    result.stage_ms      # {"views": ..., "meshing": ...}

The messages (JobEvent, JobStatus, ...) are the ones generated from
proto/vpremesh/v1/remesh.proto when the package was built: vpremesh.pb.
"""
try:
    from .v1 import remesh_pb2 as pb
except ImportError as e:  # a source folder used without building
    raise ImportError("vpremesh: the gRPC stubs are missing; install the package (pip install "
                      "--no-build-isolation ./client/python), which generates them") from e

from .client import Client
from .errors import Error
from .result import Level, Result, Stage

__all__ = ["Client", "Error", "Level", "Result", "Stage", "pb"]
