#!/usr/bin/env python3
"""Checks the energy balance of the fretting cycles in `mdrctl run SCENE --format json` (a
RunReport, from stdin or a file). For the cycles of every cycles segment:

- the loop's area, recomputed here from the step rows by the trapezoidal rule, is the report's
  tangential_work (to 1e-12), and after the first cycle it equals the dissipated energy to --bound
  (relative; the rule's error, which shrinks with the square of the steps per cycle);
- the steady state repeats: every cycle after the second dissipates what the second did and ends
  at the same F_x (to 1e-9 of the energy and of the largest |F_x|);
- the normal force does not move while the interface frets (to 1e-12 relative).

Usage: check_energy.py [--bound B] [FILE]   (prints one line; exit 1 at the first violation)"""
import argparse
import json
import sys


def fail(message):
    print("FAILED: " + message)
    sys.exit(1)


def state(row, name):
    return float(row["state"].get(name, 0))  # proto3 JSON leaves zeros out


def check_segment(rows, cycles, bound):
    """rows: the segment's step rows preceded by the row before it; cycles: its CycleEnergy."""
    per_cycle = (len(rows) - 1) // len(cycles)
    load = state(rows[0], "normal_force")
    fx_max = max(abs(state(r, "tangential_force")) for r in rows)
    worst = 0.0
    for c, cycle in enumerate(cycles):
        area = 0.0
        for k in range(c * per_cycle + 1, (c + 1) * per_cycle + 1):
            before, after = rows[k - 1], rows[k]
            if abs(state(after, "normal_force") - load) > 1e-12 * load:
                fail("step %s: F_N moved from %.17g N" % (after["step"], load))
            area += 0.5 * (state(before, "tangential_force") + state(after, "tangential_force")) * \
                (state(after, "tangential_displacement") - state(before, "tangential_displacement"))
        work = float(cycle.get("tangential_work", 0))
        dissipated = float(cycle.get("dissipated_energy", 0))
        if abs(area - work) > 1e-12 * abs(work):
            fail("cycle %d: the loop's area %.17g J is not the reported work %.17g J" %
                 (c + 1, area, work))
        if c == 0:
            continue
        difference = abs(area - dissipated) / dissipated
        worst = max(worst, difference)
        if difference > bound:
            fail("cycle %d: loop area %.10g J, dissipated %.10g J: %.2e > %.0e" %
                 (c + 1, area, dissipated, difference, bound))
        steady = float(cycles[1]["dissipated_energy"])
        if abs(dissipated - steady) > 1e-9 * steady:
            fail("cycle %d dissipated %.10g J, cycle 2 %.10g J: not steady" %
                 (c + 1, dissipated, steady))
        end = state(rows[(c + 1) * per_cycle], "tangential_force")
        end_2 = state(rows[2 * per_cycle], "tangential_force")
        if abs(end - end_2) > 1e-9 * fx_max:
            fail("cycle %d ends at F_x = %.10g N, cycle 2 at %.10g N" % (c + 1, end, end_2))
    print("ok: %s: %d cycles of %d steps at F_N = %.10g N; after the first, |loop area - "
          "dissipated| / dissipated <= %.2e (bound %.0e); cycles 2 to %d dissipate %.10g J each" %
          (cycles[0]["origin"], len(cycles), per_cycle, load, worst, bound, len(cycles),
           float(cycles[1]["dissipated_energy"])))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bound", type=float, default=1e-3,
                        help="relative bound on |loop area - dissipated energy|")
    parser.add_argument("file", nargs="?")
    args = parser.parse_args()
    report = json.load(open(args.file) if args.file else sys.stdin)
    rows = report["rows"]
    origins = sorted({c["origin"] for c in report.get("cycle_energies", [])})
    if not origins:
        fail("the run has no cycles")
    for origin in origins:
        cycles = [c for c in report["cycle_energies"] if c["origin"] == origin]
        if len(cycles) < 3:
            fail("%s: need three cycles to see a steady one repeat, got %d" % (origin, len(cycles)))
        first = next(i for i, r in enumerate(rows) if r["origin"] == origin)
        if first == 0:
            fail("%s: the cycles start from the unloaded state" % origin)
        segment = [rows[first - 1]] + [r for r in rows[first:] if r["origin"] == origin]
        check_segment(segment, cycles, args.bound)


if __name__ == "__main__":
    main()
