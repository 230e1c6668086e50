#!/usr/bin/env bash
# A synthetic campaign's example, end to end: synthesizes the loop sets of SPEC with the engine,
# then fits them and writes the report, into OUT_DIR/data and OUT_DIR/report (report.md,
# report.json and the plots). examples/rig_campaign/run.sh and examples/torsional_rig/run.sh call
# it with their spec.yaml.
# Usage: bash examples/synthesize_and_fit.sh SPEC.yaml OUT_DIR
# mdrctl: $MDRCTL, else build/release/client/mdrctl of this checkout, else mdrctl on PATH.
set -euo pipefail
spec=$(realpath "$1")
repo=$(cd "$(dirname "$0")/.." && pwd)
out=$(mkdir -p "$2" && cd "$2" && pwd)
if [[ -n ${MDRCTL:-} ]]; then
  mdrctl=$(command -v "$MDRCTL" || true)
  [[ -n $mdrctl ]] || { echo "${0##*/}: MDRCTL=$MDRCTL is not an executable" >&2; exit 1; }
  [[ $mdrctl == */* ]] && mdrctl=$(realpath "$mdrctl")
elif [[ -f $repo/build/release/client/mdrctl && -x $repo/build/release/client/mdrctl ]]; then
  mdrctl=$repo/build/release/client/mdrctl
elif [[ -f $repo/build/release/client/mdrctl/mdrctl && -x $repo/build/release/client/mdrctl/mdrctl ]]; then
  mdrctl=$repo/build/release/client/mdrctl/mdrctl
elif command -v mdrctl >/dev/null; then
  mdrctl=$(command -v mdrctl)
else
  echo "${0##*/}: mdrctl not found: set MDRCTL, build it (bash deploy/build.sh release --target" \
       "mdrctl) or put it on PATH" >&2
  exit 1
fi
# Relative paths inside OUT_DIR: the campaign and the report name their files the same wherever
# they are written.
cd "$out"
rm -rf data report
"$mdrctl" synthesize "$spec" --out data
"$mdrctl" fit data/campaign.yaml --report report
