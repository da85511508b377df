"""Involvement rule, connector choice and the wait estimate (trips.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from gidabot_navigation.errors import NoRouteError
from gidabot_navigation.guiding.messages import Trip
from gidabot_navigation.guiding.trips import HeadProgress, Role, TripPlanner, WaitModel, estimate_queue, involved, role
from gidabot_navigation.interface import GOING_TO_MEETING, ON_THE_WAY, WAITING_VISITOR


def trip(faculty, a: float, goal_id: str, way: str = "stairs", connector: str = "stairs_west",
         start: tuple[float, float] = (30.0, 12.0), uid: str = "T/v/1") -> Trip:
    loc = faculty.location(goal_id)
    origin = faculty.robot_on(a).name
    return Trip(uid=uid, origin_robot=origin, visitor_id="v", initial_floor=a, initial_x=start[0], initial_y=start[1],
                goal_floor=loc.floor, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw, way=way,
                connector=connector if a != loc.floor else "", start_id="robot", goal_id=goal_id, language="en")


@pytest.fixture(scope="module")
def planner(faculty):
    return TripPlanner(faculty)


def test_roles_and_the_involvement_rule(faculty) -> None:
    t = trip(faculty, 0, "301")
    assert [role(t, f) for f in (0, 1, 2, 3)] == [Role.START, None, None, Role.GOAL]
    same = trip(faculty, 2, "223")
    assert role(same, 2.0) is Role.SAME and not involved(same, 1)
    assert involved(replace(t, initial_floor=0.0000001), 0)     # float32 rounding


def test_table3_counts_follow_from_the_rule(faculty) -> None:
    """Paper Table 3: the 15 goals of Table 2 from floor 0 -> processed 7, 8, 8, 6."""
    floors = [0, 3, 2, 1, 2, 3, 0, 1, 2, 0, 1, 3, 2, 1, 0]
    starts = [0, *floors[:-1]]
    counts = {f: sum(1 for a, b in zip(starts, floors, strict=True) if f in (a, b)) for f in range(4)}
    assert counts == {0: 7, 1: 8, 2: 8, 3: 6}


def test_the_connector_minimises_the_whole_trip(faculty, planner) -> None:
    # west end of floor 0 to the west end of floor 3: the west staircase
    west = planner.choose_connector(0, (6.0, 12.0), 3, (faculty.location("301").pose.x,
                                                           faculty.location("301").pose.y), "stairs")
    assert west.connector.id == "stairs_west" and west.way == "stairs"
    # east end to east end: the east staircase
    east_goal = max((loc for loc in faculty.locations_on(3)), key=lambda loc: loc.pose.x)
    east = planner.choose_connector(0, (66.0, 12.0), 3, (east_goal.pose.x, east_goal.pose.y), "stairs")
    assert east.connector.id == "stairs_east"
    assert east.total == pytest.approx(east.start_leg + east.goal_leg)
    # the start robot's leg alone would not decide: start in the east, goal in the far west
    far_west = min((loc for loc in faculty.locations_on(3)), key=lambda loc: loc.pose.x)
    mixed = planner.choose_connector(0, (60.0, 12.0), 3, (far_west.pose.x, far_west.pose.y), "stairs")
    legs = {c.id: planner.leg_length(0, (60.0, 12.0), (c.meeting[0].x, c.meeting[0].y)) +
            planner.leg_length(3, (c.meeting[3].x, c.meeting[3].y), (far_west.pose.x, far_west.pose.y))
            for c in faculty.connectors_between(0, 3, "stairs")}
    assert mixed.connector.id == min(legs, key=legs.get)
    lift = planner.choose_connector(0, (6.0, 12.0), 3, (far_west.pose.x, far_west.pose.y), "lift")
    assert lift.connector.id == "lift" and lift.way == "lift"


def test_lengths_are_cached(faculty) -> None:
    p = TripPlanner(faculty)
    a = p.leg_length(0, (30.0, 12.0), (4.4, 12.0))
    n = p.plans
    assert p.leg_length(0, (30.01, 12.02), (4.4, 12.0)) == a and p.plans == n
    assert 20.0 < a < 30.0
    assert p.leg_length(0, (30.0, 12.0), (30.1, 12.0)) == 0.0
    assert p.leg_length(0, (30.0, 12.0), (-100.0, 12.0)) == math.inf


def test_no_connector_is_a_clear_error(faculty, planner) -> None:
    from gidabot_navigation.building.model import Building

    no_conn = Building(faculty.id, faculty.name, faculty.path, faculty.floors, faculty.locations, (), faculty.robots)
    with pytest.raises(NoRouteError, match="no lift or staircase joins floors 0 and 3"):
        TripPlanner(no_conn).choose_connector(0, (30.0, 12.0), 3, (10.0, 11.4), "stairs")


def test_walk_times() -> None:
    m = WaitModel()
    assert m.walk_time("stairs", 0, 3) == 60.0
    assert m.walk_time("lift", 0, 3) == 40.0
    with pytest.raises(ValueError, match="speed_factor"):
        WaitModel(speed_factor=0.0)
    with pytest.raises(ValueError, match="continue_s"):
        WaitModel(continue_s=math.nan)


def test_estimates_grow_along_the_queue(faculty, planner) -> None:
    m = WaitModel()
    robot = faculty.robot("Tartalo")
    assert estimate_queue(planner, m, robot, (30.0, 12.0), [], None, {}, 0.0) == []
    same = trip(faculty, 0, "001", uid="a")
    up = trip(faculty, 0, "301", uid="b")
    eta = estimate_queue(planner, m, robot, (30.0, 12.0), [same, up], None, {}, 0.0)
    speed = robot.max_linear * m.speed_factor
    first = planner.leg_length(0, (30.0, 12.0), (same.goal_x, same.goal_y)) / speed + m.leg_overhead_s
    assert eta[0] == pytest.approx(first, abs=0.1)
    assert eta[1] > eta[0]
    # guiding already: only the rest of the way from the current pose
    head = HeadProgress("a", ON_THE_WAY, 0.0)
    near = estimate_queue(planner, m, robot, (10.0, 12.0), [same], head, {}, 0.0)
    assert near[0] < eta[0]


def test_goal_floor_estimate_waits_for_the_visitor(faculty, planner) -> None:
    m = WaitModel()
    mari = faculty.robot("MariSorgin")
    up = trip(faculty, 0, "301", uid="b")
    not_released = estimate_queue(planner, m, mari, (30.0, 12.0), [up], None, {}, 100.0)[0]
    walk = m.walk_time("stairs", 0, 3)
    assert not_released > walk + m.continue_s
    released = estimate_queue(planner, m, mari, (4.4, 12.0), [up], HeadProgress("b", WAITING_VISITOR, 90.0),
                              {"b": 100.0}, 100.0)[0]
    to_goal = planner.leg_length(3, (4.4, 12.0), (up.goal_x, up.goal_y)) / (mari.max_linear * m.speed_factor)
    assert released == pytest.approx(walk + m.continue_s + to_goal, abs=0.2)
    later = estimate_queue(planner, m, mari, (4.4, 12.0), [up], HeadProgress("b", WAITING_VISITOR, 90.0),
                           {"b": 100.0}, 100.0 + walk + 30)[0]
    assert later == pytest.approx(m.continue_s + to_goal, abs=0.2)
    driving = estimate_queue(planner, m, mari, (30.0, 12.0), [up], HeadProgress("b", GOING_TO_MEETING, 90.0),
                             {}, 100.0)[0]
    assert driving > 0


def test_a_connector_is_offered_only_between_floors_it_serves(faculty) -> None:
    """stairs_west serving floors 1-3 only (its floor-0 pose left in the model, as the loader no longer
    allows): a trip from floor 0 is never sent to it, the validator refuses it, trips from floor 1 use it."""
    from gidabot_navigation.errors import GoalRejected
    from gidabot_navigation.guiding.messages import validate_trip

    west = faculty.find_connector("stairs_west")
    upper = replace(faculty, connectors=tuple(replace(c, serves=(1.0, 2.0, 3.0)) if c is west else c
                                              for c in faculty.connectors))
    assert [c.id for c in upper.connectors_between(0, 2, "stairs")] == ["stairs_east"]
    near_west = (8.0, 12.0)                      # stairs_west would be far shorter
    choice = TripPlanner(upper).choose_connector(0, near_west, 2, (8.0, 12.0), "stairs")
    assert choice.connector.id == "stairs_east"
    assert TripPlanner(upper).choose_connector(1, near_west, 2, (8.0, 12.0), "stairs").connector.id == "stairs_west"
    with pytest.raises(GoalRejected, match="does not serve floors 0 and 2"):
        validate_trip(upper, trip(upper, 0, "223", connector="stairs_west"))
