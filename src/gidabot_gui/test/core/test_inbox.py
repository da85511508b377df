"""The hand-over from ROS callback threads to the Qt thread (core.inbox)."""

from __future__ import annotations

from gidabot_gui.core.inbox import Inbox


def test_inbox_keeps_latest_state_and_every_event() -> None:
    inbox = Inbox(max_events=3)
    for i in range(10):
        inbox.put_state("status", "Kbot", i)
    inbox.put_state("status", "Tartalo", 1)
    for i in range(5):
        inbox.put_event("nav_event", i)
    out = inbox.drain()
    assert out.states == [("status", 9), ("status", 1)]
    assert [r for _k, r in out.events] == [2, 3, 4] and out.dropped == 2
    assert not inbox.drain()
