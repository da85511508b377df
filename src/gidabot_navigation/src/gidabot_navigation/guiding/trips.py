"""Trips across floors (ROS-free): who is involved, which connector, how long it takes.

* :func:`role` / :func:`involved`: the involvement rule of the paper (section 6.2): a
  robot keeps a goal only if the trip starts or ends on its floor.
* :class:`TripPlanner`: leg lengths with :class:`~gidabot_navigation.building.planning.GridPlanner`
  on the building's floor maps (cached), and the connector that minimises the whole
  trip (start robot's leg + goal robot's leg) for the visitor's way.
* :class:`WaitModel` and :func:`estimate_queue`: how long each queued trip keeps a
  robot busy, from planned path lengths, the robot's speed, the visitor's walk
  between floors and the time to press Continue (``docs/guiding.md``).
"""

from __future__ import annotations

import enum
import math
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building, Connector, Robot, format_floor
from gidabot_navigation.building.planning import GridPlanner
from gidabot_navigation.errors import NoRouteError, PlanningError
from gidabot_navigation.guiding.messages import Trip, same_floor
from gidabot_navigation.interface import GOING_TO_MEETING, ON_THE_WAY, WAITING_VISITOR, WAY_LIFT

DEFAULT_RADIUS = 0.3     # m, footprint radius used on a floor without a robot (the visitor's way)


class Role(enum.Enum):
    """What a robot does for a trip."""

    SAME = "same"      # start and goal on its floor: guide to the goal
    START = "start"    # start floor of a cross-floor trip: guide to the connector
    GOAL = "goal"      # goal floor of a cross-floor trip: meet the visitor, guide to the goal


def role(trip: Trip, floor: float) -> Role | None:
    """The role of the robot serving ``floor`` in ``trip``; None if it is not involved."""
    starts, ends = same_floor(trip.initial_floor, floor), same_floor(trip.goal_floor, floor)
    if starts and ends:
        return Role.SAME
    if starts:
        return Role.START
    if ends:
        return Role.GOAL
    return None


def involved(trip: Trip, floor: float) -> bool:
    """The paper's rule: keep a goal only if it starts or ends on this floor."""
    return role(trip, floor) is not None


def partner_of(building: Building, trip: Trip, floor: float) -> Robot | None:
    """The other robot of a cross-floor trip, seen from the robot on ``floor`` (None: none or no robot)."""
    r = role(trip, floor)
    if r is Role.START:
        return building.robot_on(trip.goal_floor)
    if r is Role.GOAL:
        return building.robot_on(trip.initial_floor)
    return None


@dataclass(frozen=True)
class ConnectorChoice:
    connector: Connector
    way: str
    start_leg: float     # m, start point -> connector on the start floor
    goal_leg: float      # m, connector -> goal on the goal floor

    @property
    def total(self) -> float:
        return self.start_leg + self.goal_leg


class TripPlanner:
    """Leg lengths on the building's floor maps, cached; connector choice.

    One :class:`GridPlanner` per floor (made on first use) with the footprint of the
    robot serving that floor. Lengths are cached by the end points rounded to
    ``resolution`` metres (at most ``cache_size`` entries); an impossible leg has
    length ``math.inf``.
    """

    def __init__(self, building: Building, resolution: float = 0.25, cache_size: int = 4096) -> None:
        self.building = building
        self.resolution = resolution
        self.cache_size = cache_size
        self._planners: dict[float, GridPlanner] = {}
        self._cache: OrderedDict[tuple, float] = OrderedDict()
        self.plans = 0          # number of A* searches made (cache misses)

    def planner(self, floor: float) -> GridPlanner:
        f = self.building.floor(floor)
        if f.id not in self._planners:
            robot = self.building.robot_on(f.id)
            self._planners[f.id] = GridPlanner(f.map, robot.radius if robot else DEFAULT_RADIUS)
        return self._planners[f.id]

    def leg_length(self, floor: float, a: tuple[float, float], b: tuple[float, float]) -> float:
        """Planned path length (m) from ``a`` to ``b`` on ``floor``; ``math.inf`` when there is no path."""
        q = self.resolution
        key = (float(floor), round(a[0] / q), round(a[1] / q), round(b[0] / q), round(b[1] / q))
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        if math.hypot(a[0] - b[0], a[1] - b[1]) < q:
            length = 0.0
        else:
            self.plans += 1
            try:
                length = self.planner(floor).plan(a, b).length
            except (PlanningError, KeyError):
                length = math.inf
        self._cache[key] = length
        while len(self._cache) > self.cache_size:
            self._cache.popitem(last=False)
        return length

    def meeting(self, connector_id: str, floor: float) -> Pose2D:
        """The meeting pose of a connector on a floor (KeyError if unknown)."""
        conn = self.building.find_connector(connector_id)
        f = self.building.floor(floor)
        if conn is None or f.id not in conn.meeting:
            raise KeyError(f"connector {connector_id!r} has no meeting point on floor {f.label}")
        return conn.meeting[f.id]

    def choose_connector(self, initial_floor: float, start: tuple[float, float], goal_floor: float,
                         goal: tuple[float, float], way: str) -> ConnectorChoice:
        """The connector of kind ``way`` minimising start leg + goal leg.

        If no connector of that kind joins the two floors, connectors of the other kind
        are used (the choice says which way). Raises :class:`NoRouteError` when no
        connector joins them or no leg can be planned.
        """
        a, b = self.building.floor(initial_floor).id, self.building.floor(goal_floor).id
        candidates = self.building.connectors_between(a, b, kind=way)
        if not candidates:
            candidates = self.building.connectors_between(a, b)
        if not candidates:
            raise NoRouteError(f"no lift or staircase joins floors {format_floor(a)} and {format_floor(b)}")
        best: ConnectorChoice | None = None
        for conn in candidates:
            ma, mb = conn.meeting[a], conn.meeting[b]
            choice = ConnectorChoice(conn, conn.kind, self.leg_length(a, start, (ma.x, ma.y)),
                                     self.leg_length(b, (mb.x, mb.y), goal))
            if best is None or choice.total < best.total:
                best = choice
        assert best is not None
        if not math.isfinite(best.total):
            raise NoRouteError(f"no path from ({start[0]:g}, {start[1]:g}) on floor {format_floor(a)} to "
                               f"({goal[0]:g}, {goal[1]:g}) on floor {format_floor(b)} through "
                               f"{', '.join(c.id for c in candidates)}")
        return best


# ---------------------------------------------------------------------------
# Wait estimate
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class WaitModel:
    """Durations for the wait estimate (s, m/s).

    ``speed_factor``: the mean speed while guiding as a fraction of the robot's
    ``max_linear`` (the paper's robots averaged 0.24-0.40 m/s with maxima of
    0.5-0.7 m/s); ``stairs_s_per_floor``, ``lift_wait_s`` + ``lift_s_per_floor``: the
    visitor's walk between floors; ``continue_s``: from the visitor's arrival to the
    press of Continue; ``leg_overhead_s``: turning, accelerating, dialogs per leg;
    ``pickup_distance``: a robot farther than this from the start point of a trip
    drives there first to pick the visitor up.
    """

    speed_factor: float = 0.5
    stairs_s_per_floor: float = 20.0
    lift_wait_s: float = 25.0
    lift_s_per_floor: float = 5.0
    continue_s: float = 10.0
    leg_overhead_s: float = 5.0
    pickup_distance: float = 1.5

    def __post_init__(self) -> None:
        for name in ("speed_factor", "stairs_s_per_floor", "lift_wait_s", "lift_s_per_floor", "continue_s",
                     "leg_overhead_s", "pickup_distance"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: {value!r} must be a finite number >= 0")
        if self.speed_factor <= 0:
            raise ValueError(f"speed_factor: {self.speed_factor!r} must be > 0")

    def drive_time(self, length: float, robot: Robot | None) -> float:
        """s to drive ``length`` m (a person walking ~1 m/s stands in for a missing robot)."""
        speed = (robot.max_linear if robot else 2.0) * self.speed_factor
        return length / speed if math.isfinite(length) else 0.0

    def walk_time(self, way: str, from_floor: float, to_floor: float) -> float:
        """s the visitor needs to change floors by ``way``."""
        floors = abs(to_floor - from_floor)
        if way == WAY_LIFT:
            return self.lift_wait_s + self.lift_s_per_floor * floors
        return self.stairs_s_per_floor * floors


@dataclass(frozen=True)
class HeadProgress:
    """What this robot's navigation reported last for the trip at the head of its queue."""

    goal_uid: str
    phase: int          # last own NavEvent phase for it (ON_THE_WAY, GOING_TO_MEETING, WAITING_VISITOR)
    since: float        # s, ROS time of that event


def estimate_queue(planner: TripPlanner, model: WaitModel, robot: Robot, pose: tuple[float, float] | None,
                   queue: Sequence[Trip], head: HeadProgress | None, releases: Mapping[str, float],
                   now: float) -> list[float]:
    """Estimated s from ``now`` until this robot finishes each trip of ``queue`` (FIFO).

    The robot starts at ``pose`` (its home if unknown) and drives leg after leg; a
    goal-floor leg also waits for the visitor: released at ``releases[uid]`` (ROS time
    of the start robot's GO_TO_FLOOR) plus the walk, or, not released yet, the start
    robot's leg plus the walk from when this leg starts; then ``continue_s``.
    """
    b = planner.building
    pos = pose if pose is not None else (robot.home.x, robot.home.y)
    t = 0.0
    out: list[float] = []
    for i, trip in enumerate(queue):
        r = role(trip, robot.floor)
        progress = head if (i == 0 and head is not None and head.goal_uid == trip.uid) else None
        goal_xy = (trip.goal_x, trip.goal_y)
        if r is None:
            out.append(t)
            continue
        if r is Role.GOAL:
            try:
                m = planner.meeting(trip.connector, robot.floor)
            except KeyError:
                out.append(t)
                continue
            meet = (m.x, m.y)
            after = model.continue_s + model.drive_time(planner.leg_length(robot.floor, meet, goal_xy), robot)
            if progress is not None and progress.phase == ON_THE_WAY:
                t += model.drive_time(planner.leg_length(robot.floor, pos, goal_xy), robot)
            else:
                drive = 0.0 if progress is not None and progress.phase == WAITING_VISITOR else \
                    model.drive_time(planner.leg_length(robot.floor, pos, meet), robot)
                walk = model.walk_time(trip.way, trip.initial_floor, trip.goal_floor)
                released = releases.get(trip.uid)
                if released is not None:
                    arrival = max(0.0, released + walk - now)
                else:
                    start_robot = b.robot_on(trip.initial_floor)
                    try:
                        sm = planner.meeting(trip.connector, trip.initial_floor)
                        start_leg = planner.leg_length(trip.initial_floor, (trip.initial_x, trip.initial_y),
                                                       (sm.x, sm.y))
                    except KeyError:
                        start_leg = 0.0
                    arrival = t + model.drive_time(start_leg, start_robot) + walk
                t = max(t + drive, arrival) + after
            pos = goal_xy
        else:
            if r is Role.START:
                try:
                    m = planner.meeting(trip.connector, robot.floor)
                except KeyError:
                    out.append(t)
                    continue
                target = (m.x, m.y)
            else:
                target = goal_xy
            start = (trip.initial_x, trip.initial_y)
            guiding = progress is not None and progress.phase == ON_THE_WAY
            if guiding:
                t += model.drive_time(planner.leg_length(robot.floor, pos, target), robot)
            else:
                if math.hypot(pos[0] - start[0], pos[1] - start[1]) > model.pickup_distance:
                    t += model.drive_time(planner.leg_length(robot.floor, pos, start), robot)
                t += model.drive_time(planner.leg_length(robot.floor, start, target), robot)
            pos = target
        if progress is None or progress.phase not in (ON_THE_WAY, GOING_TO_MEETING, WAITING_VISITOR):
            t += model.leg_overhead_s
        out.append(round(t, 1))
    return out
