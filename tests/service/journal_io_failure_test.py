#!/usr/bin/python3
"""Journal files that cannot be written, or vanish, under load against the real mdrd (issue #48).

Each case runs a client applying one-step batches back to back while the journal's files are
1. made immutable (chattr +i, through the FS_IOC_SETFLAGS ioctl; skipped where the file system or
   the privileges do not allow it), then writable again -- 20 times, each on a fresh mdrd: before,
   the write-ahead log's index was a memory-mapped -shm file and the next Apply killed mdrd with
   SIGBUS;
2. deleted (the database, its log and the side file), and the directory removed and made again.
Every call must be answered (OK or UNAVAILABLE; a refused Apply changes nothing), mdrd must exit 0
on SIGTERM, and a restart must restore the last acknowledged state bit for bit.

Usage: journal_io_failure_test.py --mdrd PATH --python-dir BUILD/python
"""
import argparse
import array
import fcntl
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile

FS_IOC_GETFLAGS = 0x80086601
FS_IOC_SETFLAGS = 0x40086602
FS_IMMUTABLE_FL = 0x00000010
REPETITIONS = 20
SUFFIXES = ("", "-wal", ".commit")

SCENE = {"sphere": {"radius": 0.01},
         "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                          "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3},
         "friction": 0.3}


def fail(message):
    print("FAIL:", message)
    sys.exit(1)


class Mdrd:
    def __init__(self, mdrd, journal):
        self.process = subprocess.Popen(
            [mdrd, "--listen", "127.0.0.1:0", "--journal", journal,
             "--journal-min-free-bytes", "0", "--log-level", "info"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
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


def set_immutable(paths, immutable):
    """False where the attribute cannot be set here."""
    for path in paths:
        try:
            with open(path, "rb") as file:
                flags = array.array("l", [0])
                fcntl.ioctl(file.fileno(), FS_IOC_GETFLAGS, flags, True)
                if immutable:
                    flags[0] |= FS_IMMUTABLE_FL
                else:
                    flags[0] &= ~FS_IMMUTABLE_FL
                fcntl.ioctl(file.fileno(), FS_IOC_SETFLAGS, flags, True)
        except OSError:
            return False
    return True


class Load:
    """One-step batches on a session; what was last acknowledged and what was refused."""

    def __init__(self, client, mdr, name):
        self.client, self.mdr = client, mdr
        self.session = client.create_session(SCENE, name)
        self.session.apply({"normal_force": 100})
        self.k = 0
        self.acknowledged = self.contact()
        self.refused = 0

    def contact(self):
        return self.client.export_session(self.session.name).contact.SerializeToString()

    def steps(self, count):
        for _ in range(count):
            self.k += 1
            try:
                self.session.apply([{"displacement": 2e-8 * (1 if self.k % 2 else -1)}])
            except self.mdr.MdrError as error:
                if error.code.name != "UNAVAILABLE" or "journal" not in str(error):
                    fail(f"a refusal that is not the journal's: {error}")
                self.refused += 1
                if self.contact() != self.acknowledged:
                    fail("a refused Apply changed the session")
                continue
            self.acknowledged = self.contact()


def check_restart(mdrd, journal, name, acknowledged, mdr):
    restarted = Mdrd(mdrd, journal)
    with mdr.Client(restarted.address) as client:
        got = client.export_session("sessions/" + name).contact.SerializeToString()
    if restarted.stop() != 0:
        fail("the restarted mdrd did not exit 0")
    if got != acknowledged:
        fail(f"{name}: the restored session is not the last acknowledged one")


def immutable_files(mdrd, mdr, directory):
    refused = 0
    for repetition in range(REPETITIONS):
        journal = os.path.join(directory, f"immutable{repetition}.db")
        server = Mdrd(mdrd, journal)
        with mdr.Client(server.address) as client:
            load = Load(client, mdr, "immutable")
            load.steps(20)
            # Every file of the journal there is (an -shm file too, where SQLite made one).
            paths = [os.path.join(directory, name) for name in os.listdir(directory)
                     if name.startswith(os.path.basename(journal))]
            if not set_immutable(paths, True):
                set_immutable(paths, False)
                server.stop()
                print("immutable: SKIPPED (the immutable attribute cannot be set here)")
                return
            try:
                load.steps(20)
            finally:
                set_immutable(paths, False)
            if load.refused == 0:
                fail("no Apply was refused while the journal was immutable")
            refused += load.refused
            load.steps(20)
            acknowledged = load.acknowledged
        if server.process.poll() is not None:
            fail(f"mdrd died (signal {-server.process.returncode}) with immutable journal files")
        if server.stop() != 0:
            fail("mdrd did not exit 0:\n" + "".join(server.log[-20:]))
        check_restart(mdrd, journal, "immutable", acknowledged, mdr)
    print(f"immutable: {REPETITIONS} repetitions, {refused} Applies refused UNAVAILABLE, "
          "no signal, every restart restored the last acknowledged state")


def deleted_files(mdrd, mdr, directory):
    journal_directory = os.path.join(directory, "vanishing")
    os.mkdir(journal_directory)
    journal = os.path.join(journal_directory, "deleted.db")
    server = Mdrd(mdrd, journal)
    with mdr.Client(server.address) as client:
        load = Load(client, mdr, "deleted")
        load.steps(20)
        for suffix in SUFFIXES:
            os.remove(journal + suffix)
        load.steps(20)
        if load.refused:
            fail(f"{load.refused} Applies refused after the files were deleted")
        shutil.rmtree(journal_directory)
        load.steps(10)
        if load.refused != 10:
            fail(f"{load.refused} of 10 Applies refused while the directory was gone")
        os.mkdir(journal_directory)
        load.steps(20)
        if load.refused != 10:
            fail("Applies refused once the directory was back")
        acknowledged = load.acknowledged
    if server.stop() != 0:
        fail("mdrd did not exit 0:\n" + "".join(server.log[-20:]))
    if not any("event=journal_rewritten" in line for line in server.log):
        fail("the rewrite was not logged")
    check_restart(mdrd, journal, "deleted", acknowledged, mdr)
    print("deleted: files deleted then the directory removed under load; every acknowledged "
          "batch restored")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--python-dir", required=True)
    args = parser.parse_args()
    sys.path.insert(0, args.python_dir)
    import mdr
    with tempfile.TemporaryDirectory() as directory:
        try:
            immutable_files(args.mdrd, mdr, directory)
            deleted_files(args.mdrd, mdr, directory)
        finally:
            for name in os.listdir(directory):
                path = os.path.join(directory, name)
                if os.path.isfile(path):
                    set_immutable([path], False)
    print("PASS")


if __name__ == "__main__":
    main()
