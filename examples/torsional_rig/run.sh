#!/usr/bin/env bash
# The torsional rig example: synthesizes the torsional loop sets of spec.yaml with the engine,
# then fits them and writes the report (report/report.md, report.json and the plots).
# Usage: bash examples/torsional_rig/run.sh [OUT_DIR]   (default: examples/torsional_rig itself)
# mdrctl: $MDRCTL, else build/release/client/mdrctl of this checkout, else mdrctl on PATH.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
exec bash "$here/../synthesize_and_fit.sh" "$here/spec.yaml" "${1:-$here}"
