"""Shared fixtures of gidabot_sim's unit tests: rospy without a master (``fake_ros``, see sim_support.py)."""

from __future__ import annotations

import pytest
from sim_support import FakePublisher, FakeRos, FakeSubscriber


@pytest.fixture
def fake_ros(monkeypatch: pytest.MonkeyPatch) -> FakeRos:
    import rospy

    ros = FakeRos()
    monkeypatch.setattr(rospy, "Publisher", lambda topic, data_class, **kw: FakePublisher(ros, topic, data_class, **kw))
    monkeypatch.setattr(rospy, "Subscriber", lambda topic, data_class, callback, callback_args=None, **kw:
                        FakeSubscriber(ros, topic, data_class, callback, callback_args, **kw))
    monkeypatch.setattr(rospy, "Service", lambda name, _type, handler: ros.services.__setitem__(name, handler))
    monkeypatch.setattr(rospy, "Timer", lambda _period, callback, *a, **kw: ros.timers.append(callback))
    monkeypatch.setattr(rospy, "get_param", ros.get_param)
    monkeypatch.setattr(rospy, "has_param", lambda name: name in ros.params)
    monkeypatch.setattr(rospy, "set_param", ros.params.__setitem__)
    monkeypatch.setattr(rospy, "resolve_name", ros.resolve_name)
    monkeypatch.setattr(rospy, "get_name", lambda: "/test_node")
    monkeypatch.setattr(rospy, "get_time", lambda: ros.now)
    return ros
