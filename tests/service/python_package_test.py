"""The vpremesh Python package (client/python) against the real server, run
by python_package_test.cpp with the package installed in a fresh virtual
environment. The server asks for a token and speaks TLS; the harness passes:

  VPR_SERVER      HOST:PORT of the server (--workers 1)
  VPR_TOKEN       a valid tenant token
  VPR_TLS_CA      the CA that signed the server's certificate
  VPR_MTLS_SERVER a server that also asks for a client certificate signed by that CA
  VPR_CERTS       the folder of client.pem and client.key (signed by it)
  VPR_SMALL       a Draco sphere that remeshes in a moment
  VPR_LARGE       a Draco sphere whose job runs for a while
  VPR_OUT         a folder: result.drc and result.json for the harness to check
"""
import json
import logging
import os
import re
import socket
import struct
import subprocess
import sys
import threading
import unittest

import grpc
import vpremesh

ENV = os.environ
TARGET = 300
STAGES = {"views", "render", "image_saliency", "unproject", "saliency_field", "meshing"}


def client(**kwargs):
    options = dict(token=ENV["VPR_TOKEN"], tls_ca=ENV["VPR_TLS_CA"])
    options.update(kwargs)
    return vpremesh.Client(options.pop("address", ENV["VPR_SERVER"]), **options)


class Relay:
    """A TCP relay in front of the server that dies as a machine does once it
    has passed `limit` bytes to the client: its connections are reset and new
    ones refused, so the client sees the transport fail mid-stream."""

    def __init__(self, limit=None):
        host, port = ENV["VPR_SERVER"].rsplit(":", 1)
        self.backend = (host, int(port))
        self.limit, self.to_client, self.sockets = limit, 0, []
        self.lock = threading.Lock()
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.address = f"127.0.0.1:{self.listener.getsockname()[1]}"
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while True:
            try:
                near, _ = self.listener.accept()
            except OSError:
                return  # cut
            far = socket.create_connection(self.backend)
            with self.lock:
                self.sockets += [near, far]
            threading.Thread(target=self._pipe, args=(near, far, False), daemon=True).start()
            threading.Thread(target=self._pipe, args=(far, near, True), daemon=True).start()

    def _pipe(self, source, sink, to_client):
        try:
            while data := source.recv(1 << 16):
                if to_client:
                    with self.lock:
                        room = len(data) if self.limit is None else self.limit - self.to_client
                        data = data[:room]
                        self.to_client += len(data)
                    sink.sendall(data)
                    if self.limit is not None and self.to_client >= self.limit:
                        self.cut()
                        return
                else:
                    sink.sendall(data)
        except OSError:
            pass

    def cut(self):
        self.listener.close()
        with self.lock:
            for s in self.sockets:
                try:
                    s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))  # a reset
                    s.shutdown(socket.SHUT_RDWR)
                    s.close()
                except OSError:
                    pass


def kinds(events):
    return [e.WhichOneof("event") for e in events]


class PackageTest(unittest.TestCase):
    def test_remesh_returns_the_mesh_its_field_and_the_stage_timings(self):
        events = []
        with client() as c:
            result = c.remesh(ENV["VPR_SMALL"], TARGET, progress=events.append, label="python_package_test")
        self.assertTrue(result.mesh.startswith(b"DRACO"))
        self.assertEqual(len(result.mesh), result.summary.result_bytes)
        self.assertEqual(result.summary.input_vertices, 642)
        self.assertLessEqual(abs(result.summary.output_vertices - TARGET), 0.02 * TARGET)
        self.assertEqual(len(result.saliency), result.summary.output_vertices)
        self.assertEqual(str(result.saliency.dtype), "float32")  # NumPy is there (python3-numpy)
        self.assertTrue(STAGES <= set(result.stage_ms), result.stage_ms)
        self.assertTrue(all(s.ms > 0 and s.device for s in result.stages), result.stages)
        # progress saw every event, in order, from queued to completed.
        self.assertEqual([e.sequence for e in events], list(range(len(events))))
        self.assertEqual(kinds(events)[:2], ["queued", "started"])
        self.assertEqual(kinds(events)[-1], "completed")
        self.assertTrue(result.job_id.startswith("j-"))
        out = ENV["VPR_OUT"]
        with open(os.path.join(out, "result.drc"), "wb") as f:
            f.write(result.mesh)
        with open(os.path.join(out, "result.json"), "w") as f:
            json.dump({"target": TARGET, "output_vertices": result.summary.output_vertices,
                       "saliency_values": len(result.saliency)}, f)

    def test_a_level_of_detail_chain_gives_every_level_with_its_field(self):
        with client() as c:
            result = c.remesh(ENV["VPR_SMALL"], None, levels=[400, 0.25])
            with self.assertRaises(vpremesh.Error) as caught:
                c.remesh(ENV["VPR_SMALL"], None, levels=[400, 0])
            with self.assertRaises(TypeError):
                c.remesh(ENV["VPR_SMALL"], None, levels=["many"])
        self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("level 1: no target", caught.exception.message)
        self.assertEqual([l.level for l in result.levels], [0, 1])
        for level, asked in zip(result.levels, (400, 161)):  # 0.25 of 642 = 160.5, rounded half up
            self.assertTrue(level.mesh.startswith(b"DRACO"))
            self.assertEqual(len(level.mesh), level.summary.result_bytes)
            self.assertEqual(level.summary.target_vertices, asked)
            self.assertLessEqual(abs(level.summary.output_vertices - asked), 0.02 * asked)
            self.assertEqual(len(level.saliency), level.summary.output_vertices)
        self.assertEqual(result.mesh, result.levels[0].mesh)
        front = [s.name for s in result.stages if s.front_half]
        self.assertEqual(front.count("render"), 1, result.stages)
        self.assertEqual({s.level for s in result.stages if not s.front_half}, {0, 1})

    def test_without_numpy_the_field_is_a_list(self):
        script = ("import sys; sys.modules['numpy'] = None; import vpremesh, os; "
                  "r = vpremesh.Client(os.environ['VPR_SERVER'], os.environ['VPR_TOKEN'], os.environ['VPR_TLS_CA'])"
                  ".remesh(os.environ['VPR_SMALL'], 300); "
                  "print(type(r.saliency).__name__, len(r.saliency), r.summary.output_vertices)")
        kind, values, vertices = subprocess.run([sys.executable, "-c", script], check=True, capture_output=True,
                                                text=True).stdout.split()
        self.assertEqual(kind, "list")
        self.assertEqual(values, vertices)

    def test_options_map_to_the_spec_by_name(self):
        with client() as c:
            result = c.remesh(ENV["VPR_SMALL"], TARGET, device="cpu", seed=7, return_saliency=False,
                              return_input_saliency=True)
        self.assertEqual(len(result.saliency), 0)  # asked not to send it
        self.assertEqual(len(result.input_saliency), result.summary.input_vertices)
        self.assertTrue(all(s.device.startswith(("cpu", "egl", "osmesa")) for s in result.stages), result.stages)
        with client() as c:
            with self.assertRaisesRegex(TypeError, "unknown option 'colour'"):
                c.remesh(ENV["VPR_SMALL"], TARGET, colour="red")
            with self.assertRaisesRegex(ValueError, "device='gpu': not one of any, cpu, cuda"):
                c.remesh(ENV["VPR_SMALL"], TARGET, device="gpu")

    def test_a_bad_token_is_unauthenticated(self):
        for token in ("not-a-token", None):
            with client(token=token) as c, self.assertRaises(vpremesh.Error) as caught:
                c.remesh(ENV["VPR_SMALL"], TARGET)
            self.assertEqual(caught.exception.code, grpc.StatusCode.UNAUTHENTICATED)
            self.assertIn("token", caught.exception.message)

    def test_a_bad_target_is_an_invalid_argument(self):
        with client() as c, self.assertRaises(vpremesh.Error) as caught:
            c.remesh(ENV["VPR_SMALL"], 10)
        self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("target_vertices is 10", caught.exception.message)

    def test_mutual_tls_needs_the_client_certificate(self):
        certs = ENV["VPR_CERTS"]
        with client(address=ENV["VPR_MTLS_SERVER"], token=None) as c, self.assertRaises(vpremesh.Error) as caught:
            c.get("j-0000000000000000", timeout=2)  # waits for a handshake that keeps failing
        self.assertIn(caught.exception.code, (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED))
        with client(address=ENV["VPR_MTLS_SERVER"], token=None, tls_cert=os.path.join(certs, "client.pem"),
                    tls_key=os.path.join(certs, "client.key")) as c, self.assertRaises(vpremesh.Error) as caught:
            c.get("j-0000000000000000", timeout=10)
        self.assertEqual(caught.exception.code, grpc.StatusCode.NOT_FOUND)  # the call reached the server

    def test_an_unknown_job_is_not_found(self):
        with client() as c, self.assertRaises(vpremesh.Error) as caught:
            c.get("j-0000000000000000")
        self.assertEqual(caught.exception.code, grpc.StatusCode.NOT_FOUND)

    def test_cancel_a_submitted_job(self):
        with client() as c:
            busy = c.submit(ENV["VPR_LARGE"], 3000)  # holds the one worker
            queued = c.submit(ENV["VPR_SMALL"], TARGET)
            self.assertEqual(c.cancel(queued).state, vpremesh.pb.JOB_STATE_CANCELLED)
            events = list(c.watch(queued))
            self.assertEqual(kinds(events)[-1], "cancelled")
            self.assertEqual(events[-1].cancelled.code, grpc.StatusCode.CANCELLED.value[0])
            self.assertEqual(c.get(queued).state, vpremesh.pb.JOB_STATE_CANCELLED)
            c.cancel(busy)  # running: it stops at its next stage boundary
            self.assertEqual(kinds(c.watch(busy))[-1], "cancelled")

    def test_remesh_raises_when_its_job_is_cancelled(self):
        with client() as c, client() as other, self.assertRaises(vpremesh.Error) as caught:
            c.remesh(ENV["VPR_LARGE"], 3000,
                     progress=lambda e: e.WhichOneof("event") == "started" and other.cancel(e.job_id))
        self.assertEqual(caught.exception.code, grpc.StatusCode.CANCELLED)
        self.assertTrue(caught.exception.job_id)

    def test_a_remesh_left_early_or_past_its_timeout_cancels_its_job(self):
        class Stop(Exception):
            pass

        def stop_when_started(event):
            if event.WhichOneof("event") == "started":
                raise Stop(event.job_id)

        with client() as c:
            with self.assertRaises(Stop) as stopped:
                c.remesh(ENV["VPR_LARGE"], 3000, progress=stop_when_started)
            self.assertEqual(kinds(c.watch(stopped.exception.args[0]))[-1], "cancelled")
            # Fourteen 2048-px views make the job run for several seconds on
            # any machine, so the deadline passes while it runs, not after.
            with self.assertRaises(vpremesh.Error) as caught:
                c.remesh(ENV["VPR_LARGE"], 3000, views=14, resolution=2048, timeout=1.0)
            self.assertEqual(caught.exception.code, grpc.StatusCode.DEADLINE_EXCEEDED)
            self.assertTrue(caught.exception.job_id)
            last = list(c.watch(caught.exception.job_id))[-1]
            self.assertIn(last.WhichOneof("event"), ("cancelled", "failed"))

    def test_an_upload_passes_over_a_replica_that_is_down(self):
        down = socket.create_server(("127.0.0.1", 0))  # a port nobody listens on once closed
        down_address = f"127.0.0.1:{down.getsockname()[1]}"
        down.close()
        with client(address=[down_address, ENV["VPR_SERVER"]]) as c, \
                self.assertLogs("vpremesh", logging.WARNING) as logs:
            result = c.remesh(ENV["VPR_SMALL"], TARGET)
            job = c.submit(ENV["VPR_SMALL"], TARGET)
            self.assertEqual(kinds(c.watch(job))[-1], "completed")
        self.assertEqual(len(result.saliency), result.summary.output_vertices)
        self.assertIn(f"{down_address} does not accept connections; trying {ENV['VPR_SERVER']}", logs.output[0])
        self.assertEqual(len([line for line in logs.output if "does not accept" in line]), 2)

    def test_watch_yields_every_event_in_order(self):
        with client() as c:
            job = c.submit(ENV["VPR_SMALL"], TARGET)
            events = list(c.watch(job))
            self.assertEqual([e.sequence for e in events], list(range(len(events))))
            self.assertEqual(kinds(events)[:2], ["queued", "started"])
            self.assertIn("stage", kinds(events))
            self.assertEqual(kinds(events)[-1], "completed")
            self.assertTrue(all(e.job_id == job for e in events))
            later = list(c.watch(job, from_sequence=3))
            self.assertEqual([e.SerializeToString() for e in later], [e.SerializeToString() for e in events[3:]])

    def test_watch_reattaches_to_the_next_replica_when_its_server_is_lost(self):
        with client() as c:
            job = c.submit(ENV["VPR_SMALL"], TARGET)
            whole = list(c.watch(job))
        relay = Relay()  # measures the stream
        with client(address=relay.address) as c:
            self.assertEqual([e.SerializeToString() for e in c.watch(job)], [e.SerializeToString() for e in whole])
        relay.cut()
        # Early (the TLS handshake and the first events) and late (within the
        # result chunks): events before the cut are not yielded again.
        latest_resume = 0
        for percent in (40, 90):
            with self.subTest(percent=percent):
                relay_dies = Relay(relay.to_client * percent // 100)
                with client(address=[relay_dies.address, ENV["VPR_SERVER"]]) as c, \
                        self.assertLogs("vpremesh", logging.WARNING) as logs:
                    events = list(c.watch(job))
                self.assertEqual([e.SerializeToString() for e in events], [e.SerializeToString() for e in whole])
                resumed = re.search(f"lost {relay_dies.address} .*; re-attaching to job {job} on "
                                    f"{ENV['VPR_SERVER']} from event ([0-9]+)", logs.output[0])
                self.assertTrue(resumed, logs.output)
                latest_resume = max(latest_resume, int(resumed.group(1)))
        self.assertGreater(latest_resume, 0)  # from_sequence was used, not only a replay from 0

if __name__ == "__main__":
    unittest.main(verbosity=2)
