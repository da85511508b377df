"""Simulated time (ROS-free): one formula on every floor, and sim-time schedules.

``sim_time = (wall_now - start_wall) * speed``: every floor's simulator derives its
``/clock`` from the same ``start_wall`` and ``speed``, so stamps agree across the
robots' masters without any exchange. Physics catches up to that target in fixed
steps; a starved CPU makes the catch-up bigger but never lets a floor drift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gidabot_sim.errors import SimConfigError

MAX_SPEED = 1000.0


@dataclass(frozen=True)
class SimClock:
    """``speed`` sim seconds per wall second, sim time 0 at wall time ``start_wall`` (s since the epoch)."""

    speed: float
    start_wall: float

    def __post_init__(self) -> None:
        if not (isinstance(self.speed, (int, float)) and math.isfinite(self.speed) and 0 < self.speed <= MAX_SPEED):
            raise SimConfigError(f"speed: {self.speed!r} must be a number in (0, {MAX_SPEED:g}] "
                                 "(sim seconds per wall second)")
        if not (isinstance(self.start_wall, (int, float)) and math.isfinite(self.start_wall)
                and self.start_wall >= 0):
            raise SimConfigError(f"start_wall: {self.start_wall!r} must be a wall time >= 0 (s since the epoch)")

    @classmethod
    def create(cls, speed: float, start_wall: float, wall_now: float) -> SimClock:
        """``start_wall`` 0 means "now"."""
        return cls(float(speed), float(wall_now) if float(start_wall) == 0.0 else float(start_wall))

    def sim_time(self, wall: float) -> float:
        """Sim seconds at wall time ``wall`` (negative before ``start_wall``: the simulation has not started)."""
        return (wall - self.start_wall) * self.speed

    def wall_time(self, sim: float) -> float:
        """Wall time at which sim time reaches ``sim``."""
        return self.start_wall + sim / self.speed


def tick_period(speed: float, clock_step: float = 0.05, max_rate: float = 100.0) -> float:
    """Wall seconds between two ``/clock`` messages.

    Aim for ``clock_step`` sim seconds per tick (control loops get that resolution) but
    never more than ``max_rate`` messages per wall second: at 10x with the defaults that
    is 100 Hz wall, 0.1 s of sim time per tick.
    """
    for name, value in (("speed", speed), ("clock_step", clock_step), ("max_rate", max_rate)):
        if not (math.isfinite(value) and value > 0):
            raise SimConfigError(f"{name}: {value!r} must be a finite number > 0")
    return max(clock_step / speed, 1.0 / max_rate)


class Periodic:
    """A sim-time schedule at ``rate`` Hz aligned to multiples of the period (so floors stamp alike).

    :meth:`due` is true at most once per call when a period boundary has been crossed since
    the last firing; missed periods are skipped, not replayed.
    """

    def __init__(self, rate: float) -> None:
        if not (math.isfinite(rate) and rate > 0):
            raise SimConfigError(f"rate: {rate!r} must be a finite number of Hz > 0")
        self.period = 1.0 / rate
        self.next = 0.0

    def due(self, now: float) -> bool:
        if now + 1e-9 < self.next:
            return False
        self.next = (math.floor(now / self.period + 1e-9) + 1) * self.period
        return True

    def reset(self) -> None:
        self.next = 0.0


def next_cycle(due: float, period: float, now: float) -> float:
    """When the next cycle of a ``period`` loop is due, after the one due at ``due`` ran at ``now``
    (rospy.Rate's rule): one period later, but re-anchored at ``now`` when the loop fell more than a
    period behind (missed cycles are skipped, not run back to back) or time jumped back."""
    nxt = due + period
    if nxt < now - period or nxt > now + period:
        return now + period
    return nxt
