#!/usr/bin/env bash
# The rig campaign example: synthesizes the loop sets of spec.yaml with the engine, then fits
# them and writes the report (report/report.md, report.json and the plots).
# Usage: bash examples/rig_campaign/run.sh [OUT_DIR]   (default: examples/rig_campaign itself)
# mdrctl: $MDRCTL, else build/release/client/mdrctl of this checkout, else mdrctl on PATH.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
out=$(mkdir -p "${1:-$here}" && cd "${1:-$here}" && pwd)
if [[ -n ${MDRCTL:-} ]]; then
  mdrctl=$(command -v "$MDRCTL" || true)
  [[ -n $mdrctl ]] || { echo "run.sh: MDRCTL=$MDRCTL is not an executable" >&2; exit 1; }
  [[ $mdrctl == */* ]] && mdrctl=$(realpath "$mdrctl")
elif [[ -f $repo/build/release/client/mdrctl && -x $repo/build/release/client/mdrctl ]]; then
  mdrctl=$repo/build/release/client/mdrctl
elif [[ -f $repo/build/release/client/mdrctl/mdrctl && -x $repo/build/release/client/mdrctl/mdrctl ]]; then
  mdrctl=$repo/build/release/client/mdrctl/mdrctl
elif command -v mdrctl >/dev/null; then
  mdrctl=$(command -v mdrctl)
else
  echo "run.sh: mdrctl not found: set MDRCTL, build it (bash deploy/build.sh release --target" \
       "mdrctl) or put it on PATH" >&2
  exit 1
fi
# Relative paths inside OUT_DIR: the campaign and the report name their files the same wherever
# they are written.
cd "$out"
rm -rf data report
"$mdrctl" synthesize "$here/spec.yaml" --out data
"$mdrctl" fit data/campaign.yaml --report report
