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

Then a fretting history (a Hertz session driven back and forth, FRETTING_STEPS steps) with a
SIGKILL after EVERY step and a restart, once with --journal-snapshot-every 1 and once with the
default, the sync mode changing from step to step: every restart must succeed (a SIGKILL is never
taken for damage) and restore the session bit for bit, compared with a reference mdrd without a
journal fed the same steps. Amplitudes: 0.6 of the displacement at the friction limit (four
steps a quarter cycle) and the dense small-amplitude variants 0.02 and 0.001 (eight steps a
quarter cycle), whose states today's Contact::Restore accepts too. The same for two interface
sessions of three Hertz summits (INTERFACE_STEPS steps each): a shared motion pressed to a total
normal force and fretted by total tangential forces and displacements, and a contact list whose
steps carry one value per contact (depths, increments, tangential force targets).

Finally damaged journals against the binary: a truncated write-ahead log, flipped bytes in it
and a dropped table each make mdrd exit 1 with a message naming the file and the damage; with
--journal-recover it starts from what is intact, logs what was dropped, and the next start
without the flag succeeds.

Usage: journal_crash_test.py --mdrd PATH --python-dir BUILD/python
"""
import argparse
import os
import random
import re
import shutil
import signal
import sqlite3
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


STARTED = []  # every mdrd this test started, ended on failure


def fail(message):
    print("FAIL:", message)
    for process in STARTED:
        if process.poll() is None:
            process.kill()
    sys.exit(1)


class Mdrd:
    """mdrd on a free port with a journal; the port is read from its log."""

    def __init__(self, mdrd, journal, log_path, snapshot_every="25", sync="normal", extra=()):
        self.log_path = log_path
        self.log = open(log_path, "a")
        start = os.path.getsize(log_path)
        journal_flags = ["--no-journal"] if journal is None else [
            "--journal", journal, "--journal-sync", sync,
            "--journal-snapshot-every", snapshot_every]
        self.process = subprocess.Popen(
            [mdrd, "--listen", "127.0.0.1:0", "--log-level", "info"] + journal_flags +
            list(extra), stdout=self.log, stderr=subprocess.STDOUT)
        STARTED.append(self.process)
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


FRETTING_STEPS = 30


def fretting_steps(scene_pb2, amplitude, per_quarter):
    """A depth step, then the displacement driven back and forth (a triangle wave)."""
    steps = [scene_pb2.Step(depth=DEPTH)]
    peak = amplitude * FRICTION * KAPPA * DEPTH
    period = 4 * per_quarter
    for k in range(1, FRETTING_STEPS):
        phase = k % period
        triangle = (phase if phase <= per_quarter else
                    2 * per_quarter - phase if phase <= 3 * per_quarter else phase - period)
        steps.append(scene_pb2.Step(depth=DEPTH, displacement=peak * triangle / per_quarter))
    return steps


def kill_after_every_step(args, grpc, pb, rpc, scene, steps, snapshot_every, directory,
                          label=None):
    """SIGKILL after every step; each restart restores the session bit for bit."""
    label = label or f"fretting-{len(steps)}-{steps[-1].displacement:.3g}"
    run = f"{label}-{snapshot_every}"
    journal = os.path.join(directory, f"{run}.sqlite")
    log_path = os.path.join(directory, f"{run}.log")
    open(log_path, "w").close()
    reference_server = Mdrd(args.mdrd, None, os.path.join(directory, "reference.log"))
    reference_channel = grpc.insecure_channel(f"127.0.0.1:{reference_server.port}")
    reference = rpc.ContactServiceStub(reference_channel)
    name = "sessions/fretting"
    syncs = ("off", "normal", "full")
    server = Mdrd(args.mdrd, journal, log_path, snapshot_every, syncs[0])
    for stub in (rpc.ContactServiceStub(grpc.insecure_channel(f"127.0.0.1:{server.port}")),
                 reference):
        stub.CreateSession(pb.CreateSessionRequest(session=pb.Session(scene=scene),
                                                   session_id="fretting"), timeout=10)
    for index, step in enumerate(steps):
        channel = grpc.insecure_channel(f"127.0.0.1:{server.port}")
        rpc.ContactServiceStub(channel).Apply(
            pb.ApplyRequest(session=name, steps=[step], request_id=f"step-{index}"), timeout=10)
        channel.close()
        reference.Apply(pb.ApplyRequest(session=name, steps=[step]), timeout=10)
        server.process.send_signal(signal.SIGKILL)
        server.process.wait()
        server = Mdrd(args.mdrd, journal, log_path, snapshot_every, syncs[(index + 1) % 3])
        if "level=critical" in server.startup_log or "level=error" in server.startup_log:
            fail(f"restart after step {index}:\n{server.startup_log}")
        channel = grpc.insecure_channel(f"127.0.0.1:{server.port}")
        restored = rpc.ContactServiceStub(channel).ExportSession(
            pb.ExportSessionRequest(name=name), timeout=10)
        channel.close()
        expected = reference.ExportSession(pb.ExportSessionRequest(name=name), timeout=10)
        if (restored.SerializeToString(deterministic=True) !=
                expected.SerializeToString(deterministic=True)):
            fail(f"snapshot every {snapshot_every}: after step {index} the restored session "
                 f"differs from the reference")
    server.process.send_signal(signal.SIGTERM)
    reference_server.process.send_signal(signal.SIGTERM)
    if server.process.wait(timeout=30) != 0 or reference_server.process.wait(timeout=30) != 0:
        fail("mdrd did not exit 0 on SIGTERM")
    reference_channel.close()
    print(f"{label}, snapshot every {snapshot_every}: {len(steps)} SIGKILLs, every restart "
          f"restored the session bit for bit")


INTERFACE_STEPS = 12
SUMMIT_HEIGHTS = (0.0, 0.4 * DEPTH, -0.3 * DEPTH)  # explicit population around the H1 depth
SUMMIT_RADII = (RADIUS, 0.5 * RADIUS, 2 * RADIUS)


def interface_scene(scene, kind):
    """The H1 material and friction as an interface of three Hertz summits."""
    interface = type(scene)()
    interface.CopyFrom(scene)
    interface.interface.kind = kind
    interface.interface.explicit_list.heights.extend(SUMMIT_HEIGHTS)
    interface.interface.explicit_list.radii.extend(SUMMIT_RADII)
    return interface


def shared_motion_steps(scene_pb2):
    """Pressed to a total force, then fretted by total tangential forces and displacements."""
    peak = 0.6 * FRICTION * KAPPA * DEPTH
    steps = [scene_pb2.Step(depth=DEPTH), scene_pb2.Step(normal_force=150.0)]
    for k in range(INTERFACE_STEPS - 2):
        steps.append(scene_pb2.Step(tangential_force=(-1) ** k * 20.0) if k % 3 == 2 else
                     scene_pb2.Step(displacement=peak * (-0.8) ** k))
    return steps


def contact_list_steps(scene_pb2):
    """Each contact pressed and sheared its own way, per-contact force targets included."""
    generator = random.Random(17)
    steps = [scene_pb2.Step(depth=0, contact_normal_values=[DEPTH, 0.5 * DEPTH, 1.2 * DEPTH])]
    for k in range(INTERFACE_STEPS - 1):
        if k % 4 == 3:
            steps.append(scene_pb2.Step(
                tangential_force=0,
                contact_tangential_values=[generator.uniform(-5, 5) for _ in SUMMIT_RADII]))
            continue
        slip = FRICTION * KAPPA * DEPTH
        steps.append(scene_pb2.Step(
            depth_increment=0,
            contact_normal_values=[generator.uniform(-0.05, 0.05) * DEPTH for _ in SUMMIT_RADII],
            displacement_increment=0,
            contact_tangential_values=[generator.uniform(-0.3, 0.3) * slip for _ in SUMMIT_RADII]))
    return steps


def run_to_exit(mdrd, journal, extra=()):
    """mdrd that must refuse to start: its exit code and output."""
    result = subprocess.run(
        [mdrd, "--listen", "127.0.0.1:0", "--journal", journal] + list(extra),
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=30)
    return result.returncode, result.stdout


def damaged_journals(args, grpc, pb, rpc, scene_pb2, scene, directory):
    """Truncated log, flipped log bytes, dropped table: refused, then recovered on request."""
    journal = os.path.join(directory, "killed.sqlite")
    log_path = os.path.join(directory, "killed.log")
    open(log_path, "w").close()
    server = Mdrd(args.mdrd, journal, log_path)
    channel = grpc.insecure_channel(f"127.0.0.1:{server.port}")
    stub = rpc.ContactServiceStub(channel)
    stub.CreateSession(pb.CreateSessionRequest(session=pb.Session(scene=scene),
                                               session_id="kept"), timeout=10)
    for depth in (0.5, 1.0, 0.8, 1.2, 1.1):
        stub.Apply(pb.ApplyRequest(session="sessions/kept",
                                   steps=[scene_pb2.Step(depth=depth * DEPTH)]), timeout=10)
    channel.close()
    server.process.send_signal(signal.SIGKILL)
    server.process.wait()

    def truncate_log(path):
        with open(path + "-wal", "r+b") as log:
            log.truncate(os.path.getsize(path + "-wal") - 100)

    def flip_log_byte(path):
        with open(path + "-wal", "r+b") as log:
            log.seek(os.path.getsize(path + "-wal") * 3 // 4)
            byte = log.read(1)
            log.seek(-1, 1)
            log.write(bytes([byte[0] ^ 0x5A]))

    def drop_table(path):
        connection = sqlite3.connect(path)
        connection.execute("DROP TABLE batches")
        connection.commit()
        connection.close()

    lost = " missing: the database ends at commit"
    for damage, expected in ((truncate_log, lost), (flip_log_byte, lost),
                             (drop_table, "table batches is missing")):
        image = os.path.join(directory, f"{damage.__name__}.sqlite")
        for suffix in ("", "-wal", ".commit"):
            shutil.copyfile(journal + suffix, image + suffix)
        damage(image)
        code, output = run_to_exit(args.mdrd, image)
        if code != 1 or f'"{image}" is damaged' not in output or expected not in output:
            fail(f"{damage.__name__}: mdrd exited {code}:\n{output}")
        if "--journal-recover" not in output:
            fail(f"{damage.__name__}: the refusal does not name --journal-recover:\n{output}")
        recover_log = os.path.join(directory, f"{damage.__name__}.log")
        open(recover_log, "w").close()
        recovered = Mdrd(args.mdrd, image, recover_log, extra=["--journal-recover"])
        dropped = re.findall(r"event=journal_recovery_dropped .*", recovered.startup_log)
        if not dropped or expected not in "".join(dropped):
            fail(f"{damage.__name__}: the recovery did not log the drop:\n"
                 f"{recovered.startup_log}")
        channel = grpc.insecure_channel(f"127.0.0.1:{recovered.port}")
        rpc.ContactServiceStub(channel).GetSession(pb.GetSessionRequest(name="sessions/kept"),
                                                   timeout=10)
        channel.close()
        recovered.process.send_signal(signal.SIGTERM)
        if recovered.process.wait(timeout=30) != 0:
            fail(f"{damage.__name__}: recovered mdrd did not exit 0 on SIGTERM")
        again = Mdrd(args.mdrd, image, recover_log)  # consistent again: no flag needed
        again.process.send_signal(signal.SIGTERM)
        again.process.wait(timeout=30)
        print(f"{damage.__name__}: refused (exit 1, {expected!r}), recovered: {dropped[0]}")


def main():
    parser = argparse.ArgumentParser()
    for name in ("--mdrd", "--python-dir"):
        parser.add_argument(name, required=True)
    args = parser.parse_args()
    sys.path.insert(0, args.python_dir)  # the API's Python modules, generated by CMake
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

        for amplitude, per_quarter in ((0.6, 4), (0.02, 8), (0.001, 8)):
            steps = fretting_steps(scene_pb2, amplitude, per_quarter)
            for snapshot_every in ("1", "1000"):
                kill_after_every_step(args, grpc, pb, rpc, scene, steps, snapshot_every,
                                      directory)
        for label, kind, steps in (
                ("shared-motion", scene_pb2.Interface.KIND_SHARED_MOTION,
                 shared_motion_steps(scene_pb2)),
                ("contact-list", scene_pb2.Interface.KIND_CONTACT_LIST,
                 contact_list_steps(scene_pb2))):
            for snapshot_every in ("1", "1000"):
                kill_after_every_step(args, grpc, pb, rpc, interface_scene(scene, kind), steps,
                                      snapshot_every, directory, label)
        damaged_journals(args, grpc, pb, rpc, scene_pb2, scene, directory)
    print("journal crash test: ok")


if __name__ == "__main__":
    main()
