#!/usr/bin/env bash
# Runs the rough-interface example through the service: mdrctl (embedded server, or --server
# HOST:PORT for a running mdrd) applies rough_interface.yaml (3000 asperities, F_N = 5 kN, three
# fretting cycles), writes the table as CSV, checks the energy balance and plots the loop F_x over
# u_x, the energy dissipated per cycle beside the loop's area and the contact counts, into
# build/release/examples/rough_interface/.
#   bash examples/rough_interface/run.sh [extra mdrctl run flags, e.g. --server localhost:50051]
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"
bash deploy/build.sh release --target mdrctl
mdrctl=build/release/client/mdrctl
scene=examples/rough_interface/rough_interface.yaml
out=build/release/examples/rough_interface
mkdir -p "$out"
"$mdrctl" run "$scene" --format csv --plot "$out" "$@" >"$out/rough_interface.csv"
"$mdrctl" run "$scene" --format json "$@" | python3 examples/rough_interface/check_energy.py
echo "wrote $out/rough_interface.csv, hysteresis.png, energy_per_cycle.png, counts.png, forces.png"
