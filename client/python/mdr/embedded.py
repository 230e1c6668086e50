"""A local mdrd for notebooks and scripts: started on a free loopback port, stopped on exit."""
from __future__ import annotations

import os
import queue
import re
import shutil
import signal
import subprocess
import threading
import time
from typing import Optional, Sequence


def find_mdrd(explicit: Optional[str] = None) -> str:
    """The mdrd binary: the argument, $MDR_MDRD, the one bundled in this package (pip install
    from the repository), mdrd on PATH, or the build tree this package was generated into
    (build/<preset>/python/mdr -> build/<preset>/server/mdrd/mdrd)."""
    here = os.path.dirname(os.path.abspath(__file__))
    candidates = [explicit, os.environ.get("MDR_MDRD"), os.path.join(here, "mdrd"),
                  shutil.which("mdrd"), os.path.join(here, "..", "..", "server", "mdrd", "mdrd")]
    for candidate in candidates:
        if candidate and os.path.isfile(candidate) and os.access(candidate, os.X_OK):
            return os.path.abspath(candidate)
    raise FileNotFoundError("mdrd not found: pass mdrd=PATH, set MDR_MDRD, put mdrd on PATH, or "
                            "install the package from the repository (pip install client/python "
                            "bundles mdrd)")


# The message limit of a server started for one script, as mdrctl's own (kEmbeddedMaxMessageBytes):
# it holds the largest request the service takes (an analysis of 10^7 samples of four columns,
# 320 MB), where mdrd's default (4 MiB) stops at about 130 000 samples.
EMBEDDED_MAX_MESSAGE_BYTES = 512 << 20


class EmbeddedServer:
    """mdrd on 127.0.0.1 with a port the system picks, no journal, and a message limit of
    EMBEDDED_MAX_MESSAGE_BYTES unless `args` or $MDR_MAX_MESSAGE_BYTES set one; `address` once
    started."""

    def __init__(self, mdrd: Optional[str] = None, args: Sequence[str] = (),
                 start_timeout: float = 30.0):
        chosen = "MDR_MAX_MESSAGE_BYTES" in os.environ or any(
            a.startswith("--max-message-bytes") for a in args)
        limit = [] if chosen else [f"--max-message-bytes={EMBEDDED_MAX_MESSAGE_BYTES}"]
        self.process = subprocess.Popen(
            [find_mdrd(mdrd), "--listen", "127.0.0.1:0", "--no-journal", *limit, *args],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.log: list = []
        self._lines: queue.Queue = queue.Queue()
        threading.Thread(target=self._pump, daemon=True).start()
        port = self._wait_for_port(start_timeout)
        self.address = f"127.0.0.1:{port}"

    def _pump(self):
        for line in self.process.stdout:
            self._lines.put(line)

    def _wait_for_port(self, timeout: float) -> int:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                line = self._lines.get(timeout=0.1)
            except queue.Empty:
                if self.process.poll() is not None:
                    raise RuntimeError("mdrd exited at start:\n" + "".join(self.log)) from None
                continue
            self.log.append(line)
            if "event=serving" in line:
                return int(re.search(r"\bport=\"?(\d+)", line).group(1))
        self.stop()
        raise TimeoutError("mdrd did not start serving:\n" + "".join(self.log))

    def stop(self, grace: float = 10.0) -> None:
        """SIGTERM (mdrd drains), then SIGKILL if it has not exited within `grace` seconds."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=grace)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        if self.process.stdout is not None:
            self.process.stdout.close()
