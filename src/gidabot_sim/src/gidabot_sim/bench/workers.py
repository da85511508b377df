"""The worker processes of the benchmarks, driven from the benchmark (ROS-free here: a worker is a ROS node of
its own, ``gidabot_sim.bench.<benchmark>_node``).

A :class:`Worker` runs ``python -m <module> <args>`` (on a robot's machine if asked) and speaks its line
protocol: commands on its stdin, one JSON object per line on its stdout, each with an ``event``
(:meth:`Worker.expect` waits for one). :func:`percentile` summarises the latencies the workers measure.
"""

from __future__ import annotations

import json
import select
import subprocess
import sys
import time

from gidabot_sim.runner.procs import ProcessGroup


class Worker:
    """One worker process of a benchmark: started at once, stopped by :meth:`close` (``quit``, else killed)."""

    def __init__(self, group: ProcessGroup, name: str, env: dict[str, str], module: str, args: list[str],
                 command: list[str] | None = None) -> None:
        """``python -m <module> <args>`` (a benchmark's worker node, speaking this line protocol); ``command``:
        what runs that command line (a robot's machine); none = this machine."""
        log = open(group.log_dir / f"{name}.log", "ab") if group.log_dir else subprocess.DEVNULL  # noqa: SIM115
        self.proc = subprocess.Popen([*(command or []), sys.executable, "-m", module, *args],
                                     env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log, text=True,
                                     bufsize=1, start_new_session=True)
        if hasattr(log, "close"):
            log.close()
        self.name = name

    def send(self, cmd: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(cmd + "\n")
        self.proc.stdin.flush()

    def expect(self, event: str, timeout: float) -> dict:
        assert self.proc.stdout is not None
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            ready, _, _ = select.select([self.proc.stdout], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                break
            line = self.proc.stdout.readline()
            if not line:
                raise RuntimeError(f"bench worker {self.name} exited (code {self.proc.poll()})")
            msg = json.loads(line)
            if msg.get("event") == event:
                return msg
        raise RuntimeError(f"bench worker {self.name}: no {event!r} within {timeout:g} s")

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.send("quit")
                self.proc.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait(timeout=5)


def percentile(values: list[float], q: float) -> float:
    """Percentile ``q`` (0..100) of ``values``: the sorted value at the rounded rank q % of the way (NaN when
    empty)."""
    if not values:
        return float("nan")
    s = sorted(values)
    return s[min(len(s) - 1, max(0, int(round(q / 100.0 * (len(s) - 1)))))]

