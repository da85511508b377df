"""What the visitor is shown before confirming a trip (ROS-free): the robots involved and their waits."""

from __future__ import annotations

from dataclasses import dataclass

from gidabot_gui.core.model import Fleet, TourInfo
from gidabot_navigation.building.model import Building
from gidabot_navigation.interface import WAY_LIFT, WAY_STAIRS


@dataclass(frozen=True)
class RobotWait:
    """Pending requests of one robot involved in a trip."""

    robot: str
    floor: float
    here: bool                 # this screen's robot
    known: bool                # online, with a status or pending list
    num: int = 0
    wait_s: float | None = None


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


def robot_wait(fleet: Fleet, name: str, here: bool, now: float) -> RobotWait:
    robot = fleet.building.robot(name)
    info = fleet.wait_of(name, now)
    if info is None:
        return RobotWait(name, robot.floor, here, known=False)
    return RobotWait(name, robot.floor, here, known=True, num=info[0], wait_s=info[1])


def ways_between(building: Building, a: float, b: float) -> tuple[str, ...]:
    """The ways (stairs first, then lift) that connect floors ``a`` and ``b``."""
    if a == b:
        return ()
    return tuple(w for w in (WAY_STAIRS, WAY_LIFT) if building.connectors_between(a, b, w))


def plan_request(fleet: Fleet, robot: str, goal_id: str, now: float) -> RequestPlan:
    """The confirmation of going from this robot to ``goal_id``: start robot and goal-floor robot."""
    building = fleet.building
    goal = building.location(goal_id)
    here = building.robot(robot)
    waits = [robot_wait(fleet, robot, True, now)]
    goal_robot = building.robot_on(goal.floor)
    if goal_robot is not None and goal_robot.name != robot:
        waits.append(robot_wait(fleet, goal_robot.name, False, now))
    return RequestPlan(goal.id, goal.floor, here.floor, ways_between(building, here.floor, goal.floor),
                       tuple(waits), goal_robot is not None)


def tour_waits(fleet: Fleet, robot: str, tour: TourInfo, now: float) -> tuple[RobotWait, ...]:
    """Waits of this robot and of the robot of the tour's first stop."""
    waits = [robot_wait(fleet, robot, True, now)]
    if tour.goals:
        first = fleet.building.robot_on(tour.goals[0][0])
        if first is not None and first.name != robot:
            waits.append(robot_wait(fleet, first.name, False, now))
    return tuple(waits)


def tour_ways(building: Building, start_floor: float, tour: TourInfo) -> tuple[str, ...]:
    """Ways usable for every floor change of ``tour`` (starting on ``start_floor``)."""
    floors = [start_floor, *[f for f, _r, _d in tour.goals]]
    ways = [WAY_STAIRS, WAY_LIFT]
    for a, b in zip(floors, floors[1:], strict=False):
        if a != b and building.find_floor(a) and building.find_floor(b):
            ways = [w for w in ways if building.connectors_between(a, b, w)]
    changes = any(a != b for a, b in zip(floors, floors[1:], strict=False))
    return tuple(ways) if changes else ()
