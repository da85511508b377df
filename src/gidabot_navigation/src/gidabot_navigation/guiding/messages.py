"""Plain-Python forms of the guiding messages and their validation (ROS-free).

The guiding cores (:mod:`~gidabot_navigation.guiding.goal_manager`,
:mod:`~gidabot_navigation.guiding.navigation`) and the GUI never see a ROS message:
:mod:`gidabot_navigation.ros.convert` turns ``gidabot_msgs`` messages into the dataclasses below
(:class:`Trip` = Goal, :class:`NavEventData` = NavEvent, :class:`CancelData` = Cancel,
:class:`CommandData` = VisitorCommand, :class:`PendingData` = PendingRequests,
:class:`RobotStatusData` = RobotStatus, :class:`PoseData` = NavPose) and back. Everything that comes from outside
(another robot, the GUI) is untrusted and goes through :func:`validate_trip`,
:func:`validate_cancel`, :func:`validate_event` or :func:`validate_command` first:
they raise :class:`~gidabot_navigation.errors.GoalRejected` naming the bad value.

The messages' constants (phases, commands, reasons, ways) are in :mod:`gidabot_navigation.interface`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, replace

from gidabot_navigation.building.model import Building, format_floor
from gidabot_navigation.errors import GoalRejected, TourNameError
from gidabot_navigation.interface import (
    COMMAND_NAMES,
    DEFAULT_LANGUAGE,
    FINAL_PHASES,
    LANGUAGES,
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_NONE,
    LEG_START,
    LEG_STATE_NAMES,
    LEG_STATES,
    LEGS,
    PHASE_NAMES,
    REASON_ADMIN,
    REASON_OFFLINE,
    REASON_TIMEOUT,
    REASON_UNREACHABLE,
    REASON_VISITOR,
    REASON_VISITOR_LOST,
    REASONS,
    STAFF_COMMAND_NAMES,
    WAYS,
    Phase,
)
from gidabot_navigation.senders import (
    MAX_UID,
    SCOPE_CANCEL,
    SCOPE_EVENT,
    SCOPE_STAFF,
    SCOPE_TOUR_EDIT,
    HandledUids,
    fingerprint,
    make_uid,
)
from gidabot_navigation.tours.tour_file import MAX_GOALS, check_tour_file_name

# the phase a robot shows its visitor when another robot drops a trip for this reason
PHASE_OF_REASON = {REASON_VISITOR: Phase.CANCELLED_ELSEWHERE, REASON_UNREACHABLE: Phase.UNREACHABLE,
                   REASON_TIMEOUT: Phase.TIMEOUT, REASON_OFFLINE: Phase.PARTNER_OFFLINE,
                   REASON_ADMIN: Phase.CANCELLED_ELSEWHERE, REASON_VISITOR_LOST: Phase.VISITOR_LOST}

# -- limits of untrusted text (uids: senders.UID_FORMAT; who may use which uid: senders.Senders) ------
MAX_ID = 64          # robot, visitor, location, connector ids
MAX_DETAIL = 400
_UID_RE = re.compile(r"^[A-Za-z0-9_.:/@+-]{1,160}\Z")    # a uid's charset and length (uids: MAX_UID)
_ID_RE = re.compile(r"^[A-Za-z0-9_.:@+-]{1,64}\Z")
START_ROBOT = "robot"     # Goal.start_id when the trip starts at the robot's pose
POSE_TOLERANCE = 1.0      # m: a goal_pose this far from its location's pose means the buildings differ


def same_floor(a: float, b: float) -> bool:
    """True when two floor numbers are the same floor (float32 rounding tolerated)."""
    return math.isfinite(a) and math.isfinite(b) and abs(a - b) < 1e-3


def show(value: object, limit: int = 60) -> str:
    """A short printable form of an untrusted value for log lines and errors."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


# ---------------------------------------------------------------------------
# Message forms
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Trip:
    """A gidabot_msgs/Goal: one visitor's trip from a start point to a goal point.

    Poses are in the map frame of their floor (m, rad). ``way`` is the visitor's
    choice (kept on one-floor goals too, so a tour remembers it); ``connector`` is
    the lift/staircase used for the floor change ("" on one floor).
    """

    uid: str
    origin_robot: str
    visitor_id: str
    initial_floor: float
    initial_x: float
    initial_y: float
    goal_floor: float
    goal_x: float
    goal_y: float
    goal_yaw: float
    way: str
    connector: str
    start_id: str
    goal_id: str
    language: str
    tour_file: str = ""
    tour_step: int = -1
    stamp: float = 0.0            # s, ROS time when the visitor confirmed
    # who serves each leg (docs/guiding.md, "Who serves a leg"): written only by origin_robot
    start_robot: str = ""
    start_state: int = LEG_NONE
    goal_robot: str = ""
    goal_state: int = LEG_NONE
    attempt: int = 0              # version of the assignment; the highest wins

    @property
    def cross_floor(self) -> bool:
        return not same_floor(self.initial_floor, self.goal_floor)

    @property
    def in_tour(self) -> bool:
        return bool(self.tour_file)

    def leg_robot(self, leg: str) -> str:
        return self.start_robot if leg == LEG_START else self.goal_robot

    def leg_state(self, leg: str) -> int:
        return self.start_state if leg == LEG_START else self.goal_state

    def leg_of(self, robot: str) -> str | None:
        """The leg this assignment names ``robot`` for (proposed or committed), or None."""
        return next((leg for leg in LEGS if self.leg_state(leg) != LEG_NONE and self.leg_robot(leg) == robot), None)

    def committed(self, leg: str) -> str:
        """The robot serving ``leg`` once committed, else ""."""
        return self.leg_robot(leg) if self.leg_state(leg) == LEG_COMMITTED else ""

    def with_leg(self, leg: str, robot: str, state: int, attempt: int) -> Trip:
        """This trip with ``leg`` given to ``robot`` in ``state``, as assignment ``attempt``."""
        if leg == LEG_START:
            return replace(self, start_robot=robot, start_state=state, attempt=attempt)
        return replace(self, goal_robot=robot, goal_state=state, attempt=attempt)


@dataclass(frozen=True)
class NavEventData:
    """A gidabot_msgs/NavEvent."""

    uid: str
    robot: str
    floor: float
    goal_uid: str
    phase: int
    language: str = DEFAULT_LANGUAGE
    way: str = ""
    connector: str = ""
    target_floor: float = 0.0
    location_id: str = ""
    tour_file: str = ""
    tour_step: int = -1
    detail: str = ""
    stamp: float = 0.0
    leg: str = ""                 # LEG_START / LEG_GOAL: the leg of the trip the event is about
    attempt: int = 0              # the Goal.attempt the emitting robot acted under (ACCEPTED / DECLINED: answered)
    assignee: str = ""            # the other robot: ASSIGNED serves ``leg``; GO_TO_FLOOR waits; PARTNER_* partner
    eta: float = 0.0              # s, ACCEPTED / ASSIGNED: until the serving robot is with the visitor (start leg)
    #                               or at the meeting point (goal leg)
    x: float = 0.0                # m, SEARCHING_VISITOR / VISITOR_LOST: where the visitor was last seen (map of floor)
    y: float = 0.0

    @property
    def final(self) -> bool:
        return self.phase in FINAL_PHASES


@dataclass(frozen=True)
class CancelData:
    """A gidabot_msgs/Cancel."""

    uid: str
    goal_uid: str
    origin_robot: str
    reason: str
    detail: str = ""
    stamp: float = 0.0


@dataclass(frozen=True)
class CommandData:
    """A gidabot_msgs/VisitorCommand.

    :attr:`key` identifies one button press: the uid *and* its stamp (a GUI that restarts
    counts its command uids from 1 again; a replayed command has both the same)."""

    command: int
    uid: str = ""
    visitor_id: str = ""
    goal_id: str = ""
    way: str = ""
    language: str = ""
    goal_uid: str = ""
    tour_file: str = ""
    tour_step: int = -1
    stamp: float = 0.0

    @property
    def key(self) -> str:
        return command_key(self.uid, self.stamp)


@dataclass(frozen=True)
class PendingData:
    """A gidabot_msgs/PendingRequests: one robot's queue, head first, and its waits."""

    robot: str
    floor: float
    num: int                       # requests in the queue (as many as ``goals`` when sent)
    wait_new: float                # s before this robot could start a new request
    goals: tuple[Trip, ...] = ()
    eta: tuple[float, ...] = ()    # s from ``stamp`` until each goal is finished by this robot
    stamp: float = 0.0             # s, ROS time of the estimate


@dataclass(frozen=True)
class RobotStatusData:
    """A gidabot_msgs/RobotStatus: one robot's state, pose (its floor's map frame) and load."""

    robot: str
    floor: float
    x: float
    y: float
    yaw: float
    linear: float                  # m/s
    angular: float                 # rad/s
    battery: float                 # 0..1 (the navigation's -1: unknown)
    state: str                     # a RobotState (as received: untrusted)
    pending: int
    current_goal_uid: str = ""
    busy_for: float = 0.0          # s until the queue is empty
    stamp: float = 0.0
    frame_id: str = ""


@dataclass(frozen=True)
class PoseData:
    """A gidabot_msgs/NavPose: one robot's pose in its floor's map frame."""

    robot: str
    floor: float
    x: float
    y: float
    yaw: float
    stamp: float = 0.0
    frame_id: str = ""


@dataclass(frozen=True)
class WayAsk:
    """A gidabot_msgs/MakeWay: robot ``robot`` (the sender) asks ``robots`` of its floor to clear ``way`` (points in
    the floor's map frame, m); no robots: its ask is over."""

    robot: str
    floor: float
    robots: tuple[str, ...]
    way: tuple[tuple[float, float], ...]
    stamp: float = 0.0
    frame_id: str = ""


MAX_WAY_POINTS = 200      # points of a way in a WayAsk (a string-pulled plan has a few dozen)


def validate_ask(building: Building, ask: WayAsk) -> WayAsk:
    """Check a MakeWay: a known robot on its floor, the robots asked on that floor (not itself), a way of at most
    :data:`MAX_WAY_POINTS` finite points on the floor's map; an ask naming robots has a way."""
    robot = _text(ask.robot, "make_way robot", MAX_ID, _ID_RE, empty=False)
    asker = building.find_robot(robot)
    if asker is None:
        raise GoalRejected("robot", f"make_way robot {show(robot)} is not a robot of building {building.id}")
    floor = _finite(ask.floor, "make_way floor")
    if not same_floor(floor, asker.floor):
        raise GoalRejected("floor", f"make_way floor {format_floor(floor)} is not robot {robot}'s floor "
                                    f"({format_floor(asker.floor)})")
    robots = []
    for name in ask.robots:
        name = _text(name, "make_way robots", MAX_ID, _ID_RE, empty=False)
        other = building.find_robot(name)
        if other is None or name == robot or not same_floor(other.floor, asker.floor):
            raise GoalRejected("robot", f"make_way robots: {show(name)} is not another robot of floor "
                                        f"{format_floor(asker.floor)}")
        robots.append(name)
    if len(ask.way) > MAX_WAY_POINTS:
        raise GoalRejected("way", f"make_way way: {len(ask.way)} points, at most {MAX_WAY_POINTS}")
    grid = building.floor(asker.floor).map
    way = []
    for x, y in ask.way:
        x, y = _finite(x, "make_way way x"), _finite(y, "make_way way y")
        if not grid.contains(x, y):
            raise GoalRejected("way", f"make_way way point ({x:g}, {y:g}) is off floor {format_floor(floor)}'s map")
        way.append((x, y))
    if robots and len(way) < 2:
        raise GoalRejected("way", "make_way: robots asked without a way (at least two points)")
    return replace(ask, robot=robot, floor=asker.floor, robots=tuple(robots), way=tuple(way))


def command_key(uid: object, stamp: object) -> str:
    """The de-duplication key of a visitor command ("" = none: a command without uid is never a duplicate)."""
    if not isinstance(uid, str) or not uid:
        return ""
    t = stamp if isinstance(stamp, (int, float)) and math.isfinite(stamp) else 0.0
    return f"{uid[:MAX_UID]}@{t:.6f}"


# -- actions the cores ask their adapters to carry out --------------------------------

@dataclass(frozen=True)
class SendGoal:
    """Publish ``trip`` on /gidabot/goals."""

    trip: Trip


@dataclass(frozen=True)
class SendCancel:
    """Publish ``cancel`` on /gidabot/cancels."""

    cancel: CancelData


@dataclass(frozen=True)
class SendAsk:
    """Publish ``ask`` on /gidabot/make_way."""

    ask: WayAsk


@dataclass(frozen=True)
class SendEvent:
    """Publish ``event`` on /gidabot/nav_events."""

    event: NavEventData


@dataclass(frozen=True)
class MoveTo:
    """Send a move_base goal (x, y, yaw in the floor's map frame); results come back with ``token``."""

    token: int
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class StopMoving:
    """Cancel the move_base goal ``token`` (the robot stops and is free)."""

    token: int


Action = SendGoal | SendCancel | SendEvent | MoveTo | StopMoving


# ---------------------------------------------------------------------------
# Helpers shared by the cores
# ---------------------------------------------------------------------------

class UidMaker:
    """This robot's uids (:data:`~gidabot_navigation.senders.UID_FORMAT`): ``<robot>/event/<tag>.<token>``,
    ``<robot>/cancel/<tag>.<token>``, ``<robot>/staff/<tag>.<token>`` (staff commands),
    ``<robot>/tour-edit/<tag>.<token>`` (admin edits to the tour store), and ``<robot>/<visitor>/<tag>.<token>``
    for goals (the GUI knows its visitor's trips by that prefix). Every token is drawn at random: a restarted node
    never reuses a uid, and nobody can tell the next one before it is published."""

    def __init__(self, robot: str, tag: str) -> None:
        self.robot = robot
        self.tag = tag

    def event(self) -> str:
        return make_uid(self.robot, SCOPE_EVENT, self.tag)

    def cancel(self) -> str:
        return make_uid(self.robot, SCOPE_CANCEL, self.tag)

    def goal(self, visitor_id: str) -> str:
        return make_uid(self.robot, visitor_id, self.tag)

    def staff(self) -> str:
        return make_uid(self.robot, SCOPE_STAFF, self.tag)

    def tour_edit(self) -> str:
        return make_uid(self.robot, SCOPE_TOUR_EDIT, self.tag)


def base36(number: int) -> str:
    """``number`` (>= 0) in base 36: a short tag, e.g. of the wall clock at start."""
    digits = "0123456789abcdefghijklmnopqrstuvwxyz"
    out = ""
    while True:
        number, rem = divmod(number, 36)
        out = digits[rem] + out
        if number == 0:
            return out


# the fields of a Goal that change with each attempt of its assignment: not part of the trip's content
ASSIGNMENT_FIELDS = ("start_robot", "start_state", "goal_robot", "goal_state", "attempt")


def trip_digest(trip: Trip) -> str:
    """The content of a (validated) goal, the same for every attempt of its assignment (its stamp left out)."""
    return fingerprint(trip, ("stamp", *ASSIGNMENT_FIELDS))


def nav_event_digest(ev: NavEventData) -> str:
    """The content of a (validated) NavEvent (its stamp and free-text detail left out)."""
    return fingerprint(ev, ("stamp", "detail"))


def cancel_digest(cancel: CancelData) -> str:
    """The content of a (validated) Cancel (its stamp and free-text detail left out)."""
    return fingerprint(cancel, ("stamp", "detail"))


class SeenSet(HandledUids):
    """A bounded set of ids (oldest forgotten first), without content: ids already handled."""

    def recent(self, n: int) -> list[str]:  # type: ignore[override]
        """The ``n`` most recently added ids, oldest first (what a restarted node must remember)."""
        return [uid for uid, _ in super().recent(n)]


class Counters(dict):
    """Named counters (rejected_<reason>, duplicates, ...) for diagnostics and tests."""

    def inc(self, key: str, n: int = 1) -> None:
        self[key] = self.get(key, 0) + n


# ---------------------------------------------------------------------------
# Validation of untrusted input
# ---------------------------------------------------------------------------

def _text(value: object, what: str, limit: int, pattern: re.Pattern[str] | None = None,
          empty: bool = True) -> str:
    if not isinstance(value, str):
        raise GoalRejected("type", f"{what} {show(value)} is not a string")
    if len(value) > limit:
        raise GoalRejected("too_long", f"{what} is {len(value)} characters long; at most {limit} allowed "
                                       f"({show(value, 40)})")
    if not value:
        if empty:
            return value
        raise GoalRejected("empty", f"{what} is empty")
    if pattern is not None and not pattern.match(value):
        raise GoalRejected("text", f"{what} {show(value)} holds characters other than letters, digits "
                                   "and _ . : / @ + -")
    if pattern is None and any(ord(ch) < 32 or ord(ch) == 127 for ch in value):
        raise GoalRejected("text", f"{what} {show(value)} holds control characters")
    return value


def _finite(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise GoalRejected("type", f"{what} {show(value)} is not a number")
    number = float(value)
    if not math.isfinite(number):
        raise GoalRejected("not_finite", f"{what} is {number!r}; expected a finite number")
    return number


def _floor_of(building: Building, value: object, what: str) -> float:
    number = _finite(value, what)
    floor = building.find_floor(number)
    if floor is None:
        raise GoalRejected("floor", f"{what} {format_floor(number)} is not a floor of building {building.id} "
                                    f"(floors {', '.join(f.label for f in building.floors)})")
    return floor.id


def _tour(tour_file: object, tour_step: object, what: str) -> tuple[str, int]:
    tour_file = _text(tour_file, f"{what} tour_file", 64)
    if isinstance(tour_step, bool) or not isinstance(tour_step, int):
        raise GoalRejected("type", f"{what} tour_step {show(tour_step)} is not an integer")
    if not tour_file:
        if tour_step != -1:
            raise GoalRejected("tour", f"{what} tour_step is {tour_step} without a tour_file; expected -1")
        return "", -1
    try:
        check_tour_file_name(tour_file)
    except TourNameError as err:
        raise GoalRejected("tour", f"{what}: {err}") from err
    if not 0 <= tour_step < MAX_GOALS:
        raise GoalRejected("tour", f"{what} tour_step {tour_step} is outside 0..{MAX_GOALS - 1}")
    return tour_file, tour_step


def validate_trip(building: Building, trip: Trip) -> Trip:
    """Check a goal from /gidabot/goals; return it normalised (floor ids, the building's goal pose).

    Rejects: non-string or overlong text, NaN/inf numbers, unknown floors, an origin
    robot that is not in the building or not on the initial floor, an unknown goal
    location or one on another floor, a goal pose far from that location (the robots'
    building files differ), a floor change without a valid way and connector, an
    unknown language, an unsafe tour file name.
    """
    uid = _text(trip.uid, "uid", MAX_UID, _UID_RE, empty=False)
    origin = _text(trip.origin_robot, "origin_robot", MAX_ID, _ID_RE, empty=False)
    robot = building.find_robot(origin)
    if robot is None:
        raise GoalRejected("robot", f"origin_robot {show(origin)} is not a robot of building {building.id} "
                                    f"({', '.join(r.name for r in building.robots)})")
    visitor = _text(trip.visitor_id, "visitor_id", MAX_ID, _ID_RE)
    a = _floor_of(building, trip.initial_floor, "initial_floor")
    b = _floor_of(building, trip.goal_floor, "goal_floor")
    if building.has_robot(a) and not same_floor(a, robot.floor):
        raise GoalRejected("floor", f"initial_floor {format_floor(a)} is not the floor of origin robot {origin} "
                                    f"({format_floor(robot.floor)})")
    ix, iy = _finite(trip.initial_x, "initial_pose.x"), _finite(trip.initial_y, "initial_pose.y")
    gx, gy = _finite(trip.goal_x, "goal_pose.x"), _finite(trip.goal_y, "goal_pose.y")
    _finite(trip.goal_yaw, "goal_pose orientation")
    grid = building.floor(a).map
    if not grid.contains(ix, iy):
        raise GoalRejected("pose", f"initial_pose ({ix:g}, {iy:g}) is outside the map of floor {format_floor(a)}")
    goal_id = _text(trip.goal_id, "goal_id", MAX_ID, _ID_RE, empty=False)
    loc = building.find_location(goal_id)
    if loc is None:
        raise GoalRejected("location", f"goal_id {show(goal_id)} is not a location of building {building.id}")
    if not same_floor(loc.floor, b):
        raise GoalRejected("location", f"goal_id {goal_id} is on floor {format_floor(loc.floor)}, "
                                       f"not on goal_floor {format_floor(b)}")
    off = math.hypot(gx - loc.pose.x, gy - loc.pose.y)
    if off > POSE_TOLERANCE:
        raise GoalRejected("pose", f"goal_pose ({gx:g}, {gy:g}) is {off:.1f} m from location {goal_id} at "
                                   f"({loc.pose.x:g}, {loc.pose.y:g}); the robots' building files differ")
    start_id = _text(trip.start_id, "start_id", MAX_ID, _ID_RE)
    if start_id and start_id != START_ROBOT and building.find_location(start_id) is None:
        raise GoalRejected("location", f"start_id {show(start_id)} is neither {START_ROBOT!r} nor a location")
    if not building.has_robot(a):
        # a tour going on from a floor without robot: the visitor starts at the last place visited there
        start = building.find_location(start_id)
        if start is None or not same_floor(start.floor, a) or math.hypot(ix - start.pose.x, iy - start.pose.y) \
                > POSE_TOLERANCE:
            raise GoalRejected("location", f"a trip from floor {format_floor(a)} (no robot) must start at a location "
                                           f"of that floor, not at start_id {show(start_id)} ({ix:g}, {iy:g})")
    way = _text(trip.way, "way", 16)
    connector = _text(trip.connector, "connector", MAX_ID, _ID_RE)
    if way and way not in WAYS:
        raise GoalRejected("way", f"way {show(way)} is not one of {', '.join(WAYS)} (or '' on one floor)")
    if a != b:
        if not way:
            raise GoalRejected("way", f"a trip from floor {format_floor(a)} to {format_floor(b)} needs a way "
                                      f"({', '.join(WAYS)})")
        conn = building.find_connector(connector)
        if conn is None:
            raise GoalRejected("connector", f"connector {show(connector)} is not a lift or staircase of the "
                                            f"building ({', '.join(c.id for c in building.connectors)})")
        if a not in conn.serves or b not in conn.serves:
            raise GoalRejected("connector", f"connector {connector} does not serve floors {format_floor(a)} "
                                            f"and {format_floor(b)}")
        if conn.kind != way:
            raise GoalRejected("connector", f"connector {connector} is a {conn.kind}, but way is {way}")
    elif connector:
        raise GoalRejected("connector", f"connector {show(connector)} given for a trip on one floor; expected ''")
    language = _text(trip.language, "language", 8)
    if language not in LANGUAGES:
        raise GoalRejected("language", f"language {show(language)} is not one of {', '.join(LANGUAGES)}")
    tour_file, tour_step = _tour(trip.tour_file, trip.tour_step, "goal")
    stamp = trip.stamp if isinstance(trip.stamp, (int, float)) and math.isfinite(trip.stamp) else 0.0
    attempt = trip.attempt
    if isinstance(attempt, bool) or not isinstance(attempt, int) or not 0 <= attempt < 2 ** 32:
        raise GoalRejected("assignment", f"attempt {show(attempt)} is not an integer in 0..2^32-1")
    legs = {leg: _leg(building, trip, leg, a if leg == LEG_START else b, a != b or leg == LEG_START)
            for leg in LEGS}
    return replace(trip, uid=uid, origin_robot=origin, visitor_id=visitor, initial_floor=a, initial_x=ix,
                   initial_y=iy, goal_floor=b, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw,
                   way=way, connector=connector, start_id=start_id, goal_id=goal_id, language=language,
                   tour_file=tour_file, tour_step=tour_step, stamp=float(stamp), start_robot=legs[LEG_START][0],
                   start_state=legs[LEG_START][1], goal_robot=legs[LEG_GOAL][0], goal_state=legs[LEG_GOAL][1])


def _leg(building: Building, trip: Trip, leg: str, floor: float, exists: bool) -> tuple[str, int]:
    """Check one leg's assignment: a robot of the leg's floor proposed or committed when the floor has robots
    (and the leg exists: a one-floor trip has only the start leg), else none."""
    robot = _text(trip.leg_robot(leg), f"{leg}_robot", MAX_ID, _ID_RE)
    state = trip.leg_state(leg)
    if isinstance(state, bool) or state not in LEG_STATES:
        raise GoalRejected("assignment", f"{leg}_state {show(state)} is not one of "
                                         f"{', '.join(f'{k}={v}' for k, v in LEG_STATE_NAMES.items())}")
    if not exists or not building.has_robot(floor):
        if state != LEG_NONE or robot:
            why = "a trip on one floor has no goal leg" if not exists else \
                f"floor {format_floor(floor)} has no robot"
            raise GoalRejected("assignment", f"{leg} leg assigned to {show(robot)} ({LEG_STATE_NAMES[state]}): {why}")
        return "", LEG_NONE
    if state == LEG_NONE:
        if leg == LEG_GOAL and not robot:
            return "", LEG_NONE       # the goal floor's robots are all out of service: the visitor goes alone
        raise GoalRejected("assignment", f"{leg} leg on floor {format_floor(floor)} has no robot assigned "
                                         f"(robots there: {', '.join(r.name for r in building.robots_on(floor))})")
    serving = building.find_robot(robot)
    if serving is None or not same_floor(serving.floor, floor):
        raise GoalRejected("assignment", f"{leg}_robot {show(robot)} is not a robot of floor {format_floor(floor)} "
                                         f"({', '.join(r.name for r in building.robots_on(floor))})")
    return robot, state


def validate_cancel(building: Building, cancel: CancelData) -> CancelData:
    """Check a Cancel from /gidabot/cancels (ids, a known origin robot, a known reason)."""
    uid = _text(cancel.uid, "cancel uid", MAX_UID, _UID_RE, empty=False)
    goal_uid = _text(cancel.goal_uid, "cancel goal_uid", MAX_UID, _UID_RE, empty=False)
    origin = _text(cancel.origin_robot, "cancel origin_robot", MAX_ID, _ID_RE, empty=False)
    if building.find_robot(origin) is None:
        raise GoalRejected("robot", f"cancel origin_robot {show(origin)} is not a robot of building {building.id}")
    reason = _text(cancel.reason, "cancel reason", 16)
    if reason not in REASONS:
        raise GoalRejected("reason", f"cancel reason {show(reason)} is not one of {', '.join(REASONS)}")
    detail = cancel.detail if isinstance(cancel.detail, str) else ""
    return replace(cancel, uid=uid, goal_uid=goal_uid, origin_robot=origin, reason=reason,
                   detail=detail[:MAX_DETAIL])


def validate_event(building: Building, event: NavEventData) -> NavEventData:
    """Check the parts of a NavEvent guiding acts on (uid, robot, goal_uid, phase, tour info)."""
    uid = _text(event.uid, "event uid", MAX_UID, _UID_RE, empty=False)
    robot = _text(event.robot, "event robot", MAX_ID, _ID_RE, empty=False)
    if building.find_robot(robot) is None:
        raise GoalRejected("robot", f"event robot {show(robot)} is not a robot of building {building.id}")
    goal_uid = _text(event.goal_uid, "event goal_uid", MAX_UID, _UID_RE)
    if isinstance(event.phase, bool) or not isinstance(event.phase, int) or event.phase not in PHASE_NAMES:
        raise GoalRejected("phase", f"event phase {show(event.phase)} is not a known NavEvent phase")
    tour_file, tour_step = _tour(event.tour_file, event.tour_step, "event")
    way = event.way if isinstance(event.way, str) and event.way in WAYS else ""
    language = event.language if event.language in LANGUAGES else DEFAULT_LANGUAGE
    if event.leg not in ("", *LEGS):
        raise GoalRejected("leg", f"event leg {show(event.leg)} is not one of {', '.join(LEGS)} (or '')")
    if isinstance(event.attempt, bool) or not isinstance(event.attempt, int) or not 0 <= event.attempt < 2 ** 32:
        raise GoalRejected("assignment", f"event attempt {show(event.attempt)} is not an integer in 0..2^32-1")
    assignee = _text(event.assignee, "event assignee", MAX_ID, _ID_RE)
    if assignee and building.find_robot(assignee) is None:
        raise GoalRejected("robot", f"event assignee {show(assignee)} is not a robot of building {building.id}")
    if event.phase in (Phase.ACCEPTED, Phase.DECLINED, Phase.ASSIGNED) and (not goal_uid or not event.leg):
        raise GoalRejected("leg", f"a {PHASE_NAMES[event.phase]} event needs a goal_uid and a leg")
    if event.phase == Phase.ASSIGNED and not assignee:
        raise GoalRejected("assignment", "an assigned event needs an assignee")
    eta = event.eta if isinstance(event.eta, (int, float)) and math.isfinite(event.eta) and event.eta >= 0 else 0.0
    x, y = ((float(v) if isinstance(v, (int, float)) and math.isfinite(v) else 0.0) for v in (event.x, event.y))
    return replace(event, uid=uid, robot=robot, goal_uid=goal_uid, tour_file=tour_file, tour_step=tour_step,
                   way=way, language=language, assignee=assignee, eta=float(eta), x=x, y=y)


def validate_command(cmd: CommandData) -> CommandData:
    """Check a VisitorCommand from the GUI / simulated visitor (lengths, enums; not the building)."""
    if isinstance(cmd.command, bool) or not isinstance(cmd.command, int) or cmd.command not in COMMAND_NAMES:
        raise GoalRejected("command", f"command {show(cmd.command)} is not one of "
                                      f"{', '.join(f'{k}={v}' for k, v in COMMAND_NAMES.items())}")
    _text(cmd.uid, "command uid", MAX_UID)
    visitor = _text(cmd.visitor_id, "visitor_id", MAX_ID)
    visitor = visitor if _ID_RE.match(visitor or "-") else ""
    goal_id = _text(cmd.goal_id, "goal_id", MAX_ID)
    way = _text(cmd.way, "way", 16)
    if way and way not in WAYS:
        raise GoalRejected("way", f"way {show(way)} is not one of {', '.join(WAYS)} (or '' for the default)")
    language = _text(cmd.language, "language", 8)
    if language and language not in LANGUAGES:
        raise GoalRejected("language", f"language {show(language)} is not one of {', '.join(LANGUAGES)}")
    goal_uid = _text(cmd.goal_uid, "goal_uid", MAX_UID, _UID_RE)
    tour_file = _text(cmd.tour_file, "tour_file", 64)
    if tour_file:
        try:
            check_tour_file_name(tour_file)
        except TourNameError as err:
            raise GoalRejected("tour", str(err)) from err
    if isinstance(cmd.tour_step, bool) or not isinstance(cmd.tour_step, int):
        raise GoalRejected("type", f"tour_step {show(cmd.tour_step)} is not an integer")
    return replace(cmd, visitor_id=visitor, goal_id=goal_id, way=way, language=language, goal_uid=goal_uid,
                   tour_file=tour_file)


def own_event_digest(building: Building, ev: NavEventData) -> str:
    """:func:`nav_event_digest` of an event made here, as a receiver computes it from the validated event
    ("": content unknown, for an event that would not validate)."""
    try:
        return nav_event_digest(validate_event(building, ev))
    except GoalRejected:
        return ""


def uids(items: Iterable[Trip]) -> list[str]:
    return [t.uid for t in items]


# ---------------------------------------------------------------------------
# Staff commands (gidabot_msgs/StaffCommand, /gidabot/staff)
# ---------------------------------------------------------------------------

MAX_STAFF_DETAIL = 200
MAX_USER = 64
_USER_RE = re.compile(r"^[A-Za-z0-9_.@-]{1,64}\Z")


@dataclass(frozen=True)
class StaffCommandData:
    """A gidabot_msgs/StaffCommand: a staff action at ``robot``'s dashboard about ``target_robot``."""

    uid: str
    robot: str
    user: str
    command: int
    target_robot: str
    version: int
    detail: str = ""
    stamp: float = 0.0

    @property
    def key(self) -> tuple[int, str]:
        """What orders the commands about one target: the largest key is in force."""
        return self.version, self.robot


def validate_staff(building: Building, cmd: StaffCommandData) -> StaffCommandData:
    """Check a StaffCommand (uid in the sending robot's namespace, robots of the building, a known command, a
    version in 1..2^64-1, a user name, a detail without control characters); return it with ``detail`` cut to
    :data:`MAX_STAFF_DETAIL` characters."""
    uid = _text(cmd.uid, "staff uid", MAX_UID, _UID_RE, empty=False)
    robot = _text(cmd.robot, "staff robot", MAX_ID, _ID_RE, empty=False)
    if building.find_robot(robot) is None:
        raise GoalRejected("robot", f"staff robot {show(robot)} is not a robot of building {building.id}")
    if not uid.startswith(f"{robot}/"):
        raise GoalRejected("namespace", f"staff uid {show(uid)} is not in the namespace of robot {robot}")
    target = _text(cmd.target_robot, "staff target_robot", MAX_ID, _ID_RE, empty=False)
    if building.find_robot(target) is None:
        raise GoalRejected("robot", f"staff target_robot {show(target)} is not a robot of building {building.id}")
    if isinstance(cmd.command, bool) or cmd.command not in STAFF_COMMAND_NAMES:
        raise GoalRejected("command", f"staff command {show(cmd.command)} is not one of "
                                      f"{', '.join(f'{int(k)}={v}' for k, v in STAFF_COMMAND_NAMES.items())}")
    if isinstance(cmd.version, bool) or not isinstance(cmd.version, int) or not 0 < cmd.version < 2 ** 64:
        raise GoalRejected("version", f"staff version {show(cmd.version)} is not an integer in 1..2^64-1")
    user = _text(cmd.user, "staff user", MAX_USER, _USER_RE, empty=False)
    detail = cmd.detail if isinstance(cmd.detail, str) else ""
    detail = _text(detail[:MAX_STAFF_DETAIL], "staff detail", MAX_STAFF_DETAIL)
    stamp = cmd.stamp if isinstance(cmd.stamp, (int, float)) and math.isfinite(cmd.stamp) else 0.0
    return replace(cmd, uid=uid, robot=robot, user=user, command=int(cmd.command), target_robot=target,
                   detail=detail, stamp=float(stamp))
