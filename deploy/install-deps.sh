#!/usr/bin/env bash
# Installs the Debian 12 packages this project builds and tests with, only if any is missing.
# Idempotent: used by the README commands, .ci/run and deploy/Dockerfile alike.
#   install-deps.sh            build, test and tool packages
#   install-deps.sh --build    only what compiling mdrd, mdrctl and the probe needs (the container's
#                              build stage: no test, plot or Python tools)
#   install-deps.sh --runtime  only what mdrd and mdrctl need to run (the container's last stage)
set -euo pipefail

RUNTIME_PACKAGES=(
  ca-certificates libgrpc++1.51 libgrpc29 libprotobuf32 libgsl27 libgslcblas0 libspdlog1.10 libfmt9
  libabsl20220623 libc-ares2 libre2-9 libssl3 libsqlite3-0 libyaml-cpp0.7 libcpp-httplib0.11
  libmatio11 libfftw3-double3
)
COMPILE_PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libgrpc++-dev protobuf-compiler-grpc protobuf-compiler libprotobuf-dev
  libeigen3-dev libgsl-dev libspdlog-dev libgtest-dev libgmock-dev
  libcli11-dev libyaml-cpp-dev libsqlite3-dev libcpp-httplib-dev libmatio-dev libfftw3-dev
)
BUILD_PACKAGES=(
  "${COMPILE_PACKAGES[@]}" git libbenchmark-dev nlohmann-json3-dev openssl
  python3 python3-grpcio python3-grpc-tools python3-numpy python3-yaml python3-matplotlib
  gnuplot-nox prometheus
  gfortran python3-venv python3-setuptools
  octave liboctave-dev
)
if [ "${1:-}" = "--runtime" ]; then
  PACKAGES=("${RUNTIME_PACKAGES[@]}")
elif [ "${1:-}" = "--build" ]; then
  PACKAGES=("${COMPILE_PACKAGES[@]}")
else
  PACKAGES=("${BUILD_PACKAGES[@]}")
fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: missing packages: ${missing[*]}; run as root or install them" >&2
  exit 1
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
