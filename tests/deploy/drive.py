#!/usr/bin/python3
"""Client side of tests/deploy/run.sh, through the Python package mdr (PYTHONPATH=build/python):
creates sessions and streams fretting batches to a server or router, remembers what was
acknowledged, and verifies sessions bit for bit against a reference mdrd on this host that is
fed the same acknowledged batches.

  drive.py load     --address A --state F --sessions N --batches B [--backends A0,A1,A2]
  drive.py more     --address A --state F --batches B --skip-backend I --backends ...
  drive.py verify   --address A --state F --mdrd PATH
"""
import argparse
import json
import math
import sys

import grpc

import mdr

H1 = {"sphere": {"radius": 0.01}, "friction": 0.3,
      "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                       "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
STEPS_PER_BATCH = 10


def batch(session_index, batch_index):
    """Batch batch_index of session session_index: the normal load first, then fretting steps."""
    if batch_index == 0:
        return [{"normal_force": 100.0}]
    amplitude = 0.4e-6 * (1 + 0.1 * (session_index % 5))
    return [{"displacement": amplitude * math.sin(2 * math.pi * (batch_index * STEPS_PER_BATCH + m)
                                                  / (7 * STEPS_PER_BATCH))}
            for m in range(STEPS_PER_BATCH)]


def stream(client, record, count):
    """Streams `count` more batches to the session; returns how many were acknowledged."""
    session = mdr.Session(client, record["name"])
    first = record["acknowledged"]
    batches = (batch(record["index"], first + j) for j in range(count))
    for _ in session.stream(batches, outputs=(), window=8):
        record["acknowledged"] += 1
    return record["acknowledged"] - first


def holder(record, backends):
    """The index of the one backend that holds the session (asked directly, not routed)."""
    holders = []
    for index, address in enumerate(backends):
        with mdr.Client(address, timeout=10) as direct:
            try:
                direct.get_session(record["name"])
                holders.append(index)
            except mdr.MdrError as error:
                if error.code != grpc.StatusCode.NOT_FOUND:
                    raise
    if len(holders) != 1:
        sys.exit(f"drive: {record['name']} is held by backends {holders}, not exactly one")
    return holders[0]


def load(args, state):
    """Creates and streams to `--sessions` sessions. With --backends, goes on creating until every
    instance holds one (at most 8 times as many): the router hashes random session ids, and the
    rest of run.sh kills one instance and scrapes another, each of which must hold sessions."""
    backends = args.backends.split(",") if args.backends else []
    with mdr.Client(args.address, timeout=60) as client:
        index = 0
        while index < args.sessions or (
                backends and not all_hold(state, len(backends)) and index < 8 * args.sessions):
            session = client.create_session(H1)
            record = {"name": session.name, "index": index, "acknowledged": 0}
            stream(client, record, args.batches)
            if backends:
                record["backend"] = holder(record, backends)
            state["sessions"].append(record)
            index += 1
    if backends:
        spread = [sum(r["backend"] == b for r in state["sessions"]) for b in range(len(backends))]
        print(f"drive: {len(state['sessions'])} sessions spread over the instances as {spread}")
        if not all_hold(state, len(backends)):
            sys.exit("drive: the router did not spread the sessions over every instance")


def all_hold(state, count):
    """Whether each of the `count` instances holds at least one of the sessions."""
    return {r["backend"] for r in state["sessions"]} == set(range(count))


def more(args, state):
    """Streams to every session not on the skipped (killed) backend; sessions on it must fail
    with UNAVAILABLE, and change nothing."""
    undisturbed = refused = 0
    with mdr.Client(args.address, timeout=60, max_attempts=1) as client:
        for record in state["sessions"]:
            if record["backend"] != args.skip_backend:
                stream(client, record, args.batches)
                undisturbed += 1
                continue
            try:
                stream(client, dict(record), 1)
                sys.exit(f"drive: {record['name']} answered while its instance was down")
            except mdr.MdrError as error:
                if error.code != grpc.StatusCode.UNAVAILABLE:
                    sys.exit(f"drive: {record['name']}: {error} (expected UNAVAILABLE)")
                refused += 1
    print(f"drive: {undisturbed} sessions on the other instances streamed on undisturbed, "
          f"{refused} on the stopped one answered UNAVAILABLE")


def verify(args, state):
    """Every session through the address equals a reference session fed the same batches."""
    steps = 0
    with mdr.Client(args.address, timeout=60) as client, \
            mdr.Client.embedded(args.mdrd) as reference:
        for record in state["sessions"]:
            got = client.export_session(record["name"])
            with reference.session(H1) as expected:
                for j in range(record["acknowledged"]):
                    expected.apply(batch(record["index"], j), outputs=())
                want = expected.export()
            if (got.contact.SerializeToString() != want.contact.SerializeToString()
                    or got.applied_steps != want.applied_steps):
                sys.exit(f"drive: {record['name']} differs from its reference after "
                         f"{record['acknowledged']} batches ({got.applied_steps} steps held, "
                         f"{want.applied_steps} expected)")
            steps += got.applied_steps
    print(f"drive: {len(state['sessions'])} sessions, {steps} acknowledged steps, "
          f"all bit for bit equal to the reference")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("command", choices=["load", "more", "verify"])
    parser.add_argument("--address", required=True)
    parser.add_argument("--state", required=True)
    parser.add_argument("--sessions", type=int, default=4)
    parser.add_argument("--batches", type=int, default=20)
    parser.add_argument("--backends", default="")
    parser.add_argument("--skip-backend", type=int, default=-1)
    parser.add_argument("--mdrd", default=None)
    args = parser.parse_args()
    state = {"sessions": []}
    if args.command != "load":
        with open(args.state) as f:
            state = json.load(f)
    {"load": load, "more": more, "verify": verify}[args.command](args, state)
    with open(args.state, "w") as f:
        json.dump(state, f)


if __name__ == "__main__":
    main()
