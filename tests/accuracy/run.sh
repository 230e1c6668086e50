#!/usr/bin/env bash
# Regenerates docs/report/: accuracy against run time (CSV, Markdown, PNG plots), the core
# benchmarks, and the service load test (mdr_load: unary, batched and streamed Apply beside an
# echo of the same shape, 1/10/100 sessions; about a minute), the many-contact benchmarks, the loop analysis and fit (issue #24). One command, a few minutes on 2 cores:
#   bash tests/accuracy/run.sh            (full study)
#   bash tests/accuracy/run.sh --quick    (fewer resolutions, for a smoke run)
set -euo pipefail
cd "$(dirname "$0")/../.."
quick=${1:-}
out=docs/report
bash deploy/build.sh release --target mdr_accuracy_study mdr_core_bench mdr_load \
  mdr_interface_bench mdr_interface_load mdr_operations_bench mdr_analysis_bench mdr_fairness mdrd \
  capi_bench mdr_million_asperities
mkdir -p "$out"
echo "accuracy study -> $out/accuracy.csv"
build/release/tests/accuracy/mdr_accuracy_study $quick > "$out/accuracy.csv"
echo "core benchmarks -> $out/core_bench.json"
build/release/tests/bench/mdr_core_bench --benchmark_repetitions=3 \
  --benchmark_report_aggregates_only=true --benchmark_out_format=json \
  --benchmark_out="$out/core_bench.json" > /dev/null
echo "service one-step cost -> $out/operations_bench.json"
build/release/tests/bench/mdr_operations_bench --benchmark_repetitions=3 \
  --benchmark_report_aggregates_only=true --benchmark_out_format=json \
  --benchmark_out="$out/operations_bench.json" > /dev/null
echo "interface benchmarks -> $out/interface_bench.json"
build/release/tests/bench/mdr_interface_bench --benchmark_filter=-MillionAsperities \
  --benchmark_repetitions=3 --benchmark_report_aggregates_only=true \
  --benchmark_out_format=json --benchmark_out="$out/interface_bench.json" > /dev/null
echo "10^6 asperities (a process each, for its resident size) -> $out/million_asperities_{1,2}.json"
for workers in 1 2; do
  build/release/tests/bench/mdr_interface_bench --benchmark_filter="MillionAsperities/$workers/" \
    --benchmark_out_format=json --benchmark_out="$out/million_asperities_$workers.json" > /dev/null
done
echo "10^6 asperities through the service -> $out/million_service.txt"
{ build/release/tests/bench/mdr_million_asperities
  build/release/tests/bench/mdr_million_asperities --log-sigma 0.5; } > "$out/million_service.txt"
echo "loop analysis and identification -> $out/analysis_bench.json"
build/release/tests/bench/mdr_analysis_bench --benchmark_repetitions=3 \
  --benchmark_report_aggregates_only=true --benchmark_out_format=json \
  --benchmark_out="$out/analysis_bench.json" > /dev/null
echo "contact list through the service -> $out/interface_load.txt"
{ build/release/tests/bench/mdr_interface_load --seconds 3
  build/release/tests/bench/mdr_interface_load --seconds 3 --no-energy; } > "$out/interface_load.txt"
echo "steps through the C interface -> $out/capi_bench.json"
build/release/tests/capi/capi_bench --benchmark_out_format=json \
  --benchmark_out="$out/capi_bench.json" > /dev/null
echo "fairness between two tokens -> $out/fairness.txt"
{ for run in 1 2 3; do
    build/release/tests/bench/mdr_fairness --mdrd build/release/server/mdrd/mdrd --seconds 5
  done
  build/release/tests/bench/mdr_fairness --mdrd build/release/server/mdrd/mdrd --seconds 5 \
    --alice-competes; } > "$out/fairness.txt"
echo "load test -> $out/load.json, two more stream runs -> $out/load_streams_{2,3}.json"
build/release/tests/bench/mdr_load --json "$out/load.json" > /dev/null
for run in 2 3; do
  build/release/tests/bench/mdr_load --only "stream window" --json "$out/load_streams_$run.json" \
    > /dev/null
done
echo "execution model under heavy calls and inline streams -> $out/execution.txt"
{ build/release/tests/bench/mdr_load --execution --execution-seconds 4
  build/release/tests/bench/mdr_load --execution --execution-seconds 4 --inline-clients-compete \
    | grep inline; } > "$out/execution.txt"
/usr/bin/python3 tests/accuracy/report.py "$out"
echo "wrote $(ls "$out" | tr '\n' ' ')"
