"""Roles from the assignment, connector choice, the wait estimate and the ranking of robots for a leg (trips.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from gidabot_navigation.errors import NoRouteError
from gidabot_navigation.guiding.messages import Trip
from gidabot_navigation.guiding.trips import (
    HeadProgress,
    RobotView,
    Role,
    TripPlanner,
    WaitModel,
    estimate_queue,
    needed_legs,
    queue_end,
    rank_candidates,
    role,
)
from gidabot_navigation.interface import LEG_COMMITTED, LEG_GOAL, LEG_NONE, LEG_START, Phase


def trip(faculty, a: float, goal_id: str, way: str = "stairs", connector: str = "stairs_west",
         start: tuple[float, float] = (30.0, 12.0), uid: str = "T/v/1", start_robot: str = "",
         goal_robot: str = "") -> Trip:
    """A trip from floor ``a`` whose legs are committed to the first robots of their floors (or those given)."""
    loc = faculty.location(goal_id)
    s = start_robot or faculty.robots_on(a)[0].name
    g = goal_robot or (faculty.robots_on(loc.floor)[0].name if a != loc.floor and faculty.has_robot(loc.floor)
                       else "")
    return Trip(uid=uid, origin_robot=s, visitor_id="v", initial_floor=a, initial_x=start[0], initial_y=start[1],
                goal_floor=loc.floor, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw, way=way,
                connector=connector if a != loc.floor else "", start_id="robot", goal_id=goal_id, language="en",
                start_robot=s, start_state=LEG_COMMITTED, goal_robot=g,
                goal_state=LEG_COMMITTED if g else LEG_NONE, attempt=2)


@pytest.fixture(scope="module")
def planner(faculty):
    return TripPlanner(faculty)


def test_roles_follow_the_assignment(faculty, faculty6) -> None:
    t = trip(faculty, 0, "301")
    assert [role(t, r.name) for r in faculty.robots] == [Role.START, None, None, Role.GOAL]
    same = trip(faculty, 2, "223")
    assert role(same, "Galtxagorri") is Role.SAME and role(same, "Kbot") is None
    # two robots on floor 2 of faculty6: the one named serves, the other has no part
    up = trip(faculty6, 0, "223", goal_robot="Lamia")
    assert role(up, "Lamia") is Role.GOAL and role(up, "Galtxagorri") is None
    assert needed_legs(faculty6, up) == [LEG_START, LEG_GOAL] and needed_legs(faculty6, same) == [LEG_START]


def test_no_goal_leg_on_a_floor_without_robot(faculty3) -> None:
    t = trip(faculty3, 0, "223")
    assert t.goal_state == LEG_NONE and needed_legs(faculty3, t) == [LEG_START]


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


def test_warm_up_makes_every_floors_planner_and_no_search(faculty) -> None:
    trips = TripPlanner(faculty)
    trips.warm_up()
    assert sorted(trips._planners) == sorted(f.id for f in faculty.floors)
    assert trips.plans == 0
    before = dict(trips._planners)
    trips.leg_length(faculty.floors[0].id, (5.0, 5.0), (6.0, 7.0))
    assert trips._planners == before                    # the first leg uses the planner made at start-up


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
    assert estimate_queue(planner, m, robot, (30.0, 12.0), [], None, {}, 0.0).eta == ()
    same = trip(faculty, 0, "001", uid="a")
    up = trip(faculty, 0, "301", uid="b")
    eta = estimate_queue(planner, m, robot, (30.0, 12.0), [same, up], None, {}, 0.0).eta
    speed = robot.max_linear * m.speed_factor
    first = planner.leg_length(0, (30.0, 12.0), (same.goal_x, same.goal_y)) / speed + m.leg_overhead_s
    assert eta[0] == pytest.approx(first, abs=0.1)
    assert eta[1] > eta[0]
    # guiding already: only the rest of the way from the current pose
    head = HeadProgress("a", Phase.ON_THE_WAY, 0.0)
    near = estimate_queue(planner, m, robot, (10.0, 12.0), [same], head, {}, 0.0).eta
    assert near[0] < eta[0]


def test_goal_floor_estimate_waits_for_the_visitor(faculty, planner) -> None:
    m = WaitModel()
    mari = faculty.robot("MariSorgin")
    up = trip(faculty, 0, "301", uid="b")
    not_released = estimate_queue(planner, m, mari, (30.0, 12.0), [up], None, {}, 100.0).eta[0]
    walk = m.walk_time("stairs", 0, 3)
    assert not_released > walk + m.continue_s
    released = estimate_queue(planner, m, mari, (4.4, 12.0), [up], HeadProgress("b", Phase.WAITING_VISITOR, 90.0),
                              {"b": 100.0}, 100.0).eta[0]
    to_goal = planner.leg_length(3, (4.4, 12.0), (up.goal_x, up.goal_y)) / (mari.max_linear * m.speed_factor)
    assert released == pytest.approx(walk + m.continue_s + to_goal, abs=0.2)
    later = estimate_queue(planner, m, mari, (4.4, 12.0), [up], HeadProgress("b", Phase.WAITING_VISITOR, 90.0),
                           {"b": 100.0}, 100.0 + walk + 30).eta[0]
    assert later == pytest.approx(m.continue_s + to_goal, abs=0.2)
    driving = estimate_queue(planner, m, mari, (30.0, 12.0), [up], HeadProgress("b", Phase.GOING_TO_MEETING, 90.0),
                             {}, 100.0).eta[0]
    assert driving > 0


def test_a_trip_from_a_floor_without_robot_waits_for_the_unguided_stops(faculty3) -> None:
    """Kbot meets a visitor coming from floor 2 (no robot): not before ``unguided_s`` after the trip was made."""
    p, m = TripPlanner(faculty3), WaitModel()
    last = faculty3.location("274")
    t = replace(trip(faculty3, 1, "113", uid="c"), initial_floor=2.0, initial_x=last.pose.x, initial_y=last.pose.y,
                start_id="274", start_robot="", start_state=LEG_NONE, goal_floor=1.0, goal_robot="Kbot",
                connector="stairs_west", stamp=100.0)
    t = replace(t, goal_robot="Kbot", goal_state=LEG_COMMITTED)
    kbot = faculty3.robot("Kbot")
    at_once = estimate_queue(p, m, kbot, (30.0, 12.0), [t], None, {}, 100.0).eta[0]
    later = estimate_queue(p, m, kbot, (30.0, 12.0), [t], None, {}, 100.0 + m.unguided_s).eta[0]
    assert at_once > m.unguided_s + m.walk_time("stairs", 2, 1) + m.continue_s
    assert later < at_once - 100.0       # by then Kbot's own drive to the staircase is what counts


def test_ranking_prefers_the_robot_at_the_meeting_point_soonest(faculty6) -> None:
    """Floor 2 of faculty6: Galtxagorri parks at x 30, Lamia at x 54. For the west staircase Galtxagorri is
    first; for the east one Lamia; a queue moves a robot back; offline and excluded robots are left out."""
    p, m = TripPlanner(faculty6), WaitModel()
    west = trip(faculty6, 0, "201", connector="stairs_west", goal_robot="Lamia")
    east = trip(faculty6, 0, "231", connector="stairs_east", goal_robot="Lamia", start=(60.0, 12.0))
    up = lambda r: True  # noqa: E731
    assert [c.robot for c in rank_candidates(p, m, west, LEG_GOAL, {}, up, 0.0)] == ["Galtxagorri", "Lamia"]
    assert [c.robot for c in rank_candidates(p, m, east, LEG_GOAL, {}, up, 0.0)] == ["Lamia", "Galtxagorri"]
    busy = {"Galtxagorri": RobotView(faculty6.robot("Galtxagorri"), (trip(faculty6, 2, "231", uid="x"),), 300.0,
                                     None, 0.0)}
    ranked = rank_candidates(p, m, west, LEG_GOAL, busy, up, 0.0)
    assert [c.robot for c in ranked] == ["Lamia", "Galtxagorri"] and ranked[1].eta > 300.0
    # 100 s later its wait is 100 s shorter
    assert rank_candidates(p, m, west, LEG_GOAL, busy, up, 100.0)[1].eta == pytest.approx(ranked[1].eta - 100, abs=0.2)
    assert [c.robot for c in rank_candidates(p, m, west, LEG_GOAL, {}, lambda r: r != "Galtxagorri", 0.0)] == ["Lamia"]
    assert [c.robot for c in rank_candidates(p, m, west, LEG_GOAL, {}, up, 0.0, exclude=["Lamia"])] == ["Galtxagorri"]


def test_the_start_leg_stays_with_the_visitors_robot_unless_another_is_much_sooner(faculty6) -> None:
    p, m = TripPlanner(faculty6), WaitModel()
    up = lambda r: True  # noqa: E731
    t = trip(faculty6, 1, "101", start=(30.0, 12.0), start_robot="Kbot")
    kbot, basajaun = faculty6.robot("Kbot"), faculty6.robot("Basajaun")
    # Kbot free: Kbot, although nobody is nearer than Kbot anyway
    assert rank_candidates(p, m, t, LEG_START, {}, up, 0.0, prefer="Kbot", prefer_gain=20.0)[0].robot == "Kbot"
    # Kbot busy for 200 s, Basajaun free 24 m away (~80 s): Basajaun comes
    busy = {"Kbot": RobotView(kbot, (trip(faculty6, 1, "119", uid="k", start_robot="Kbot"),), 200.0, None, 0.0),
            "Basajaun": RobotView(basajaun)}
    ranked = rank_candidates(p, m, t, LEG_START, busy, up, 0.0, prefer="Kbot", prefer_gain=20.0)
    assert [c.robot for c in ranked] == ["Basajaun", "Kbot"]
    # busy for a little only: it stays with Kbot (Basajaun would not be 20 s sooner)
    short = {**busy, "Kbot": replace(busy["Kbot"], wait_new=50.0, queue=(trip(faculty6, 1, "112", uid="k",
                                                                               start_robot="Kbot"),))}
    assert rank_candidates(p, m, t, LEG_START, short, up, 0.0, prefer="Kbot", prefer_gain=20.0)[0].robot == "Kbot"


def test_queue_end_is_where_the_last_leg_ends(faculty6) -> None:
    p = TripPlanner(faculty6)
    lamia = faculty6.robot("Lamia")
    assert queue_end(p, RobotView(lamia)) == (lamia.home.x, lamia.home.y)
    assert queue_end(p, RobotView(lamia, pose=(10.0, 12.0))) == (10.0, 12.0)
    start_leg = trip(faculty6, 2, "301", connector="stairs_east", start_robot="Lamia", uid="s")
    assert queue_end(p, RobotView(lamia, (start_leg,))) == (67.6, 12.0)      # the east staircase's meeting point
    goal_leg = trip(faculty6, 0, "223", goal_robot="Lamia", uid="g")
    assert queue_end(p, RobotView(lamia, (start_leg, goal_leg))) == (goal_leg.goal_x, goal_leg.goal_y)


def test_a_robot_whose_pose_is_off_the_free_space_is_still_ranked(faculty6) -> None:
    """A status with a pose in the map's margin (no localisation yet, or a bad one): the straight line."""
    p, m = TripPlanner(faculty6), WaitModel()
    t = trip(faculty6, 0, "223", goal_robot="Lamia")
    views = {"Galtxagorri": RobotView(faculty6.robot("Galtxagorri"), pose=(0.0, 0.0))}
    ranked = rank_candidates(p, m, t, LEG_GOAL, views, lambda r: True, 0.0)
    assert {c.robot for c in ranked} == {"Galtxagorri", "Lamia"} and all(math.isfinite(c.eta) for c in ranked)


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
