#!/usr/bin/env bash
# Builds the libFuzzer targets (engine: the physics core; request: the service's request validation;
# capi: libmdr_c's C functions; rig: mdrctl's CSV and MATLAB readers)
# with clang-14 under ASan + UBSan and runs each on the corpus kept in
# tests/fuzz/corpus (new inputs go to a scratch copy, not the repo).
#   tests/fuzz/run.sh [RUNS]     deterministic: fixed seed, RUNS inputs per target (default 20000);
#                                this is what CI runs
#   MDR_FUZZ_SECONDS=600 tests/fuzz/run.sh   explore: random seed for that many seconds per target
set -euo pipefail
cd "$(dirname "$0")/../.."
runs=${1:-20000}
bash deploy/install-deps.sh
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz
if [ -n "${MDR_FUZZ_SECONDS:-}" ]; then
  budget=(-max_total_time="$MDR_FUZZ_SECONDS")
else
  budget=(-seed=1 -runs="$runs")
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
artifacts=build/fuzz/artifacts
mkdir -p "$artifacts"
# Leaks inside third-party libraries that the project cannot free (the file says which, and why).
export LSAN_OPTIONS="suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0"
for target in engine request capi rig; do
  mkdir -p "$work/$target"
  echo "fuzz: $target (${budget[*]})"
  # The rig target reads MAT files through matio, which asks malloc for what a corrupt file
  # declares: beyond the address space glibc returns NULL and mdrctl refuses the file
  # (corpus/rig/regression-matio-beyond-address-space), where ASan would abort. Allocations that
  # do succeed stay bounded by libFuzzer's -malloc_limit_mb (2 GB by default).
  asan_options=""
  [ "$target" = rig ] && asan_options="allocator_may_return_null=1"
  set +e
  ASAN_OPTIONS="$asan_options" \
  "build/fuzz/tests/fuzz/mdr_${target}_fuzz" "${budget[@]}" -timeout=10 -print_final_stats=1 \
    -artifact_prefix="$artifacts/" "$work/$target" "tests/fuzz/corpus/$target" > "$work/log" 2>&1
  status=$?
  set -e
  if [ "$status" -ne 0 ]; then
    grep -E "invariant|ERROR|runtime error|SUMMARY" "$work/log" | head -n 20 >&2 || tail -n 20 "$work/log" >&2
    echo "fuzz: $target failed (exit $status); inputs kept in $artifacts:" >&2
    ls "$artifacts" >&2
    exit "$status"
  fi
  tail -n 6 "$work/log"
done
