"""How often a node's main loop runs (ROS-free), for its diagnostics and the demo's report.

A loop that wakes at least ``nominal_hz`` times per wall second (on its input or its timeout) calls
:meth:`LoopMeter.tick` once per iteration with its ROS time (sim time in a simulation) and its
monotonic wall time. The counts go into the node's ``/diagnostics``; the report compares, over a run,
the iterations per sim second with the nominal rate at the run's speed (a starved or frozen process
runs fewer).
"""

from __future__ import annotations

import math


class LoopMeter:
    def __init__(self, nominal_hz: float) -> None:
        if not (math.isfinite(nominal_hz) and nominal_hz > 0):
            raise ValueError(f"nominal_hz: {nominal_hz!r} must be > 0")
        self.nominal_hz = float(nominal_hz)
        self.count = 0
        self.last: tuple[float, float] | None = None      # (ros, wall) of the latest iteration
        self.max_gap_wall = 0.0

    def tick(self, ros: float, wall: float) -> None:
        if self.last is not None:
            self.max_gap_wall = max(self.max_gap_wall, wall - self.last[1])
        self.count += 1
        self.last = (ros, wall)

    def values(self) -> dict[str, str]:
        """``loop_count``, ``loop_ros``/``loop_wall`` (times of the latest iteration: the report takes
        differences), ``loop_nominal_hz`` (wall), ``loop_max_gap_wall_s``."""
        ros, wall = self.last if self.last is not None else (0.0, 0.0)
        return {"loop_count": str(self.count), "loop_ros": f"{ros:.3f}", "loop_wall": f"{wall:.3f}",
                "loop_nominal_hz": f"{self.nominal_hz:g}", "loop_max_gap_wall_s": f"{self.max_gap_wall:.3f}"}
