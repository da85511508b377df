"""What a visitor is shown before confirming (core.plans): the robots involved, their waits, the ways."""

from __future__ import annotations

from dataclasses import replace

from gidabot_gui.core.model import Fleet, TourInfo
from gidabot_gui.core.plans import plan_request, tour_ways
from gidabot_navigation.guiding.messages import PendingData


def test_plan_shows_both_robots_and_ways(faculty, status) -> None:
    fleet = Fleet(faculty)
    fleet.update_status(status("Kbot", 1, pending=1, busy_for=200.0), 10.0)
    fleet.update_status(status("Galtxagorri", 2, x=4.4), 10.0)
    fleet.update_pending(PendingData("Galtxagorri", 2, 2, 400.0), 10.0)
    plan = plan_request(fleet, "Kbot", "223", 11.0)
    assert plan.changes_floor and plan.ways == ("stairs", "lift")
    here, goal = plan.waits
    assert (here.robot, here.here, here.num, here.wait_s, here.leg) == ("Kbot", True, 1, 199.0, "start")
    # Galtxagorri stands at the west staircase's meeting point: its wait only (1 s older)
    assert (goal.robot, goal.num, goal.wait_s, goal.leg) == ("Galtxagorri", 2, 399.0, "goal")
    same = plan_request(fleet, "Kbot", "101", 11.0)
    assert not same.changes_floor and same.ways == () and len(same.waits) == 1


def test_plan_names_the_robots_that_would_serve_each_leg(faculty6, status) -> None:
    """faculty6: Kbot is busy, Basajaun free: Basajaun would come; upstairs Lamia is nearer the staircase."""
    fleet = Fleet(faculty6)
    fleet.update_status(status("Kbot", 1, x=30.0, pending=1, busy_for=300.0), 10.0)
    fleet.update_status(status("Basajaun", 1, x=40.0), 10.0)
    fleet.update_status(status("Galtxagorri", 2, x=40.0), 10.0)
    fleet.update_status(status("Lamia", 2, x=62.0), 10.0)
    plan = plan_request(fleet, "Kbot", "231", 10.0)          # 231: the east end of floor 2: the east staircase
    start, goal = plan.waits
    assert (start.robot, start.here, start.leg) == ("Basajaun", False, "start") and start.wait_s < 60
    assert (goal.robot, goal.leg) == ("Lamia", "goal") and goal.wait_s < 30
    # Basajaun offline: Kbot itself, after its queue
    fleet.update_status(status("Kbot", 1, x=30.0, pending=1, busy_for=300.0), 20.0)
    for name in ("Galtxagorri", "Lamia"):
        fleet.update_status(status(name, 2, x=62.0), 20.0)
    start, _ = plan_request(fleet, "Kbot", "231", 20.0).waits
    assert (start.robot, start.here) == ("Kbot", True) and start.wait_s >= 290


def test_plan_without_robot_on_goal_floor(faculty) -> None:
    building = replace(faculty, robots=tuple(r for r in faculty.robots if r.name != "MariSorgin"))
    plan = plan_request(Fleet(building), "Kbot", "301", 0.0)
    assert not plan.robot_on_goal_floor and [w.robot for w in plan.waits] == ["Kbot"]
    assert not plan.waits[0].known                    # no status yet: not available


def test_tour_ways(faculty, tour) -> None:
    assert tour_ways(faculty, 0, TourInfo("a.tour", "", "en", ((0, "014", "x"),))) == ()
    assert tour_ways(faculty, 1, tour) == ("stairs", "lift")
