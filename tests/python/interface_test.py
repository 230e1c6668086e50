#!/usr/bin/python3
"""Interface sessions (scene.interface, issue #17) through the Python package mdr, against a real
mdrd started by the package (Client.embedded): scenes built with mdr.interface_scene, contact
lists stepped with mdr.contact_step's packed values, the "interface.*" outputs and contact_index
of Session.query. Every contact must answer bit for bit like a single session driven the same
way. The package is imported from the build tree (PYTHONPATH=<build>/python).

Usage: interface_test.py --mdrd PATH
"""
import argparse
import sys
import unittest

import grpc
import numpy as np

import mdr

ARGS = None

# Reference vector H1: steel sphere R = 10 mm on a steel flat, mu = 0.3; its depth at 100 N and
# its tangential displacement at 15 N.
H1 = {"sphere": {"radius": 0.01}, "friction": 0.3,
      "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                       "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
DEPTH, DISPLACEMENT = 3.4829098839e-6, 4.6949658143e-7
# Three summits around H1's depth, of three radii.
HEIGHTS = np.array([0, 0.4 * DEPTH, -0.3 * DEPTH])
RADII = np.array([0.01, 0.005, 0.02])
CONTACT_MASK = ["state", "jager_weights", "energy", "tangential_stiffness", "memory_pieces"]


def single_scene(i):
    """The single session of contact i of the explicit population."""
    return dict(H1, sphere={"radius": float(RADII[i])})


def without_timing(response):
    """The QueryResponse without compute_seconds: what must match bit for bit."""
    copy = type(response)()
    copy.CopyFrom(response)
    copy.ClearField("compute_seconds")
    return copy.SerializeToString(deterministic=True)


class InterfaceTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.client = mdr.Client.embedded(ARGS.mdrd)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()

    def explicit(self, kind):
        return self.client.session(mdr.interface_scene(H1, kind, heights=HEIGHTS, radii=RADII))

    def test_shared_motion_totals_are_the_sum_of_single_sessions_bit_for_bit(self):
        approach = 0.8 * DEPTH
        displacements = [0.2 * DISPLACEMENT, -0.1 * DISPLACEMENT, 0.3 * DISPLACEMENT]
        with self.explicit("shared_motion") as interface:
            interface.apply([{"depth": approach}] + [{"displacement": u} for u in displacements])
            q = interface.query(["state", "interface.totals"])
            totals = q.interface.totals
            self.assertIsInstance(totals, mdr.InterfaceTotals)
            self.assertEqual(q.interface.contact_count, 3)
            states, stiffnesses = [], []
            for i in range(3):
                with self.client.session(single_scene(i)) as single:
                    # Contact i has the depth approach - h_i with h_i = -heights[i].
                    single.apply([{"depth": approach + HEIGHTS[i]}] +
                                 [{"displacement": u} for u in displacements])
                    alone = single.query(CONTACT_MASK)
                    by_index = interface.query(CONTACT_MASK, contact_index=i)
                    self.assertEqual(without_timing(by_index.response),
                                     without_timing(alone.response), f"contact {i}")
                    self.assertIsNone(by_index.interface)
                    states.append(alone.state)
                    stiffnesses.append(alone.response.tangential_stiffness)
            # Summed in contact order, as the interface sums them.
            self.assertEqual(totals.normal_force, sum(s.normal_force for s in states))
            self.assertEqual(totals.tangential_force, sum(s.tangential_force for s in states))
            self.assertEqual(totals.dissipated_energy, sum(s.dissipated_energy for s in states))
            self.assertEqual(totals.friction_limit, sum(s.friction_limit for s in states))
            self.assertEqual(totals.in_contact, sum(s.depth > 0 for s in states))
            self.assertEqual(totals.in_contact, 3)
            self.assertEqual(totals.tangential_stiffness_positive,
                             sum(k.positive for k in stiffnesses))
            self.assertEqual(totals.tangential_stiffness_negative,
                             sum(k.negative for k in stiffnesses))
            e_star = 210e9 / (2 * (1 - 0.3**2))  # dF_N/d(approach) = sum of 2 E* a_i
            self.assertAlmostEqual(totals.normal_stiffness /
                                   sum(2 * e_star * s.contact_radius for s in states), 1,
                                   delta=1e-12)
            self.assertEqual(q.state.depth, approach)
            self.assertEqual(q.state.tangential_displacement, displacements[-1])
            self.assertEqual(q.state.normal_force, totals.normal_force)
            self.assertEqual(q.state.applied_steps, 4)

    def test_contact_list_steps_with_packed_values_like_single_sessions(self):
        depth_increments = np.array([[DEPTH, 0.5 * DEPTH, 1.5 * DEPTH],
                                     [0, -0.1 * DEPTH, 0.2 * DEPTH]])
        displacement_increments = DISPLACEMENT * np.array([[0.1, -0.2, 0], [-0.3, 0.1, 0.05]])
        forces = np.array([80.0, 30.0, 200.0])
        steps = [mdr.contact_step(depth_increment=dz, displacement_increment=du)
                 for dz, du in zip(depth_increments, displacement_increments)]
        # The oneof chooses the meaning and holds 0; the values are packed bit for bit.
        self.assertEqual(steps[0].WhichOneof("normal"), "depth_increment")
        self.assertEqual(steps[0].depth_increment, 0)
        self.assertEqual(list(steps[1].contact_tangential_values),
                         displacement_increments[1].tolist())
        force_step = mdr.contact_step(normal_force=forces)
        self.assertIsNone(force_step.WhichOneof("tangential"))
        self.assertEqual(len(force_step.contact_tangential_values), 0)
        with self.explicit("contact_list") as contacts:
            applied = contacts.apply(steps)
            np.testing.assert_array_equal(applied.applied_steps, [1, 2])
            contacts.apply(force_step)
            total = contacts.query(["interface.totals"]).interface.totals
            self.assertAlmostEqual(total.normal_force / forces.sum(), 1, delta=1e-12)
            radii = [0, 1e-5, 5e-5]
            for i in range(3):
                with self.client.session(single_scene(i)) as single:
                    single.apply([{"depth_increment": dz[i], "displacement_increment": du[i]}
                                  for dz, du in zip(depth_increments, displacement_increments)])
                    single.apply({"normal_force": forces[i]})
                    mask = CONTACT_MASK + ["tractions"]
                    alone = single.query(mask, radii=radii)
                    by_index = contacts.query(mask, radii=radii, contact_index=i)
                    self.assertEqual(without_timing(by_index.response),
                                     without_timing(alone.response), f"contact {i}")
                    np.testing.assert_array_equal(by_index.tractions["value"],
                                                  alone.tractions["value"])

    def test_generated_interface_histogram_sums_to_the_contacts_in_contact(self):
        scene = mdr.interface_scene(H1, "shared_motion", generated={
            "count": 300, "height_scale": 0.3 * DEPTH, "seed": 17,
            "radius_distribution": "RADIUS_DISTRIBUTION_LOGNORMAL", "log_sigma": 0.2})
        target = 250.0
        with self.client.session(scene) as s:
            s.apply([{"normal_force": target}, {"tangential_force": 0.5 * 0.3 * target}])
            q = s.query(["interface.totals", "interface.slip_histogram", "interface.memory_bytes"],
                        slip_histogram_bins=7)
            totals, histogram = q.interface.totals, q.interface.slip_histogram
            self.assertEqual(q.interface.contact_count, 300)
            self.assertAlmostEqual(totals.normal_force / target, 1, delta=1e-12)
            self.assertLessEqual(abs(totals.tangential_force - 0.15 * target),
                                 1e-12 * totals.friction_limit)
            self.assertEqual(histogram.dtype, np.uint64)
            self.assertEqual(histogram.shape, (7,))
            self.assertGreater(totals.in_contact, 0)
            self.assertEqual(int(histogram.sum()), totals.in_contact)
            self.assertEqual(totals.sticking + totals.partial_slip + totals.gross_slip,
                             totals.in_contact)
            self.assertGreater(q.interface.memory_bytes, 300 * 100)
            # Only what is asked: no totals, no histogram, no bytes.
            only_count = s.query(["interface.memory_bytes"]).interface
            self.assertIsNone(only_count.totals)
            self.assertEqual(only_count.slip_histogram.shape, (0,))
            self.assertEqual(s.query(["state"]).interface, None)

    def test_export_import_of_an_interface_continues_bit_for_bit(self):
        with self.explicit("contact_list") as contacts:
            contacts.apply(mdr.contact_step(depth=HEIGHTS + DEPTH))
            with self.client.import_session(contacts.export()) as copy:
                step = mdr.contact_step(displacement=DISPLACEMENT * np.array([0.3, -0.2, 0.1]))
                self.assertEqual(contacts.apply(step).state, copy.apply(step).state)
                mask = ["interface.totals"]
                self.assertEqual(contacts.query(mask).interface.totals,
                                 copy.query(mask).interface.totals)

    def test_bad_contact_index_and_bins_name_the_field_and_change_nothing(self):
        with self.explicit("shared_motion") as interface:
            interface.apply({"depth": DEPTH})
            with self.assertRaises(mdr.MdrError) as raised:
                interface.query(["state"], contact_index=3)
            error = raised.exception
            self.assertEqual(error.code, grpc.StatusCode.INVALID_ARGUMENT)
            self.assertEqual(error.field, "contact_index")
            self.assertIn("[0, 2]", error.message)
            with self.assertRaises(mdr.MdrError) as raised:
                interface.query(["jager_weights"])  # one contact's output needs its index
            self.assertEqual(raised.exception.field, "contact_index")
            with self.assertRaises(mdr.MdrError) as raised:
                interface.query(["interface.slip_histogram"], slip_histogram_bins=0)
            self.assertEqual(raised.exception.field, "slip_histogram_bins")
            with self.assertRaisesRegex(ValueError, "contact_index must be >= 0"):
                interface.query(["state"], contact_index=-1)
            with self.assertRaisesRegex(ValueError, "slip_histogram_bins"):
                interface.query(["interface.slip_histogram"], slip_histogram_bins=2**31)
            self.assertEqual(interface.get().state.applied_steps, 1)
        with self.client.session(H1) as single:
            with self.assertRaises(mdr.MdrError) as raised:
                single.query(["state"], contact_index=0)
            self.assertEqual(raised.exception.field, "contact_index")

    def test_bad_per_contact_values_name_the_field_and_change_nothing(self):
        with self.explicit("contact_list") as contacts:
            contacts.apply(mdr.contact_step(depth=[DEPTH, DEPTH, DEPTH]))
            before = contacts.export()
            with self.assertRaises(mdr.MdrError) as raised:
                contacts.apply([mdr.contact_step(displacement=[1e-8, 1e-8, 1e-8]),
                                mdr.contact_step(depth_increment=[1e-8, 1e-8])])
            self.assertEqual(raised.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
            self.assertEqual(raised.exception.field, "steps[1].contact_normal_values")
            self.assertIn("one value per contact (3), got 2", raised.exception.message)
            with self.assertRaises(mdr.MdrError) as raised:
                contacts.apply(mdr.contact_step(normal_force=[10, -3, 10]))
            self.assertEqual(raised.exception.field, "steps[0].contact_normal_values[1]")
            with self.assertRaises(mdr.MdrError) as raised:
                contacts.apply(mdr.contact_step(depth=[DEPTH, np.nan, DEPTH]))
            self.assertEqual(raised.exception.field, "steps[0].contact_normal_values[1]")
            self.assertIn("finite", raised.exception.message)
            after = contacts.export()
            after.source_name = before.source_name
            self.assertEqual(after, before)
        with self.client.session(H1) as single:  # per-contact values need a contact list
            with self.assertRaises(mdr.MdrError) as raised:
                single.apply(mdr.contact_step(depth=[DEPTH]))
            self.assertEqual(raised.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
            self.assertEqual(raised.exception.field, "steps[0].contact_normal_values")
            self.assertIn("KIND_CONTACT_LIST", raised.exception.message)

    def test_numpy_arrays_in_dicts_convert_and_non_finite_values_reach_the_server(self):
        step = mdr.to_step({"depth": 0, "contact_normal_values": np.array([1.0, np.inf])})
        self.assertEqual(list(step.contact_normal_values), [1.0, np.inf])
        scene = mdr.to_scene(dict(H1, interface={"kind": "KIND_CONTACT_LIST",
                                                 "explicit_list": {"heights": np.zeros(2)}}))
        self.assertEqual(list(scene.interface.explicit_list.heights), [0.0, 0.0])

    def test_client_side_misuse_is_refused_before_any_call(self):
        with self.assertRaisesRegex(ValueError, "at most one of depth, depth_increment"):
            mdr.contact_step(depth=[1.0], normal_force=[1.0])
        with self.assertRaisesRegex(ValueError, r"displacement must be one-dimensional.*\(2, 2\)"):
            mdr.contact_step(displacement=np.zeros((2, 2)))
        with self.assertRaisesRegex(ValueError, "kind must be one of"):
            mdr.interface_scene(H1, "rough", heights=[0.0])
        with self.assertRaisesRegex(ValueError, "exactly one population"):
            mdr.interface_scene(H1, "shared_motion")
        with self.assertRaisesRegex(ValueError, "exactly one population"):
            mdr.interface_scene(H1, "shared_motion", heights=[0.0], generated={"count": 1})
        with self.assertRaisesRegex(ValueError, "radii belong to an explicit population"):
            mdr.interface_scene(H1, "shared_motion", radii=[0.01], generated={"count": 1})
        with self.assertRaisesRegex(ValueError, "no_such_field"):
            mdr.interface_scene(H1, "shared_motion", generated={"no_such_field": 1})

    def test_bad_scene_names_the_proto_path(self):
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.create_session(mdr.interface_scene(H1, "shared_motion",
                                                           generated={"count": 0}))
        self.assertEqual(raised.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("scene.interface.generated.count", raised.exception.field)
        self.assertIn("[1, 10000000]", raised.exception.message)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
