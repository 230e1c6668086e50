#!/usr/bin/python3
"""Crash test of the session journal against the real mdrd binary.

mdrd runs with a journal in a temporary directory (snapshots every 25 batches, so the crash
falls between compactions); a client streams random batches of 1-3 steps (each with a request id)
into one session and, after a number of responses, kills mdrd with SIGKILL while messages are
still in flight. mdrd restarts on the same journal, and the test checks:
- every acknowledged batch is there, and the restored session is bit for bit (ExportSession) a
  reference session that applied exactly the batches the journal holds: the acknowledged ones and
  possibly a few whole batches whose responses were lost in the crash (journaled before they
  were answered), never part of a batch;
- a retry of such a batch with its request id is recognised (replayed, not applied twice) while
  it is among the session's last 64 batches (the request ids survive the restart and
  compaction), and the first batch that was not applied is applied by its retry;
- a deleted session stays deleted.

Usage: journal_crash_test.py --mdrd PATH --proto-dir DIR --out-dir DIR --python-tests DIR
"""
import argparse
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time

BATCHES_SENT = 2000
ACKNOWLEDGED_BEFORE_KILL = 300
REMEMBERED_REQUEST_IDS = 64  # CompletedRequests::kCapacity

# Reference vector H1: steel sphere R = 10 mm on a steel flat, mu = 0.3, F_N = 100 N.
YOUNGS_MODULUS, POISSON_RATIO, RADIUS, FRICTION = 210e9, 0.3, 0.01, 0.3
DEPTH = 3.4829098839e-6
KAPPA = (1 / (2 * (1 - POISSON_RATIO**2) / YOUNGS_MODULUS)) / (
    1 / (2 * (2 - POISSON_RATIO) / (4 * YOUNGS_MODULUS / (2 * (1 + POISSON_RATIO)))))


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


class Mdrd:
    """mdrd on a free port with a journal; the port is read from its log."""

    def __init__(self, mdrd, journal, log_path):
        self.log_path = log_path
        self.log = open(log_path, "a")
        start = os.path.getsize(log_path)
        self.process = subprocess.Popen(
            [mdrd, "--listen", "127.0.0.1:0", "--journal", journal, "--journal-sync", "normal",
             "--journal-snapshot-every", "25", "--log-level", "info"],
            stdout=self.log, stderr=subprocess.STDOUT)
        for _ in range(200):
            text = open(log_path).read()[start:]
            found = re.search(r"event=serving .*port=(\d+)", text)
            if found:
                self.port = int(found.group(1))
                self.startup_log = text
                return
            if self.process.poll() is not None:
                fail(f"mdrd exited early:\n{text}")
            time.sleep(0.05)
        fail("mdrd did not start")


def random_batches(scene_pb2, count, seed):
    generator = random.Random(seed)
    batches = []
    for _ in range(count):
        steps = []
        for _ in range(generator.randint(1, 3)):
            depth = DEPTH * generator.uniform(0.6, 1.4)
            steps.append(scene_pb2.Step(
                depth=depth,
                displacement=generator.uniform(-0.8, 0.8) * FRICTION * KAPPA * depth))
        batches.append(steps)
    return batches


def main():
    parser = argparse.ArgumentParser()
    for name in ("--mdrd", "--proto-dir", "--out-dir", "--python-tests"):
        parser.add_argument(name, required=True)
    args = parser.parse_args()
    sys.path.insert(0, args.python_tests)
    from client_test import generate_stubs  # the API's Python modules, generated at test time
    generate_stubs(args.proto_dir, args.out_dir)
    import grpc
    from mdr.v1 import contact_service_pb2 as pb
    from mdr.v1 import contact_service_pb2_grpc as rpc
    from mdr.v1 import scene_pb2

    scene = scene_pb2.Scene(friction=FRICTION)
    scene.sphere.radius = RADIUS
    pair = scene.elastic_pair
    pair.youngs_modulus_1 = pair.youngs_modulus_2 = YOUNGS_MODULUS
    pair.poisson_ratio_1 = pair.poisson_ratio_2 = POISSON_RATIO
    batches = random_batches(scene_pb2, BATCHES_SENT, seed=2024)
    name = "sessions/crash"

    def request(index, session=name):
        return pb.ApplyRequest(session=session, steps=batches[index],
                               request_id=f"batch-{index}")

    with tempfile.TemporaryDirectory() as directory:
        journal = os.path.join(directory, "journal.sqlite")
        log_path = os.path.join(directory, "mdrd.log")
        open(log_path, "w").close()

        server = Mdrd(args.mdrd, journal, log_path)
        channel = grpc.insecure_channel(f"127.0.0.1:{server.port}")
        stub = rpc.ContactServiceStub(channel)
        for session_id in ("crash", "deleted"):
            stub.CreateSession(pb.CreateSessionRequest(session=pb.Session(scene=scene),
                                                       session_id=session_id), timeout=10)
        stub.DeleteSession(pb.DeleteSessionRequest(name="sessions/deleted"), timeout=10)

        def messages():
            for index in range(BATCHES_SENT):
                yield pb.StreamApplyRequest(apply=request(index))

        acknowledged = 0
        try:
            for response in stub.StreamApply(messages(), timeout=60):
                if response.status.code != 0:
                    fail(f"batch {acknowledged}: {response.status.message}")
                acknowledged += 1
                if acknowledged == ACKNOWLEDGED_BEFORE_KILL:
                    server.process.send_signal(signal.SIGKILL)
                    server.process.wait()
                    break
        except grpc.RpcError:
            pass  # the stream ends with the server
        channel.close()
        if acknowledged != ACKNOWLEDGED_BEFORE_KILL:
            fail(f"only {acknowledged} responses before the stream ended")

        server = Mdrd(args.mdrd, journal, log_path)
        restored_log = re.search(r"event=journal_restored .*", server.startup_log)
        print("restart:", restored_log.group(0) if restored_log else "no journal_restored line")
        channel = grpc.insecure_channel(f"127.0.0.1:{server.port}")
        stub = rpc.ContactServiceStub(channel)
        restored = stub.ExportSession(pb.ExportSessionRequest(name=name), timeout=10)

        # The batches the journal held: a whole number of them, at least the acknowledged ones.
        steps_after, total = [0], 0
        for steps in batches:
            total += len(steps)
            steps_after.append(total)
        if restored.applied_steps not in steps_after:
            fail(f"{restored.applied_steps} steps restored: part of a batch was applied")
        held = steps_after.index(restored.applied_steps)
        if held < acknowledged:
            fail(f"only {held} batches restored, {acknowledged} were acknowledged")
        print(f"acknowledged {acknowledged} batches, restored {held} "
              f"({held - acknowledged} journaled whose responses the crash lost)")

        # The reference: a session without any crash that applied exactly those batches.
        stub.CreateSession(pb.CreateSessionRequest(session=pb.Session(scene=scene),
                                                   session_id="reference"), timeout=10)
        for index in range(held):
            stub.Apply(request(index, "sessions/reference"), timeout=10)
        reference = stub.ExportSession(pb.ExportSessionRequest(name="sessions/reference"),
                                       timeout=10)
        if restored.contact.SerializeToString() != reference.contact.SerializeToString():
            fail("the restored contact differs from the reference")
        if restored.applied_steps != reference.applied_steps:
            fail("applied_steps differ from the reference")
        print(f"restored state equals the reference bit for bit ({restored.applied_steps} steps, "
              f"{len(restored.contact.memory)} memory vertices)")

        # Retries: the unacknowledged batches that were applied are recognised as far as the
        # session remembers request ids (its last 64 batches, across the restart and the last
        # compaction), and the first batch that was not applied is applied.
        remembered = range(max(acknowledged, held - REMEMBERED_REQUEST_IDS), held)
        for index in remembered:
            if not stub.Apply(request(index), timeout=10).replayed:
                fail(f"the retry of batch {index} was applied twice")
        retried = stub.Apply(request(held), timeout=10)
        if retried.replayed or retried.state.applied_steps != steps_after[held + 1]:
            fail(f"the retry of batch {held} (never applied) was not applied")
        print(f"retries: {len(remembered)} recognised as applied, batch {held} applied")

        try:
            stub.GetSession(pb.GetSessionRequest(name="sessions/deleted"), timeout=10)
            fail("the deleted session came back")
        except grpc.RpcError as error:
            if error.code() != grpc.StatusCode.NOT_FOUND:
                fail(f"deleted session: {error.code()}")
        channel.close()
        server.process.send_signal(signal.SIGTERM)
        if server.process.wait(timeout=30) != 0:
            fail("mdrd did not exit 0 on SIGTERM")
    print("journal crash test: ok")


if __name__ == "__main__":
    main()
