#!/usr/bin/python3
"""SIGTERM during heavy work against the real mdrd binary.

mdrd runs with --shutdown-grace 1, two workers and a journal in a temporary directory. Heavy
work runs on both: an Apply of 10 000 steps on a grid of 2^20 springs (tens of seconds), and
CreateSession calls with a tabulated profile of the most samples allowed (100 000, tolerance
1e-12, about a second each since the O(N log N) construction; 17 s for 10 000 samples before)
back to back. Then mdrd gets SIGTERM and must exit 0 within the grace period plus a second (plus
a margin for a loaded machine: a behavioural bound, not a speed test; before the execution model
it took tens of seconds). Restarted on the same journal, it must hold no step of the interrupted
batch and no tabulated session whose create was not answered OK: nothing is created or applied
after the drain interrupted it.

Usage: shutdown_test.py --mdrd PATH --proto-dir DIR --out-dir DIR --python-tests DIR
"""
import argparse
import math
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time

GRACE_SECONDS = 1.0
EXIT_BOUND_SECONDS = GRACE_SECONDS + 1.0 + 2.0  # grace + 1 s, and 2 s of margin
SAMPLES = 100000
GRID_SPRINGS = 1 << 20
BATCH_STEPS = 10000
YOUNGS_MODULUS, POISSON_RATIO, RADIUS, FRICTION = 210e9, 0.3, 0.01, 0.3
DEPTH = 3.4829098839e-6


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


def start_mdrd(mdrd, journal, log_path):
    log = open(log_path, "a")
    start = os.path.getsize(log_path)
    process = subprocess.Popen(
        [mdrd, "--listen", "127.0.0.1:0", "--journal", journal, "--shutdown-grace",
         str(GRACE_SECONDS), "--workers", "2", "--max-message-bytes", str(64 << 20),
         "--log-level", "info"], stdout=log, stderr=subprocess.STDOUT)
    for _ in range(200):
        text = open(log_path).read()[start:]
        found = re.search(r"event=serving .*port=(\d+)", text)
        if found:
            return process, int(found.group(1))
        if process.poll() is not None:
            fail(f"mdrd exited early:\n{text}")
        time.sleep(0.05)
    fail("mdrd did not start")


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

    def scene():
        result = scene_pb2.Scene(friction=FRICTION)
        pair = result.elastic_pair
        pair.youngs_modulus_1 = pair.youngs_modulus_2 = YOUNGS_MODULUS
        pair.poisson_ratio_1 = pair.poisson_ratio_2 = POISSON_RATIO
        return result

    # A sphere with a small ripple: the grid refines around every sample.
    tabulated = scene()
    r_max = 5e-4
    radii = [r_max * i / (SAMPLES - 1) for i in range(SAMPLES)]
    tabulated.tabulated.radii.extend(radii)
    tabulated.tabulated.heights.extend(
        r * r / (2 * RADIUS) * (1 + 1e-3 * math.sin(r / r_max * 20)) for r in radii)
    tabulated.tabulated.tolerance = 1e-12
    grid = scene()
    grid.sphere.radius = RADIUS
    grid.method = scene_pb2.METHOD_GRID
    grid.grid.size = GRID_SPRINGS
    grid.grid.max_radius = 1e-3

    with tempfile.TemporaryDirectory() as directory:
        journal = os.path.join(directory, "journal.sqlite")
        log_path = os.path.join(directory, "mdrd.log")
        open(log_path, "w").close()
        process, port = start_mdrd(args.mdrd, journal, log_path)
        channel = grpc.insecure_channel(f"127.0.0.1:{port}")
        stub = rpc.ContactServiceStub(channel)
        stub.CreateSession(pb.CreateSessionRequest(session=pb.Session(scene=grid),
                                                   session_id="grid"), timeout=60)
        steps = [scene_pb2.Step(depth=DEPTH * (1 + 0.1 * (i % 2))) for i in range(BATCH_STEPS)]

        outcomes = {}
        created = set()  # tabulated sessions answered OK

        def apply():
            try:
                stub.Apply(pb.ApplyRequest(session="sessions/grid", steps=steps), timeout=600)
                outcomes["apply"] = "OK"
            except grpc.RpcError as error:
                outcomes["apply"] = error.code().name

        def create_until_refused():
            for index in range(10**6):
                try:
                    stub.CreateSession(pb.CreateSessionRequest(
                        session=pb.Session(scene=tabulated), session_id=f"tabulated-{index}"),
                        timeout=600)
                    created.add(f"sessions/tabulated-{index}")
                except grpc.RpcError as error:
                    outcomes["create"] = error.code().name
                    return

        threads = [threading.Thread(target=apply), threading.Thread(target=create_until_refused)]
        for thread in threads:
            thread.start()
        time.sleep(1.5)  # both workers are computing
        if outcomes:
            fail(f"heavy work ended before SIGTERM: {outcomes}; make it heavier")
        signalled = time.monotonic()
        process.send_signal(signal.SIGTERM)
        try:
            code = process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            process.kill()
            fail("mdrd did not exit within 60 s of SIGTERM")
        elapsed = time.monotonic() - signalled
        for thread in threads:
            thread.join()
        channel.close()
        print(f"mdrd exited {code} {elapsed:.2f} s after SIGTERM (grace {GRACE_SECONDS} s); "
              f"calls: {outcomes}, {len(created)} tabulated creates answered OK")
        if code != 0:
            fail(f"exit code {code}")
        if elapsed > EXIT_BOUND_SECONDS:
            fail(f"exit took {elapsed:.2f} s, above {EXIT_BOUND_SECONDS} s")
        if outcomes.get("apply") == "OK":
            fail(f"the grid batch completed: {outcomes}; make it heavier")

        process, port = start_mdrd(args.mdrd, journal, log_path)
        channel = grpc.insecure_channel(f"127.0.0.1:{port}")
        stub = rpc.ContactServiceStub(channel)
        names = [s.name for s in stub.ListSessions(pb.ListSessionsRequest(), timeout=10).sessions]
        state = stub.GetSession(pb.GetSessionRequest(name="sessions/grid"), timeout=10).state
        channel.close()
        process.send_signal(signal.SIGTERM)
        process.wait(timeout=30)
        unanswered = set(names) - created - {"sessions/grid"}
        if "sessions/grid" not in names or unanswered:
            fail(f"sessions after the restart: {names}; created without an OK answer: "
                 f"{sorted(unanswered)}")
        if state.applied_steps != 0:
            fail(f"{state.applied_steps} steps of the interrupted batch were applied")
    print("PASS")


if __name__ == "__main__":
    main()
