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
for kind in 0 1; do
  valgrind --tool=callgrind --callgrind-out-file="$work/callgrind.$kind" \
    --toggle-collect='*MeasuredCycles*' "$bench" --benchmark_filter="StepInstructions/$kind/" \
    --benchmark_format=json > "$work/bench.$kind.json" 2> "$work/valgrind.$kind.log"
  python3 - "$work/callgrind.$kind" "$work/bench.$kind.json" <<'PY'
import json, sys
instructions = None
for line in open(sys.argv[1]):
    if line.startswith(("summary:", "totals:")):
        instructions = int(line.split()[1])
        break
run = json.load(open(sys.argv[2]))["benchmarks"][0]
steps = run["asperity_steps"]
print(f"{run['label']}: {instructions / steps:.0f} instructions per asperity-step "
      f"({instructions} over {steps:.0f})")
PY
done
for answer in 0 1; do
  valgrind --tool=callgrind --callgrind-out-file="$work/callgrind.answer$answer" \
    --toggle-collect='*InlineAnswers::Next*' "$operations" \
    --benchmark_filter="InlineAnswer/$answer\$" --benchmark_min_time=0.02 \
    --benchmark_format=json > "$work/answer.$answer.json" 2> "$work/valgrind.answer$answer.log"
  python3 - "$work/callgrind.answer$answer" "$work/answer.$answer.json" <<'PY'
import json, sys
instructions = None
for line in open(sys.argv[1]):
    if line.startswith(("summary:", "totals:")):
        instructions = int(line.split()[1])
        break
run = json.load(open(sys.argv[2]))["benchmarks"][0]
messages = run["messages_in_process"]
print(f"inline message, {run['label']} ({run['answer_bytes']:.0f} bytes): "
      f"{instructions / messages:.0f} instructions per message ({instructions} over {messages:.0f})")
PY
done
