#!/usr/bin/env bash
# The rig campaign example: synthesizes the loop sets of spec.yaml with the engine, then fits
# them and writes the report (report/report.md, report.json and the plots).
# Usage: bash examples/rig_campaign/run.sh [OUT_DIR]   (default: examples/rig_campaign itself)
# mdrctl: $MDRCTL, else build/release/client/mdrctl of this checkout, else mdrctl on PATH.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
exec bash "$here/../synthesize_and_fit.sh" "$here/spec.yaml" "${1:-$here}"
