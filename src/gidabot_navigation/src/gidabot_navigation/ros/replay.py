"""Recent events replayed to a subscriber that connects late ("latched events").

A ROS subscriber sees only what is published after it connected. A node that is
killed and respawned (or starts a few seconds after its peers) would therefore miss
every event published while it was down: a goal, a Cancel, the visitor's Continue.
Event publishers keep what they published in the last ``window`` wall seconds (at
most ``limit`` messages) and send it again, on that connection only, to every new
subscriber. Receivers already ignore event uids they have handled
(docs/interfaces.md), so a replay only fills the gap; a node that restarts keeps
its handled uids across the restart (:mod:`gidabot_navigation.guiding.state`).

:class:`ReplayBuffer` is ROS-free; :class:`ReplayPublisher` wraps ``rospy.Publisher``.
A node's events are replayed to relay ends too (a relay end that was down missed
them; it forwards only what it has not forwarded before). A relay end's own event
publishers replay to no relay: relays never forward what a relay published.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Any

from gidabot_navigation.interface import is_relay_end
from gidabot_navigation.ros.rospy_internals import peer_of, publisher_lock

DEFAULT_WINDOW = 60.0     # wall s of events a late subscriber gets again


class ReplayBuffer:
    """The items added in the last ``window`` s (monotonic clock), at most ``limit`` (oldest dropped)."""

    def __init__(self, window: float = DEFAULT_WINDOW, limit: int = 100,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not (window >= 0 and limit >= 0):
            raise ValueError(f"replay window {window!r} s and limit {limit!r} must be >= 0")
        self.window = float(window)
        self.limit = int(limit)
        self.clock = clock
        self._items: deque[tuple[float, Any]] = deque()
        self._lock = threading.Lock()
        self.replayed = 0                  # items sent again to late subscribers

    def add(self, item: Any) -> None:
        if self.limit == 0 or self.window == 0:
            return
        now = self.clock()
        with self._lock:
            self._items.append((now, item))
            self._trim(now)

    def recent(self) -> list[Any]:
        """What a subscriber connecting now gets, oldest first."""
        now = self.clock()
        with self._lock:
            self._trim(now)
            return [item for _, item in self._items]

    def __len__(self) -> int:
        with self._lock:
            return len(self._items)

    def _trim(self, now: float) -> None:
        while self._items and (len(self._items) > self.limit or now - self._items[0][0] > self.window):
            self._items.popleft()


def replay_to_peer(buffer: ReplayBuffer, lock: AbstractContextManager[Any], peer_publish: Callable[..., Any],
                   skip_relays: bool = False) -> int:
    """Send ``buffer``'s recent items through ``peer_publish``, each under the publisher's ``lock``
    (:func:`gidabot_navigation.ros.rospy_internals.publisher_lock`: rospy's ``peer_publish`` shares the
    publisher's serialisation buffer with ``publish``). Returns the count.

    ``skip_relays`` (a relay's own publishers): no replay to a relay subscriber, which would never
    forward it. A node's events are replayed to a relay end too: one that (re)started missed them, and
    it forwards only those it has not forwarded before (digests in its journal)."""
    if skip_relays and is_relay_end(peer_of(peer_publish)):
        return 0
    sent = 0
    for msg in buffer.recent():
        with lock:
            peer_publish(msg)
        sent += 1
    buffer.replayed += sent
    return sent


class ReplayPublisher:
    """A ``rospy.Publisher`` whose recent messages are replayed to every new (non-relay) subscriber.

    ``limit`` defaults to half the queue size, so a replay never overflows the new connection's queue.
    """

    def __init__(self, topic: str, data_class: type, queue_size: int, window: float = DEFAULT_WINDOW,
                 limit: int | None = None, latch: bool = False) -> None:
        import rospy

        owner = self

        class _Listener(rospy.SubscribeListener):
            def peer_subscribe(self, topic_name: str, topic_publish: Callable, peer_publish: Callable) -> None:
                replay_to_peer(owner.buffer, publisher_lock(owner.pub), peer_publish)

        self.buffer = ReplayBuffer(window, max(1, queue_size // 2) if limit is None else limit)
        self.pub = rospy.Publisher(topic, data_class, queue_size=queue_size, latch=latch,
                                   subscriber_listener=_Listener())

    def publish(self, msg: Any) -> None:
        self.buffer.add(msg)
        self.pub.publish(msg)

    def get_num_connections(self) -> int:
        return int(self.pub.get_num_connections())

    def unregister(self) -> None:
        self.pub.unregister()
