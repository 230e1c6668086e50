#!/usr/bin/python3
"""Torsion (scene.torsion, issue #49) through the Python package mdr against a real mdrd started
by the package (Client.embedded): a twist by moment target gives the Hertz closed forms, the
"torsion.*" outputs arrive, an export continues bit for bit after an import, a tangential step
is refused naming the field and changing nothing, and the in-process client (the C library)
refuses a torsional scene instead of stepping it tangentially. The package is imported from the
build tree (PYTHONPATH=<build>/python).

Usage: torsion_test.py --mdrd PATH --library PATH
"""
import argparse
import math
import sys
import unittest

import grpc

import mdr

ARGS = None

# Reference vector H1 (steel sphere R = 10 mm on a steel flat, mu = 0.3), twisted.
H1 = {"sphere": {"radius": 0.01}, "friction": 0.3,
      "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                       "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
TWISTED = dict(H1, torsion={})
E_STAR = 210e9 / (2 * (1 - 0.3**2))
G_T = 210e9 / (2 * 1.3) / 2


def contact_radius(normal_force):
    return (3 * normal_force * 0.01 / (4 * E_STAR)) ** (1 / 3)


class TorsionTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.client = mdr.Client.embedded(ARGS.mdrd)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()

    def test_a_twist_to_a_moment_gives_the_hertz_closed_forms(self):
        a = contact_radius(100)
        full_slip = 3 * math.pi * 0.3 * 100 * a / 16
        with self.client.session(TWISTED) as session:
            loaded = session.apply({"normal_force": 100}).state
            self.assertAlmostEqual(loaded.full_slip_moment / full_slip, 1, delta=1e-12)
            stiffness = session.query(["torsion.stiffness"]).response.torsion
            self.assertAlmostEqual(stiffness.stiffness_positive / (16 * G_T * a**3 / 3), 1,
                                   delta=1e-12)
            state = session.apply({"twisting_moment": 0.5 * full_slip}).state
            self.assertAlmostEqual(state.twisting_moment / (0.5 * full_slip), 1, delta=1e-12)
            self.assertGreater(state.twist, 0)
            torsion = session.query(["torsion"], radii=[0.5 * a, 0.99 * a]).response.torsion
            self.assertEqual(len(torsion.slip_intervals), 1)
            self.assertEqual(torsion.slip_intervals[0].direction, 1)
            # In the slip annulus the traction is mu p(r): Hertz's p0 sqrt(1 - r^2/a^2).
            p0 = 3 * 100 / (2 * math.pi * a**2)
            outer = torsion.tractions[1]
            self.assertAlmostEqual(outer.value / (0.3 * p0 * math.sqrt(1 - 0.99**2)), 1,
                                   delta=1e-9)
            self.assertGreater(torsion.stored_energy, 0)

    def test_an_import_continues_bit_for_bit(self):
        with self.client.session(TWISTED) as session:
            session.apply([{"normal_force": 100}, {"twist": 3e-3}, {"twist_increment": -4e-3}])
            with self.client.import_session(session.export()) as copy:
                for step in ({"normal_force": 130}, {"twist": 1e-3}, {"twisting_moment": -1e-3}):
                    self.assertEqual(session.apply(step).state, copy.apply(step).state)
                self.assertEqual(session.export().torsion, copy.export().torsion)

    def test_a_tangential_step_is_refused_naming_the_field_and_changes_nothing(self):
        with self.client.session(TWISTED) as session:
            session.apply([{"normal_force": 100}, {"twist": 2e-3}])
            before = session.export()
            with self.assertRaises(mdr.MdrError) as raised:
                session.apply([{"twist": 3e-3}, {"displacement": 1e-7}])
            self.assertEqual(raised.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
            self.assertEqual(raised.exception.field, "steps[1].displacement")
            self.assertIn("no exact model", raised.exception.message)
            self.assertEqual(session.export().torsion, before.torsion)
        with self.client.session(H1) as tangential:
            with self.assertRaises(mdr.MdrError) as raised:
                tangential.apply({"twist": 1e-3})
            self.assertEqual(raised.exception.field, "steps[0].twist")

    def test_the_in_process_client_refuses_a_torsional_scene(self):
        local = mdr.Client.embedded(in_process=True, library=ARGS.library)
        with self.assertRaises(mdr.MdrError) as raised:
            local.create_session(TWISTED)
        self.assertEqual(raised.exception.field, "scene.torsion")
        self.assertIn("mdrd", raised.exception.message)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--library", required=True)
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
