"""The chaos probe of one master, driven from ``gidabot chaos`` (ROS-free: the probe is a process of its own).

:class:`ChaosProbeClient` starts ``gidabot_sim.chaos.probe_node`` where that master is (a robot's machine) and
speaks its JSON-lines protocol (docs in the probe's module): first deliveries after a moment, a fresh
subscription on a restarted master, the robot's plan, publishing a message, the nodes' counters. Everything the
probe recorded is in its JSON-lines file (:meth:`ChaosProbeClient.records`).
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gidabot_sim.errors import ChaosError
from gidabot_sim.runner.building_runner import node_executable


class ChaosProbeClient:
    """The chaos probe process on one master (``gidabot_sim.chaos.probe_node``), driven by JSON lines;
    ``command`` runs its command line where that master is (a robot's machine)."""

    def __init__(self, robot: str, env: dict[str, str], out: Path, log: Path, timeout: float = 30.0,
                 command: Callable[[list[str]], list[str]] = list) -> None:
        self.robot = robot
        self.out = out
        self.timeout = timeout
        out.parent.mkdir(parents=True, exist_ok=True)
        self._log = open(log, "ab")  # noqa: SIM115 - closed in close()
        argv = command([sys.executable, node_executable("gidabot_sim", "chaos_probe"), "--robot", robot,
                        "--out", str(out)])
        self.proc = subprocess.Popen(argv, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log,
                                     start_new_session=True, text=True, bufsize=1)
        self._read(60.0, "start")

    def _read(self, timeout: float, what: str) -> dict[str, Any]:
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        if not ready:
            raise ChaosError(f"chaos probe of {self.robot} did not answer {what} within {timeout:g} s")
        line = self.proc.stdout.readline()
        if not line:
            raise ChaosError(f"chaos probe of {self.robot} exited (code {self.proc.poll()})")
        return json.loads(line)

    def call(self, op: str, **kw: Any) -> dict[str, Any]:
        if self.proc.poll() is not None:
            raise ChaosError(f"chaos probe of {self.robot} exited with {self.proc.returncode}")
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps({"op": op, **kw}) + "\n")
        self.proc.stdin.flush()
        reply = self._read(self.timeout, op)
        if not reply.get("ok"):
            raise ChaosError(f"chaos probe of {self.robot}: {op} failed: {reply.get('error')}")
        return reply

    def first(self, topic: str, since: float, stamped: float | None = None) -> dict[str, float]:
        """robot -> wall time of its first ``topic`` message received after ``since`` (and stamped at or after
        ROS time ``stamped``: sent after that moment, not a stale one a link delivers when it comes back)."""
        kw = {} if stamped is None else {"stamped": stamped}
        return self.call("deliveries", topic=topic, since=since, **kw)["first"]

    def close(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(OSError, ValueError, ChaosError):
                self.call("quit")
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(timeout=5)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=5)
        for stream in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(OSError):
                stream.close()  # type: ignore[union-attr]
        self._log.close()

    def records(self) -> list[dict[str, Any]]:
        out = []
        with contextlib.suppress(FileNotFoundError), open(self.out, encoding="utf-8") as f:
            for line in f:
                with contextlib.suppress(json.JSONDecodeError):
                    out.append(json.loads(line))
        return out
