#!/usr/bin/python3
"""A full journal against the real mdrd (issue #27).

mdrd runs under a file-size limit (RLIMIT_FSIZE, set in the child only: Popen restores SIGXFSZ to
its default there, so a write beyond the limit would kill a process that does not ignore it):

1. With --journal-min-free-bytes below the limit's room: batches are accepted until the room
   falls below the floor, then new work (Apply, CreateSession) is refused UNAVAILABLE naming the
   floor, while ExportSession and DeleteSession go on; mdrd stays up and exits 0 on SIGTERM; a
   restart without the limit restores every acknowledged batch (the export before the stop, bit
   for bit) and not the deleted session.
2. With no floor (--journal-min-free-bytes 0): the writes run into the limit itself; they fail
   with EFBIG as an I/O error (UNAVAILABLE), mdrd is not killed by SIGXFSZ, and a restart
   restores what was acknowledged.

Usage: journal_full_test.py --mdrd PATH --python-dir BUILD/python
"""
import argparse
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile

LIMIT_BYTES = 2 << 20
FLOOR_BYTES = 512 << 10
STEPS_PER_BATCH = 2000
MAX_BATCHES = 400

SCENE = {"sphere": {"radius": 0.01},
         "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                          "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3},
         "friction": 0.3}


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


class Mdrd:
    def __init__(self, mdrd, journal, floor, limit=None):
        def preexec():
            if limit is not None:
                resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        self.process = subprocess.Popen(
            [mdrd, "--listen", "127.0.0.1:0", "--journal", journal,
             "--journal-min-free-bytes", str(floor), "--log-level", "info"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, preexec_fn=preexec)
        self.log = []
        for line in self.process.stdout:
            self.log.append(line)
            found = re.search(r"event=serving.*\bport=\"?(\d+)", line)
            if found:
                self.address = "127.0.0.1:" + found.group(1)
                return
        fail("mdrd did not start:\n" + "".join(self.log))

    def stop(self):
        self.process.send_signal(signal.SIGTERM)
        self.log += self.process.stdout.readlines()
        self.process.stdout.close()
        return self.process.wait(timeout=60)


def fill(session, mdr):
    """Applies fretting batches until one is refused; the refusal and the batches accepted."""
    accepted = 0
    for k in range(MAX_BATCHES):
        amplitude = 1e-7 * (1 + k % 3)
        steps = [{"displacement": amplitude * ((i % 4) - 1.5)} for i in range(STEPS_PER_BATCH)]
        try:
            session.apply(steps)
        except mdr.MdrError as error:
            return error, accepted
        accepted += 1
    fail(f"{MAX_BATCHES} batches accepted under a {LIMIT_BYTES}-byte file-size limit")


def contact_of(client, name):
    return client.export_session(name).contact.SerializeToString()


def floor_refuses_new_work_and_deletions_go_on(mdrd, mdr, directory):
    journal = os.path.join(directory, "floor.db")
    server = Mdrd(mdrd, journal, FLOOR_BYTES, LIMIT_BYTES)
    with mdr.Client(server.address) as client:
        kept = client.create_session(SCENE, "kept")
        freed = client.create_session(SCENE, "freed")
        for session in (kept, freed):
            session.apply({"normal_force": 100})
        refusal, accepted = fill(kept, mdr)
        if refusal.code.name != "UNAVAILABLE" or "--journal-min-free-bytes" not in str(refusal):
            fail(f"the refusal is not the floor's: {refusal}")
        if accepted < 5:
            fail(f"only {accepted} batches before the floor")
        try:
            client.create_session(SCENE, "another")
            fail("a new session was created below the floor")
        except mdr.MdrError as error:
            if error.code.name != "UNAVAILABLE":
                fail(f"CreateSession below the floor: {error}")
        before = contact_of(client, kept.name)  # Export goes on
        client.delete_session(freed.name)       # and so does Delete
    if server.process.poll() is not None:
        fail("mdrd died below the floor")
    if server.stop() != 0:
        fail("mdrd did not exit 0:\n" + "".join(server.log[-20:]))
    if not any("event=journal_low_space" in line for line in server.log):
        fail("the low space was not logged")
    restarted = Mdrd(mdrd, journal, 0)
    with mdr.Client(restarted.address) as client:
        names = [s.name for s in client.list_sessions()]
        if names != ["sessions/kept"]:
            fail(f"sessions after the restart: {names}")
        if contact_of(client, "sessions/kept") != before:
            fail("the restored session is not the one acknowledged")
    restarted.stop()
    print(f"floor: {accepted} batches, then UNAVAILABLE; export and delete went on; restored")


def the_limit_itself_is_an_io_error(mdrd, mdr, directory):
    journal = os.path.join(directory, "limit.db")
    server = Mdrd(mdrd, journal, 0, LIMIT_BYTES)
    with mdr.Client(server.address) as client:
        session = client.create_session(SCENE, "full")
        session.apply({"normal_force": 100})
        refusal, accepted = fill(session, mdr)
        if refusal.code.name != "UNAVAILABLE" or "journal" not in str(refusal):
            fail(f"the refusal is not the journal's: {refusal}")
        if server.process.poll() is not None:
            fail(f"mdrd died at the file-size limit (signal {-server.process.returncode})")
        before = contact_of(client, session.name)
    server.process.kill()  # no clean shutdown: what the journal holds is all there is
    server.process.wait()
    restarted = Mdrd(mdrd, journal, 0)
    with mdr.Client(restarted.address) as client:
        if contact_of(client, "sessions/full") != before:
            fail("the restored session is not the one acknowledged")
    restarted.stop()
    print(f"limit: {accepted} batches, then UNAVAILABLE from EFBIG; mdrd alive; restored")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--python-dir", required=True)
    args = parser.parse_args()
    sys.path.insert(0, args.python_dir)
    import mdr
    with tempfile.TemporaryDirectory() as directory:
        floor_refuses_new_work_and_deletions_go_on(args.mdrd, mdr, directory)
        the_limit_itself_is_an_io_error(args.mdrd, mdr, directory)
    print("PASS")


if __name__ == "__main__":
    main()
