"""The one exception the package raises for the service's answers."""
import grpc

_BY_NUMBER = {code.value[0]: code for code in grpc.StatusCode}


def status_code(number):
    """grpc.StatusCode of a google.rpc.Code number (a Failure's code)."""
    return _BY_NUMBER.get(number, grpc.StatusCode.UNKNOWN)


class Error(Exception):
    """A call or a job that did not succeed.

    code: a grpc.StatusCode (INVALID_ARGUMENT for a bad upload or target,
    UNAUTHENTICATED for a missing or wrong token, CANCELLED for a cancelled
    job, ...); message: the server's one line naming the problem; job_id: the
    job's id when one was assigned, else "".
    """

    def __init__(self, code, message, job_id=""):
        super().__init__(f"{code.name}: {message}")
        self.code = code
        self.message = message
        self.job_id = job_id

    @classmethod
    def from_rpc(cls, error, address="", job_id=""):
        code, message = error.code(), " ".join((error.details() or "").split())
        # A transport failure should name the server it could not reach; the
        # server's own answers do not need it.
        if code in (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED) and address \
                and address not in message:
            message = f"{address}: {message}"
        return cls(code, message, job_id)

    @classmethod
    def from_failure(cls, failure, job_id=""):
        return cls(status_code(failure.code), failure.message, job_id)
