"""Builds the package mdr with its API modules, generated from the repository's proto/ into the
build (as proto/CMakeLists.txt does for the build tree): protoc for the messages of every .proto
file there, grpc_python_plugin for the stub of contact_service.proto. Metadata: pyproject.toml.

It also bundles the engine, so that `pip install client/python` alone gives a working package:
libmdr_c.so.1 (in-process sessions and analysis) and mdrd (Client.embedded()), copied into the
package from the project's CMake build of the targets mdr_c and mdrd. The build directory is
$MDR_CMAKE_BUILD_DIR, else the repository's build/release: an existing build is reused (only
what changed is rebuilt), a missing one is configured with the release preset first (Debian's
packages only, about 15 minutes on 2 cores). MDR_BUNDLE_ENGINE=0 skips the bundle (the package
then finds the library and mdrd through $MDR_C_LIBRARY, $MDR_MDRD or the system's paths)."""
import glob
import os
import shutil
import subprocess

from setuptools import setup
from setuptools.command.build_py import build_py

REPOSITORY = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
PROTO_ROOT = os.path.join(REPOSITORY, "proto")


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
        if os.environ.get("MDR_BUNDLE_ENGINE", "1") != "0":
            self._bundle_engine()

    def _bundle_engine(self):
        """libmdr_c.so.1 and mdrd from the project's CMake build, into the package."""
        cmake = _tool("cmake", "cmake")
        build = os.environ.get("MDR_CMAKE_BUILD_DIR") or os.path.join(REPOSITORY, "build",
                                                                      "release")
        if not os.path.isfile(os.path.join(build, "CMakeCache.txt")):
            if not os.path.isfile(os.path.join(REPOSITORY, "CMakePresets.json")):
                raise RuntimeError(
                    f"no CMake build at {build} and {REPOSITORY} is not the mdr repository: "
                    f"install from a clone, set MDR_CMAKE_BUILD_DIR to a configured build, or "
                    f"set MDR_BUNDLE_ENGINE=0 and provide libmdr_c and mdrd yourself")
            print(f"mdr: configuring {build} (the release preset) to build libmdr_c and mdrd")
            subprocess.run([cmake, "--preset", "release"], cwd=REPOSITORY, check=True)
        subprocess.run([cmake, "--build", build, "--target", "mdr_c", "mdrd"], check=True)
        package = os.path.join(self.build_lib, "mdr")
        for built, name in ((os.path.join(build, "capi", "libmdr_c.so.1"), "libmdr_c.so.1"),
                            (os.path.join(build, "server", "mdrd", "mdrd"), "mdrd")):
            # copy, not copy2 of a symlink: the package holds the library itself
            shutil.copyfile(os.path.realpath(built), os.path.join(package, name))
            os.chmod(os.path.join(package, name), 0o755)


setup(cmdclass={"build_py": BuildWithApi})
