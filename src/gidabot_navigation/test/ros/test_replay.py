"""Recent events replayed to late subscribers (replay.py), without ROS."""

from __future__ import annotations

import threading

import pytest

from gidabot_navigation.interface import Node, global_name, relay_end_name
from gidabot_navigation.ros.replay import ReplayBuffer, replay_to_peer
from gidabot_navigation.ros.rospy_internals import peer_of


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_buffer_keeps_the_window_and_the_limit() -> None:
    clock = Clock()
    buf = ReplayBuffer(window=10.0, limit=3, clock=clock)
    for i in range(5):
        buf.add(i)
        clock.t += 1.0
    assert buf.recent() == [2, 3, 4]                 # limit: the oldest dropped
    clock.t = 13.5
    assert buf.recent() == [4]                       # 2 and 3 are older than 10 s
    clock.t = 100.0
    assert buf.recent() == [] and len(buf) == 0
    off = ReplayBuffer(window=0.0, limit=5, clock=clock)
    off.add("x")
    assert off.recent() == []
    with pytest.raises(ValueError):
        ReplayBuffer(window=-1.0)


class Conn:
    def __init__(self, endpoint_id: str) -> None:
        self.endpoint_id = endpoint_id


class Impl:
    """Stands for rospy's _PublisherImpl: a lock around every peer publish (rospy_internals.publisher_lock)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()


def publish_single_for(conn: Conn, impl: Impl, sent: list) -> object:
    """A closure shaped like rospy's ``publish_single`` (it closes over the connection)."""
    def publish_single(data: object) -> None:
        assert impl.lock.locked()
        sent.append((conn.endpoint_id, data))
    return publish_single


def test_replay_goes_to_a_late_subscriber_under_the_lock_and_to_relays_unless_a_relay_publishes() -> None:
    buf = ReplayBuffer(window=60.0, limit=10)
    for i in range(3):
        buf.add(f"event-{i}")
    impl, sent = Impl(), []
    node = global_name(Node.GOAL_MANAGER)
    assert peer_of(publish_single_for(Conn(node), impl, sent)) == node
    assert replay_to_peer(buf, impl.lock, publish_single_for(Conn(node), impl, sent)) == 3
    assert sent == [(node, "event-0"), (node, "event-1"), (node, "event-2")]
    relay = Conn(relay_end_name("Tartalo", "Kbot"))
    assert replay_to_peer(buf, impl.lock, publish_single_for(relay, impl, sent), skip_relays=True) == 0
    assert replay_to_peer(buf, impl.lock, publish_single_for(relay, impl, sent)) == 3     # a node's events: forwarded
    assert buf.replayed == 6 and not impl.lock.locked()
    assert peer_of(lambda data: None) == ""           # unknown peer: replayed to
