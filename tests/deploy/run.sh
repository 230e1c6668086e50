#!/usr/bin/env bash
# Proves the deployment with the real image (podman, runc, HAProxy, Prometheus's promtool, all
# Debian packages installed if missing; base images made locally by debootstrap):
#   (--format docker: the OCI format has no HEALTHCHECK, podman would drop it.)
#   1. one container serves the example scene and reports healthy; its journal on a volume survives
#      a kill -9 of the container (every acknowledged step back, bit for bit); it drains on SIGTERM
#      within its grace period;
#   2. three containers behind HAProxy (deploy/haproxy/haproxy.cfg): clients that know only the
#      router create, stream to and query many sessions, pinned by x-session-id; killing one
#      instance disturbs no session of the others, and once it is back its sessions are whole; an
#      instance's Prometheus metrics pass promtool and count the run's calls and journal writes.
# Prints one summary line. Needs the release build's mdrd and Python package (tests/run.sh makes
# them). Traffic stays on 127.0.0.1.
set -euo pipefail
cd "$(dirname "$0")/../.."
source tests/deploy/lib.sh
started=$(date +%s)
work=$(mktemp -d)
IMAGE=localhost/mdrd:deploy-test
NAMES=(mdr-deploy-0 mdr-deploy-1 mdr-deploy-2 mdr-deploy-single)
ROUTER_PORT=50160
PORTS=(50161 50162 50163)
SINGLE_PORT=50164
GRACE=5

cleanup() {
  [ -f "$work/haproxy.pid" ] && kill "$(cat "$work/haproxy.pid")" 2>/dev/null || true
  for name in "${NAMES[@]}"; do "${P[@]}" rm -f -t 0 "$name" >/dev/null 2>&1 || true; done
  "${P[@]}" image prune -f >/dev/null 2>&1 || true  # the build stages of earlier builds
  for name in "${NAMES[@]}"; do "${P[@]}" volume rm -f "$name" >/dev/null 2>&1 || true; done
  rm -rf "$work"
}
trap cleanup EXIT

# run_instance NAME PORT: a container with its journal on the volume NAME, listening on PORT.
run_instance() {
  "${P[@]}" run -d --name "$1" --network=host "${ULIMITS[@]}" -v "$1:/var/lib/mdr/journal" \
    -e MDR_LISTEN="127.0.0.1:$2" -e MDR_METRICS_LISTEN="127.0.0.1:$(($2 + 100))" \
    -e MDR_SHUTDOWN_GRACE=$GRACE "$IMAGE" >/dev/null 2>>"$work/podman.log"
}

# wait_healthy NAME: the image's own HEALTHCHECK command, run until it passes (30 s at most).
# (Podman cannot start its systemd timers for it here; that complaint goes to podman.log.)
wait_healthy() {
  for _ in $(seq 60); do
    "${P[@]}" healthcheck run "$1" >/dev/null 2>&1 && return 0
    sleep 0.5
  done
  "${P[@]}" logs "$1" | tail -20 >&2
  fail "$1 did not become healthy"
}

drive() { PYTHONPATH=build/release/python /usr/bin/python3 tests/deploy/drive.py "$@"; }

# scrape PORT: an instance's /metrics (its gRPC port + 100), checked by Prometheus' promtool and
# for what the run did; prints "calls journal_writes sessions".
scrape() {
  local text="$work/metrics-$1.txt"
  /usr/bin/python3 -c "import sys, urllib.request; sys.stdout.write(urllib.request.urlopen(sys.argv[1], timeout=10).read().decode())" \
    "http://127.0.0.1:$(($1 + 100))/metrics" > "$text" || fail "no metrics on port $(($1 + 100))"
  promtool check metrics < "$text" >/dev/null 2>&1 || fail "promtool rejects the metrics: $(promtool check metrics < "$text" 2>&1 | head -3)"
  awk '/^mdr_rpc_calls_total\{/ { calls += $NF } /^mdr_journal_write_seconds_count/ { writes += $NF }
       /^mdr_sessions / { sessions = $NF }
       END { if (calls < 1 || writes < 1 || sessions < 1) exit 1; printf "%d %d %d", calls, writes, sessions }' \
    "$text" || fail "metrics on port $(($1 + 100)) do not show the run's calls: $(grep -c '^mdr_' "$text") series"
}

install_tools
cleanup; work=$(mktemp -d)
bash deploy/build.sh release --target mdrd mdrctl mdr_python >/dev/null
base_images
log "building the image"
"${P[@]}" build --format docker --network=host "${ULIMITS[@]}" --pull=never -q -f deploy/Dockerfile -t "$IMAGE" . >/dev/null
size=$("${P[@]}" image inspect "$IMAGE" --format '{{.Size}}')
size_mb=$((size / 1000000))

# 1. One instance.
single=${NAMES[3]}
run_instance "$single" $SINGLE_PORT
wait_healthy "$single"
"${P[@]}" exec "$single" mdrctl run /usr/local/share/mdr/examples/hertz_cattaneo_mindlin.json \
  --server 127.0.0.1:$SINGLE_PORT > "$work/example.txt"
grep -qE '^ +4 .* 15 ' "$work/example.txt" || fail "the example scene did not reach F_x = 15 N: $(cat "$work/example.txt")"
drive load --address 127.0.0.1:$SINGLE_PORT --state "$work/single.json" --sessions 4 --batches 30
"${P[@]}" kill -s KILL "$single" >/dev/null
"${P[@]}" start "$single" >/dev/null 2>>"$work/podman.log"
wait_healthy "$single"
restored=$(drive verify --address 127.0.0.1:$SINGLE_PORT --state "$work/single.json" \
  --mdrd build/release/server/mdrd/mdrd)
log "after kill -9: $restored"
t0=$(date +%s.%N)
"${P[@]}" stop -t $((GRACE + 10)) "$single" >/dev/null
drain_seconds=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }')
code=$("${P[@]}" inspect "$single" --format '{{.State.ExitCode}}')
[ "$code" = 0 ] || fail "mdrd exited with $code after SIGTERM"
# Into a file first: with pipefail, `logs | grep -q` fails when grep's early exit cuts off logs.
"${P[@]}" logs "$single" > "$work/single.log" 2>&1
grep -q "event=draining" "$work/single.log" || fail "no drain in the log after SIGTERM"
awk -v t="$drain_seconds" -v g=$GRACE 'BEGIN { exit !(t <= g + 1) }' ||
  fail "SIGTERM took ${drain_seconds} s (grace $GRACE s)"

# 2. Three instances behind the router.
backends=()
for i in 0 1 2; do
  run_instance "${NAMES[$i]}" "${PORTS[$i]}"
  backends+=("127.0.0.1:${PORTS[$i]}")
done
for i in 0 1 2; do wait_healthy "${NAMES[$i]}"; done
ROUTER_BIND=127.0.0.1:$ROUTER_PORT ROUTER_BACKEND_0=${backends[0]} ROUTER_BACKEND_1=${backends[1]} \
  ROUTER_BACKEND_2=${backends[2]} haproxy -D -p "$work/haproxy.pid" -f deploy/haproxy/haproxy.cfg
router=127.0.0.1:$ROUTER_PORT
list=$(IFS=,; echo "${backends[*]}")
spread=$(drive load --address $router --state "$work/router.json" --sessions 12 --batches 20 --backends "$list")
log "$spread"
# mdrctl (the C++ client) through the router: it creates a session, applies and queries; each
# call reaches the session's instance only because the client routes by x-session-id.
for _ in 1 2 3; do
  build/release/client/mdrctl run examples/fretting_mindlin_deresiewicz.yaml --server $router \
    > "$work/mdrctl.txt" || fail "mdrctl through the router: $(tail -3 "$work/mdrctl.txt")"
done
victim=1
"${P[@]}" kill -s KILL "${NAMES[$victim]}" >/dev/null
during=$(drive more --address $router --state "$work/router.json" --batches 10 --skip-backend $victim --backends "$list")
log "$during"
"${P[@]}" start "${NAMES[$victim]}" >/dev/null 2>>"$work/podman.log"
wait_healthy "${NAMES[$victim]}"
whole=$(drive verify --address $router --state "$work/router.json" --mdrd build/release/server/mdrd/mdrd)
log "through the router after the restart: $whole"
metrics=$(scrape "${PORTS[0]}")
read -r calls writes held <<< "$metrics"
log "metrics of ${NAMES[0]}: $calls calls, $writes journal writes, $held sessions (promtool: valid)"

elapsed=$(( $(date +%s) - started ))
echo "deploy: passed in ${elapsed} s: image ${size_mb} MB built and healthy; one instance: example served, ${restored#drive: } after kill -9, drained in ${drain_seconds} s (grace ${GRACE} s); three behind HAProxy: ${spread#drive: }; one killed: ${during#drive: }; restarted: ${whole#drive: }; metrics of one instance valid for promtool: $calls calls, $writes journal writes, $held sessions"
