"""Trips across floors (ROS-free): who does what, which connector, how long it takes.

* :func:`role`: what a robot does in a trip, from the trip's assignment (the leg that
  names it: ``docs/guiding.md``, *Who serves a leg*).
* :class:`TripPlanner`: leg lengths with :class:`~gidabot_navigation.building.planning.GridPlanner`
  on the building's floor maps (cached), and the connector that minimises the whole
  trip (start leg + goal leg) for the visitor's way.
* :class:`WaitModel` and :func:`estimate_queue`: how long each queued trip keeps a
  robot busy, from planned path lengths, the robot's speed, the visitor's walk
  between floors and the time to press Continue (``docs/guiding.md``).
* :class:`RobotView` and :func:`rank_candidates`: which robots of a floor could serve a
  leg, soonest first (their queues and poses as they broadcast them).
* :func:`preview_trip`: what the visitor is shown before confirming a trip: the robot that
  would serve each leg and its wait, ranked as the robot will rank them (the GUI's
  confirmation, and the simulated visitor that decides on it).
"""

from __future__ import annotations

import enum
import math
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building, Connector, Location, Robot, format_floor
from gidabot_navigation.building.planning import GridPlanner
from gidabot_navigation.errors import NoRouteError, PlanningError
from gidabot_navigation.guiding.messages import START_ROBOT, Trip
from gidabot_navigation.interface import LEG_COMMITTED, LEG_GOAL, LEG_NONE, LEG_START, WAY_LIFT, Phase

DEFAULT_RADIUS = 0.3     # m, footprint radius used on a floor without a robot (the visitor's way)
PERSON = None            # drive_time(..., PERSON): the visitor walking alone


class Role(enum.Enum):
    """What a robot does for a trip."""

    SAME = "same"      # the start leg of a one-floor trip: guide to the goal
    START = "start"    # the start leg of a cross-floor trip: guide to the connector
    GOAL = "goal"      # the goal leg: meet the visitor at the connector, guide to the goal


def role(trip: Trip, robot: str) -> Role | None:
    """The role of ``robot`` in ``trip``: the leg its assignment names it for (proposed or committed)."""
    leg = trip.leg_of(robot)
    if leg is None:
        return None
    if leg == LEG_GOAL:
        return Role.GOAL
    return Role.START if trip.cross_floor else Role.SAME


def leg_floor(trip: Trip, leg: str) -> float:
    return trip.initial_floor if leg == LEG_START else trip.goal_floor


def needed_legs(building: Building, trip: Trip) -> list[str]:
    """The legs a robot must serve: the start leg when its floor has a robot, the goal leg of a cross-floor
    trip when the goal floor has one."""
    legs = [LEG_START] if building.has_robot(trip.initial_floor) else []
    if trip.cross_floor and building.has_robot(trip.goal_floor):
        legs.append(LEG_GOAL)
    return legs


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
        """The planner of ``floor``, for the widest robot serving it (a path it can take suits them all)."""
        f = self.building.floor(floor)
        if f.id not in self._planners:
            radius = max((r.radius for r in self.building.robots_on(f.id)), default=DEFAULT_RADIUS)
            self._planners[f.id] = GridPlanner(f.map, radius, keep_out=f.keep_out_zones)
        return self._planners[f.id]

    def warm_up(self) -> None:
        """Make every floor's planner now (a node calls it at start-up): making one inflates that floor's
        costmap (about 80 ms of CPU for a floor of the faculty), which the first leg asked about would
        otherwise pay at the start of a tour, while the simulated floors wait for their CPU."""
        for f in self.building.floors:
            self.planner(f.id)

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
    drives there first to pick the visitor up; ``unguided_s``: what a visitor sent to
    a floor without robot spends there before a trip from that floor can start.
    """

    speed_factor: float = 0.5
    stairs_s_per_floor: float = 20.0
    lift_wait_s: float = 25.0
    lift_s_per_floor: float = 5.0
    continue_s: float = 10.0
    leg_overhead_s: float = 5.0
    pickup_distance: float = 1.5
    unguided_s: float = 120.0

    def __post_init__(self) -> None:
        for name in ("speed_factor", "stairs_s_per_floor", "lift_wait_s", "lift_s_per_floor", "continue_s",
                     "leg_overhead_s", "pickup_distance", "unguided_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}: {value!r} must be a finite number >= 0")
        if self.speed_factor <= 0:
            raise ValueError(f"speed_factor: {self.speed_factor!r} must be > 0")

    def drive_time(self, length: float, robot: Robot | None) -> float:
        """s to drive ``length`` m (a person walking ~1 m/s stands in for a missing robot: :data:`PERSON`)."""
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


@dataclass(frozen=True)
class QueueEstimate:
    """:func:`estimate_queue`'s answer: when each trip is done, and where the robot is then."""

    eta: tuple[float, ...]           # s from now until each trip of the queue is finished
    end: tuple[float, float]         # m, where the robot is once the queue is done


def meeting_xy(planner: TripPlanner, trip: Trip, floor: float) -> tuple[float, float] | None:
    try:
        m = planner.meeting(trip.connector, floor)
    except KeyError:
        return None
    return (m.x, m.y)


def leg_point(planner: TripPlanner, trip: Trip, leg: str) -> tuple[float, float] | None:
    """Where the robot serving ``leg`` meets the visitor: the start point, or the goal floor's meeting point."""
    if leg == LEG_START:
        return (trip.initial_x, trip.initial_y)
    return meeting_xy(planner, trip, trip.goal_floor)


def estimate_queue(planner: TripPlanner, model: WaitModel, robot: Robot, pose: tuple[float, float] | None,
                   queue: Sequence[Trip], head: HeadProgress | None, releases: Mapping[str, float],
                   now: float) -> QueueEstimate:
    """Estimated s from ``now`` until this robot finishes each trip of ``queue`` (FIFO), by the leg each
    trip's assignment names it for (a trip naming it for none takes no time).

    The robot starts at ``pose`` (its home if unknown) and drives leg after leg; a
    goal leg also waits for the visitor: released at ``releases[uid]`` (ROS time
    of the start robot's GO_TO_FLOOR) plus the walk, or, not released yet, the start
    robot's leg plus the walk from when this leg starts (a trip starting on a floor
    without robot: ``unguided_s`` from when it was made, then the visitor's walk); then ``continue_s``.
    """
    pos = pose if pose is not None else (robot.home.x, robot.home.y)
    t = 0.0
    out: list[float] = []
    for i, trip in enumerate(queue):
        r = role(trip, robot.name)
        progress = head if (i == 0 and head is not None and head.goal_uid == trip.uid) else None
        goal_xy = (trip.goal_x, trip.goal_y)
        if r is None:
            out.append(t)
            continue
        if r is Role.GOAL:
            meet = meeting_xy(planner, trip, robot.floor)
            if meet is None:
                out.append(t)
                continue
            after = model.continue_s + model.drive_time(planner.leg_length(robot.floor, meet, goal_xy), robot)
            if progress is not None and progress.phase == Phase.ON_THE_WAY:
                t += model.drive_time(planner.leg_length(robot.floor, pos, goal_xy), robot)
            else:
                drive = 0.0 if progress is not None and progress.phase == Phase.WAITING_VISITOR else \
                    model.drive_time(planner.leg_length(robot.floor, pos, meet), robot)
                t = max(t + drive, _visitor_arrival(planner, model, trip, t, releases, now)) + after
            pos = goal_xy
        else:
            target = meeting_xy(planner, trip, robot.floor) if r is Role.START else goal_xy
            if target is None:
                out.append(t)
                continue
            start = (trip.initial_x, trip.initial_y)
            guiding = progress is not None and progress.phase == Phase.ON_THE_WAY
            if guiding:
                t += model.drive_time(planner.leg_length(robot.floor, pos, target), robot)
            else:
                if math.hypot(pos[0] - start[0], pos[1] - start[1]) > model.pickup_distance:
                    t += model.drive_time(planner.leg_length(robot.floor, pos, start), robot)
                t += model.drive_time(planner.leg_length(robot.floor, start, target), robot)
            pos = target
        if progress is None or progress.phase not in (Phase.ON_THE_WAY, Phase.GOING_TO_MEETING, Phase.WAITING_VISITOR):
            t += model.leg_overhead_s
        out.append(round(t, 1))
    return QueueEstimate(tuple(out), pos)


def _visitor_arrival(planner: TripPlanner, model: WaitModel, trip: Trip, t: float, releases: Mapping[str, float],
                     now: float) -> float:
    """s from now until the visitor of ``trip`` reaches the goal floor's meeting point (``t``: when this robot
    starts on the trip)."""
    walk = model.walk_time(trip.way, trip.initial_floor, trip.goal_floor)
    released = releases.get(trip.uid)
    if released is not None:
        return max(0.0, released + walk - now)
    start_robot = planner.building.find_robot(trip.start_robot) if trip.start_state != LEG_NONE else PERSON
    sm = meeting_xy(planner, trip, trip.initial_floor)
    start_leg = planner.leg_length(trip.initial_floor, (trip.initial_x, trip.initial_y), sm) if sm else 0.0
    if trip.start_state == LEG_NONE:        # from a floor without robot: after the visitor's unguided stops
        return max(0.0, trip.stamp + model.unguided_s - now) + model.drive_time(start_leg, PERSON) + walk
    return t + model.drive_time(start_leg, start_robot) + walk


# ---------------------------------------------------------------------------
# Which robot can serve a leg soonest
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class RobotView:
    """What a robot broadcast about itself: its queue (``/gidabot/pending``) and pose (``/gidabot/status``)."""

    robot: Robot
    queue: tuple[Trip, ...] = ()
    wait_new: float = 0.0                      # s before it could start a new trip, as of ``heard``
    pose: tuple[float, float] | None = None    # m; None: its home
    heard: float = 0.0                         # wall s when its pending list was received


@dataclass(frozen=True)
class Candidate:
    robot: str
    eta: float          # s until it could be at the leg's meeting point with the visitor (its queue first)


def queue_end(planner: TripPlanner, view: RobotView) -> tuple[float, float]:
    """Where ``view.robot`` is once its queue is done: the end of the last leg it holds, else its pose."""
    for trip in reversed(view.queue):
        r = role(trip, view.robot.name)
        if r is Role.START:
            end = meeting_xy(planner, trip, view.robot.floor)
            if end is not None:
                return end
        elif r is not None:
            return (trip.goal_x, trip.goal_y)
    if view.pose is not None:
        return view.pose
    return (view.robot.home.x, view.robot.home.y)


def rendezvous_eta(planner: TripPlanner, model: WaitModel, view: RobotView, point: tuple[float, float],
                   now_wall: float) -> float:
    """s until ``view.robot`` could be at ``point`` (on its floor) for a new trip: its queue, then the drive."""
    ready = max(0.0, view.wait_new - max(0.0, now_wall - view.heard))
    end = queue_end(planner, view)
    drive = planner.leg_length(view.robot.floor, end, point)
    if not math.isfinite(drive):       # a pose off the free space (localisation): the straight line will do
        drive = math.hypot(point[0] - end[0], point[1] - end[1])
    return round(ready + model.drive_time(drive, view.robot), 1)


def rank_candidates(planner: TripPlanner, model: WaitModel, trip: Trip, leg: str, views: Mapping[str, RobotView],
                    online: Callable[[str], bool], now_wall: float, prefer: str = "",
                    prefer_gain: float = 0.0, exclude: Iterable[str] = ()) -> list[Candidate]:
    """The online robots of ``leg``'s floor that could serve it, soonest at the leg's meeting point first.

    ``prefer`` (the robot where the visitor stands, for the start leg) goes first when it is free, and
    another robot goes before it only if at least ``prefer_gain`` s sooner; ties keep the building's order.
    A robot without a view is taken as idle at its home.
    """
    point = leg_point(planner, trip, leg)
    if point is None:
        return []
    skip = set(exclude)
    ranked: list[tuple[float, int, Candidate]] = []
    for index, robot in enumerate(planner.building.robots_on(leg_floor(trip, leg))):
        if robot.name in skip or not online(robot.name):
            continue
        view = views.get(robot.name) or RobotView(robot)
        eta = rendezvous_eta(planner, model, view, point, now_wall)
        if robot.name == prefer:
            key = -math.inf if not view.queue and view.wait_new <= 0 else eta
        else:
            key = eta + (prefer_gain if prefer else 0.0)
        ranked.append((key, index, Candidate(robot.name, eta)))
    return [c for _, _, c in sorted(ranked, key=lambda x: (x[0], x[1]))]


# ---------------------------------------------------------------------------
# What the visitor is shown before confirming
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class LegPreview:
    """The robot that would serve one leg of a trip not made yet, and how soon it could be there."""

    leg: str                      # LEG_START or LEG_GOAL
    floor: float
    candidate: Candidate | None   # the first of :func:`rank_candidates`; None: no robot of the floor is online

    @property
    def wait_s(self) -> float | None:
        """s until that robot is with the visitor (start leg) or at the meeting point (goal leg); None: unknown."""
        if self.candidate is None or not math.isfinite(self.candidate.eta):
            return None
        return self.candidate.eta


def preview_trip(planner: TripPlanner, model: WaitModel, origin: Robot, pose: tuple[float, float], goal: Location,
                 way: str, views: Mapping[str, RobotView], online: Callable[[str], bool], now_wall: float,
                 prefer_gain: float) -> tuple[LegPreview, ...]:
    """Who would serve each leg of a trip from ``origin``'s screen (the visitor at ``pose``) to ``goal`` by ``way``
    (the connector minimising the whole trip), and how soon: the start leg (``origin`` itself when free, or
    another robot of its floor coming at least ``prefer_gain`` s sooner), and across floors, to a floor with
    robots, the goal leg (the robot of the goal floor first at the meeting point). What the origin robot will
    decide when the visitor confirms (:func:`rank_candidates` over the same views), before anything is sent."""
    building = planner.building
    trip = Trip(uid="", origin_robot=origin.name, visitor_id="", initial_floor=origin.floor, initial_x=pose[0],
                initial_y=pose[1], goal_floor=goal.floor, goal_x=goal.pose.x, goal_y=goal.pose.y,
                goal_yaw=goal.pose.yaw, way=way, connector="", start_id=START_ROBOT, goal_id=goal.id,
                language="en", start_robot=origin.name, start_state=LEG_COMMITTED)
    legs = [(LEG_START, origin.floor)]
    if not math.isclose(goal.floor, origin.floor) and building.has_robot(goal.floor):
        try:
            choice = planner.choose_connector(origin.floor, pose, goal.floor, (goal.pose.x, goal.pose.y), way)
        except NoRouteError:
            choice = None
        if choice is not None:
            trip = replace(trip, way=choice.way, connector=choice.connector.id)
            legs.append((LEG_GOAL, goal.floor))
    out = []
    for leg, floor in legs:
        ranked = rank_candidates(planner, model, trip, leg, views, online, now_wall,
                                 prefer=origin.name if leg == LEG_START else "", prefer_gain=prefer_gain)
        out.append(LegPreview(leg, floor, ranked[0] if ranked else None))
    return tuple(out)
