#!/usr/bin/env bash
# Instructions per asperity-step of the interface step and of the contact list (issue #54),
# counted by callgrind over BM_StepInstructions's measured cycles alone (10^4 Hertz asperities,
# Mindlin-Deresiewicz cycling with energy, 1 worker, after one warm cycle); then per inline
# stream message answering the whole state and one force (ApplyRequest.state_mask), step and
# serialized answer (BM_InlineAnswer, H1 with energy):
#   bash tests/bench/instructions.sh
# Installs valgrind if it is missing; builds mdr_interface_bench if it is not built. Takes about
# two minutes (callgrind runs the code some 50 times slower).
set -euo pipefail
cd "$(dirname "$0")/../.."
command -v valgrind > /dev/null || apt-get install -y --no-install-recommends valgrind > /dev/null
bench=build/release/tests/bench/mdr_interface_bench
operations=build/release/tests/bench/mdr_operations_bench
if [ ! -x "$bench" ] || [ ! -x "$operations" ]; then
  cmake --preset release > /dev/null
  cmake --build --preset release --target mdr_interface_bench mdr_operations_bench
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# count NAME FUNCTION_GLOB BENCH FILTER PER_COUNTER UNIT: callgrind's instructions inside
# FUNCTION_GLOB over one benchmark run, divided by the run's counter PER_COUNTER.
count() {
  local name=$1 collect=$2 binary=$3 filter=$4 per=$5 unit=$6
  valgrind --tool=callgrind --callgrind-out-file="$work/callgrind.$name" \
    --toggle-collect="$collect" "$binary" --benchmark_filter="$filter" \
    --benchmark_min_time=0.2 --benchmark_format=json > "$work/$name.json" \
    2> "$work/valgrind.$name.log"
  python3 - "$work/callgrind.$name" "$work/$name.json" "$per" "$unit" <<'PY'
import json, sys
instructions = None
for line in open(sys.argv[1]):
    if line.startswith(("summary:", "totals:")):
        instructions = int(line.split()[1])
        break
run = json.load(open(sys.argv[2]))["benchmarks"][0]
items = run[sys.argv[3]]
print(f"{run['label']}: {instructions / items:.0f} instructions per {sys.argv[4]} "
      f"({instructions} over {items:.0f})")
PY
}
for kind in 0 1; do
  count "step$kind" '*MeasuredCycles*' "$bench" "StepInstructions/$kind/" asperity_steps \
    asperity-step
done
for answer in 0 1; do
  count "answer$answer" '*InlineAnswers::Next*' "$operations" "InlineAnswer/$answer\$" \
    messages_in_process "inline message"
done
