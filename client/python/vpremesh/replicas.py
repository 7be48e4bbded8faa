"""The servers a client may use: one address, or several replicas that serve
the same jobs (a Redis queue), with a channel each, made when first used and
kept. The counterpart of client/replicas.* and client/channel.* in C++.

Reachability is learnt from calls, not from channel_ready_future: grpcio's
connectivity polling thread fails ("Channel closed!") when a channel is
closed while it runs."""
import json
import logging
import os
import time

import grpc

from .v1 import remesh_pb2_grpc

log = logging.getLogger("vpremesh")

# As the C++ client's channel (client/channel.cpp): uploads retried on a
# transport failure before the server accepted them; the reconnect backoff
# capped at 2 s, so that a replica that restarts is reachable again soon.
_SERVICE_CONFIG = json.dumps({"methodConfig": [{
    "name": [{"service": "vpremesh.v1.RemeshService", "method": "Remesh"},
             {"service": "vpremesh.v1.RemeshService", "method": "Submit"}],
    "retryPolicy": {"maxAttempts": 5, "initialBackoff": "0.1s", "maxBackoff": "1s", "backoffMultiplier": 2,
                    "retryableStatusCodes": ["UNAVAILABLE"]}}]})
_CHANNEL_OPTIONS = [
    ("grpc.max_receive_message_length", 8 << 20),  # chunks are at most 1 MiB of payload
    ("grpc.max_send_message_length", 8 << 20),
    ("grpc.initial_reconnect_backoff_ms", 100),
    ("grpc.min_reconnect_backoff_ms", 100),
    ("grpc.max_reconnect_backoff_ms", 2000),
    ("grpc.enable_retries", 1),
    ("grpc.service_config", _SERVICE_CONFIG),
]
# Words of gRPC's UNAVAILABLE messages when no connection was made, so that
# no byte of an upload reached a server (client/grpc_errors.cpp). A reset or
# a closed socket is not among them: the server may have had the upload.
_NOT_CONNECTED = ("failed to connect", "Connection refused", "DNS resolution failed", "No route to host")


def is_connection_failure(error):
    """True when a grpc.RpcError says no server was reached."""
    details = error.details() or ""
    return error.code() == grpc.StatusCode.UNAVAILABLE and any(w in details for w in _NOT_CONNECTED)


def _pem(value):
    """A PEM file's bytes: from bytes as they are, from PEM text, or from a path."""
    if value is None or isinstance(value, bytes):
        return value
    if isinstance(value, str) and value.lstrip().startswith("-----BEGIN"):
        return value.encode()
    with open(os.fspath(value), "rb") as f:
        return f.read()


def credentials(tls, tls_ca, tls_cert, tls_key):
    """Channel credentials, or None for plaintext."""
    if (tls_cert is None) != (tls_key is None):
        raise ValueError("tls_cert and tls_key go together")
    if not tls and tls_ca is None and tls_cert is None:
        return None
    return grpc.ssl_channel_credentials(root_certificates=_pem(tls_ca), private_key=_pem(tls_key),
                                        certificate_chain=_pem(tls_cert))


class Deadline:
    """A whole operation's time, shared by every call it makes to any replica:
    moving to another replica does not give it more time."""

    def __init__(self, timeout):
        self.at = None if timeout is None else time.monotonic() + timeout

    def left(self):
        """Seconds left for a call's timeout (None: no deadline)."""
        return None if self.at is None else max(0.0, self.at - time.monotonic())

    def passed(self):
        return self.at is not None and time.monotonic() >= self.at


class Replicas:
    def __init__(self, addresses, creds):
        if isinstance(addresses, str):
            addresses = addresses.split(",")
        self.addresses = [a.strip() for a in addresses if a.strip()]
        if not self.addresses:
            raise ValueError("no server address")
        self._creds = creds
        self._channels = [None] * len(self.addresses)
        self._stubs = [None] * len(self.addresses)

    def __len__(self):
        return len(self.addresses)

    def address(self, i):
        """Indices wrap around: i + 1 is the next replica, round robin."""
        return self.addresses[i % len(self)]

    def channel(self, i):
        i %= len(self)
        if self._channels[i] is None:
            a = self.addresses[i]
            self._channels[i] = grpc.secure_channel(a, self._creds, _CHANNEL_OPTIONS) if self._creds \
                else grpc.insecure_channel(a, _CHANNEL_OPTIONS)
            self._stubs[i] = remesh_pb2_grpc.RemeshServiceStub(self._channels[i])
        return self._channels[i]

    def stub(self, i):
        self.channel(i)
        return self._stubs[i % len(self)]

    def wait_for_ready(self, deadline):
        """A call's wait_for_ready. With one server and a deadline, the call
        waits for the server to accept a connection (one that comes up late
        does not fail the call), as the C++ client does. Without a deadline it
        does not (it could wait forever); uploads are still retried for a
        couple of seconds (_SERVICE_CONFIG). With several servers an
        unreachable one is passed over instead."""
        return len(self) == 1 and deadline.at is not None

    def close(self):
        for c in self._channels:
            if c is not None:
                c.close()
        self._channels = [None] * len(self)
        self._stubs = [None] * len(self)
