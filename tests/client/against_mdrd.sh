#!/usr/bin/env bash
# mdrctl against a real mdrd started here on a free port: run (a single contact and a contact
# list), every session subcommand, apply as a batch and as a stream, query, export and import (the
# imported session continues identically), a torsional session.
set -euo pipefail
mdrd=$1
mdrctl=$2
examples=$3
dir=$(mktemp -d)
: >"$dir/mdrd.log"
"$mdrd" --listen 127.0.0.1:0 --log-level info --no-journal >"$dir/mdrd.log" 2>&1 &
mdrd_pid=$!
trap 'kill $mdrd_pid 2>/dev/null || true; wait $mdrd_pid 2>/dev/null || true; rm -rf "$dir"' EXIT
port=""
for _ in $(seq 100); do
  port=$(sed -n 's/.*event=serving .*port=\([0-9]*\).*/\1/p' "$dir/mdrd.log")
  [[ -n $port ]] && break
  sleep 0.1
done
[[ -n $port ]] || { echo "mdrd did not start:"; cat "$dir/mdrd.log"; exit 1; }
ctl() { "$mdrctl" "$@" --server "127.0.0.1:$port"; }
expect() {  # expect REGEX TEXT
  grep -Eq -- "$1" <<<"$2" || { echo "expected /$1/ in:"; echo "$2"; exit 1; }
  echo "ok: $1"
}

out=$(ctl run "$examples/fretting_mindlin_deresiewicz.yaml")
expect '^ +2 +path\[1\] +1\.07238163[56]e-06 +1\.07[123][0-9]*e-06$' "$out"

# An interface scene: per-step totals and counts, one contact's state and the slip histogram.
out=$(ctl run "$examples/contact_list.yaml" --contact-index 0 --histogram-bins 2 --format csv)
expect '^29,300,(30|29\.99999999[0-9]*|30\.00000000[0-9]*),[0-9.e-]+,3,2,0$' "$out"
expect '^29,3\.482909884e-06,4\.694965814e-07,100,15,0\.0001866255578,' "$out"
expect '^step,0-0\.5,0\.5-1$' "$out"

out=$(ctl session create "$examples/contact_list.yaml" --id list)
out=$(ctl apply list '{depth_increment: 0, contact_normal_values: [3.4829098839e-6, 0, 1e-6]}')
expect '^ +1 +0 +0 +[0-9.e-]+ +0 +0' "$out"
out=$(ctl query list --mask interface.totals,interface.slip_histogram --histogram-bins 3)
expect '^interface\.totals\.in_contact +2$' "$out"
expect '^interface\.slip_histogram\[0\] +2$' "$out"
out=$(ctl query list --mask state.normal_force --contact-index 0)
expect '^state\.normal_force +100$' "$out"
ctl session delete list >/dev/null

out=$(ctl session create "$examples/hertz_cattaneo_mindlin.json" --id h1)
expect '^name +sessions/h1$' "$out"
out=$(ctl apply h1 '{normal_force: 100}' '{tangential_force: 15}')
expect '^ +2 +3\.482909884e-06 +4\.694965814e-07 +100 +15 ' "$out"
out=$(ctl apply h1 --stream '{tangential_force: 10}' '{tangential_force: 15}' --format csv)
expect '^2,3\.482909884e-06,[0-9.e-]+,100,15,' "$out"
out=$(ctl session get sessions/h1)
expect '^state\.applied_steps +4$' "$out"
out=$(ctl session list --format csv)
expect '^4,sessions/h1,100,15,' "$out"
out=$(ctl query h1 --mask state.tangential_force,energy --format json)
expect '"tangential_force": (15(\.0+[0-9]?)?|14\.9999999999999[0-9]*)[,}\n]?' "$out"  # 15 N to round-off
expect '"dissipated_energy": [0-9]' "$out"

ctl export h1 -o "$dir/h1.json"
out=$(ctl import "$dir/h1.json" --id h1-copy)
expect '^name +sessions/h1-copy$' "$out"
a=$(ctl apply h1 '{tangential_force: -15}' --format json)
b=$(ctl apply h1-copy '{tangential_force: -15}' --format json)
[[ "$(grep -v compute_seconds <<<"$a")" == "$(grep -v compute_seconds <<<"$b")" ]] ||
  { echo "imported session differs:"; diff <(echo "$a") <(echo "$b"); exit 1; }
echo "ok: imported session continues identically"

# A torsional session: the run's loop energy, apply's twist and moment columns, the torsion
# outputs, and a tangential step refused naming its field.
out=$(ctl run "$examples/torsional_fretting.yaml")
expect '^ +2 +path\[1\] +1\.81731961[0-9]e-05 +1\.81[67][0-9]*e-05$' "$out"
out=$(ctl session create "$examples/torsional_fretting.yaml" --id twisted)
out=$(ctl apply twisted '{normal_force: 100}' '{twisting_moment: 0.0029593735330}')
expect '^ +2 +3\.482909884e-06 +100 +0\.0001866255578 +0\.004814125[0-9]* +0\.002959373533 ' "$out"
out=$(ctl query twisted --mask torsion.stiffness,torsion.slip_intervals)
expect '^torsion\.stiffness_negative +1\.4(0000000[0-9]*|e\+00)?$' "$out"  # 16 G_t a^3 / 3
expect '^torsion\.slip_intervals\[0\]\.r_begin +9\.33127[0-9]*e-05$' "$out"  # a / 2
if err=$(ctl apply twisted '{displacement: 1e-7}' 2>&1); then echo "a tangential step succeeded"; exit 1; fi
expect 'steps\[0\]\.displacement: must be unset in a torsional session' "$err"

out=$(ctl session delete h1)
expect '^deleted sessions/h1$' "$out"
if err=$(ctl session get h1 2>&1); then echo "get after delete succeeded"; exit 1; fi
expect '^mdrctl: .*sessions/h1' "$err"
out=$(ctl session list)
expect 'sessions/h1-copy' "$out"
