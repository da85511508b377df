"""Python side of tests/ros_probe.py: a process on one robot's master that publishes and records.

    with Probe(sim.env("Kbot"), log_dir) as p:
        p.sub("tour_store/catalog", "gidabot_msgs/TourCatalog")
        p.pub("tour_store/edit", "gidabot_msgs/Tour", {"file_name": "x.tour", ...})
        p.wait("tour_store/catalog", lambda m: ..., timeout=5)

The process runs in its own session and is killed by process group on close.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Mapping
from pathlib import Path

PROBE = Path(__file__).resolve().parent / "ros_probe.py"


class ProbeError(RuntimeError):
    pass


class Probe:
    def __init__(self, env: Mapping[str, str], log_path: Path | None = None, timeout: float = 30.0,
                 command: Callable[[list[str]], list[str]] = list) -> None:
        """``command``: how to run the probe's command line (e.g. in a robot's machine, conftest.SimBuilding)."""
        self.timeout = timeout
        self.log_path = log_path
        self._log = open(log_path, "ab") if log_path else subprocess.DEVNULL  # noqa: SIM115 - closed in close()
        self.proc = subprocess.Popen(command([sys.executable, str(PROBE)]), env=dict(env), stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self._log, start_new_session=True,
                                     text=True, bufsize=1)
        self._seen: dict[str, int] = {}

    def __enter__(self) -> Probe:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(OSError, ValueError):
                self.proc.stdin.write(json.dumps({"op": "quit"}) + "\n")
                self.proc.stdin.flush()
            try:
                self.proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(timeout=5)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        for stream in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(OSError):
                stream.close()
        if hasattr(self._log, "close"):
            self._log.close()

    def call(self, **cmd: object) -> dict:
        if self.proc.poll() is not None:
            raise ProbeError(f"probe exited with {self.proc.returncode} (log {self.log_path})")
        self.proc.stdin.write(json.dumps(cmd) + "\n")
        self.proc.stdin.flush()
        ready, _, _ = select.select([self.proc.stdout], [], [], self.timeout)
        if not ready:
            raise ProbeError(f"probe did not answer {cmd.get('op')} within {self.timeout} s (log {self.log_path})")
        line = self.proc.stdout.readline()
        if not line:
            raise ProbeError(f"probe closed its output (log {self.log_path})")
        reply = json.loads(line)
        if not reply.get("ok"):
            raise ProbeError(f"probe {cmd.get('op')} failed: {reply.get('error')}")
        return reply

    def sub(self, topic: str, type_: str) -> None:
        self.call(op="sub", topic=topic, type=type_)

    def pub(self, topic: str, type_: str, msg: dict, subs: int = 1, latch: bool = False) -> None:
        self.call(op="pub", topic=topic, type=type_, msg=msg, subs=subs, latch=latch)

    def msgs(self, topic: str, since: int = 0) -> list[dict]:
        return self.call(op="msgs", topic=topic, since=since)["msgs"]

    def wait(self, topic: str, predicate: Callable[[dict], bool], timeout: float, what: str = "",
             since: int = 0) -> dict:
        """The first message on ``topic`` (from index ``since``) satisfying ``predicate``."""
        deadline = time.monotonic() + timeout
        while True:
            for msg in self.msgs(topic, since):
                if predicate(msg):
                    return msg
            if time.monotonic() > deadline:
                raise ProbeError(f"timed out after {timeout} s waiting on {topic} for {what or 'a message'}")
            time.sleep(0.05)
