"""Which robots are online (ROS-free): partner liveness from their RobotStatus, in WALL time.

Liveness is a property of the network, so it is measured with a monotonic wall clock
passed in by the caller (``time.monotonic()`` in the nodes), never ROS time: a starved
CPU running the simulator at 10x must not make robots look offline.
"""

from __future__ import annotations

import math


class PeerLiveness:
    """Last time a status of each robot was heard; a robot is offline after ``offline_after`` s.

    A robot never heard counts as online during the first ``offline_after`` s after
    ``started`` (the node just came up and statuses are on their way), offline after.
    """

    def __init__(self, offline_after: float, started: float) -> None:
        if not (math.isfinite(offline_after) and offline_after > 0):
            raise ValueError(f"offline_after: {offline_after!r} must be a positive number of seconds")
        self.offline_after = float(offline_after)
        self.started = float(started)
        self._last: dict[str, float] = {}

    def heard(self, robot: str, now: float) -> None:
        self._last[robot] = now

    def last_heard(self, robot: str) -> float | None:
        return self._last.get(robot)

    def online(self, robot: str, now: float) -> bool:
        last = self._last.get(robot, self.started)
        return now - last < self.offline_after

    def offline_since(self, robot: str, now: float) -> float | None:
        """Wall time since which ``robot`` counts as offline (its last status + ``offline_after``), or None."""
        if self.online(robot, now):
            return None
        return self._last.get(robot, self.started) + self.offline_after
