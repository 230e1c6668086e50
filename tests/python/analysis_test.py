#!/usr/bin/python3
"""The analysis of measured loops (issue #24; docs/analysis.md) through the Python package mdr,
against a real mdrd started by the package (Client.embedded): loops made with a session through a
rig, analysed (Client.analyze_loops), fitted (fit_loops), and the exact fretting map and backbone
checked against the closed forms for a Hertz sphere; errors naming their field. The package is
imported from the build tree (PYTHONPATH=<build>/python).

Usage: analysis_test.py --mdrd PATH [--source-dir REPO (default: this file's)]
"""
import argparse
import math
import os
import re
import subprocess
import sys
import unittest
from typing import NamedTuple

import grpc
import numpy as np

import mdr
from mdr.v1 import analysis_pb2

ARGS = None

# Reference vector H1 (steel sphere R = 10 mm on a steel flat, mu = 0.3) behind a tangential rig
# of 2e-8 m/N (50 N/um), as examples/fretting_rig.yaml.
MU, RADIUS, C_T = 0.3, 0.01, 2e-8
H1 = {"sphere": {"radius": RADIUS}, "friction": MU,
      "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                       "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
RIG = dict(H1, rig={"tangential_compliance": C_T})
E_STAR = 210e9 / (2 * (1 - 0.3**2))
G_STAR = 1 / (2 * (2 - 0.3) / (4 * 210e9 / (2 * 1.3)))  # the MDR's G*: 2 G* a is k_x
KAPPA = E_STAR / G_STAR
# The actuator amplitude at which the contact runs +-15 N at 100 N (fretting_rig.yaml).
AMPLITUDE = 7.6949658143e-7
PER_CYCLE, CYCLES = 300, 4
# Sample indices of the reversals: the pressed state is sample 0, then u = A sin(2 pi k / 300).
REVERSALS = 75 + 150 * np.arange(2 * CYCLES)
LABELLED_CONTACT = ("force_amplitude", "force_offset", "dissipated_energy", "half_opening",
                    "system_free_ratio", "normal_force", "friction_coefficient",
                    "energy_friction_coefficient")
LABELLED_RIG = ("displacement_amplitude", "energy_ratio", "sliding_ratio", "secant_stiffness",
                "stiffness_increasing", "stiffness_decreasing")


def hertz_depth(normal_force):
    return (3 * normal_force / (4 * E_STAR * math.sqrt(RADIUS))) ** (2 / 3)


class Loops(NamedTuple):
    """What the rig records per step (from the pressed state on) and the engine's own values."""
    actuator: np.ndarray  # m
    force: np.ndarray  # N
    contact: np.ndarray  # the contact's displacement, m
    energy: np.ndarray  # dissipated since the start, J


def make_loops(client, normal_force, amplitude, scene=RIG):
    """Press to normal_force, then CYCLES sinusoidal cycles of the actuator, PER_CYCLE samples
    each."""
    with client.session(scene) as s:
        pressed = s.apply({"normal_force": normal_force})
        k = np.arange(1, CYCLES * PER_CYCLE + 1)
        run = s.apply([{"displacement": u} for u in amplitude * np.sin(2 * np.pi * k / PER_CYCLE)])
    first = pressed.state
    return Loops(np.r_[first.actuator_displacement, run.actuator_displacement],
                 np.r_[first.tangential_force, run.tangential_force],
                 np.r_[first.tangential_displacement, run.tangential_displacement],
                 np.r_[first.dissipated_energy, run.dissipated_energy])


class AnalysisTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.client = mdr.Client.embedded(ARGS.mdrd)
        cls.loops = make_loops(cls.client, 100.0, AMPLITUDE)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()

    def assertRelative(self, actual, expected, tolerance, message=None):
        np.testing.assert_allclose(actual, expected, rtol=tolerance, atol=0, err_msg=message or "")

    # AnalyzeLoops.
    def test_cycles_of_loops_through_a_rig(self):
        loops = self.loops
        time = 1e-3 * np.arange(loops.actuator.size)
        r = self.client.analyze_loops(loops.actuator, loops.force, 100.0, time,
                                      rig_compliance=C_T)
        self.assertIsInstance(r, mdr.LoopAnalysisResult)
        np.testing.assert_array_equal(r.reversals, REVERSALS)
        self.assertEqual(len(r), CYCLES - 1)  # from the first upper reversal to the last
        self.assertEqual(r.first_sample.dtype, np.int64)
        np.testing.assert_array_equal(r.first_sample, REVERSALS[0:6:2])
        np.testing.assert_array_equal(r.lower_reversal, REVERSALS[1:6:2])
        np.testing.assert_array_equal(r.last_sample, REVERSALS[2:7:2])
        np.testing.assert_array_equal(r.start_time, time[r.first_sample])
        self.assertAlmostEqual(r.reversal_threshold / (0.05 * 2 * AMPLITUDE), 1, delta=1e-12)
        for k, (first, last) in enumerate(zip(r.first_sample, r.last_sample)):
            cycle = slice(first, last + 1)
            self.assertRelative(r.force_amplitude[k], np.abs(loops.force[cycle]).max(), 1e-12)
            self.assertRelative(r.contact.displacement_amplitude[k],
                                np.abs(loops.contact[cycle]).max(), 1e-9)
            # The trapezoidal loop area against the engine's dissipation over the cycle.
            engine = loops.energy[last] - loops.energy[first]
            self.assertRelative(r.dissipated_energy[k], engine, 1e-3)
        self.assertLess(np.abs(r.force_offset).max(), 1e-9 * r.force_amplitude.max())
        self.assertTrue(np.all(r.dissipated_energy > 0))
        self.assertRelative(r.dissipated_energy, r.dissipated_energy[0], 1e-9)  # steady cycles
        self.assertRelative(r.force_amplitude, 15.0, 1e-9)
        self.assertRelative(r.displacement_amplitude, AMPLITUDE, 1e-12)
        np.testing.assert_array_equal(r.normal_force, 100.0)
        self.assertRelative(r.friction_coefficient, r.force_amplitude / 100, 1e-15)
        self.assertTrue(np.all(r.contact.secant_stiffness > 1.5 * r.secant_stiffness))
        self.assertFalse(r.flags.not_closed.any())
        self.assertEqual(r.flags.not_closed.dtype, bool)
        self.assertLess(r.flags.closure_error.max(), 1e-9)
        self.assertIsNone(r.regime)  # no scene
        self.assertIsNone(r.onset_system_free_ratio)
        self.assertEqual(r.friction_drift, r.raw.friction_drift)
        self.assertAlmostEqual(r.friction_drift, 0, delta=1e-9)
        self.assertFalse(r.friction_drifts)
        self.assertEqual(len(r.raw.cycles), 3)

    def test_a_run_of_a_million_samples_fits_the_embedded_servers_message_limit(self):
        # 24 MB of samples: past mdrd's default limit (4 MiB), within the embedded server's.
        per_cycle, cycles = 500, 2000
        k = np.arange(per_cycle * cycles + 1)
        u = AMPLITUDE * np.sin(2 * np.pi * k / per_cycle)
        f = 15.0 * np.tanh(np.sin(2 * np.pi * k / per_cycle - 0.3))
        r = self.client.analyze_loops(u, f, 100.0, 1e-4 * k)
        self.assertEqual(len(r), cycles - 1)
        self.assertRelative(r.displacement_amplitude, AMPLITUDE, 1e-9)

    def test_figures_labelled_contact_are_the_rig_free_ones(self):
        loops = self.loops
        through = self.client.analyze_loops(loops.actuator, loops.force, 100.0,
                                            rig_compliance=C_T)
        alone = self.client.analyze_loops(loops.contact, loops.force, 100.0)
        self.assertIsNone(alone.contact)  # no rig_compliance: no contact figures
        for name in LABELLED_CONTACT:
            self.assertEqual(through.measures[name], "contact", name)
            self.assertRelative(getattr(through, name), getattr(alone, name), 1e-8, name)
        for name in LABELLED_RIG:
            self.assertEqual(through.measures[name], "contact+rig", name)
            # The rig is softer than the contact: delta* at least doubles, slopes fall.
            ratio = getattr(through, name) / getattr(alone, name)
            self.assertTrue(np.all(np.abs(ratio - 1) > 0.3), (name, ratio))
            # The contact figures recomputed from u - C_t F_x are the rig-free ones.
            self.assertRelative(getattr(through.contact, name), getattr(alone, name), 1e-6, name)
        contact_names = {name for name in through.measures if name.startswith("contact.")}
        self.assertEqual(contact_names, {"contact." + name for name in through.contact})
        self.assertTrue(all(through.measures[name] == "contact" for name in contact_names))

    def test_regimes_against_the_scenes_onset(self):
        sliding = make_loops(self.client, 100.0, 4e-6)  # beyond the onset's 1.87 um
        onset_c = 0.2 / (2 ** (1 / 3) - 1)  # A_t / B_t of a sphere
        for loops, regime in ((self.loops, "partial_slip"), (sliding, "gross_slip")):
            # A measured normal force column, one value per sample, gives P.
            r = self.client.analyze_loops(loops.actuator, loops.force,
                                          np.full(loops.force.size, 100.0), scene=RIG)
            self.assertEqual(r.regime.tolist(), [regime] * 3)
            self.assertRelative(r.onset_system_free_ratio, onset_c, 1e-9)
            np.testing.assert_array_equal(r.normal_force, 100.0)
        self.assertRelative(r.friction_coefficient, MU, 1e-9)  # the plateau of gross slip
        # A sensor that cannot resolve loops this narrow calls them stuck.
        stuck = self.client.analyze_loops(self.loops.actuator, self.loops.force, 100.0,
                                          scene=RIG, displacement_resolution=1e-3)
        self.assertEqual(stuck.regime.tolist(), ["sticking"] * 3)

    # FitLoops.
    def test_fit_recovers_friction_modulus_and_rig_from_two_loads(self):
        sets = [make_loops(self.client, 50.0, 8e-7), make_loops(self.client, 200.0, 1.5e-6)]
        start = dict(H1, friction=1.27 * MU, rig={"tangential_compliance": 0.75 * C_T})
        calls = []
        fit = self.client.fit_loops(
            start, [(sets[0].actuator, sets[0].force, 50.0),
                    {"displacement": sets[1].actuator.tolist(), "tangential_force": sets[1].force,
                     "normal_force": 200}],
            {"friction": {"lower": 0.05, "upper": 1},
             "rig_compliance": {"lower": 1e-9, "upper": 1e-7},
             "effective_modulus": {"lower": 1e10, "upper": 1e12, "initial": 0.75 * E_STAR}},
            progress=lambda *args: calls.append(args))
        self.assertIsInstance(fit, mdr.LoopFitResult)
        self.assertEqual(fit.names, ("friction", "rig_compliance", "effective_modulus"))
        truth = np.array([MU, C_T, E_STAR])
        self.assertRelative(fit.value, truth, 1e-6)
        self.assertEqual(fit.values, dict(zip(fit.names, fit.value)))
        self.assertEqual(fit["rig_compliance"].value, fit.value[1])
        self.assertTrue(fit["friction"].identified)
        self.assertTrue(fit.identified.all() and fit.all_identified and fit.converged)
        self.assertTrue(np.all(fit.lower_95 <= fit.value) and np.all(fit.value <= fit.upper_95))
        self.assertTrue(np.all(fit.standard_error < 1e-6 * truth))
        self.assertLess(fit.residual_rms, 1e-8)
        # Residuals count from each set's second reversal (burn-in 2) on.
        self.assertEqual(fit.residuals, 2 * (CYCLES * PER_CYCLE + 1 - REVERSALS[1]))
        self.assertEqual(fit.correlation.shape, (3, 3))
        np.testing.assert_allclose(fit.correlation, fit.correlation.T, rtol=0, atol=1e-12)
        np.testing.assert_allclose(np.diag(fit.correlation), 1, rtol=0, atol=1e-12)
        self.assertTrue(np.all(np.abs(fit.correlation) <= 1 + 1e-12))
        self.assertEqual(fit.weakest_combination.shape, (3,))
        self.assertLess(fit.condition_number, 1e8)
        self.assertEqual(fit.notes, list(fit.raw.notes))
        self.assertRelative(fit.fitted_scene.friction, MU, 1e-6)
        self.assertRelative(fit.fitted_scene.rig.tangential_compliance, C_T, 1e-6)
        self.assertRelative(fit.fitted_scene.elastic_pair.youngs_modulus_1, 210e9, 1e-6)
        self.assertEqual(fit.fitted_scene.sphere.radius, RADIUS)
        # The practitioners' guess from the two loads: a starting value, within 15 %; a line
        # through two points leaves no residual for its error, which the server reports as 0.
        self.assertRelative(fit.guessed_rig_compliance, C_T, 0.15)
        self.assertIsNone(fit.guessed_rig_compliance_error)  # two loads: no residual left
        # Progress: iterations in order, values by name, the last one the result's.
        self.assertGreaterEqual(len(calls), 2)
        iterations = [iteration for iteration, _, _ in calls]
        self.assertEqual(iterations, sorted(set(iterations)))
        self.assertEqual(iterations[-1], fit.iterations)
        self.assertLess(calls[-1][1], 1e-3 * calls[0][1])
        self.assertEqual(list(calls[-1][2]), list(fit.names))
        self.assertEqual(list(calls[-1][2].values()), fit.value.tolist())
        # One load alone: no compliance guess.
        alone = self.client.fit_loops(start, [(sets[0].actuator, sets[0].force, 50.0)],
                                      [{"parameter": "friction", "lower": 0.05, "upper": 1}])
        self.assertIsNone(alone.guessed_rig_compliance)
        self.assertIsNone(alone.guessed_rig_compliance_error)
        self.assertEqual(alone.correlation.shape, (1, 1))

    def test_fit_with_a_normal_force_column_nuisances_and_models(self):
        """A measured normal-force column replayed as measured, a force offset per set, the
        sets' adequacy, the nuisances with their effects and the models sample by sample."""
        sets = [make_loops(self.client, 50.0, 8e-7), make_loops(self.client, 200.0, 1.5e-6)]
        offset = 0.3  # N, the force sensor's zero
        columns = [{"displacement": loops.actuator, "tangential_force": loops.force + offset,
                    "normal_force": np.full(loops.actuator.size, load),
                    "declared_normal_force": load}
                   for loops, load in zip(sets, (50.0, 200.0))]
        start = dict(H1, friction=1.27 * MU, rig={"tangential_compliance": 0.75 * C_T})
        fit = self.client.fit_loops(
            start, columns, {"friction": {"lower": 0.05, "upper": 1},
                             "rig_compliance": {"lower": 1e-9, "upper": 1e-7}},
            nuisances=["force_offset"], burn_in_reversals=0, include_models=True)
        self.assertRelative(fit.value, [MU, C_T], 1e-6)
        self.assertEqual(len(fit.interval), 2)  # each the larger of Wald's and the sandwich's
        self.assertTrue(set(fit.interval) <= {"wald", "half_cycle_sandwich"}, fit.interval)
        self.assertTrue(fit.adequate)
        self.assertEqual(fit.sets.normal_force_measured.tolist(), [True, True])
        self.assertEqual(fit.sets.load_mismatch.tolist(), [False, False])
        self.assertEqual(fit.sets.misfit.tolist(), [False, False])
        self.assertEqual(fit.sets.reduced_chi_square.shape, (2,))
        offsets = [n for n in fit.nuisances if n.name == "force_offset"]
        self.assertEqual([n.set for n in offsets], [0, 1])
        for n in offsets:
            self.assertAlmostEqual(n.value, offset, delta=1e-6)
            self.assertEqual(set(n.effect), {"friction", "rig_compliance"})
        self.assertEqual(len([n for n in fit.nuisances if n.name == "displacement_offset"]), 2)
        self.assertEqual(len(fit.models), 2)
        for model, loops in zip(fit.models, sets):
            self.assertEqual(model.predicted_force.shape, loops.force.shape)
            np.testing.assert_allclose(model.predicted_force, loops.force + offset, rtol=0,
                                       atol=1e-6)
        # A declared load the column contradicts: a mismatch, nothing identified.
        wrong = dict(columns[0], declared_normal_force=80.0)
        mismatch = self.client.fit_loops(start, [wrong, columns[1]],
                                         {"friction": {"lower": 0.05, "upper": 1}})
        self.assertEqual(mismatch.sets.load_mismatch.tolist(), [True, False])
        self.assertFalse(mismatch.adequate or mismatch.all_identified)
        self.assertIn("declared normal force 80 N", " ".join(mismatch.notes))

    def test_an_exception_in_progress_stops_the_fit_and_propagates(self):
        class Stop(Exception):
            pass

        def progress(iteration, rms, values):
            raise Stop(iteration)

        loops = self.loops
        with self.assertRaises(Stop):
            self.client.fit_loops(dict(RIG, friction=0.4), [(loops.actuator, loops.force, 100)],
                                  {"friction": {"lower": 0.1, "upper": 1}}, progress=progress)
        backbone = self.client.backbone(RIG, 100, [10.0])  # the client still works
        self.assertEqual(backbone.force_amplitude.shape, (1,))

    def test_calls_are_retried_on_unavailable_fit_loops_only_before_its_first_message(self):
        client = mdr.Client(self.client.address, max_attempts=3, initial_backoff=0.001)
        real, calls, failures = client._stub, [], {}

        class Unavailable(grpc.RpcError):
            def code(self):
                return grpc.StatusCode.UNAVAILABLE

            def details(self):
                return "try again"

            def trailing_metadata(self):
                return ()

        class FailingStream:
            """A FitLoops stream that sends `messages`, then fails with UNAVAILABLE."""
            def __init__(self, messages):
                self.messages = messages

            def __iter__(self):
                yield from self.messages
                raise Unavailable()

            def cancel(self):
                pass

        class FlakyStub:
            def __getattr__(self, method):
                def call(request, **kwargs):
                    calls.append(method)
                    if calls.count(method) == 1:
                        if method != "FitLoops":
                            raise Unavailable()
                        return FailingStream(failures.get("first", []))
                    return getattr(real, method)(request, **kwargs)
                return call

        client._stub = FlakyStub()
        loops, free = self.loops, {"friction": {"lower": 0.1, "upper": 1}}
        try:
            self.assertEqual(len(client.analyze_loops(loops.actuator, loops.force)), 3)
            self.assertEqual(len(client.backbone(RIG, 100, [10]).damping_ratio), 1)
            self.assertEqual(len(client.fretting_map(RIG, 100, [0.5]).regime), 1)
            self.assertEqual(calls.count("AnalyzeLoops"), 2)
            self.assertEqual(calls.count("Backbone"), 2)
            self.assertEqual(calls.count("FrettingMap"), 2)
            fit = client.fit_loops(dict(RIG, friction=0.4), [(loops.actuator, loops.force, 100)],
                                   free)
            self.assertEqual(calls.count("FitLoops"), 2)
            self.assertRelative(fit.value, [MU], 1e-6)
            # After a message the fit is not repeated: the caller has seen its progress.
            calls.clear()
            progress = analysis_pb2.FitLoopsResponse()
            progress.progress.iteration = 1
            progress.progress.values.append(0.35)
            failures["first"] = [progress]
            seen = []
            with self.assertRaises(mdr.MdrError) as raised:
                client.fit_loops(RIG, [(loops.actuator, loops.force, 100)], free,
                                 progress=lambda *args: seen.append(args))
            self.assertEqual(raised.exception.code, grpc.StatusCode.UNAVAILABLE)
            self.assertEqual(calls.count("FitLoops"), 1)
            self.assertEqual(seen, [(1, 0.0, {"friction": 0.35})])
        finally:
            client.close()

    # FrettingMap and Backbone.
    def test_fretting_map_shapes_regimes_and_onsets(self):
        loads = np.array([50.0, 100.0, 200.0])
        relative = np.array([0.25, 0.5, 0.9, 1.1, 2.0, 4.0])
        m = self.client.fretting_map(RIG, loads, relative)
        self.assertIsInstance(m, mdr.FrettingMapResult)
        np.testing.assert_array_equal(m.normal_forces, loads)
        np.testing.assert_array_equal(m.relative_amplitudes, relative)
        for name in m.loops:
            self.assertEqual(m.loops[name].shape, (3, 6), name)
            self.assertEqual(m.onset[name].shape, (3,), name)
        self.assertEqual(m.regime.shape, (3, 6))
        below = relative < 1
        self.assertTrue(np.all(m.regime[:, below] == "partial_slip"), m.regime)
        self.assertTrue(np.all(m.regime[:, ~below] == "gross_slip"), m.regime)
        np.testing.assert_array_equal(m.normal_force, np.repeat(loads[:, None], 6, axis=1))
        # The onset: Q* = mu P, the contact's A_t = 1/5, B_t = 2^(1/3) - 1, delta*_c = mu kappa
        # delta; the actuator moves C_t Q* more.
        self.assertRelative(m.onset.force_amplitude, MU * loads, 1e-12)
        self.assertRelative(m.onset.contact_energy_ratio, 0.2, 1e-9)
        self.assertRelative(m.onset.contact_sliding_ratio, 2 ** (1 / 3) - 1, 1e-9)
        self.assertRelative(m.onset.contact_amplitude, MU * KAPPA * hertz_depth(loads), 1e-9)
        self.assertRelative(m.onset.actuator_amplitude,
                            m.onset.contact_amplitude + C_T * m.onset.force_amplitude, 1e-12)
        # The map's amplitudes are multiples of each force's onset.
        self.assertRelative(m.actuator_amplitude,
                            np.outer(m.onset.actuator_amplitude, relative), 1e-12)
        self.assertTrue(np.all(m.force_amplitude[:, below] < MU * loads[:, None]))
        self.assertRelative(m.force_amplitude[:, ~below],
                            np.repeat(MU * loads[:, None], 3, axis=1), 1e-12)
        self.assertTrue(np.all(np.diff(m.force_amplitude, axis=1) >= 0))
        self.assertTrue(np.all(np.diff(m.dissipated_energy, axis=1) > 0))
        self.check_damping(m.loops)
        self.check_damping(m.onset)

    def check_damping(self, loops):
        """zeta = Ed / (2 pi Q* delta*) = 2 A / pi, with A = Ed / (4 delta* Q*) in (0, 1]: a
        damping ratio in (0, 2/pi]."""
        self.assertRelative(loops.damping_ratio, loops.dissipated_energy / (
            2 * np.pi * loops.force_amplitude * loops.actuator_amplitude), 1e-12)
        self.assertRelative(loops.damping_ratio, 2 * loops.energy_ratio / np.pi, 1e-12)
        self.assertTrue(np.all(loops.damping_ratio > 0))
        self.assertTrue(np.all(loops.damping_ratio < 2 / np.pi))
        self.assertRelative(loops.secant_stiffness,
                            loops.force_amplitude / loops.actuator_amplitude, 1e-12)

    def test_backbone_by_force_follows_mindlin(self):
        load = 100.0
        forces = np.array([0.3, 3, 10, 20, 29.9])
        b = self.client.backbone(RIG, load, forces)
        self.assertIsInstance(b, mdr.BackboneResult)
        self.assertEqual(b.kind, "force")
        np.testing.assert_array_equal(b.amplitudes, forces)
        for name in b.loops:
            self.assertEqual(b.loops[name].shape, (5,), name)
        self.assertRelative(b.force_amplitude, forces, 1e-12)
        # Mindlin: the loop's tips on the virgin curve Phi(v) = mu P [1 - (1 - v/L)^(3/2)],
        # L = mu kappa delta, and Ed = 8 int_0^delta* Phi - 4 Q* delta*.
        limit = MU * KAPPA * hertz_depth(load)
        contact = limit * (1 - (1 - forces / (MU * load)) ** (2 / 3))
        self.assertRelative(b.contact_amplitude, contact, 1e-9)
        area = MU * load * (contact - 0.4 * limit * (1 - (1 - contact / limit) ** 2.5))
        self.assertRelative(b.dissipated_energy, 8 * area - 4 * forces * contact, 1e-8)
        self.assertRelative(b.actuator_amplitude, contact + C_T * forces, 1e-12)
        # At small amplitude the full-stick stiffness 2 G* a in series with the rig; softening
        # and more damping with the amplitude.
        full_stick = 1 / (1 / (2 * G_STAR * math.sqrt(RADIUS * hertz_depth(load))) + C_T)
        self.assertRelative(b.secant_stiffness[0], full_stick, 2e-3)
        self.assertTrue(np.all(np.diff(b.secant_stiffness) < 0))
        self.assertTrue(np.all(np.diff(b.damping_ratio) > 0))
        self.check_damping(b.loops)

    def test_backbone_by_actuator_displacement(self):
        amplitudes = [2e-7, 1e-6, 4e-6]  # the last beyond the onset (1.87 um at 100 N)
        b = self.client.backbone(RIG, 100, amplitudes, kind="actuator_displacement")
        self.assertEqual(b.kind, "actuator_displacement")
        self.assertRelative(b.actuator_amplitude, amplitudes, 1e-12)
        self.assertTrue(np.all(b.force_amplitude[:2] < MU * 100))
        self.assertRelative(b.force_amplitude[2], MU * 100, 1e-12)
        self.check_damping(b.loops)

    # Errors.
    def test_bad_samples_are_named_by_the_server(self):
        u, f = self.loops.actuator.copy(), self.loops.force
        u[12] = np.nan
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.analyze_loops(u, f)
        self.assertEqual(raised.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertEqual(raised.exception.field, "samples.displacement[12]")
        self.assertIn("must be in [-1, 1], got nan", raised.exception.message)
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.analyze_loops(self.loops.actuator, f[:-1])
        self.assertEqual(raised.exception.field, "samples.tangential_force")
        self.assertIn(f"got {f.size - 1} for {f.size}", raised.exception.message)
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.analyze_loops(self.loops.actuator, f, time=np.zeros(f.size))
        self.assertEqual(raised.exception.field, "samples.time[1]")
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.analyze_loops(self.loops.actuator[:10], f[:10])
        self.assertEqual(raised.exception.code, grpc.StatusCode.FAILED_PRECONDITION)
        self.assertEqual(raised.exception.field, "samples.displacement")
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.analyze_loops(self.loops.actuator, f, hook_tolerance=0)
        self.assertEqual(raised.exception.field, "options.hook_tolerance")
        with self.assertRaises(mdr.MdrError) as raised:  # a scene needs the normal force
            self.client.analyze_loops(self.loops.actuator, f, scene=RIG)
        self.assertEqual(raised.exception.code, grpc.StatusCode.FAILED_PRECONDITION)
        self.assertEqual(raised.exception.field, "options.normal_force")
        # FitLoops' errors arrive through its stream, naming the set.
        bad = self.loops.actuator.copy()
        bad[5] = np.inf
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.fit_loops(RIG, [(self.loops.actuator, f, 100), (bad, f, 100)],
                                  {"friction": {"lower": 0.1, "upper": 1}})
        self.assertEqual(raised.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertEqual(raised.exception.field, "sets[1].samples.displacement[5]")
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.fit_loops(RIG, [(self.loops.actuator, f, 100)],
                                  {"friction": {"lower": 0.5, "upper": 1}})
        self.assertEqual(raised.exception.field, "free[0].initial")
        self.assertIn("0.3", raised.exception.message)

    def test_bad_map_and_backbone_arguments_name_the_field(self):
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.fretting_map(RIG, [100, np.nan], [0.5])
        self.assertEqual(raised.exception.field, "normal_forces[1]")
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.fretting_map(RIG, 100, [0.5, 101])
        self.assertEqual(raised.exception.field, "relative_amplitudes[1]")
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.backbone(RIG, 100, [10, 40])
        self.assertEqual(raised.exception.field, "amplitudes[1]")
        self.assertIn("mu F_N = 30 N", raised.exception.message)
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.backbone(dict(RIG, friction=-1), 100, [10])
        self.assertEqual(raised.exception.field, "scene.friction")

    def test_client_side_misuse_is_refused_before_any_call(self):
        u, f = self.loops.actuator, self.loops.force
        for free in ({"frictoin": {"lower": 0.1, "upper": 1}},
                     [{"parameter": "frictoin", "lower": 0.1, "upper": 1}]):
            with self.assertRaisesRegex(ValueError, r"unknown fit parameter 'frictoin'.*"
                                                    r"friction, effective_modulus"):
                self.client.fit_loops(RIG, [(u, f, 100)], free)
        with self.assertRaisesRegex(ValueError, r"free\[0\] \(friction\) needs upper"):
            self.client.fit_loops(RIG, [(u, f, 100)], {"friction": {"lower": 0.1}})
        with self.assertRaisesRegex(ValueError, "unknown key 'lowr'"):
            self.client.fit_loops(RIG, [(u, f, 100)], {"friction": {"lowr": 0.1, "upper": 1}})
        with self.assertRaisesRegex(ValueError, r"sets\[0\]\.declared_normal_force needs"):
            self.client.fit_loops(RIG, [{"displacement": u, "tangential_force": f,
                                         "normal_force": 100, "declared_normal_force": 100}],
                                  {"friction": {"lower": 0.1, "upper": 1}})
        with self.assertRaisesRegex(ValueError, r"sets\[1\] must be \(displacement"):
            self.client.fit_loops(RIG, [(u, f, 100), (u, f)],
                                  {"friction": {"lower": 0.1, "upper": 1}})
        with self.assertRaisesRegex(ValueError, r"sets\[0\]: unknown key 'times'"):
            self.client.fit_loops(RIG, [{"displacement": u, "tangential_force": f,
                                         "normal_force": 100, "times": u}],
                                  {"friction": {"lower": 0.1, "upper": 1}})
        with self.assertRaisesRegex(ValueError, "unknown nuisance 'offset'"):
            self.client.fit_loops(RIG, [(u, f, 100)], {"friction": {"lower": 0.1, "upper": 1}},
                                  nuisances=["offset"])
        with self.assertRaisesRegex(ValueError, "max_iterations must be an integer"):
            self.client.fit_loops(RIG, [(u, f, 100)], {"friction": {"lower": 0.1, "upper": 1}},
                                  max_iterations=2.5)
        with self.assertRaisesRegex(ValueError, r"displacement must be one-dimensional.*\(2, 3\)"):
            self.client.analyze_loops(np.zeros((2, 3)), np.zeros(6))
        with self.assertRaisesRegex(ValueError, "tangential_force: could not convert"):
            self.client.analyze_loops(u, ["a"] * u.size)
        with self.assertRaisesRegex(ValueError, "kind must be one of force, actuator_displacement"):
            self.client.backbone(RIG, 100, [10], kind="displacement")

    def test_identify_rig_example(self):
        env = dict(os.environ, MDR_MDRD=ARGS.mdrd)
        out = subprocess.run([sys.executable, "examples/python/identify_rig.py"], check=True,
                             cwd=ARGS.source_dir, env=env, timeout=120, stdout=subprocess.PIPE,
                             text=True).stdout
        estimates = dict(re.findall(r"^(friction|effective_modulus|rig_compliance) += (\S+)",
                                    out, re.MULTILINE))
        self.assertEqual(len(estimates), 3, out)
        truth = {"friction": MU, "effective_modulus": E_STAR, "rig_compliance": C_T}
        for name, value in estimates.items():  # 0.05 N of noise: within 1 %
            self.assertAlmostEqual(float(value) / truth[name], 1, delta=0.01, msg=out)
        cycles = re.findall(r"^cycle \d: Q\* = (\S+) N, .*, (\w+)$", out, re.MULTILINE)
        self.assertEqual(len(cycles), 2, out)  # 3 cycles from the pressed state: 2 complete
        for force_amplitude, regime in cycles:  # +-2 um at 100 N: beyond the onset (1.87 um)
            self.assertAlmostEqual(float(force_amplitude) / 30, 1, delta=0.01)
            self.assertEqual(regime, "gross_slip")
        self.assertEqual(re.findall(r"the \+-2 um run is (.*)$", out, re.MULTILINE),
                         ["gross slip", "gross slip", "partial slip"])
        runs = re.findall(r"^\S+ N run: noise (\S+) m and (\S+) N, .*: (\w+)$", out, re.MULTILINE)
        self.assertEqual(len(runs), 3, out)
        for displacement_noise, force_noise, verdict in runs:  # 5 nm and 0.05 N: within 30 %
            self.assertAlmostEqual(float(displacement_noise) / 5e-9, 1, delta=0.3, msg=out)
            self.assertAlmostEqual(float(force_noise) / 0.05, 1, delta=0.3, msg=out)
            self.assertEqual(verdict, "adequate", out)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--source-dir", default=os.path.join(os.path.dirname(
        os.path.abspath(__file__)), "..", ".."))
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
