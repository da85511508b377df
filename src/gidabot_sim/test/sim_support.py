"""Helpers shared by gidabot_sim's unit tests: a logger that keeps its lines, a fake of actionlib's
SimpleActionServer, and rospy without a master (the ``fake_ros`` fixture of conftest.py puts :class:`FakeRos` in
rospy's place: the adapters are built as in a node, what they publish is recorded, their callbacks are fed ROS
messages by hand)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

_MISSING = object()


class ListLog:
    """A :class:`gidabot_navigation.logs.Logger` keeping its lines (warnings start with "W ", errors "E ")."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, msg: str) -> None:
        self.lines.append(msg)

    def warning(self, msg: str) -> None:
        self.lines.append("W " + msg)

    def error(self, msg: str) -> None:
        self.lines.append("E " + msg)


class FakeActionServer:
    """actionlib's SimpleActionServer as far as the move_base stand-in uses it: :meth:`send` a goal (any object),
    the results in :attr:`results`."""

    def __init__(self, name: str = "", action: type | None = None, auto_start: bool = False) -> None:
        self.name, self.started = name, False
        self.new: Any = None
        self.active = self.preempt = False
        self.results: list[tuple[str, str]] = []
        self.feedbacks: list[Any] = []
        self.goal_cb: Callable[[], None] = lambda: None
        self.preempt_cb: Callable[[], None] = lambda: None

    def register_goal_callback(self, cb: Callable[[], None]) -> None:
        self.goal_cb = cb

    def register_preempt_callback(self, cb: Callable[[], None]) -> None:
        self.preempt_cb = cb

    def start(self) -> None:
        self.started = True

    def send(self, goal: Any) -> None:
        self.new = goal
        self.goal_cb()

    def is_new_goal_available(self) -> bool:
        return self.new is not None

    def accept_new_goal(self) -> Any:
        goal, self.new, self.active, self.preempt = self.new, None, True, False
        return goal

    def is_active(self) -> bool:
        return self.active

    def is_preempt_requested(self) -> bool:
        return self.preempt

    def _end(self, kind: str, text: str) -> None:
        self.active = False
        self.results.append((kind, text))

    def set_preempted(self, _result: Any = None, text: str = "") -> None:
        self._end("preempted", text)

    def set_succeeded(self, _result: Any = None, text: str = "") -> None:
        self._end("succeeded", text)

    def set_aborted(self, _result: Any = None, text: str = "") -> None:
        self._end("aborted", text)

    def publish_feedback(self, feedback: Any) -> None:
        self.feedbacks.append(feedback)


class FakePublisher:
    def __init__(self, ros: FakeRos, topic: str, data_class: type, **kw: Any) -> None:
        self.topic, self.data_class, self.kw = topic, data_class, kw
        self.sent: list[Any] = []
        self.connections = 1
        ros.pubs[topic] = self

    def publish(self, msg: Any) -> None:
        assert isinstance(msg, self.data_class), f"{self.topic}: {type(msg).__name__} is not a {self.data_class}"
        self.sent.append(msg)

    def get_num_connections(self) -> int:
        return self.connections

    def unregister(self) -> None:
        self.connections = 0


class FakeSubscriber:
    def __init__(self, ros: FakeRos, topic: str, data_class: type, callback: Callable, callback_args: Any = None,
                 **kw: Any) -> None:
        self.topic, self.data_class, self.callback, self.args, self.kw = topic, data_class, callback, callback_args, kw
        self.active = True
        ros.subs.setdefault(topic, []).append(self)

    def unregister(self) -> None:
        self.active = False


class FakeRos:
    """What the fixture puts in rospy's place: parameters, publishers and subscribers by topic, services by name,
    timers, the node's time."""

    def __init__(self) -> None:
        self.params: dict[str, Any] = {}
        self.pubs: dict[str, FakePublisher] = {}
        self.subs: dict[str, list[FakeSubscriber]] = {}
        self.services: dict[str, Callable] = {}
        self.timers: list[Callable] = []
        self.now = 0.0

    def get_param(self, name: str, default: Any = _MISSING) -> Any:
        if name in self.params:
            return self.params[name]
        if default is _MISSING:
            raise KeyError(name)
        return default

    @staticmethod
    def resolve_name(name: str) -> str:
        return "/test_node/" + name[1:] if name.startswith("~") else name if name.startswith("/") else "/" + name

    def deliver(self, topic: str, msg: Any) -> None:
        """``msg`` to every active subscriber of ``topic``, as rospy calls them."""
        subs = [s for s in self.subs.get(topic, []) if s.active]
        assert subs, f"nobody subscribes to {topic}"
        for sub in subs:
            assert isinstance(msg, sub.data_class)
            if sub.args is None:
                sub.callback(msg)
            else:
                sub.callback(msg, sub.args)

    def subscribed(self, topic: str) -> bool:
        return any(s.active for s in self.subs.get(topic, []))
