"""What the ROS adapters of gidabot_navigation's nodes share: who sent a message, the bounded inbox their
callbacks fill, carrying out a core's actions with its state kept, and their diagnostics.

A callback copies or enqueues and returns (:class:`Inbox`); the node's one loop takes the inputs out and
hands them to its core. The sender of a message is the callerid in its connection header: a relay end's
name means the message came from another robot (:func:`from_relay`).
"""

from __future__ import annotations

import queue
from collections.abc import Callable, Mapping
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from gidabot_navigation.guiding.messages import Action
from gidabot_navigation.guiding.state import StateFile
from gidabot_navigation.interface import is_relay_end
from gidabot_navigation.ros.convert import ros_time


def sender(msg: object) -> str:
    """The node that published ``msg`` (its callerid), "" if unknown."""
    header = getattr(msg, "_connection_header", None) or {}
    return str(header.get("callerid", ""))


def from_relay(msg: object) -> bool:
    """True when ``msg`` was published by a relay end, i.e. it came from another robot."""
    return is_relay_end(sender(msg))


class Inbox:
    """The bounded queue between a node's callbacks (any thread) and its loop: ``(kind, payload)`` items;
    what does not fit is dropped and counted (:attr:`dropped`), a callback never blocks."""

    def __init__(self, size: int) -> None:
        self._queue: queue.Queue[tuple[str, object]] = queue.Queue(size)
        self.dropped = 0

    def put(self, kind: str, payload: object = None) -> None:
        try:
            self._queue.put_nowait((kind, payload))
        except queue.Full:
            self.dropped += 1

    def get(self, timeout: float) -> tuple[str, object]:
        """The next item, waiting at most ``timeout`` s; ``("", None)`` when there was none."""
        try:
            return self._queue.get(timeout=timeout) if timeout > 0 else self._queue.get_nowait()
        except queue.Empty:
            return "", None

    def __len__(self) -> int:
        return self._queue.qsize()


def carry_out(store: StateFile | None, state: Callable[[], dict[str, Any]], actions: list[Action],
              durable: list[Action], execute: Callable[[list[Action]], None], changed: bool) -> None:
    """Carry out a core's ``actions`` (``execute``); with a ``store``, ``state()`` is saved first with the
    ``durable`` ones as its outbox, and when the input ``changed`` it (:meth:`StateFile.commit`)."""
    if store is None:
        execute(actions)
    else:
        store.commit(state, actions, durable, execute, changed)


def diagnostics(name: str, robot: str, values: Mapping[str, object], warn: bool, message: str,
                now: float) -> DiagnosticArray:
    """A ``/diagnostics`` message of one status: ``name``, the robot as its hardware id, WARN or OK, a one-line
    ``message`` and ``values`` (sorted by key, as text); stamped ``now`` (ROS s)."""
    status = DiagnosticStatus()
    status.name = name
    status.hardware_id = robot
    status.level = DiagnosticStatus.WARN if warn else DiagnosticStatus.OK
    status.message = message
    status.values = [KeyValue(str(k), str(v)) for k, v in sorted(values.items())]
    arr = DiagnosticArray()
    arr.header.stamp = ros_time(now)
    arr.status = [status]
    return arr
