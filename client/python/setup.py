"""Generates the gRPC stubs from proto/vpremesh/v1/remesh.proto while the
package is built, so that the stubs always match the proto of the checkout
and no generated code is kept in git.

The compiler: grpc_tools (pip's grpcio-tools) when the building interpreter
has it, else `protoc` with `grpc_python_plugin` (Debian 12: protobuf-compiler
and protobuf-compiler-grpc, whose output suits python3-protobuf 3.21 and
python3-grpcio 1.51). $PROTOC and $GRPC_PYTHON_PLUGIN override the programs;
$VPREMESH_PROTO_DIR the folder holding vpremesh/v1/remesh.proto (by default
the repository's proto/, two folders up from here).
"""
import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
PROTO = Path("vpremesh") / "v1" / "remesh.proto"


def proto_dir():
    candidates = [os.environ.get("VPREMESH_PROTO_DIR"), HERE / "proto", HERE.parent.parent / "proto"]
    for d in candidates:
        if d and (Path(d) / PROTO).is_file():
            return Path(d)
    raise SystemExit(f"vpremesh: cannot find {PROTO} (looked in {[str(c) for c in candidates if c]}); "
                     "build from the repository's client/python, or set VPREMESH_PROTO_DIR")


def compiler_command(out):
    if importlib.util.find_spec("grpc_tools") is not None:
        return [sys.executable, "-m", "grpc_tools.protoc", f"--grpc_python_out={out}"]
    protoc = os.environ.get("PROTOC") or shutil.which("protoc")
    plugin = os.environ.get("GRPC_PYTHON_PLUGIN") or shutil.which("grpc_python_plugin")
    if not protoc or not plugin:
        raise SystemExit("vpremesh: generating the gRPC stubs needs grpc_tools (pip install grpcio-tools) or "
                         "protoc and grpc_python_plugin (Debian: apt install protobuf-compiler protobuf-compiler-grpc)")
    return [protoc, f"--plugin=protoc-gen-grpc={plugin}", f"--grpc_out={out}"]


class BuildWithStubs(build_py):
    def run(self):
        super().run()
        # An editable install imports from the source folder: the stubs go
        # there (git ignores them); otherwise into the build folder only.
        out = HERE if getattr(self, "editable_mode", False) else Path(self.build_lib)
        src = proto_dir()
        (out / "vpremesh" / "v1").mkdir(parents=True, exist_ok=True)
        command = compiler_command(out) + [f"--proto_path={src}", f"--python_out={out}", str(src / PROTO)]
        self.announce("vpremesh: " + " ".join(command), level=2)
        subprocess.run(command, check=True)


setup(cmdclass={"build_py": BuildWithStubs})
