"""Hand-over from ROS callback threads to the Qt thread (ROS-free, Qt-free).

Callbacks only put records here and return; the GUI drains the inbox from a
QTimer in its own thread. State records (status, pose, pending, catalog) keep
only the latest value per key, so a burst of 10 Hz statuses from many robots
costs one update per robot per drain; events (NavEvents, edit results) are kept
in order, up to ``max_events`` (older ones are dropped and counted).
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Any


@dataclass
class Drained:
    states: list[tuple[str, Any]] = field(default_factory=list)   # (kind, record), latest per key
    events: list[tuple[str, Any]] = field(default_factory=list)   # (kind, record), in arrival order
    dropped: int = 0

    def __bool__(self) -> bool:
        return bool(self.states or self.events)


class Inbox:
    def __init__(self, max_events: int = 1000) -> None:
        self._lock = threading.Lock()
        self._states: dict[tuple[str, str], Any] = {}
        self._events: deque[tuple[str, Any]] = deque()
        self._max_events = max_events
        self._dropped = 0
        self.received = 0

    def put_state(self, kind: str, key: str, record: Any) -> None:
        with self._lock:
            self._states.pop((kind, key), None)      # re-insert: drained in order of last arrival
            self._states[(kind, key)] = record
            self.received += 1

    def put_event(self, kind: str, record: Any) -> None:
        with self._lock:
            if len(self._events) >= self._max_events:
                self._events.popleft()
                self._dropped += 1
            self._events.append((kind, record))
            self.received += 1

    def drain(self) -> Drained:
        with self._lock:
            out = Drained([(k[0], v) for k, v in self._states.items()], list(self._events), self._dropped)
            self._states.clear()
            self._events.clear()
            self._dropped = 0
        return out
