"""A node's ROS adapter without a master: rospy's publishers, subscribers, timers and clock replaced by
recorders, so a test builds the real node class, feeds messages to its callbacks and reads what it publishes."""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any

import genpy
import pytest
import rospy


class FakePublisher:
    """Records what is published (for ``rospy.Publisher`` and ``ReplayPublisher`` alike)."""

    def __init__(self, bus: FakeRos, topic: str, cls: type, **_kw: Any) -> None:
        self.topic, self.cls, self.sent = topic, cls, []
        self.buffer = SimpleNamespace(replayed=0)
        bus.pubs.setdefault(topic, []).append(self)

    def publish(self, msg: genpy.Message) -> None:
        assert isinstance(msg, self.cls), (self.topic, type(msg))
        buf = io.BytesIO()
        msg.serialize(buf)                  # what a subscriber would receive
        self.sent.append(msg)

    def unregister(self) -> None:
        pass


@dataclass
class FakeRos:
    """The master the node sees: its publishers by topic, its subscribers' callbacks, the ROS clock."""

    now: float = 100.0
    pubs: dict[str, list[FakePublisher]] = field(default_factory=dict)
    subs: dict[str, list[tuple[Callable, object]]] = field(default_factory=dict)

    def publisher(self, topic: str, cls: type, **kw: Any) -> FakePublisher:
        return FakePublisher(self, topic, cls, **kw)

    def subscriber(self, topic: str, cls: type, callback: Callable, callback_args: object = None,
                   **_kw: Any) -> SimpleNamespace:
        self.subs.setdefault(topic, []).append((callback, callback_args))
        return SimpleNamespace(unregister=lambda: None)

    def feed(self, topic: str, msg: object, callerid: str = "/someone") -> None:
        """Deliver ``msg`` to every subscriber of ``topic`` as published by ``callerid``."""
        msg._connection_header = {"callerid": callerid}  # type: ignore[attr-defined]
        assert topic in self.subs, f"nobody subscribes to {topic}"
        for callback, args in self.subs[topic]:
            if args is None:
                callback(msg)
            else:
                callback(msg, args)

    def sent(self, topic: str) -> list[genpy.Message]:
        return [m for p in self.pubs.get(topic, []) for m in p.sent]


def fake_ros(monkeypatch: pytest.MonkeyPatch, *modules: object) -> FakeRos:
    """Replace rospy's publishers, subscribers, timers and clock (and each module's ``ReplayPublisher``)."""
    bus = FakeRos()
    monkeypatch.setattr(rospy, "Publisher", bus.publisher)
    monkeypatch.setattr(rospy, "Subscriber", bus.subscriber)
    monkeypatch.setattr(rospy, "Timer", lambda *a, **k: SimpleNamespace(shutdown=lambda: None))
    monkeypatch.setattr(rospy, "get_time", lambda: bus.now)
    monkeypatch.setattr(rospy.Time, "now", staticmethod(lambda: rospy.Time.from_sec(bus.now)))
    monkeypatch.setattr(rospy, "is_shutdown", lambda: False)
    for module in modules:
        if hasattr(module, "ReplayPublisher"):
            monkeypatch.setattr(module, "ReplayPublisher", bus.publisher)
    return bus


def raw(msg: genpy.Message, callerid: str = "/someone") -> SimpleNamespace:
    """``msg`` as a ``rospy.AnyMsg`` subscriber receives it: its bytes and connection header."""
    buf = io.BytesIO()
    msg.serialize(buf)
    return SimpleNamespace(_buff=buf.getvalue(), _connection_header={"callerid": callerid})


def spin(node: Any) -> None:
    """Run a node's loop (``spin_once``) until every input fed so far is handled."""
    node.spin_once(0.0)
    while len(node.inbox):
        node.spin_once(0.0)


def phases(bus: FakeRos) -> list[int]:
    """The phases of the NavEvents published so far, in order."""
    from gidabot_navigation.interface import Topic
    from gidabot_navigation.ros.convert import event_from_msg

    return [event_from_msg(m).phase for m in bus.sent(Topic.NAV_EVENTS)]
