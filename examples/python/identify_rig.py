#!/usr/bin/python3
"""Identifies a contact and its test rig from fretting loops (docs/analysis.md). The measurements
are made with the exact engine: the steel sphere H1 (R = 10 mm on steel, mu = 0.3) behind a rig of
2e-8 m/N is cycled by its actuator at +-2 um, three cycles of 200 samples at each of 30, 100 and
300 N, with 0.05 N of Gaussian noise on the recorded force and 5 nm on the recorded displacement
(seed 24). From a start 20-30 % off, FitLoops finds mu, E* and the rig's compliance with 95 %
intervals, each run's noise and whether the model explains it; then the 100 N run's cycles are
analysed with the identified rig (its contact figures) and classified against the fitted scene's
onset of gross slip, and a fretting map places the runs. Usage: identify_rig.py"""
import numpy as np

import mdr

TRUTH = {"sphere": {"radius": 0.01}, "friction": 0.3,
         "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                          "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3},
         "rig": {"tangential_compliance": 2e-8}}
LOADS = (30.0, 100.0, 300.0)  # N
AMPLITUDE, CYCLES, PER_CYCLE, NOISE = 2e-6, 3, 200, 0.05  # m, -, -, N
DISPLACEMENT_NOISE = 5e-9  # m
E_STAR = 210e9 / (2 * (1 - 0.3**2))  # Pa
rng = np.random.default_rng(24)


def measure(client, normal_force):
    """The actuator's position (m) and the noisy tangential force (N) from the pressed state on."""
    with client.session(TRUTH) as s:
        s.apply({"normal_force": normal_force})
        k = np.arange(1, CYCLES * PER_CYCLE + 1)
        run = s.apply([{"displacement": u}
                       for u in AMPLITUDE * np.sin(2 * np.pi * k / PER_CYCLE)])
    u = np.r_[0.0, run.actuator_displacement]
    f = np.r_[0.0, run.tangential_force] + rng.normal(0, NOISE, u.size)
    return u + rng.normal(0, DISPLACEMENT_NOISE, u.size), f


with mdr.Client.embedded() as client:
    runs = {load: measure(client, load) for load in LOADS}
    start = dict(TRUTH, friction=0.38, rig={"tangential_compliance": 1.5e-8})
    fit = client.fit_loops(
        start, [(u, f, load) for load, (u, f) in runs.items()],
        {"friction": {"lower": 0.05, "upper": 1},
         "effective_modulus": {"lower": 1e10, "upper": 1e12, "initial": 0.75 * E_STAR},
         "rig_compliance": {"lower": 1e-9, "upper": 1e-7}},
        progress=lambda i, rms, values: print(f"  iteration {i}: residual rms {rms:.4g} N"))
    print(f"fit: {fit.iterations} iterations, residual rms {fit.residual_rms:.4g} N "
          f"(noise {NOISE} N), condition number {fit.condition_number:.3g}")
    for name in fit.names:
        e = fit[name]
        verdict = "" if e.identified else ", not identified"
        print(f"{name:<17} = {e.value:.6g} +- {e.standard_error:.2g} "
              f"(95 %: [{e.lower_95:.6g}, {e.upper_95:.6g}]{verdict})")
    print(f"guessed rig compliance from the loads: {fit.guessed_rig_compliance:.4g} m/N")
    for k, load in enumerate(LOADS):
        verdict = "misfit" if fit.sets.misfit[k] else "adequate"
        print(f"{load:g} N run: noise {fit.sets.displacement_noise[k]:.3g} m and "
              f"{fit.sets.force_noise[k]:.3g} N, reduced chi-square "
              f"{fit.sets.reduced_chi_square[k]:.3f}: {verdict}")
    for note in fit.notes:
        print(f"note: {note}")

    u, f = runs[100.0]
    r = client.analyze_loops(u, f, 100.0, scene=fit.fitted_scene,
                             rig_compliance=fit["rig_compliance"].value)
    print(f"100 N run: {len(r)} cycles, reversal threshold {r.reversal_threshold:.3g} m")
    for k in range(len(r)):
        print(f"cycle {k + 1}: Q* = {r.force_amplitude[k]:.4f} N, "
              f"Ed = {r.dissipated_energy[k]:.4g} J, "
              f"delta* = {r.displacement_amplitude[k] * 1e6:.4f} um "
              f"(contact {r.contact.displacement_amplitude[k] * 1e6:.4f} um), "
              f"A = {r.energy_ratio[k]:.3f} (contact {r.contact.energy_ratio[k]:.3f}), "
              f"C = {r.system_free_ratio[k]:.3f}, {r.regime[k]}")

    m = client.fretting_map(fit.fitted_scene, LOADS, [1.0])
    for load, onset in zip(LOADS, m.onset.actuator_amplitude):
        where = "gross slip" if AMPLITUDE >= onset else "partial slip"
        print(f"{load:g} N: onset of gross slip at +-{onset * 1e6:.3f} um: the +-2 um run is "
              f"{where}")
