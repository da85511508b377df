"""What a visitor is shown before confirming (core.plans): the robots involved, their waits, the ways."""

from __future__ import annotations

from dataclasses import replace

from gidabot_gui.core.model import Fleet, PendingData, TourInfo
from gidabot_gui.core.plans import plan_request, tour_ways


def test_plan_shows_both_robots_and_ways(faculty, status) -> None:
    fleet = Fleet(faculty)
    fleet.update_status(status("Kbot", 1, pending=1, busy_for=200.0), 10.0)
    fleet.update_status(status("Galtxagorri", 2), 10.0)
    fleet.update_pending(PendingData("Galtxagorri", 2, 2, 400.0), 10.0)
    plan = plan_request(fleet, "Kbot", "223", 11.0)
    assert plan.changes_floor and plan.ways == ("stairs", "lift")
    here, goal = plan.waits
    assert (here.robot, here.here, here.num, here.wait_s) == ("Kbot", True, 1, 200.0)
    assert (goal.robot, goal.num, goal.wait_s) == ("Galtxagorri", 2, 400.0)
    same = plan_request(fleet, "Kbot", "101", 11.0)
    assert not same.changes_floor and same.ways == () and len(same.waits) == 1


def test_plan_without_robot_on_goal_floor(faculty) -> None:
    building = replace(faculty, robots=tuple(r for r in faculty.robots if r.name != "MariSorgin"))
    plan = plan_request(Fleet(building), "Kbot", "301", 0.0)
    assert not plan.robot_on_goal_floor and [w.robot for w in plan.waits] == ["Kbot"]
    assert not plan.waits[0].known                    # no status yet: not available


def test_tour_ways(faculty, tour) -> None:
    assert tour_ways(faculty, 0, TourInfo("a.tour", "", "en", ((0, "014", "x"),))) == ()
    assert tour_ways(faculty, 1, tour) == ("stairs", "lift")
