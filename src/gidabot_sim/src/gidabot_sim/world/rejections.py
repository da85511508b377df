"""Rejected inputs, counted and logged without flooding the log (ROS-free).

The simulator and the navigation stand-ins drop an input they cannot use (a NaN command, a pose off the
map, a malformed answer) and go on; :class:`CountingLog` counts them by kind (the simulator reports the
counts in its diagnostics) and logs the first few of each kind, then one in ``every``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from gidabot_navigation.errors import GidaBotError

T = TypeVar("T")


class CountingLog:
    """Counts rejected inputs by kind and logs the first ``first`` of each kind, then every ``every``-th,
    so hostile input cannot flood the log."""

    def __init__(self, log: Callable[[str], None], first: int = 10, every: int = 100) -> None:
        self.log, self.first, self.every = log, first, every
        self.counts: dict[str, int] = {}

    def reject(self, kind: str, message: str) -> None:
        n = self.counts.get(kind, 0) + 1
        self.counts[kind] = n
        if n <= self.first or n % self.every == 0:
            self.log(f"rejected {kind} (#{n}): {message}")

    def read(self, kind: str, what: str, read: Callable[[], T]) -> T | None:
        """``read()`` (an input converted); None when it raises a GidaBotError, counted and logged as a rejected
        ``kind`` after ``what`` (the log line's start, e.g. "amcl: ignoring")."""
        try:
            return read()
        except GidaBotError as err:
            self.reject(kind, f"{what} {err}")
            return None
