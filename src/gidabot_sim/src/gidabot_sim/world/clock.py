"""Simulated time (ROS-free): the speed ceiling of a floor's clock, and sim-time schedules.

A floor's clock advances only by steps the simulator has computed (:mod:`gidabot_sim.world.lockstep`);
:class:`Pacer` keeps it from running faster than its speed ceiling and counts the wall time it spent
behind that ceiling. It never makes up lost time by jumping: a floor that cannot keep up runs slower.
"""

from __future__ import annotations

import math

from gidabot_sim.errors import SimConfigError

MAX_SPEED = 1000.0


def check_speed(speed: float | None) -> float | None:
    """``speed`` (sim seconds per wall second) as a ceiling: a number in (0, MAX_SPEED], or None (no ceiling)."""
    if speed is None:
        return None
    if isinstance(speed, bool) or not isinstance(speed, (int, float)) or not (
            math.isfinite(speed) and 0 < speed <= MAX_SPEED):
        raise SimConfigError(f"speed: {speed!r} must be a number in (0, {MAX_SPEED:g}] (sim seconds per wall "
                             "second), or none for no ceiling")
    return float(speed)


class Pacer:
    """The speed ceiling: sim time ``t`` may be reached no earlier than wall time :meth:`due` ``(t)``.

    The schedule runs from an anchor (a wall time and the sim time reached then) at ``speed``. A stop
    reached late by up to ``slack`` wall seconds is made up by not sleeping before the next steps (each
    one still computed); later than that, the schedule is re-anchored at that stop, so the clock never
    runs faster than the ceiling to catch up what it lost. :attr:`behind` adds up the wall time lost
    against the ceiling at those re-anchorings; :meth:`behind_at` includes the lateness still pending.
    ``speed`` None: no ceiling (as fast as the simulation goes), never behind.
    """

    def __init__(self, speed: float | None, start_wall: float, start_sim: float = 0.0, slack: float = 0.05) -> None:
        if not (math.isfinite(start_wall) and math.isfinite(start_sim)):
            raise SimConfigError(f"start: wall {start_wall!r}, sim {start_sim!r} must be finite")
        if not (math.isfinite(slack) and slack >= 0):
            raise SimConfigError(f"slack: {slack!r} must be >= 0 wall seconds")
        self.speed = check_speed(speed)
        self.slack = float(slack)
        self.anchor_wall, self.anchor_sim = float(start_wall), float(start_sim)
        self.behind = 0.0

    def due(self, t: float) -> float:
        """Wall time at which sim time ``t`` may be reached (-inf without a ceiling)."""
        if self.speed is None:
            return -math.inf
        return self.anchor_wall + (t - self.anchor_sim) / self.speed

    def lateness(self, t: float, wall: float) -> float:
        """Wall seconds by which reaching ``t`` at ``wall`` is behind the schedule (0 when on time)."""
        if self.speed is None:
            return 0.0
        return max(0.0, wall - self.due(t))

    def reached(self, t: float, wall: float) -> None:
        """The world reached sim time ``t`` at ``wall``; re-anchors when it was late beyond the slack."""
        late = self.lateness(t, wall)
        if late > self.slack:
            self.behind += late
            self.anchor_wall, self.anchor_sim = wall, t

    def behind_at(self, t: float, wall: float) -> float:
        """Wall seconds behind the ceiling so far, with the world at ``t`` at ``wall``."""
        return self.behind + self.lateness(t, wall)

    def set_speed(self, speed: float | None, t: float, wall: float) -> None:
        """A new ceiling from now on (the world is at ``t`` at ``wall``): the lateness so far is counted and the
        schedule starts again from here."""
        speed = check_speed(speed)
        if speed == self.speed:
            return
        self.behind += self.lateness(t, wall)
        self.speed = speed
        self.anchor_wall, self.anchor_sim = wall, t


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
