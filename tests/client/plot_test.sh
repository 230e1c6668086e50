#!/usr/bin/env bash
# mdrctl run SCENE --plot DIR [NAME...] writes non-empty PNG files: the NAMEs given, by default
# hysteresis, forces, energy per cycle, profiles, tractions, weights. Exit 77 (CTest: skipped)
# only when gnuplot is not installed.
set -euo pipefail
mdrctl=$1
scene=$2
shift 2
names=("$@")
(( ${#names[@]} )) || names=(hysteresis forces energy_per_cycle profiles tractions weights)
if ! command -v gnuplot >/dev/null; then
  echo "SKIPPED: gnuplot is not installed (apt-get install gnuplot-nox)"
  exit 77
fi
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
"$mdrctl" run "$scene" --plot "$dir/plots" >/dev/null
for name in "${names[@]}"; do
  png="$dir/plots/$name.png"
  [[ -s $png ]] || { echo "missing or empty: $name.png"; ls -l "$dir/plots"; exit 1; }
  magic=$(head -c 8 "$png" | od -An -tx1 | tr -d ' \n')
  [[ $magic == 89504e470d0a1a0a ]] || { echo "$name.png is not a PNG ($magic)"; exit 1; }
  echo "ok $name.png $(stat -c %s "$png") bytes"
done
