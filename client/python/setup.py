"""Builds the package mdr with its API modules, generated from the repository's proto/ into the
build (as proto/CMakeLists.txt does for the build tree): protoc for the messages of every .proto
file there, grpc_python_plugin for the stub of contact_service.proto. Metadata: pyproject.toml."""
import glob
import os
import shutil
import subprocess

from setuptools import setup
from setuptools.command.build_py import build_py

PROTO_ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..",
                                           "proto"))


def _tool(name: str, package: str) -> str:
    path = shutil.which(name)
    if path is None:
        raise RuntimeError(f"{name} not found: install Debian's {package} to build mdr's API "
                           f"modules")
    return path


class BuildWithApi(build_py):
    """build_py, then the generated modules (mdr/v1/*_pb2*.py, google/rpc/*_pb2.py)."""

    def run(self):
        super().run()
        protos = sorted(os.path.relpath(path, PROTO_ROOT)
                        for path in glob.glob(os.path.join(PROTO_ROOT, "**", "*.proto"),
                                              recursive=True))
        if not protos:
            raise RuntimeError(f"no .proto files under {PROTO_ROOT}: build from the repository")
        protoc = _tool("protoc", "protobuf-compiler")
        plugin = _tool("grpc_python_plugin", "protobuf-compiler-grpc")
        subprocess.run([protoc, f"-I{PROTO_ROOT}", f"--python_out={self.build_lib}", *protos],
                       check=True)
        subprocess.run([protoc, f"-I{PROTO_ROOT}", f"--plugin=protoc-gen-grpc_python={plugin}",
                        f"--grpc_python_out={self.build_lib}", "mdr/v1/contact_service.proto"],
                       check=True)


setup(cmdclass={"build_py": BuildWithApi})
