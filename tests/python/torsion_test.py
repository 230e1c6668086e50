#!/usr/bin/python3
"""Torsion (scene.torsion, issue #49) through the Python package mdr against a real mdrd started
by the package (Client.embedded): a twist by moment target gives the Hertz closed forms, the
"torsion.*" outputs arrive, an export continues bit for bit after an import, a tangential step
is refused naming the field and changing nothing, and the in-process client (the C library's
mdr_torsion) answers a torsional session as the server does, bit for bit, refusals included,
with snapshots moving both ways. The package is imported from the build tree
(PYTHONPATH=<build>/python).

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

    def test_in_process_torsion_is_the_servers_bit_for_bit(self):
        steps = ([{"normal_force": 100}]
                 + [{"twist": 3e-3 * math.sin(2 * math.pi * i / 12)} for i in range(1, 25)]
                 + [{"twisting_moment": m} for m in (1e-3, -2e-3, 5e-4)]
                 + [{"twist_increment": -1e-3}, {"normal_force": 130}, {"depth_increment": 1e-8},
                    {}])
        more = [{"twist": 2e-3}, {"twisting_moment": -1e-3}, {"depth": 4.5e-6}]
        step_outputs = ["state", "substeps", "path_error", "dissipated_energy"]
        radii = [0, 5e-5, 1e-4, 1.5e-4, 2e-4, 3e-4]
        with mdr.Client.embedded(in_process=True, library=ARGS.library) as local, \
                local.session(TWISTED) as here, self.client.session(TWISTED) as there:
            self.assertIsInstance(here, mdr.inprocess.InProcessTorsionSession)
            a = here.apply(steps, outputs=step_outputs).response
            b = there.apply(steps, outputs=step_outputs).response
            self.assertEqual(len(a.step_results), len(steps))
            for mine, theirs in zip(a.step_results, b.step_results):
                self.assertEqual(serialized(mine), serialized(theirs))
            self.assertEqual(serialized(a.state), serialized(b.state))
            self.assertGreater(a.state.memory_vertices, 1)
            mine, theirs = (s.query(["state", "torsion"], radii=radii).response
                            for s in (here, there))
            self.assertEqual(serialized(mine.state), serialized(theirs.state))
            self.assertEqual(serialized(mine.torsion), serialized(theirs.torsion))
            self.assertEqual(len(mine.torsion.memory_pieces), a.state.memory_vertices)
            self.assertEqual(len(mine.torsion.tractions), len(radii))
            for path in ("torsion.stiffness", "torsion.stored_energy"):
                self.assertEqual(serialized(here.query([path]).response.torsion),
                                 serialized(there.query([path]).response.torsion))
            mine, theirs = here.export(), there.export()
            self.assertEqual(serialized(mine.torsion), serialized(theirs.torsion))
            self.assertEqual(serialized(mine.scene), serialized(theirs.scene))
            self.assertEqual(mine.applied_steps, theirs.applied_steps)
            # Snapshots both ways: each side continues the other's state as its own.
            with self.client.import_session(mine) as on_server, \
                    local.import_session(theirs) as in_process:
                slipping = 0
                for step in more:
                    self.assertEqual(serialized(on_server.apply(step).state),
                                     serialized(in_process.apply(step).state))
                    mine, theirs = (s.query(["torsion"], radii=radii).response.torsion
                                    for s in (in_process, on_server))
                    self.assertEqual(serialized(mine), serialized(theirs))
                    slipping += len(mine.slip_intervals)
                self.assertGreater(slipping, 0)
                self.assertEqual(serialized(in_process.export().torsion),
                                 serialized(on_server.export().torsion))

    def test_in_process_refusals_are_the_servers_and_change_nothing(self):
        bad_batches = [
            [{"twist": float("nan")}],
            [{"twist": 1e-3}, {"normal_force": 120, "twist": 1e-3}],
            [{"twisting_moment": 1.0}],
            [{"displacement": 1e-7}],
            [{"twist": 1e-3}, {"depth_increment": float("inf")}],
            [{"normal_force": -1}],
        ]
        with mdr.Client.embedded(in_process=True, library=ARGS.library) as local, \
                local.session(TWISTED) as here, self.client.session(TWISTED) as there:
            for session in (here, there):
                session.apply([{"normal_force": 100}, {"twist": 2e-3}])
            before = here.export()
            for batch in bad_batches:
                with self.assertRaises(mdr.MdrError) as mine:
                    here.apply(batch)
                with self.assertRaises(mdr.MdrError) as theirs:
                    there.apply(batch)
                self.assertEqual((mine.exception.code, mine.exception.field),
                                 (theirs.exception.code, theirs.exception.field), batch)
                self.assertEqual(mine.exception.message, theirs.exception.message, batch)
                self.assertEqual(serialized(here.export().torsion), serialized(before.torsion))
            # The outputs of the other kind of session are refused, as the server refuses them.
            for path in ("tangential_stiffness", "pressure"):
                with self.assertRaises(mdr.MdrError) as raised:
                    here.query([path], radii=[0.0])
                self.assertEqual(raised.exception.code, grpc.StatusCode.FAILED_PRECONDITION)
                self.assertEqual(raised.exception.field, "read_mask")
        with mdr.Client.embedded(in_process=True, library=ARGS.library) as local, \
                local.session(H1) as tangential:
            with self.assertRaises(mdr.MdrError) as raised:
                tangential.apply([{"normal_force": 100}, {"twist": 1e-3}])
            self.assertEqual(raised.exception.field, "steps[1].twist")
            self.assertEqual(tangential.query().state.applied_steps, 0)
            with self.assertRaises(mdr.MdrError) as raised:
                tangential.query(["torsion.stiffness"])
            self.assertEqual(raised.exception.code, grpc.StatusCode.FAILED_PRECONDITION)


def serialized(message) -> bytes:
    """A message's bytes: equal bytes are equal doubles, bit for bit."""
    return message.SerializeToString(deterministic=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--library", required=True)
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
