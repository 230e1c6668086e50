#!/usr/bin/env bash
# Regenerates docs/report/: accuracy against run time (CSV, Markdown, PNG plots) and the core and
# service benchmarks. One command, a few minutes on 2 cores:
#   bash tests/accuracy/run.sh            (full study)
#   bash tests/accuracy/run.sh --quick    (fewer resolutions, for a smoke run)
set -euo pipefail
cd "$(dirname "$0")/../.."
quick=${1:-}
out=docs/report
targets=(mdr_accuracy_study mdr_core_bench)
[ -f tests/bench/service_bench.cc ] && targets+=(mdr_service_bench)
bash deploy/build.sh release --target "${targets[@]}"
mkdir -p "$out"
echo "accuracy study -> $out/accuracy.csv"
build/release/tests/accuracy/mdr_accuracy_study $quick > "$out/accuracy.csv"
echo "core benchmarks -> $out/core_bench.json"
build/release/tests/bench/mdr_core_bench --benchmark_repetitions=3 \
  --benchmark_report_aggregates_only=true --benchmark_out_format=json \
  --benchmark_out="$out/core_bench.json" > /dev/null
if [ -x build/release/tests/bench/mdr_service_bench ]; then
  echo "service benchmarks -> $out/service_bench.json"
  build/release/tests/bench/mdr_service_bench --benchmark_out_format=json \
    --benchmark_out="$out/service_bench.json" > /dev/null
fi
/usr/bin/python3 tests/accuracy/report.py "$out"
echo "wrote $(ls "$out" | tr '\n' ' ')"
