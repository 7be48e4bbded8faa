"""vpremesh.Client: remesh, submit, watch, get and cancel over gRPC."""
import os

import grpc

from .errors import Error
from .follower import follow
from .replicas import Deadline, Replicas, credentials, is_connection_failure, log
from .result import Assembler
from .spec import make_spec
from .v1 import remesh_pb2

CHUNK = 1 << 20  # remesh.proto: an upload chunk is at most 1 MiB


def _read(mesh):
    """The upload's bytes, from bytes or from a file's path."""
    if isinstance(mesh, (bytes, bytearray, memoryview)):
        return bytes(mesh)
    with open(os.fspath(mesh), "rb") as f:
        return f.read()


def _requests(spec, data):
    yield remesh_pb2.RemeshRequest(spec=spec)
    for offset in range(0, len(data), CHUNK):
        yield remesh_pb2.RemeshRequest(mesh_chunk=data[offset:offset + CHUNK])


class Client:
    """A client of vpremesh.v1.RemeshService.

    address: "HOST:PORT", or several replicas that serve the same jobs (a
    list, or one string with commas), as `vpremesh --server` takes them.
    token: the tenant's bearer token (docs/security.md), sent as
    `authorization: Bearer TOKEN` on every call. tls_ca: connect over TLS
    trusting this CA (a PEM file's path, or its bytes); tls=True trusts the
    system's CAs; tls_cert and tls_key (paths or bytes) for mutual TLS.
    reattach_timeout: how long remesh and watch keep re-attaching to a job,
    replica after replica, without a new event (0: never re-attach).

    Every failure raises vpremesh.Error (its code a grpc.StatusCode), except
    options that are not options (TypeError) or values of the wrong type
    (TypeError, ValueError), raised before anything is sent.
    """

    def __init__(self, address, token=None, tls_ca=None, *, tls=False, tls_cert=None, tls_key=None,
                 reattach_timeout=60.0):
        self._replicas = Replicas(address, credentials(tls, tls_ca, tls_cert, tls_key))
        self._metadata = (("authorization", f"Bearer {token}"),) if token else ()
        self.reattach_timeout = reattach_timeout

    def close(self):
        self._replicas.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def remesh(self, mesh, target_vertices, *, progress=None, timeout=None, **options):
        """Uploads a Draco file (its path, or its bytes), follows the job to
        its end and returns a Result: the output mesh (Draco bytes), one
        saliency value per output vertex, the stage timings and the summary.

        options: fields of JobSpec or PipelineOptions by name (device="cpu",
        seed=3, density="uniform", return_mesh=False, ...). progress: called
        with each JobEvent as it arrives. timeout: seconds for the whole job;
        when it passes, or when the caller stops it (KeyboardInterrupt), the
        job is cancelled. A failed or cancelled job raises vpremesh.Error.
        """
        data = _read(mesh)
        spec = make_spec(target_vertices, len(data), options, "remesh")
        deadline = Deadline(timeout)

        def open_remesh(i):
            return self._replicas.stub(i).Remesh(_requests(spec, data), metadata=self._metadata,
                                                 timeout=deadline.left(),
                                                 wait_for_ready=self._replicas.wait_for_ready(deadline))

        assembler = Assembler()
        events = follow(self._replicas, self._metadata, open_remesh, 0, "", deadline, self.reattach_timeout,
                        cancel_at_deadline=True)
        try:
            for event in events:
                if progress is not None:
                    progress(event)
                assembler.add(event)
        finally:
            events.close()  # at once, not when collected: an unfinished Remesh call cancels its job
        return assembler.result()

    def submit(self, mesh, target_vertices, *, timeout=None, **options):
        """Uploads as remesh does and returns the job's id as soon as the job
        is queued; follow it with watch, poll it with get."""
        data = _read(mesh)
        spec = make_spec(target_vertices, len(data), options, "submit")
        deadline = Deadline(timeout)
        # The first replica, in list order, that accepts a connection: an
        # upload that reached a server is never sent again (it could run the
        # job twice).
        for i in range(len(self._replicas)):
            try:
                ref = self._replicas.stub(i).Submit(_requests(spec, data), metadata=self._metadata,
                                                    timeout=deadline.left(),
                                                    wait_for_ready=self._replicas.wait_for_ready(deadline))
                break
            except grpc.RpcError as e:
                if i + 1 == len(self._replicas) or not is_connection_failure(e):
                    raise Error.from_rpc(e, self._replicas.address(i)) from None
                log.warning("%s does not accept connections; trying %s", self._replicas.address(i),
                            self._replicas.address(i + 1))
        return ref.job_id

    def watch(self, job_id, from_sequence=0, *, timeout=None):
        """An iterator of the job's events (JobEvent messages, in sequence
        order, each once), from event `from_sequence` (0: replays what already
        happened) to its last: `completed`, `failed` or `cancelled`. A failed
        job is not an exception here: its last event says how it ended. When
        the server goes away the job is picked up on the next replica.
        Stopping the iteration does not cancel the job."""
        deadline = Deadline(timeout)
        ref = remesh_pb2.JobRef(job_id=job_id, from_sequence=from_sequence)

        def open_watch(i):
            return self._replicas.stub(i).Watch(ref, metadata=self._metadata, timeout=deadline.left(),
                                                wait_for_ready=self._replicas.wait_for_ready(deadline))

        return follow(self._replicas, self._metadata, open_watch, 0, job_id, deadline, self.reattach_timeout,
                      from_sequence=from_sequence)

    def get(self, job_id, *, timeout=30):
        """The job's JobStatus (state, queue position, failure or summary)."""
        return self._unary("GetJob", job_id, timeout)

    def cancel(self, job_id, *, timeout=30):
        """Cancels a queued or running job (a running one stops at its next
        stage boundary); returns its JobStatus after the request. Cancelling a
        finished job changes nothing."""
        return self._unary("CancelJob", job_id, timeout)

    def _unary(self, method, job_id, timeout):
        """One call, tried on the next replica while one is UNAVAILABLE."""
        deadline = Deadline(timeout)
        ref = remesh_pb2.JobRef(job_id=job_id)
        for i in range(len(self._replicas)):
            try:
                return getattr(self._replicas.stub(i), method)(ref, metadata=self._metadata, timeout=deadline.left(),
                                                               wait_for_ready=self._replicas.wait_for_ready(deadline))
            except grpc.RpcError as e:
                if e.code() != grpc.StatusCode.UNAVAILABLE or i + 1 == len(self._replicas):
                    raise Error.from_rpc(e, self._replicas.address(i), job_id) from None
