#!/usr/bin/env bash
# Installs missing packages, builds mdrctl and runs a scene file on the embedded server.
# Usage: examples/run.sh [SCENE.json]   (default: examples/hertz_cattaneo_mindlin.json)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
scene=$(realpath "${1:-$repo/examples/hertz_cattaneo_mindlin.json}")
cd "$repo"
bash deploy/build.sh release --target mdrctl
build/release/client/mdrctl run "$scene"
