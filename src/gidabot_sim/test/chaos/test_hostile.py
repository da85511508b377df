"""The hostile messages: every template builds a valid message, robots filled in."""

from __future__ import annotations

import math

import pytest

from gidabot_sim.chaos.hostile import HOSTILE_MESSAGES, fill_placeholders, hostile_by_name


def test_every_hostile_template_builds_a_message() -> None:
    pytest.importorskip("gidabot_msgs.msg")
    import io

    import roslib.message

    from gidabot_sim.chaos.probe_node import build_message

    for h in HOSTILE_MESSAGES:
        data = fill_placeholders(h.msg, "Kbot", "Tartalo")
        data = {k: v for k, v in data.items() if k != "header"}
        msg = build_message(roslib.message.get_message_class(h.type), data)
        buf = io.BytesIO()
        msg.serialize(buf)                      # what the probe publishes is a valid message of its type
        assert buf.tell() > 0, h.name
    goal = build_message(roslib.message.get_message_class("gidabot_msgs/Goal"),
                         fill_placeholders(hostile_by_name("goal_huge_strings").msg, "Kbot", "Tartalo"))
    assert len(goal.goal_id) == 300_000 and goal.goal_id == "9" * 300_000
    nan = build_message(roslib.message.get_message_class("gidabot_msgs/Goal"),
                        hostile_by_name("goal_nan_pose").msg)
    assert math.isnan(nan.initial_pose.x)
    pend = build_message(roslib.message.get_message_class("gidabot_msgs/PendingRequests"),
                         hostile_by_name("pending_spoofed").msg)
    assert math.isnan(pend.eta[0]) and math.isinf(pend.eta[1]) and pend.wait_new == -math.inf


def test_hostile_templates_fill_in_robots() -> None:
    h = hostile_by_name("cancel_ghost_robot")
    msg = fill_placeholders(h.msg, "Kbot", "Tartalo")
    assert msg["goal_uid"] == "Tartalo/v/gm.x.1" and msg["origin_robot"] == "Ghost"
    big = fill_placeholders(hostile_by_name("goal_huge_strings").msg, "Kbot", "Tartalo")
    assert big["goal_id"] == ["__repeat__", "9", 300_000]
    with pytest.raises(KeyError):
        hostile_by_name("nope")
