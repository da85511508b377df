"""Guiding message forms: validation of hostile input."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from gidabot_navigation.errors import GoalRejected
from gidabot_navigation.guiding import messages as gt
from gidabot_navigation.guiding.messages import CommandData, Trip, validate_command, validate_trip
from gidabot_navigation.interface import Cmd


def good_trip(faculty) -> Trip:
    loc = faculty.location("301")
    return Trip(uid="Tartalo/v/gm.x.1", origin_robot="Tartalo", visitor_id="v", initial_floor=0.0, initial_x=30.0,
                initial_y=12.0, goal_floor=3.0, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw,
                way="stairs", connector="stairs_west", start_id="robot", goal_id="301", language="en")


def test_a_good_trip_passes_normalised(faculty) -> None:
    trip = replace(good_trip(faculty), goal_x=good_trip(faculty).goal_x + 0.3, initial_floor=1e-5)
    out = validate_trip(faculty, trip)
    assert out.initial_floor == 0.0 and out.goal_x == faculty.location("301").pose.x   # the building's pose


HOSTILE = [
    ("NaN floor", {"goal_floor": math.nan}, "not_finite"),
    ("inf x", {"initial_x": math.inf}, "not_finite"),
    ("NaN yaw", {"goal_yaw": math.nan}, "not_finite"),
    ("unknown floor", {"goal_floor": 7.0}, "floor"),
    ("mezzanine that does not exist", {"initial_floor": 0.5}, "floor"),
    ("origin not on initial floor", {"initial_floor": 1.0}, "floor"),
    ("unknown origin", {"origin_robot": "R2D2"}, "robot"),
    ("unknown location", {"goal_id": "999"}, "location"),
    ("location on another floor", {"goal_id": "223"}, "location"),
    ("pose far from the location", {"goal_x": 1.0}, "pose"),
    ("initial pose off the map", {"initial_x": -500.0}, "pose"),
    ("huge uid", {"uid": "x" * 100000}, "too_long"),
    ("huge goal id", {"goal_id": "9" * 5000}, "too_long"),
    ("control chars", {"visitor_id": "a\x00b"}, "text"),
    ("uid with spaces", {"uid": "a b"}, "text"),
    ("empty uid", {"uid": ""}, "empty"),
    ("non-string", {"uid": 5}, "type"),
    ("bad way", {"way": "teleport"}, "way"),
    ("no way across floors", {"way": ""}, "way"),
    ("unknown connector", {"connector": "chimney"}, "connector"),
    ("connector of the wrong kind", {"connector": "lift"}, "connector"),
    ("bad language", {"language": "tlh"}, "language"),
    ("tour path traversal", {"tour_file": "../../etc/passwd", "tour_step": 0}, "tour"),
    ("tour step out of range", {"tour_file": "long_tour.tour", "tour_step": 100000}, "tour"),
    ("tour step without file", {"tour_step": 3}, "tour"),
    ("unknown start id", {"start_id": "nowhere"}, "location"),
]


@pytest.mark.parametrize(("what", "change", "reason"), HOSTILE, ids=[h[0] for h in HOSTILE])
def test_hostile_trips_are_rejected_with_a_reason(faculty, what: str, change: dict, reason: str) -> None:
    with pytest.raises(GoalRejected) as err:
        validate_trip(faculty, replace(good_trip(faculty), **change))
    assert err.value.reason == reason, (what, str(err.value))
    assert len(str(err.value)) < 400


def test_one_floor_trip_with_a_connector_is_rejected(faculty) -> None:
    loc = faculty.location("005")
    trip = replace(good_trip(faculty), goal_floor=0.0, goal_id="005", goal_x=loc.pose.x, goal_y=loc.pose.y)
    with pytest.raises(GoalRejected, match="one floor"):
        validate_trip(faculty, trip)
    assert validate_trip(faculty, replace(trip, connector="")).connector == ""


def test_commands_are_checked() -> None:
    ok = validate_command(CommandData(command=Cmd.REQUEST, goal_id="223", way="lift", language="eu",
                                      visitor_id="bad id/with slash"))
    assert ok.visitor_id == ""            # unusable in a uid: replaced by the default later
    for cmd, reason in ((CommandData(command=9), "command"), (CommandData(command=True), "command"),
                        (CommandData(command=0, way="fly"), "way"), (CommandData(command=0, language="xx"), "language"),
                        (CommandData(command=0, goal_id="x" * 1000), "too_long"),
                        (CommandData(command=3, tour_file="../x.tour"), "tour"),
                        (CommandData(command=4, tour_step="3"), "type")):
        with pytest.raises(GoalRejected) as err:
            validate_command(cmd)
        assert err.value.reason == reason


def test_uids_are_unique_across_restarts() -> None:
    a, b = gt.UidMaker("Kbot", "gm"), gt.UidMaker("Kbot", "gm", boot="other")
    assert a.event() != b.event()
    assert a.event() != a.event()
    assert a.goal("v").startswith("Kbot/v/gm.") and a.cancel().startswith("Kbot/cancel/gm.")


def test_seen_set_is_bounded() -> None:
    s = gt.SeenSet(limit=3)
    assert s.add("a") and not s.add("a")
    for x in "bcd":
        s.add(x)
    assert "a" not in s and len(s) == 3
