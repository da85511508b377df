"""What the visitor is shown before confirming a trip (ROS-free): the robots that would serve each leg and
their waits, ranked as the robot will rank them when the visitor confirms
(:func:`~gidabot_navigation.guiding.trips.rank_candidates`, ``docs/guiding.md``, *Who serves a leg*)."""

from __future__ import annotations

from dataclasses import dataclass

from gidabot_gui.core.model import Fleet, TourInfo
from gidabot_navigation.building.model import Building, Location
from gidabot_navigation.guiding.assignment import AssignConfig
from gidabot_navigation.guiding.trips import WaitModel, preview_trip
from gidabot_navigation.interface import LEG_START, WAY_LIFT, WAY_STAIRS


@dataclass(frozen=True)
class RobotWait:
    """The robot that would serve one leg of the trip, and how long until it is there."""

    robot: str
    floor: float
    here: bool                 # this screen's robot
    known: bool                # online, with a status or pending list
    num: int = 0               # requests before this one
    wait_s: float | None = None   # s until it is with the visitor (start leg) or at the meeting point (goal leg)
    leg: str = LEG_START


@dataclass(frozen=True)
class RequestPlan:
    """What the confirmation of a destination shows."""

    goal_id: str
    goal_floor: float
    start_floor: float
    ways: tuple[str, ...]      # ways available between the floors (empty on one floor)
    waits: tuple[RobotWait, ...]
    robot_on_goal_floor: bool

    @property
    def changes_floor(self) -> bool:
        return self.goal_floor != self.start_floor


def ways_between(building: Building, a: float, b: float) -> tuple[str, ...]:
    """The ways (stairs first, then lift) that connect floors ``a`` and ``b``."""
    if a == b:
        return ()
    return tuple(w for w in (WAY_STAIRS, WAY_LIFT) if building.connectors_between(a, b, w))


def leg_waits(fleet: Fleet, robot: str, goal: Location, now: float) -> tuple[RobotWait, ...]:
    """The robot of each leg of a trip from ``robot`` to ``goal`` and its wait: for the start leg this robot
    (or another of its floor coming sooner), for the goal leg the robot of the goal floor at the meeting point
    first (by the stairs when they join the floors). A leg nobody online can serve: its floor's first robot,
    not available. (:func:`~gidabot_navigation.guiding.trips.preview_trip`: the robot decides the same way.)"""
    building = fleet.building
    here = building.robot(robot)
    pose = fleet.robots[robot].pose or (here.home.x, here.home.y, here.home.yaw)
    ways = ways_between(building, here.floor, goal.floor)
    waits = []
    for p in preview_trip(fleet.planner, WaitModel(), here, (pose[0], pose[1]), goal,
                          ways[0] if ways else WAY_STAIRS, fleet.views(), lambda r: not fleet.is_offline(r, now),
                          now, AssignConfig.helper_gain):
        if p.candidate is None:
            name = robot if p.leg == LEG_START else building.robots_on(p.floor)[0].name
            waits.append(RobotWait(name, p.floor, name == robot, known=False, leg=p.leg))
            continue
        info = fleet.wait_of(p.candidate.robot, now)
        waits.append(RobotWait(p.candidate.robot, p.floor, p.candidate.robot == robot, known=True,
                               num=info[0] if info else 0, wait_s=p.wait_s, leg=p.leg))
    return tuple(waits)


def plan_request(fleet: Fleet, robot: str, goal_id: str, now: float) -> RequestPlan:
    """The confirmation of going from this robot to ``goal_id``: who serves each leg, how soon."""
    building = fleet.building
    goal = building.location(goal_id)
    here = building.robot(robot)
    return RequestPlan(goal.id, goal.floor, here.floor, ways_between(building, here.floor, goal.floor),
                       leg_waits(fleet, robot, goal, now), building.has_robot(goal.floor))


def tour_waits(fleet: Fleet, robot: str, tour: TourInfo, now: float) -> tuple[RobotWait, ...]:
    """Who serves the legs of the tour's first stop, and their waits."""
    first = fleet.building.find_location(tour.goals[0][1]) if tour.goals else None
    return leg_waits(fleet, robot, first, now) if first is not None else ()


def tour_ways(building: Building, start_floor: float, tour: TourInfo) -> tuple[str, ...]:
    """Ways usable for every floor change of ``tour`` (starting on ``start_floor``)."""
    floors = [start_floor, *[f for f, _r, _d in tour.goals]]
    ways = [WAY_STAIRS, WAY_LIFT]
    for a, b in zip(floors, floors[1:], strict=False):
        if a != b and building.find_floor(a) and building.find_floor(b):
            ways = [w for w in ways if building.connectors_between(a, b, w)]
    changes = any(a != b for a, b in zip(floors, floors[1:], strict=False))
    return tuple(ways) if changes else ()
