"""Guiding message forms: validation of hostile input."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from gidabot_navigation.errors import GoalRejected
from gidabot_navigation.guiding import messages
from gidabot_navigation.guiding.messages import (
    MAX_STAFF_DETAIL,
    CommandData,
    StaffCommandData,
    Trip,
    validate_command,
    validate_staff,
    validate_trip,
)
from gidabot_navigation.interface import LEG_COMMITTED, LEG_GOAL, LEG_NONE, LEG_PROPOSED, Cmd, Phase, StaffCmd
from gidabot_navigation.senders import uid_robot


def good_trip(faculty) -> Trip:
    loc = faculty.location("301")
    return Trip(uid="Tartalo/v/gm.x.1", origin_robot="Tartalo", visitor_id="v", initial_floor=0.0, initial_x=30.0,
                initial_y=12.0, goal_floor=3.0, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw,
                way="stairs", connector="stairs_west", start_id="robot", goal_id="301", language="en",
                start_robot="Tartalo", start_state=LEG_COMMITTED, goal_robot="MariSorgin",
                goal_state=LEG_PROPOSED, attempt=1)


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
    ("uid ending in a newline", {"uid": "u1\n"}, "text"),
    ("goal id ending in a newline", {"goal_id": "305\n"}, "text"),
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
    ("start leg of a robot of another floor", {"start_robot": "Kbot"}, "assignment"),
    ("start leg without robot", {"start_robot": "", "start_state": LEG_NONE}, "assignment"),
    ("goal leg named but in no state", {"goal_state": LEG_NONE}, "assignment"),
    ("unknown leg state", {"goal_state": 7}, "assignment"),
    ("leg state not a number", {"goal_state": True}, "assignment"),
    ("negative attempt", {"attempt": -1}, "assignment"),
    ("unknown assignee", {"goal_robot": "Nobody"}, "assignment"),
]


@pytest.mark.parametrize(("what", "change", "reason"), HOSTILE, ids=[h[0] for h in HOSTILE])
def test_hostile_trips_are_rejected_with_a_reason(faculty, what: str, change: dict, reason: str) -> None:
    with pytest.raises(GoalRejected) as err:
        validate_trip(faculty, replace(good_trip(faculty), **change))
    assert err.value.reason == reason, (what, str(err.value))
    assert len(str(err.value)) < 400


def test_a_goal_leg_given_to_nobody_is_valid(faculty) -> None:
    """The goal floor's robots are all out of service: nobody serves the goal leg, the visitor goes alone."""
    out = validate_trip(faculty, replace(good_trip(faculty), goal_robot="", goal_state=LEG_NONE))
    assert (out.goal_robot, out.goal_state) == ("", LEG_NONE)


def test_one_floor_trip_with_a_connector_is_rejected(faculty) -> None:
    loc = faculty.location("005")
    trip = replace(good_trip(faculty), goal_floor=0.0, goal_id="005", goal_x=loc.pose.x, goal_y=loc.pose.y)
    with pytest.raises(GoalRejected, match="one floor"):
        validate_trip(faculty, trip)
    with pytest.raises(GoalRejected, match="a trip on one floor has no goal leg"):
        validate_trip(faculty, replace(trip, connector=""))
    assert validate_trip(faculty, replace(trip, connector="", goal_robot="", goal_state=LEG_NONE)).connector == ""


def test_assignments_follow_the_robots_of_each_floor(faculty6, faculty3) -> None:
    trip = replace(good_trip(faculty6), goal_floor=2.0, goal_id="223", goal_x=faculty6.location("223").pose.x,
                   goal_y=faculty6.location("223").pose.y, goal_robot="Lamia")
    assert validate_trip(faculty6, trip).goal_robot == "Lamia"
    assert validate_trip(faculty6, replace(trip, goal_robot="Galtxagorri")).leg_of("Galtxagorri") == LEG_GOAL
    with pytest.raises(GoalRejected, match="goal_robot 'Basajaun' is not a robot of floor 2"):
        validate_trip(faculty6, replace(trip, goal_robot="Basajaun"))
    # floor 2 of faculty3 has no robot: the visitor finds 223 alone; nobody may be named for that leg
    t3 = replace(trip, goal_robot="", goal_state=LEG_NONE)
    assert validate_trip(faculty3, t3).goal_state == LEG_NONE
    with pytest.raises(GoalRejected, match="floor 2 has no robot"):
        validate_trip(faculty3, replace(t3, goal_robot="MariSorgin", goal_state=LEG_PROPOSED))


def test_a_tour_goes_on_from_a_floor_without_robot(faculty3) -> None:
    """A trip may start on a floor without robot, at a location there (the last stop the visitor found alone)."""
    last, nxt = faculty3.location("274"), faculty3.location("325")
    trip = Trip(uid="Kbot/v/gm.x.2", origin_robot="Kbot", visitor_id="v", initial_floor=2.0, initial_x=last.pose.x,
                initial_y=last.pose.y, goal_floor=3.0, goal_x=nxt.pose.x, goal_y=nxt.pose.y, goal_yaw=nxt.pose.yaw,
                way="stairs", connector="stairs_west", start_id="274", goal_id="325", language="en",
                tour_file="real_world.tour", tour_step=6, goal_robot="MariSorgin", goal_state=LEG_PROPOSED,
                attempt=1)
    assert validate_trip(faculty3, trip).start_state == LEG_NONE
    for change, match in (({"start_id": "robot"}, "must start at a location of that floor"),
                          ({"start_id": "325"}, "must start at a location of that floor"),
                          ({"initial_x": last.pose.x + 5}, "must start at a location of that floor"),
                          ({"start_robot": "Kbot", "start_state": LEG_COMMITTED}, "floor 2 has no robot")):
        with pytest.raises(GoalRejected, match=match):
            validate_trip(faculty3, replace(trip, **change))


def test_events_about_legs_are_checked(faculty6) -> None:
    ev = messages.NavEventData(uid="Kbot/event/gm.x.1", robot="Kbot", floor=1.0, goal_uid="Kbot/v/gm.x.1",
                         phase=Phase.ASSIGNED, leg=LEG_GOAL, attempt=3, assignee="Lamia", eta=42.0)
    assert messages.validate_event(faculty6, ev).assignee == "Lamia"
    assert messages.validate_event(faculty6, replace(ev, eta=math.nan)).eta == 0.0
    for change, reason in (({"leg": "middle"}, "leg"), ({"attempt": -2}, "assignment"),
                           ({"assignee": ""}, "assignment"), ({"assignee": "Nobody"}, "robot"),
                           ({"goal_uid": ""}, "leg"), ({"phase": Phase.ACCEPTED, "leg": ""}, "leg")):
        with pytest.raises(GoalRejected) as err:
            messages.validate_event(faculty6, replace(ev, **change))
        assert err.value.reason == reason, change


def test_commands_are_checked() -> None:
    ok = validate_command(CommandData(command=Cmd.REQUEST, goal_id="223", way="lift", language="eu",
                                      visitor_id="bad id/with slash"))
    assert ok.visitor_id == ""            # unusable in a uid: replaced by the default later
    for cmd, reason in ((CommandData(command=9), "command"), (CommandData(command=True), "command"),
                        (CommandData(command=Cmd.REQUEST, way="fly"), "way"),
                        (CommandData(command=Cmd.REQUEST, language="xx"), "language"),
                        (CommandData(command=Cmd.REQUEST, goal_id="x" * 1000), "too_long"),
                        (CommandData(command=Cmd.START_TOUR, tour_file="../x.tour"), "tour"),
                        (CommandData(command=Cmd.SKIP, tour_step="3"), "type")):
        with pytest.raises(GoalRejected) as err:
            validate_command(cmd)
        assert err.value.reason == reason


def test_uids_are_unguessable_unique_across_restarts_and_in_their_robots_namespace() -> None:
    a, b = messages.UidMaker("Kbot", "gm"), messages.UidMaker("Kbot", "gm")          # two runs of one node
    made = [a.event(), b.event(), a.event(), a.goal("v"), b.goal("v"), a.cancel()]
    assert len(set(made)) == len(made)
    for uid in made:
        token = uid.rsplit(".", 1)[1]
        assert uid_robot(uid) == "Kbot" and len(token) >= 16 and int(token, 16) >= 0     # 64 random bits at least
    assert a.goal("v").startswith("Kbot/v/gm.") and a.cancel().startswith("Kbot/cancel/gm.")
    # a counted uid (guessable), or one without its robot's namespace, is no uid of any robot
    for bad in ("Kbot/event/gm.t.1", "Kbot/v/1", "Kbot/event/gm.0123456789abcde", "Kbot/event/gm.0123456789ABCDEF",
                "/event/gm.0123456789abcdef", "Kbot/gm.0123456789abcdef", "Kbot/v/gm.0123456789abcdef/x",
                "Kbot/" + "v" * 150 + "/gm.0123456789abcdef", 7):
        assert uid_robot(bad) is None, bad


def test_seen_set_is_bounded() -> None:
    s = messages.SeenSet(limit=3)
    assert s.add("a") and not s.add("a")
    for x in "bcd":
        s.add(x)
    assert "a" not in s and len(s) == 3


# -- staff commands ------------------------------------------------------------------------
def good_staff() -> StaffCommandData:
    return StaffCommandData(uid="Kbot/staff/dash.x.1", robot="Kbot", user="ana", command=int(StaffCmd.OUT_OF_SERVICE),
                            target_robot="Tartalo", version=1_800_000_000_000_000_000, detail="a wheel squeaks",
                            stamp=1.8e9)


def test_staff_commands_are_checked(faculty) -> None:
    assert validate_staff(faculty, good_staff()) == good_staff()
    long = validate_staff(faculty, replace(good_staff(), detail="x" * 500))
    assert long.detail == "x" * MAX_STAFF_DETAIL
    for change, reason in (({"uid": "Tartalo/staff/1"}, "namespace"), ({"uid": "bad uid"}, "text"),
                           ({"robot": "Nobody", "uid": "Nobody/staff/1"}, "robot"),
                           ({"target_robot": "Nobody"}, "robot"),
                           ({"command": 7}, "command"), ({"command": True}, "command"), ({"version": 0}, "version"),
                           ({"version": 2 ** 64}, "version"), ({"user": "a b"}, "text"), ({"user": ""}, "empty"),
                           ({"detail": "line\nbreak"}, "text"), ({"target_robot": 5}, "type")):
        with pytest.raises(GoalRejected) as err:
            validate_staff(faculty, replace(good_staff(), **change))
        assert err.value.reason == reason, change
