#!/usr/bin/env bash
# Installs what is missing, then configures and builds one CMake preset (default: release).
# Usage: deploy/build.sh [preset] [extra cmake --build args...]
set -euo pipefail
cd "$(dirname "$0")/.."
preset=${1:-release}
shift || true
bash deploy/install-deps.sh
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" "$@"
