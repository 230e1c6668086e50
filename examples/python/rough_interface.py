#!/usr/bin/python3
"""A rough steel interface from Python (issue #17): 400 Hertz asperities (summit radius 0.1 mm,
Gaussian summit heights with sigma = 1 um, seed 2026) of steel on steel, mu = 0.3, share one rigid
motion. A bolt-like normal load is applied as one exact force target of the whole interface; then
the tangential displacement runs fretting cycles 0 -> +A -> -A -> 0 with the load held. Prints,
per cycle, the dissipated energy beside the loop's area (the work of F_x, trapezoidal rule over
the steps) and the asperities in partial and gross slip at the cycle's end. From the second cycle
on the cycles repeat and the two energies agree to the rule's error.
Usage: rough_interface.py [CYCLES] (default 3)."""
import sys

import numpy as np

import mdr

CYCLES = int(sys.argv[1]) if len(sys.argv) > 1 else 3
LOAD = 700.0             # N, about 1.75 N per asperity, as examples/rough_interface (3000, 5 kN)
AMPLITUDE = 0.17e-6      # m, about half the displacement at which the whole interface slides
STEPS_PER_QUARTER = 40

steel_on_steel = {"sphere": {"radius": 1e-4}, "friction": 0.3,
                  "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                                   "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
scene = mdr.interface_scene(steel_on_steel, "shared_motion", generated={
    "count": 400, "height_distribution": "HEIGHT_DISTRIBUTION_GAUSSIAN", "height_scale": 1e-6,
    "seed": 2026})

quarter = np.linspace(0, 1, STEPS_PER_QUARTER + 1)[1:]
half = np.linspace(0, 1, 2 * STEPS_PER_QUARTER + 1)[1:]
cycle = AMPLITUDE * np.concatenate([quarter, 1 - 2 * half, quarter - 1])  # 0 -> +A -> -A -> 0

with mdr.Client.embedded() as client, client.session(scene) as interface:
    def totals_of():
        return interface.query(["interface.totals"]).interface.totals

    loaded = interface.apply({"normal_force": LOAD})
    start = totals_of()
    print(f"{start.in_contact} of 400 asperities in contact at F_N = {start.normal_force:.6g} N, "
          f"approach {loaded.state.depth * 1e6:.4f} um")
    u, force, energy = [0.0], [start.tangential_force], start.dissipated_energy
    for k in range(1, CYCLES + 1):
        steps = interface.apply([{"displacement": value} for value in cycle])
        cycle_u = np.concatenate([[u[-1]], steps.tangential_displacement])
        cycle_force = np.concatenate([[force[-1]], steps.tangential_force])
        loop_area = float(np.sum(0.5 * (cycle_force[1:] + cycle_force[:-1]) * np.diff(cycle_u)))
        totals = totals_of()
        dissipated = totals.dissipated_energy - energy
        print(f"cycle {k}: dissipated {dissipated:.8e} J, loop area {loop_area:.8e} J, "
              f"partial slip {totals.partial_slip}, gross slip {totals.gross_slip}, "
              f"F_N {totals.normal_force:.12g} N")
        u, force, energy = list(cycle_u), list(cycle_force), totals.dissipated_energy
    bytes_per_contact = interface.query(["interface.memory_bytes"]).interface.memory_bytes / 400
    print(f"memory: {bytes_per_contact:.0f} bytes per asperity")
