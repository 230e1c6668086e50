#!/usr/bin/env bash
# The coverage study behind docs/analysis.md, "Coverage measured": each configuration's seeded
# replicates fitted by mdr_identify_study (the campaigns of tests/fixtures/identify_campaigns.h,
# the seeds of the unit tests: 100 ...), its summary printed. A program run by hand, not a test
# (about an hour on two cores; CTest runs the same criteria on fewer configurations).
# Usage: bash tests/analysis/coverage_study.sh [REPLICATES]   (default 100)
set -euo pipefail
cd "$(dirname "$0")/../.."
study=build/release/tests/analysis/mdr_identify_study
[[ -x $study ]] || { echo "build it first: bash deploy/build.sh release" >&2; exit 1; }
n=${1:-100}
common=(--replicates "$n" --seed 100 --samples-per-cycle 100 --force-noise 0.1)
run() {
  echo "== $1"
  shift
  "$study" "${common[@]}" "$@" | grep -v -E '^  (set|displacement_offset set|force_offset set|displacement_drift set|replicate|outlier)'
}
run "2 nm" --displacement-noise 2e-9
run "5 nm" --displacement-noise 5e-9
run "10 nm" --displacement-noise 10e-9
run "5 nm, normal load +-15 % in its column (0.1 N noise)" --displacement-noise 5e-9 \
  --normal-variation 0.15 --normal-noise 0.1
run "5 nm, offsets 0.8 N and +-0.5 um, drift 50 nm, fitted from the virgin loading" \
  --displacement-noise 5e-9 --force-offset 0.8 --displacement-offset 5e-7 --drift 5e-8 \
  --fit-offsets --fit-drift --burn-in 0
run "5 nm, 0.5 kg at 100 Hz" --displacement-noise 5e-9 --frequency 100 --mass 0.5 --fit-mass
run "5 nm, a cone fitted as a sphere" --displacement-noise 5e-9 --truth cone
run "5 nm, 20 N files declared at 60 N (normal-force column)" --displacement-noise 5e-9 \
  --loads 20 --normal-column --normal-noise 0.1 --declared-normal-force 60
