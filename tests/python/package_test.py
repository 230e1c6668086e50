#!/usr/bin/python3
"""Tests of the Python package mdr against a real mdrd started by the package itself
(Client.embedded), and of the Python examples. The package and its generated modules are
imported from the build tree (PYTHONPATH=<build>/python), as the README says.

Usage: package_test.py --mdrd PATH --source-dir REPO --out-dir DIR
"""
import argparse
import csv
import math
import os
import re
import subprocess
import sys
import unittest

import grpc
import numpy as np

import mdr

ARGS = None

# Reference vector H1: steel sphere R = 10 mm on a steel flat, mu = 0.3, F_N = 100 N.
H1 = {"sphere": {"radius": 0.01}, "friction": 0.3,
      "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                       "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
H1_CONTACT_RADIUS, H1_DEPTH, H1_P0 = 1.8662555784e-4, 3.4829098839e-6, 1.3708790787e9
H1_STICK_RADIUS_15N, H1_DISPLACEMENT_15N = 1.4812480342e-4, 4.6949658143e-7


def cattaneo_mindlin_traction(r, a, c, mu=0.3, p0=H1_P0):
    """Hertz-Cattaneo-Mindlin shear traction (mu p0 / a)[sqrt(a^2-r^2) - sqrt(c^2-r^2)]."""
    inner = np.sqrt(np.clip(c * c - r * r, 0, None))
    return mu * p0 / a * (np.sqrt(np.clip(a * a - r * r, 0, None)) - inner)


class PackageTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.client = mdr.Client.embedded(ARGS.mdrd)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()

    def loaded(self):
        session = self.client.session(H1)
        session.apply({"normal_force": 100})
        return session

    def test_apply_returns_per_step_arrays_matching_h1(self):
        with self.loaded() as s:
            result = s.apply([{"tangential_force": f} for f in (5.0, 10.0, 15.0)])
            self.assertIsInstance(result.tangential_displacement, np.ndarray)
            self.assertEqual(result.tangential_force.shape, (3,))
            np.testing.assert_allclose(result.tangential_force, [5, 10, 15], rtol=1e-12)
            self.assertAlmostEqual(result.state.tangential_displacement / H1_DISPLACEMENT_15N, 1,
                                   delta=1e-9)
            np.testing.assert_array_equal(result.applied_steps, [2, 3, 4])
            none = s.apply({"tangential_force": 15.0}, outputs=())
            self.assertEqual(none.tangential_force.shape, (0,))

    def test_query_tractions_as_arrays_match_cattaneo_mindlin(self):
        with self.loaded() as s:
            s.apply({"tangential_force": 15.0})
            radii = np.linspace(0, H1_CONTACT_RADIUS, 41)
            q = s.query(["state", "tractions", "pressure"], radii=radii)
            np.testing.assert_array_equal(q.tractions["radius"], radii)
            # a from the state, c and p0 from it in closed form (the 10-digit reference values
            # are too coarse where sqrt(c^2 - r^2) is steep).
            a = q.state.contact_radius
            self.assertAlmostEqual(a / H1_CONTACT_RADIUS, 1, delta=1e-9)
            c = a * (1 - 15.0 / (0.3 * 100.0)) ** (1 / 3)
            self.assertAlmostEqual(c / H1_STICK_RADIUS_15N, 1, delta=1e-9)
            e_star = 1 / (2 * (1 - 0.3**2) / 210e9)
            p0 = 2 * e_star * a / (math.pi * 0.01)
            expected = cattaneo_mindlin_traction(radii, a, c, p0=p0)
            np.testing.assert_allclose(q.tractions["value"], expected, rtol=1e-8,
                                       atol=1e-8 * 0.3 * H1_P0)
            self.assertEqual(q.pressure["value"].shape, (41,))
            self.assertAlmostEqual(q.state.normal_force, 100, delta=1e-9)

    def test_stream_reads_the_input_only_as_results_are_consumed(self):
        pulled = []

        def steps():
            for k in range(200):
                pulled.append(k)
                yield {"displacement": 1e-9 * k}

        with self.loaded() as s:
            window, consumed = 4, 0
            for result in s.stream(steps(), window=window):
                consumed += 1
                self.assertLessEqual(len(pulled), consumed + window)
                self.assertEqual(result.state.applied_steps, consumed + 1)
            self.assertEqual(consumed, 200)

    def test_stream_error_names_the_item_and_what_was_applied_after_it(self):
        with self.loaded() as s:
            items = [{"depth": 1e-6}, {"depth": math.inf}, {"depth": 2e-6}]
            results = []
            with self.assertRaises(mdr.MdrError) as raised:
                for result in s.stream(items, window=8):
                    results.append(result)
            error = raised.exception
            self.assertEqual(len(results), 1)
            self.assertEqual(error.code, grpc.StatusCode.INVALID_ARGUMENT)
            self.assertEqual(error.field, "steps[0].depth")
            self.assertEqual(error.item, 1)
            # The third item is applied if it was sent before the error came back: either way,
            # applied_after tells the truth about the session.
            self.assertIn(error.applied_after, (0, 1))
            self.assertEqual(s.get().state.applied_steps, 2 + error.applied_after)

    def test_errors_carry_code_field_and_message(self):
        with self.loaded() as s:
            with self.assertRaises(mdr.MdrError) as raised:
                s.apply([{"depth": 1e-6}, {"depth": math.nan}])
            error = raised.exception
            self.assertEqual(error.code, grpc.StatusCode.INVALID_ARGUMENT)
            self.assertEqual(error.field, "steps[1].depth")
            self.assertIn("finite", error.message)
            self.assertEqual(s.get().state.applied_steps, 1)  # the batch changed nothing
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.get_session("sessions/none-such")
        self.assertEqual(raised.exception.code, grpc.StatusCode.NOT_FOUND)

    def test_session_context_manager_deletes_the_session(self):
        with self.client.session(H1) as s:
            name = s.name
            self.assertIn(name, [session.name for session in self.client.list_sessions()])
        with self.assertRaises(mdr.MdrError) as raised:
            self.client.get_session(name)
        self.assertEqual(raised.exception.code, grpc.StatusCode.NOT_FOUND)

    def test_export_import_continues_bit_for_bit(self):
        with self.loaded() as s:
            s.apply([{"tangential_force": 12.0}, {"tangential_force": -3.0}])
            with self.client.import_session(s.export()) as copy:
                step = [{"tangential_force": 7.5}]
                self.assertEqual(s.apply(step).state, copy.apply(step).state)

    def test_transform_turns_a_superposition_into_memory(self):
        depth = H1_DEPTH
        response = self.client.transform(H1, superposition={
            "depth": depth, "terms": [{"weight": 1.0, "depth_a": depth, "depth_c": 0.5 * depth}]})
        self.assertGreater(len(response.memory), 1)
        self.assertEqual(response.memory[-1].z, depth)

    def test_idempotent_calls_are_retried_on_unavailable_and_others_are_not(self):
        client = mdr.Client(self.client.address, max_attempts=3, initial_backoff=0.001)
        real = client._stub
        calls = []

        class Unavailable(grpc.RpcError):
            def code(self):
                return grpc.StatusCode.UNAVAILABLE

            def details(self):
                return "try again"

            def trailing_metadata(self):
                return ()

        class FlakyStub:
            def __getattr__(self, method):
                def call(request, **kwargs):
                    calls.append(method)
                    if calls.count(method) == 1:
                        raise Unavailable()
                    return getattr(real, method)(request, **kwargs)
                return call

        client._stub = FlakyStub()
        try:
            self.assertEqual(len(client.list_sessions()), len(self.client.list_sessions()))
            self.assertEqual(calls.count("ListSessions"), 2)
            with self.assertRaises(mdr.MdrError) as raised:
                client.create_session(H1)
            self.assertEqual(raised.exception.code, grpc.StatusCode.UNAVAILABLE)
            self.assertEqual(calls.count("CreateSession"), 1)
        finally:
            client.close()

    def test_every_call_naming_a_session_carries_its_routing_id(self):
        client = mdr.Client(self.client.address)
        real, seen = client._stub, []

        class RecordingStub:
            def __getattr__(self, method):
                def call(request, **kwargs):
                    seen.append((method, dict(kwargs.get("metadata", ()))))
                    return getattr(real, method)(request, **kwargs)
                return call

        client._stub = RecordingStub()
        try:
            with client.session(H1) as s:
                s.apply({"depth": 1e-6})
                s.query(["state"])
                s.export()
            session_id = s.name.removeprefix("sessions/")
            self.assertRegex(session_id, r"^c[0-9a-f]{16}$")  # chosen by the client
            methods = [method for method, _ in seen]
            self.assertEqual(methods, ["CreateSession", "Apply", "Query", "ExportSession",
                                       "DeleteSession"])
            for method, metadata in seen:
                self.assertEqual(metadata.get(mdr.client.SESSION_ROUTING_KEY), session_id, method)
        finally:
            client.close()

    def test_scene_files_load_like_mdrctl_reads_them(self):
        path = os.path.join(ARGS.source_dir, "examples", "fretting_mindlin_deresiewicz.yaml")
        scene_file = mdr.load_scene_file(path)
        self.assertEqual(scene_file.scene.elastic_pair.youngs_modulus_1, 210e9)  # YAML "210e9"
        self.assertEqual(scene_file.scene.friction, 0.3)
        with self.assertRaises(ValueError):
            mdr.to_scene({"sphere": {"radius": 0.01}, "no_such_field": 1})
        for name in ("deep.yaml", "deep.json"):  # deeper than the parsers recurse
            deep = os.path.join(ARGS.out_dir, name)
            with open(deep, "w", encoding="utf-8") as out:
                out.write('{"scene": ' + "[" * 100000 + "]" * 100000 + "}")
            with self.assertRaisesRegex(ValueError, "nested too deep to parse"):
                mdr.load_scene_file(deep)

    def test_embedded_server_takes_long_runs_unless_told_otherwise(self):
        def limit(args=(), env=None):
            saved = os.environ.get("MDR_MAX_MESSAGE_BYTES")
            if env is not None:
                os.environ["MDR_MAX_MESSAGE_BYTES"] = env
            try:
                server = mdr.embedded.EmbeddedServer(ARGS.mdrd, args)
            finally:
                if env is not None:
                    if saved is None:
                        del os.environ["MDR_MAX_MESSAGE_BYTES"]
                    else:
                        os.environ["MDR_MAX_MESSAGE_BYTES"] = saved
            server.stop()
            return int(re.search(r"max_message_bytes=(\d+)", "".join(server.log)).group(1))
        self.assertEqual(limit(), mdr.embedded.EMBEDDED_MAX_MESSAGE_BYTES)
        self.assertEqual(limit(["--max-message-bytes=6000000"]), 6000000)
        self.assertEqual(limit(env="5000000"), 5000000)

    def test_embedded_server_stops_on_close(self):
        client = mdr.Client.embedded(ARGS.mdrd)
        process = client._server.process
        client.close()
        self.assertIsNotNone(process.poll())


class ExamplesTest(unittest.TestCase):
    def run_example(self, *args):
        env = dict(os.environ, MDR_MDRD=ARGS.mdrd)
        return subprocess.run([sys.executable, *args], check=True, cwd=ARGS.source_dir, env=env,
                              timeout=120, stdout=subprocess.PIPE, text=True).stdout

    def test_fretting_loop_writes_its_png(self):
        out = os.path.join(ARGS.out_dir, "fretting_loop.png")
        if os.path.exists(out):
            os.remove(out)
        self.run_example("examples/python/fretting_loop.py", out)
        with open(out, "rb") as png:
            data = png.read()
        self.assertEqual(data[:8], b"\x89PNG\r\n\x1a\n")
        self.assertGreater(len(data), 10000)

    def test_rig_stream_writes_one_row_of_forces_per_sample(self):
        source = os.path.join(ARGS.source_dir, "examples", "python", "rig_displacements.csv")
        out = os.path.join(ARGS.out_dir, "rig_forces.csv")
        self.run_example("examples/python/rig_stream.py", source, out, "100")
        with open(source, newline="") as stream:
            displacements = [float(row["displacement_m"]) for row in csv.DictReader(stream)]
        with open(out, newline="") as stream:
            rows = list(csv.DictReader(stream))
        self.assertEqual(len(rows), len(displacements))
        for row, u in zip(rows, displacements):
            self.assertEqual(float(row["displacement_m"]), u)
            self.assertAlmostEqual(float(row["normal_force_N"]), 100, delta=1e-9)
            self.assertLessEqual(abs(float(row["tangential_force_N"])), 30 * (1 + 1e-12))
        energies = [float(row["dissipated_energy_J"]) for row in rows]
        self.assertTrue(all(b >= a for a, b in zip(energies, energies[1:])))
        self.assertGreater(energies[-1], 0)

    def test_rough_interface_dissipates_its_loop_area_in_every_steady_cycle(self):
        out = self.run_example("examples/python/rough_interface.py", "3")
        rows = [tuple(float(value) for value in match) for match in re.findall(
            r"^cycle \d+: dissipated (\S+) J, loop area (\S+) J, partial slip (\d+), "
            r"gross slip (\d+), F_N (\S+) N$", out, re.MULTILINE)]
        self.assertEqual(len(rows), 3, out)
        for dissipated, loop_area, partial, gross, normal_force in rows:
            self.assertGreater(dissipated, 0)
            self.assertGreater(partial, 0)
            self.assertAlmostEqual(normal_force / 700, 1, delta=1e-11)  # the load is held
        # From the second cycle on: steady, and the loop's area is the dissipated energy up to
        # the trapezoidal rule's error (1.6e-4 at 40 steps per quarter).
        self.assertAlmostEqual(rows[2][0] / rows[1][0], 1, delta=1e-9)
        for dissipated, loop_area, *_ in rows[1:]:
            self.assertAlmostEqual(loop_area / dissipated, 1, delta=1e-3)
        self.assertNotAlmostEqual(rows[0][0] / rows[1][0], 1, delta=1e-3)  # the virgin cycle


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("--out-dir", required=True)
    ARGS, rest = parser.parse_known_args()
    os.makedirs(ARGS.out_dir, exist_ok=True)
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
