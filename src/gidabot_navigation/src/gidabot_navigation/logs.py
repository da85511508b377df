"""Logging the cores share (ROS-free): the logger protocol and a per-key rate limiter.

The nodes pass rospy's logger (:class:`gidabot_navigation.ros.log.RosLog`), tests a list.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol


class Logger(Protocol):
    """What the cores log through (rospy's logger in the nodes, a list in tests)."""

    def info(self, msg: str) -> None: ...
    def warning(self, msg: str) -> None: ...
    def error(self, msg: str) -> None: ...


class RateLimitedLog:
    """Logs at most ``burst`` warnings per key in a ``window`` of s, counts the rest and says how
    many were suppressed when the key's next window starts, so hostile input cannot flood the log.

    ``clock`` is in seconds (any monotonic clock: wall, sim, a test's counter).
    """

    def __init__(self, log: Logger, clock: Callable[[], float] = time.monotonic, burst: int = 10,
                 window: float = 60.0) -> None:
        self.log, self.clock, self.burst, self.window = log, clock, burst, window
        self._state: dict[str, tuple[float, int, int]] = {}   # key -> (window start, logged, suppressed)

    def warning(self, key: str, msg: str) -> None:
        now = self.clock()
        start, logged, suppressed = self._state.get(key, (now, 0, 0))
        if now - start >= self.window:
            if suppressed:
                self.log.warning(f"{suppressed} more '{key}' warning(s) suppressed in the last {self.window:g} s")
            start, logged, suppressed = now, 0, 0
        if logged < self.burst:
            self.log.warning(msg)
            logged += 1
        else:
            suppressed += 1
        self._state[key] = (start, logged, suppressed)
