#!/usr/bin/env bash
# Builds the libFuzzer targets with clang-14 under ASan + UBSan and runs each for a bounded time
# on the corpus kept in tests/fuzz/corpus (new inputs go to a scratch copy, not the repo).
# Usage: tests/fuzz/run.sh [seconds per target, default 60]
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds=${1:-60}
bash deploy/install-deps.sh
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for target in engine; do
  mkdir -p "$work/$target"
  cp -r "tests/fuzz/corpus/$target/." "$work/$target/"
  echo "fuzz: $target for ${seconds}s"
  "build/fuzz/tests/fuzz/mdr_${target}_fuzz" -max_total_time="$seconds" -timeout=10 \
    -print_final_stats=1 "$work/$target" "tests/fuzz/corpus/$target" 2>&1 | tail -n 12
done
