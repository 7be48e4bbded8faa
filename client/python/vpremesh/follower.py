"""Following a job's events to its end across server replicas, as the C++
client does (client/job_follower.*). When a stream breaks with UNAVAILABLE
(the server died, the connection was reset, the server is shutting down) and
the job's id is known, the job is picked up again with Watch(job_id,
from_sequence = the next event) on the next replica, round robin, after a
short exponential backoff, until reattach_timeout passes without a new event,
the deadline passes, or the job ends. Every event is yielded once."""
import time

import grpc

from .errors import Error
from .replicas import is_connection_failure, log
from .v1 import remesh_pb2

FIRST_BACKOFF_S = 0.1
MAX_BACKOFF_S = 2.0  # the backoff doubles up to this
TERMINAL = ("completed", "failed", "cancelled")


def follow(replicas, metadata, open_first, index, job_id, deadline, reattach_timeout, from_sequence=0,
           cancel_at_deadline=False):
    """Yields the job's events from the call open_first(index) makes, then
    from the Watch calls that pick the job up after it. A first call that
    reached no server moves on to the next replica (an upload is never sent
    twice to a server that may have had it).

    cancel_at_deadline: the Remesh call cancels its job when its deadline
    passes, a Watch that took over does not; with this the follower does.
    """
    next_sequence = from_sequence
    reattaching = False
    lost_since = None  # the first loss since the last new event
    backoff = FIRST_BACKOFF_S
    passed_over = 0  # replicas the first call could not connect to
    call = open_first(index)
    while True:
        before = next_sequence
        try:
            try:
                for event in call:
                    # A server that does not honour from_sequence replays from
                    # 0: what was yielded is not yielded again.
                    if event.sequence < next_sequence:
                        continue
                    if job_id and event.job_id and event.job_id != job_id:
                        raise Error(grpc.StatusCode.INTERNAL,
                                    f"an event of job {event.job_id} came on the stream of job {job_id}", job_id)
                    job_id = job_id or event.job_id
                    next_sequence = event.sequence + 1
                    yield event
                    if event.WhichOneof("event") in TERMINAL:
                        return
            finally:
                call.cancel()  # a Remesh call left early (the caller stopped reading) cancels its job
            raise Error(grpc.StatusCode.INTERNAL,
                        f"the event stream from {replicas.address(index)} ended before job {job_id} did", job_id)
        except grpc.RpcError as e:
            error = e
        address = replicas.address(index)
        code = error.code()
        if code == grpc.StatusCode.DEADLINE_EXCEEDED and cancel_at_deadline and reattaching:
            _cancel_quietly(replicas, metadata, job_id, index)
        if not job_id and passed_over + 1 < len(replicas) and is_connection_failure(error):
            passed_over += 1
            log.warning("%s does not accept connections; trying %s", address, replicas.address(index + 1))
            index += 1
            call = open_first(index)
            continue
        if code != grpc.StatusCode.UNAVAILABLE or reattach_timeout <= 0:
            raise Error.from_rpc(error, address, job_id)
        if not job_id:
            # Not retried: a new upload could run the job twice. A transport
            # failure names the address already; a server's own UNAVAILABLE
            # (it is shutting down) does not, and gets the note.
            if address in (error.details() or ""):
                raise Error.from_rpc(error, address)
            raise Error(code, f"{' '.join((error.details() or '').split())}; lost {address} before the job's id "
                              "came; the upload is not sent again")
        now = time.monotonic()
        if lost_since is None or next_sequence != before:
            lost_since, backoff = now, FIRST_BACKOFF_S
        if now - lost_since >= reattach_timeout:
            e = Error.from_rpc(error, address, job_id)
            raise Error(e.code, f"{e.message}; gave up re-attaching to job {job_id} after {reattach_timeout:g} s "
                                "without an event", job_id)
        following = index + 1
        log.warning("lost %s (%s); re-attaching to job %s on %s from event %d", address,
                    " ".join((error.details() or "").split()), job_id, replicas.address(following), next_sequence)
        wait = min(backoff, lost_since + reattach_timeout - now)
        if deadline.left() is not None:
            wait = min(wait, deadline.left())
        time.sleep(max(0.0, wait))
        backoff = min(backoff * 2, MAX_BACKOFF_S)
        if deadline.passed():
            if cancel_at_deadline:
                _cancel_quietly(replicas, metadata, job_id, index)
            raise Error(grpc.StatusCode.DEADLINE_EXCEEDED, f"the deadline passed while re-attaching to job {job_id}",
                        job_id)
        index, reattaching = following, True
        call = replicas.stub(index).Watch(remesh_pb2.JobRef(job_id=job_id, from_sequence=next_sequence),
                                          metadata=metadata, timeout=deadline.left())


def _cancel_quietly(replicas, metadata, job_id, index):
    """Best effort, as the Remesh call's own cancellation is: the caller gets
    DEADLINE_EXCEEDED either way."""
    ref = remesh_pb2.JobRef(job_id=job_id)
    for i in range(len(replicas)):
        try:
            replicas.stub(index + i).CancelJob(ref, metadata=metadata, timeout=5)
            return
        except grpc.RpcError as e:
            if e.code() != grpc.StatusCode.UNAVAILABLE:
                return
