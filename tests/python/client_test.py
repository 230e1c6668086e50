#!/usr/bin/python3
"""End-to-end test of mdrd from Python: generates the stubs at test time, starts mdrd
on a free port, streams loading steps and checks the forces against the Hertz and
Cattaneo-Mindlin closed forms, the error details, the configuration precedence (flag over
environment) and the drain on SIGTERM.

Usage: client_test.py --mdrd PATH --proto-dir DIR --out-dir DIR
"""
import argparse
import math
import os
import queue
import re
import signal
import subprocess
import sys
import threading
import time
import unittest

ARGS = None

# Reference vector H1: steel sphere R = 10 mm on a steel flat, mu = 0.3.
YOUNGS_MODULUS, POISSON_RATIO, RADIUS, FRICTION = 210e9, 0.3, 0.01, 0.3
E_STAR = 1 / (2 * (1 - POISSON_RATIO**2) / YOUNGS_MODULUS)
G_STAR = 1 / (2 * (2 - POISSON_RATIO) / (4 * YOUNGS_MODULUS / (2 * (1 + POISSON_RATIO))))
KAPPA = E_STAR / G_STAR


def hertz_normal_force(depth):
    return 4 / 3 * E_STAR * math.sqrt(RADIUS) * depth**1.5


def hertz_depth(normal_force):
    return (3 * normal_force / (4 * E_STAR * math.sqrt(RADIUS))) ** (2 / 3)


def cattaneo_mindlin_tangential_force(depth, displacement):
    s = 1 - (1 - displacement / (FRICTION * KAPPA * depth)) ** 1.5
    return s * FRICTION * hertz_normal_force(depth)


def protoc_command(out_dir):
    """grpc_tools.protoc when its bundled protoc knows proto3 `optional` (>= 3.15); otherwise
    (Debian 12 ships grpc_tools 1.14 with protoc 3.5.1) the system protoc with gRPC's Python
    plugin from protobuf-compiler-grpc, which generate the same modules."""
    outputs = [f"--python_out={out_dir}", f"--grpc_python_out={out_dir}"]
    version = subprocess.run([sys.executable, "-m", "grpc_tools.protoc", "--version"],
                             capture_output=True, text=True).stdout.split()[-1:]
    if version and tuple(int(p) for p in version[0].split(".")[:2]) >= (3, 15):
        import grpc_tools
        well_known = os.path.join(os.path.dirname(grpc_tools.__file__), "_proto")
        return [sys.executable, "-m", "grpc_tools.protoc", f"-I{well_known}"] + outputs
    return ["protoc", "--plugin=protoc-gen-grpc_python=/usr/bin/grpc_python_plugin"] + outputs


def generate_stubs(proto_dir, out_dir):
    """Generates the API's Python modules into out_dir (the build tree, not committed)."""
    os.makedirs(out_dir, exist_ok=True)
    protos = ["mdr/v1/scene.proto", "mdr/v1/contact_service.proto",
              "google/rpc/status.proto", "google/rpc/error_details.proto"]
    subprocess.run(protoc_command(out_dir) + [f"-I{proto_dir}"] + protos, check=True)
    sys.path.insert(0, out_dir)


class Mdrd:
    """mdrd on a free port without a journal (each run starts empty); the port and the effective
    configuration are read from its log."""

    def __init__(self, mdrd, extra_args=(), env=None):
        environment = dict(os.environ)
        environment.update(env or {})
        self.process = subprocess.Popen(
            [mdrd, "--listen", "127.0.0.1:0", "--no-journal", "--shutdown-grace", "5",
             *extra_args],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=environment)
        self.lines = queue.Queue()
        self.log = []
        threading.Thread(target=self._pump, daemon=True).start()
        self.config = self.wait_for("event=config")
        self.port = int(re.search(r"port=(\d+)", self.wait_for("event=serving")).group(1))

    def _pump(self):
        for line in self.process.stdout:
            self.lines.put(line)

    def wait_for(self, needle, timeout=10):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=0.1)
            except queue.Empty:
                if self.process.poll() is not None:
                    raise AssertionError(f"mdrd exited early: {''.join(self.log)}")
                continue
            self.log.append(line)
            if needle in line:
                return line
        raise AssertionError(f"no '{needle}' in mdrd's log: {''.join(self.log)}")

    def stop(self):
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


class MdrdClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        generate_stubs(ARGS.proto_dir, ARGS.out_dir)
        global grpc, pb, rpc, status_pb2, error_details_pb2
        import grpc
        from mdr.v1 import contact_service_pb2 as pb
        from mdr.v1 import contact_service_pb2_grpc as rpc
        from google.rpc import status_pb2, error_details_pb2
        # MDR_MAX_STEPS_PER_BATCH is overridden by the flag; MDR_MAX_SESSIONS applies.
        cls.server = Mdrd(ARGS.mdrd, ["--max-steps-per-batch", "64"],
                          env={"MDR_MAX_STEPS_PER_BATCH": "5", "MDR_MAX_SESSIONS": "7"})
        cls.channel = grpc.insecure_channel(f"127.0.0.1:{cls.server.port}")
        grpc.channel_ready_future(cls.channel).result(timeout=10)
        cls.stub = rpc.ContactServiceStub(cls.channel)

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        cls.server.stop()

    def scene(self, radius=RADIUS):
        from mdr.v1 import scene_pb2
        scene = scene_pb2.Scene(friction=FRICTION)
        scene.sphere.radius = radius
        pair = scene.elastic_pair
        pair.youngs_modulus_1 = pair.youngs_modulus_2 = YOUNGS_MODULUS
        pair.poisson_ratio_1 = pair.poisson_ratio_2 = POISSON_RATIO
        return scene

    def create_session(self):
        request = pb.CreateSessionRequest()
        request.session.scene.CopyFrom(self.scene())
        return self.stub.CreateSession(request, timeout=10)

    def message(self, session, steps, mask=("state",)):
        request = pb.StreamApplyRequest()
        request.apply.session = session
        request.apply.steps.extend(steps)
        request.apply.step_mask.paths.extend(mask)
        return request

    def test_health_reports_readiness(self):
        # grpc.health.v1 by hand: HealthCheckRequest{service: "readiness"} and the status field.
        check = self.channel.unary_unary("/grpc.health.v1.Health/Check")
        service = b"readiness"
        answer = check(b"\x0a" + bytes([len(service)]) + service, timeout=10)
        self.assertEqual(answer, b"\x08\x01")  # status: SERVING

    def test_configuration_flag_wins_over_environment(self):
        self.assertIn("max_steps_per_batch=64", self.server.config)
        self.assertIn("max_sessions=7", self.server.config)
        session = self.create_session()
        self.assertEqual(session.limits.max_steps_per_batch, 64)

    def test_streamed_steps_follow_hertz_and_cattaneo_mindlin(self):
        from mdr.v1 import scene_pb2
        session = self.create_session().name
        normal_force = 100.0
        depth = hertz_depth(normal_force)
        full_slip = FRICTION * KAPPA * depth
        increments = 40
        messages = [self.message(session, [scene_pb2.Step(normal_force=normal_force)])]
        for k in range(1, increments + 1):  # up to 95 % of the full-slip displacement
            messages.append(self.message(
                session, [scene_pb2.Step(displacement=0.95 * full_slip * k / increments)]))
        answers = list(self.stub.StreamApply(iter(messages), timeout=30))
        self.assertEqual(len(answers), len(messages))
        for k, answer in enumerate(answers):
            self.assertEqual(answer.status.code, 0, answer.status.message)
            state = answer.result.step_results[0].state
            self.assertEqual(state.applied_steps, k + 1)
            self.assertAlmostEqual(state.normal_force / normal_force, 1, delta=1e-9)
            self.assertAlmostEqual(state.depth / depth, 1, delta=1e-9)
            self.assertAlmostEqual(state.contact_radius / math.sqrt(RADIUS * depth), 1,
                                   delta=1e-9)
            expected = cattaneo_mindlin_tangential_force(depth, state.tangential_displacement)
            self.assertLessEqual(abs(state.tangential_force - expected), 1e-9 * abs(expected) + 1e-12,
                                 f"message {k}")
        # 95 % of full slip: F_x = (1 - 0.05^1.5) mu F_N.
        self.assertAlmostEqual(answers[-1].result.state.tangential_force,
                               (1 - 0.05**1.5) * FRICTION * normal_force, delta=1e-7)

    def test_errors_name_the_field_in_details(self):
        from mdr.v1 import scene_pb2
        session = self.create_session().name
        bad_step = scene_pb2.Step(depth=float("nan"))
        answers = list(self.stub.StreamApply(iter([
            self.message(session, [scene_pb2.Step(depth=1e-6), bad_step]),
            self.message(session, [scene_pb2.Step(depth=1e-6)] * 65),
            self.message(session, [scene_pb2.Step(depth=1e-6)]),
        ]), timeout=10))
        self.assertEqual(answers[0].status.code, grpc.StatusCode.INVALID_ARGUMENT.value[0])
        bad_request = error_details_pb2.BadRequest()
        self.assertTrue(answers[0].status.details[0].Unpack(bad_request))
        self.assertEqual(bad_request.field_violations[0].field, "steps[1].depth")
        self.assertEqual(answers[1].status.code, grpc.StatusCode.RESOURCE_EXHAUSTED.value[0])
        self.assertIn("limit of 64", answers[1].status.message)
        self.assertEqual(answers[2].status.code, 0)
        self.assertEqual(answers[2].result.state.applied_steps, 1)

        request = pb.CreateSessionRequest()
        request.session.scene.CopyFrom(self.scene(radius=-1))
        with self.assertRaises(grpc.RpcError) as raised:
            self.stub.CreateSession(request, timeout=10)
        self.assertEqual(raised.exception.code(), grpc.StatusCode.INVALID_ARGUMENT)
        details = dict(raised.exception.trailing_metadata())["grpc-status-details-bin"]
        rich = status_pb2.Status.FromString(details)
        rich.details[0].Unpack(bad_request)
        self.assertEqual(bad_request.field_violations[0].field, "session.scene.sphere.radius")

    def test_tractions_match_cattaneo_mindlin(self):
        from mdr.v1 import scene_pb2
        session = self.create_session().name
        depth = hertz_depth(100.0)
        displacement = FRICTION * KAPPA * depth * (1 - (1 - 0.15 / FRICTION) ** (2 / 3))
        apply = pb.ApplyRequest(session=session, steps=[scene_pb2.Step(depth=depth),
                                                        scene_pb2.Step(displacement=displacement)])
        self.assertAlmostEqual(self.stub.Apply(apply, timeout=10).state.tangential_force, 15,
                               delta=1e-7)
        query = pb.QueryRequest(session=session, radii=[0.0],
                                traction_route=pb.TRACTION_ROUTE_BOTH)
        query.read_mask.paths.extend(["tractions", "slip_intervals", "state.contact_radius"])
        answer = self.stub.Query(query, timeout=10)
        a, c = answer.state.contact_radius, answer.slip_intervals[0].r_begin
        # tau(0) = mu [p(0; a) - p(0; c)] with the Hertz peak p(0; a) = 2 E* a / (pi R).
        expected = FRICTION * 2 * E_STAR * (a - c) / (math.pi * RADIUS)
        traction = answer.tractions[0]
        self.assertEqual(traction.route, pb.TRACTION_ROUTE_BOTH)
        self.assertAlmostEqual(traction.value / expected, 1, delta=1e-9)
        self.assertAlmostEqual(traction.abel / traction.jager, 1, delta=1e-9)
        peak = FRICTION * 2 * E_STAR * a / (math.pi * RADIUS)
        self.assertLess(answer.error_estimate.traction_error, 1e-9 * peak)

    def test_zz_sigterm_drains_open_streams(self):  # last: stops the server
        from mdr.v1 import scene_pb2
        session = self.create_session().name
        outbox = queue.Queue()
        responses = self.stub.StreamApply(iter(outbox.get, None), timeout=30)
        outbox.put(self.message(session, [scene_pb2.Step(depth=1e-6)]))
        self.assertEqual(next(responses).status.code, 0)
        self.server.process.send_signal(signal.SIGTERM)
        with self.assertRaises(grpc.RpcError) as raised:
            next(responses)
        self.assertEqual(raised.exception.code(), grpc.StatusCode.UNAVAILABLE)
        self.assertIn("shutting down", raised.exception.details())
        outbox.put(None)
        self.assertEqual(self.server.process.wait(timeout=10), 0)
        self.server.wait_for("event=stopped")


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--proto-dir", required=True)
    parser.add_argument("--out-dir", required=True)
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
