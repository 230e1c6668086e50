#!/usr/bin/python3
"""Torsional records through the Python package's analysis (issue #49; docs/analysis.md,
"Torsional records"): a ball twisted on a flat, recorded by a session of the twisted H1 with a
shaft's compliance added to the twist, analysed (analyze_loops with twist= and
twisting_moment=), fitted back (fit_loops: mu, G_t and the shaft) and drawn as a backbone, against
a real mdrd started by the package (Client.embedded) and in process (libmdr_c's
mdr_analysis_run), whose answers are the server's byte for byte but for the time; a torsional
session's per-step twist, moment and full-slip moment arrays (ApplyResult); the errors naming
their fields both ways. The package is imported from the build tree (PYTHONPATH=<build>/python).

Usage: torsion_analysis_test.py --mdrd PATH --library PATH
"""
import argparse
import math
import sys
import unittest

import grpc
import numpy as np

import mdr

ARGS = None

# H1 (docs/reference-values.md): a steel sphere R = 10 mm on a steel flat, mu = 0.3, twisted at
# 100 N to the stick radius c = a/2 (PHI_HALF), where the virgin curve's moment is M_HALF.
H1 = {"sphere": {"radius": 0.01}, "friction": 0.3,
      "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                       "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
TWISTED = dict(H1, torsion={})
PHI_HALF, M_HALF = 4.8141258757e-3, 2.9593735330e-3  # rad, N m
SHAFT = 0.5  # rad/(N m)
E_STAR = 210e9 / (2 * (1 - 0.3**2))
G_T = 210e9 / (2 * 1.3) / 2  # 1/G_t = 1/G_1 + 1/G_2


def behind_shaft(compliance):
    return dict(H1, torsion={"rig_compliance": compliance})


def contact_radius(normal_force):
    return (3 * normal_force * 0.01 / (4 * E_STAR)) ** (1 / 3)


def record(client, normal_force, amplitude, cycles=3, per_cycle=200):
    """A rig's torsional record: a session of the contact pressed to normal_force, then twisted
    to amplitude sin(2 pi k / per_cycle); the twist recorded is the actuator's behind the shaft,
    phi + SHAFT M (sessions hold no shaft). Returns (twist, moment, full-slip moment)."""
    with client.session(TWISTED) as session:
        pressed = session.apply({"normal_force": normal_force})
        k = np.arange(1, cycles * per_cycle + 1)
        phase = 2 * np.pi * (k % per_cycle) / per_cycle
        run = session.apply([{"twist": phi} for phi in amplitude * np.sin(phase)])
    twist = np.r_[pressed.state.twist, run.twist]
    moment = np.r_[pressed.state.twisting_moment, run.twisting_moment]
    return twist + SHAFT * moment, moment, pressed.state.full_slip_moment


def untimed(message):
    """A response's bytes without its compute_seconds (deterministic, so equal bytes are equal
    doubles)."""
    copy = type(message)()
    copy.CopyFrom(message)
    copy.ClearField("compute_seconds")
    return copy.SerializeToString(deterministic=True)


class TorsionalAnalysisTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.client = mdr.Client.embedded(ARGS.mdrd)
        cls.local = mdr.Client.embedded(in_process=True, library=ARGS.library)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.local.close()

    def test_apply_results_carry_the_twist_the_moment_and_the_full_slip_moment(self):
        steps = [{"normal_force": 100}, {"twist": 1e-3}, {"twist": 3e-3}, {"twist": -2e-3}]
        for client in (self.client, self.local):
            with client.session(TWISTED) as session:
                result = session.apply(steps)
                states = [r.state for r in result.response.step_results]
                for name in ("twist", "twisting_moment", "full_slip_moment"):
                    self.assertEqual(getattr(result, name).tolist(),
                                     [getattr(s, name) for s in states], name)
                self.assertEqual(result.twist.tolist(), [0, 1e-3, 3e-3, -2e-3])
                self.assertGreater(result.twisting_moment[2], result.twisting_moment[1])
                slip = 3 * math.pi * 0.3 * 100 * contact_radius(100) / 16
                self.assertAlmostEqual(result.full_slip_moment[-1] / slip, 1, delta=1e-12)

    def test_a_torsional_record_is_analysed_and_classified_the_same_both_ways(self):
        twist, moment, slip = record(self.client, 100, PHI_HALF)
        answers = [client.analyze_loops(twist=twist, twisting_moment=moment, normal_force=100,
                                        scene=behind_shaft(SHAFT), rig_compliance=SHAFT)
                   for client in (self.client, self.local)]
        self.assertEqual(untimed(answers[0].raw), untimed(answers[1].raw))
        r = answers[0]
        self.assertTrue(r.torsional)
        self.assertEqual(len(r), 2)
        np.testing.assert_allclose(r.force_amplitude, M_HALF, rtol=1e-9)
        np.testing.assert_allclose(r.contact.displacement_amplitude, PHI_HALF, rtol=1e-9)
        np.testing.assert_allclose(r.displacement_amplitude, PHI_HALF + SHAFT * M_HALF,
                                   rtol=1e-9)
        # The Hertz loss per cycle at c = a/2 (docs/reference-values.md), to the trapezoidal
        # rule's 200 samples a cycle.
        np.testing.assert_allclose(r.dissipated_energy, 1.8173196119e-5, rtol=1e-3)
        self.assertTrue(np.isnan(r.friction_coefficient).all())
        self.assertTrue(np.isnan(r.energy_friction_coefficient).all())
        self.assertEqual(r.regime.tolist(), ["partial_slip"] * 2)
        self.assertEqual(r.full_slip_moment.tolist(), [slip] * 2)
        self.assertIsNone(r.onset_system_free_ratio)
        self.assertNotIn("full_slip_moment", r.figures)
        self.assertEqual(r.measures["dissipated_energy"], "contact")
        plain = self.client.analyze_loops(twist=twist, twisting_moment=moment)
        self.assertTrue(plain.torsional)
        self.assertIsNone(plain.regime)
        self.assertIsNone(plain.full_slip_moment)
        tangential = self.client.analyze_loops(moment, twist * 1e-3)
        self.assertFalse(tangential.torsional)

    def test_a_torsional_fit_gives_mu_gt_and_the_shaft_back_the_same_both_ways(self):
        sets = []
        for load in (30.0, 100.0, 300.0):
            twist, moment, _ = record(self.client, load, 6e-3, cycles=2, per_cycle=120)
            sets.append((twist, moment, load))
        start = dict(H1, friction=0.4,
                     torsion={"rig_compliance": 0.3, "torsional_modulus": 3e10})
        free = {"friction": {"lower": 0.05, "upper": 2},
                "torsional_modulus": {"lower": 1e9, "upper": 1e12},
                "rig_compliance": {"lower": 0, "upper": 10}}
        iterations = []
        fits = [client.fit_loops(start, sets, free, include_models=True,
                                 progress=lambda i, rms, values: iterations.append(values))
                for client in (self.client, self.local)]
        self.assertEqual(untimed(fits[0].raw), untimed(fits[1].raw))
        fit = fits[0]
        self.assertEqual(fit.names, ("friction", "torsional_modulus", "rig_compliance"))
        for name, truth in (("friction", 0.3), ("torsional_modulus", G_T),
                            ("rig_compliance", SHAFT)):
            self.assertAlmostEqual(fit[name].value / truth, 1, delta=1e-6, msg=name)
            self.assertTrue(fit[name].identified, name)
        self.assertTrue(fit.all_identified)
        self.assertEqual(fit.fitted_scene.torsion.torsional_modulus, fit["torsional_modulus"].value)
        self.assertEqual(fit.fitted_scene.torsion.rig_compliance, fit["rig_compliance"].value)
        self.assertIsNone(fit.guessed_rig_compliance)
        self.assertEqual(len(fit.models), 3)
        self.assertIn("torsional_modulus", iterations[0])
        # The same sets as dicts with the torsional keys.
        dicts = [{"twist": t, "twisting_moment": m, "normal_force": p} for t, m, p in sets]
        again = self.client.fit_loops(start, dicts, free)
        self.assertEqual(again.value.tolist(), fit.value.tolist())

    def test_the_torsional_backbone_through_the_shaft_the_same_both_ways(self):
        amplitudes = [1e-5, 2e-3, 6e-3]
        answers = [client.backbone(behind_shaft(SHAFT), 100, amplitudes, "actuator_displacement")
                   for client in (self.client, self.local)]
        self.assertEqual(untimed(answers[0].raw), untimed(answers[1].raw))
        b = answers[0]
        np.testing.assert_allclose(b.actuator_amplitude, amplitudes, rtol=1e-9)
        # At a small twist the contact sticks: its stiffness 16 G_t a^3 / 3 in series with the
        # shaft.
        stick = 16 * G_T * contact_radius(100) ** 3 / 3
        self.assertAlmostEqual(b.secant_stiffness[0] / (1 / (1 / stick + SHAFT)), 1, delta=1e-3)
        self.assertTrue(np.all(np.diff(b.damping_ratio) > 0))
        slip = 3 * math.pi * 0.3 * 100 * contact_radius(100) / 16
        for client in (self.client, self.local):
            with self.assertRaises(mdr.MdrError) as raised:
                client.backbone(behind_shaft(SHAFT), 100, [0.5 * slip, 2 * slip], "force")
            self.assertEqual(raised.exception.field, "amplitudes[1]")

    def test_errors_name_their_fields_both_ways(self):
        twist, moment, _ = record(self.client, 100, 3e-3, cycles=2, per_cycle=40)
        cases = [
            (dict(twist=twist, twisting_moment=moment, displacement=twist * 1e-3),
             "samples.twist"),
            (dict(twist=twist, twisting_moment=moment, normal_force=100, scene=H1),
             "scene.torsion"),
            (dict(displacement=twist * 1e-3, tangential_force=moment, normal_force=100,
                  scene=TWISTED), "scene.torsion"),
            (dict(twist=twist, twisting_moment=moment[:-1]), "samples.twisting_moment"),
            (dict(twist=np.r_[twist[:5], 101.0, twist[6:]], twisting_moment=moment),
             "samples.twist[5]"),
        ]
        for kwargs, field in cases:
            for client in (self.client, self.local):
                with self.assertRaises(mdr.MdrError) as raised:
                    client.analyze_loops(**kwargs)
                self.assertEqual(raised.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
                self.assertEqual(raised.exception.field, field, kwargs.keys())
        free = {"friction": {"lower": 0.05, "upper": 2}}
        for client in (self.client, self.local):
            with self.assertRaises(mdr.MdrError) as raised:
                client.fit_loops(TWISTED, [{"displacement": twist, "tangential_force": moment,
                                            "normal_force": 100}], free)
            self.assertEqual(raised.exception.field, "sets[0].samples")
        with self.assertRaisesRegex(ValueError, r"sets\[0\] must be \(twist, twisting_moment, "
                                                r"normal_force\[, time\]\)"):
            self.client.fit_loops(TWISTED, [(twist, moment)], free)
        with self.assertRaisesRegex(ValueError, r"sets\[0\] needs twist and twisting_moment"):
            self.client.fit_loops(TWISTED, [{"normal_force": 100}], free)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--library", required=True)
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
