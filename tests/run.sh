#!/usr/bin/env bash
# Installs missing packages, builds the release preset and runs every test; exits with CTest's code.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/build.sh release
ctest --preset release -j2
