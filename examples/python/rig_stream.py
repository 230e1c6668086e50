#!/usr/bin/python3
"""A test-rig loop: streams measured tangential displacements from a CSV file (column
displacement_m, one row per sample) to a Hertz contact held at a normal force, and writes the
forces back as CSV. Usage: rig_stream.py IN.csv OUT.csv [normal force N, default 100]."""
import csv
import sys

import mdr

source, target = sys.argv[1], sys.argv[2]
normal_force = float(sys.argv[3]) if len(sys.argv) > 3 else 100.0
scene = {"sphere": {"radius": 0.01}, "friction": 0.3,
         "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                          "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}


def samples():
    """The rig's displacements, read only as fast as the service answers (back-pressure)."""
    with open(source, newline="") as stream:
        for row in csv.DictReader(stream):
            yield {"displacement": float(row["displacement_m"])}


with mdr.Client.embedded() as client, client.session(scene) as s, \
        open(target, "w", newline="") as out:
    s.apply({"normal_force": normal_force})
    writer = csv.writer(out)
    writer.writerow(["displacement_m", "tangential_force_N", "normal_force_N",
                     "dissipated_energy_J"])
    count = 0
    for result in s.stream(samples(), window=32):
        state = result.state
        writer.writerow([repr(state.tangential_displacement), repr(state.tangential_force),
                         repr(state.normal_force), repr(state.dissipated_energy)])
        count += 1
print(f"{target}: {count} samples, dissipated {state.dissipated_energy:.6g} J")
