"""Timing how soon processes exit after a signal (the node exit tests: tests/foundation, tests/sim)."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Sequence

from gidabot_sim.errors import ProcessError
from gidabot_sim.runner.procs import wait_until


def signal_and_time(names: Sequence[str], send: Callable[[str, int], None], alive: Callable[[str], bool], sig: int,
                    wait: float) -> dict[str, float]:
    """Send ``sig`` to every process of ``names`` at once (as roslaunch does at shutdown); wall s until each one
    has exited, ``inf`` for one still running ``wait`` s after the signal."""
    sent = time.monotonic()
    for name in names:
        send(name, sig)
    exited: dict[str, float] = {}

    def all_gone() -> bool:
        for name in names:
            if name not in exited and not alive(name):
                exited[name] = time.monotonic() - sent
        return len(exited) == len(names)

    with contextlib.suppress(ProcessError):
        wait_until(all_gone, wait, "the processes' exit", interval=0.02)
    return {name: exited.get(name, float("inf")) for name in names}
