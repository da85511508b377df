"""Fault primitives for the simulated building (used by ``gidabot chaos`` and system tests).

Link cuts block every packet between two robots' loopback addresses with
iptables (both directions, OUTPUT chain; rules are tagged with a comment and
removed by :meth:`LinkCuts.clear_all`, also on errors). Processes are frozen
with SIGSTOP/SIGCONT by process group.
"""

from __future__ import annotations

import contextlib
import shutil
import subprocess
from dataclasses import dataclass, field

from gidabot_sim.errors import FaultError

COMMENT = "gidabot-chaos"


def _iptables(*args: str) -> None:
    exe = shutil.which("iptables")
    if exe is None:
        raise FaultError("iptables is not installed (tools/apt-packages.txt lists it; run make setup)")
    proc = subprocess.run([exe, "-w", "5", *args], capture_output=True, text=True, timeout=30, check=False)
    if proc.returncode != 0:
        raise FaultError(f"iptables {' '.join(args)}: {proc.stderr.strip() or proc.returncode}")


@dataclass
class LinkCuts:
    """Cut and restore the traffic between pairs of addresses; ``clear_all`` restores everything."""

    tag: str = COMMENT
    active: set[tuple[str, str]] = field(default_factory=set)

    def _rules(self, a: str, b: str) -> list[list[str]]:
        return [["OUTPUT", "-s", src, "-d", dst, "-m", "comment", "--comment", self.tag, "-j", "DROP"]
                for src, dst in ((a, b), (b, a))]

    def cut(self, a: str, b: str) -> None:
        key = tuple(sorted((a, b)))
        if key in self.active:
            return
        for rule in self._rules(*key):
            _iptables("-I", *rule)
        self.active.add(key)  # type: ignore[arg-type]

    def restore(self, a: str, b: str) -> None:
        key = tuple(sorted((a, b)))
        if key not in self.active:
            return
        for rule in self._rules(*key):
            with contextlib.suppress(FaultError):
                _iptables("-D", *rule)
        self.active.discard(key)  # type: ignore[arg-type]

    def clear_all(self) -> None:
        for a, b in list(self.active):
            self.restore(a, b)

    def __enter__(self) -> LinkCuts:
        return self

    def __exit__(self, *exc: object) -> None:
        self.clear_all()
