"""Data the GUI receives and sends (ROS-free), and the live state of every robot.

The messages the GUI shares with the robots' nodes have their forms in gidabot_navigation
(:mod:`gidabot_navigation.guiding.messages`: statuses, poses, pending lists, NavEvents, visitor commands;
:mod:`gidabot_navigation.tours.tour_store`: tours, catalogs, edit results), converted to and from ROS
messages by :mod:`gidabot_navigation.ros.convert`. Here: what only the GUI needs of them
(:func:`bounded`: received text cut to what the screen shows; :class:`TourInfo`: a catalog's tour read
like a tour file), the GUI's own outputs (:class:`InitialPose`, :class:`TourEdit`) and where they go
(:class:`Outputs`), and :class:`Fleet`, which keeps the latest status, pose and pending list of every
robot of the building and decides which robots are offline, in WALL time (monotonic seconds passed in):
liveness is a network property, a starved CPU at 10x sim speed must not hide robots.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Protocol, TypeVar

from gidabot_navigation.building.model import Building, Robot
from gidabot_navigation.errors import GoalRejected, TourError, TourNameError
from gidabot_navigation.guiding.messages import (
    CommandData,
    PendingData,
    PoseData,
    RobotStatusData,
    StaffCommandData,
    validate_staff,
    validate_trip,
)
from gidabot_navigation.guiding.trips import RobotView, TripPlanner
from gidabot_navigation.interface import StaffCmd
from gidabot_navigation.tours.tour_file import MAX_GOALS, tour_from_lines
from gidabot_navigation.tours.tour_file import Tour as TourFile
from gidabot_navigation.tours.tour_store import TourMessage

MAX_TEXT = 256          # longer strings from other nodes are cut (hostile or broken input)
OFFLINE_AFTER = 5.0     # s (wall) without a status before a robot is shown offline


def clip(text: object, limit: int = MAX_TEXT) -> str:
    """``text`` as a str of at most ``limit`` characters (control characters removed)."""
    s = text if isinstance(text, str) else str(text)
    s = "".join(ch for ch in s[: limit * 2] if ch.isprintable())
    return s[:limit]


def finite(*values: float) -> bool:
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)


# longest text kept of a received field (others: MAX_TEXT), and of a received list
TEXT_LIMITS = {"robot": 64, "state": 32, "language": 8, "way": 16, "connector": 64, "location_id": 64,
               "tour_file": 64, "leg": 8, "assignee": 64, "file_name": 64, "reason": 32, "error": 400, "detail": 400}
MAX_ITEMS = 256

R = TypeVar("R")


def bounded(record: R) -> R:
    """A received record (a dataclass of gidabot_navigation's message forms) as the GUI keeps it: every text
    field :func:`clip`-ped to its :data:`TEXT_LIMITS`, every list cut to :data:`MAX_ITEMS`."""
    changes: dict[str, object] = {}
    for f in fields(record):  # type: ignore[arg-type]
        value = getattr(record, f.name)
        if isinstance(value, str):
            changes[f.name] = clip(value, TEXT_LIMITS.get(f.name, MAX_TEXT))
        elif isinstance(value, tuple):
            changes[f.name] = value[:MAX_ITEMS]
    return replace(record, **changes)  # type: ignore[type-var]


# ---------------------------------------------------------------- inputs
@dataclass(frozen=True)
class TourInfo:
    """One tour of gidabot_msgs/TourCatalog."""

    file_name: str
    name: str
    language: str
    goals: tuple[tuple[float, str, str], ...]   # (floor, room, description)

    @property
    def title(self) -> str:
        """The display name ("open_day.tour" without a name shows as "Open day")."""
        return self.name or TourFile(self.file_name, "", ()).display_name

    @property
    def floors(self) -> list[float]:
        seen: list[float] = []
        for floor, _room, _desc in self.goals:
            if floor not in seen:
                seen.append(floor)
        return seen


def tour_info(t: TourMessage) -> TourInfo | None:
    """A catalog's tour, its goal lines read exactly as a tour file's (``tour_file.tour_from_lines``: spacing and
    floors such as ``0.0`` tolerated), or None if they are malformed (the store validated them already)."""
    try:
        tour = tour_from_lines(t.file_name, t.tour_name.strip(), list(t.tour_goals_info[:MAX_GOALS]))
    except (TourError, TourNameError):
        return None
    return TourInfo(tour.file_name, clip(t.tour_name, 80), clip(t.language, 8),
                    tuple((g.floor, g.room, g.description) for g in tour.goals))


# ---------------------------------------------------------------- outputs
@dataclass(frozen=True)
class InitialPose:
    """geometry_msgs/PoseWithCovarianceStamped on ``initialpose`` (frame ``map`` of ``floor``)."""

    floor: float
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class TourEdit:
    """gidabot_msgs/Tour to publish on ``tour_store/edit``."""

    uid: str
    file_name: str
    tour_name: str
    language: str
    floor: float
    goal_lines: tuple[str, ...]
    deleted: bool = False

    def message(self, robot: str, stamp: float) -> TourMessage:
        """The edit as the tour store reads it (``robot``: this GUI's; the store gives the version)."""
        return TourMessage(uid=self.uid, origin_robot=robot, editor_robot=robot, deleted=self.deleted,
                           language=self.language, floor=self.floor, tour_name=self.tour_name,
                           file_name=self.file_name, tour_goals_info=self.goal_lines, stamp=stamp)


class Outputs(Protocol):
    """Where the GUI's messages go (the ROS adapter's publishers; a recorder in tests)."""

    def send_command(self, cmd: CommandData) -> None: ...

    def send_initial_pose(self, pose: InitialPose) -> None: ...

    def send_tour_edit(self, edit: TourEdit) -> None: ...


# ---------------------------------------------------------------- fleet
@dataclass
class RobotLive:
    """What is known of one robot."""

    robot: Robot
    status: RobotStatusData | None = None
    pose: tuple[float, float, float] | None = None   # x, y, yaw (latest of status / poses)
    pending: PendingData | None = None
    last_status: float | None = None                 # wall time of the last status
    pending_at: float | None = None


@dataclass
class Fleet:
    """The robots of the building as this GUI sees them."""

    building: Building
    offline_after: float = OFFLINE_AFTER
    robots: dict[str, RobotLive] = field(default_factory=dict)
    service: dict[str, StaffCommandData] = field(default_factory=dict)   # robot -> the staff command in force
    rejected: int = 0                 # inputs ignored (unknown robot, NaN...)
    last_rejection: str = ""
    planner: TripPlanner = field(init=False, repr=False)   # path lengths for the waits (cached)

    def __post_init__(self) -> None:
        for r in self.building.robots:
            self.robots[r.name] = RobotLive(r)
        self.planner = TripPlanner(self.building)

    def _reject(self, why: str) -> bool:
        self.rejected += 1
        self.last_rejection = why
        return False

    def _live(self, name: str) -> RobotLive | None:
        return self.robots.get(name) if isinstance(name, str) else None

    def update_status(self, s: RobotStatusData, now: float) -> bool:
        """Take a status received at wall time ``now``; False (counted) if it is unusable."""
        live = self._live(s.robot)
        if live is None:
            return self._reject(f"status of unknown robot {clip(s.robot, 40)!r}")
        live.status = s
        live.last_status = now
        if finite(s.x, s.y, s.yaw):
            live.pose = (s.x, s.y, s.yaw)
        else:
            return self._reject(f"status of {s.robot} with a pose that is not finite ({s.x}, {s.y}, {s.yaw})")
        return True

    def update_pose(self, p: PoseData, now: float) -> bool:
        live = self._live(p.robot)
        if live is None:
            return self._reject(f"pose of unknown robot {clip(p.robot, 40)!r}")
        if not finite(p.x, p.y, p.yaw):
            return self._reject(f"pose of {p.robot} is not finite ({p.x}, {p.y}, {p.yaw})")
        live.pose = (p.x, p.y, p.yaw)
        return True

    def update_pending(self, p: PendingData, now: float) -> bool:
        live = self._live(p.robot)
        if live is None:
            return self._reject(f"pending requests of unknown robot {clip(p.robot, 40)!r}")
        goals = []
        for trip in p.goals:
            try:
                goals.append(validate_trip(self.building, trip))
            except GoalRejected as err:
                self._reject(f"pending goal of {p.robot}: {err}")
        live.pending = replace(p, goals=tuple(goals))
        live.pending_at = now
        return True

    def update_staff(self, cmd: StaffCommandData, now: float) -> bool:
        """A staff command from a dashboard (/gidabot/staff): for each robot the one with the largest
        (version, robot) is in force; an invalid one is counted."""
        try:
            cmd = validate_staff(self.building, cmd)
        except GoalRejected as err:
            return self._reject(f"staff command: {err}")
        known = self.service.get(cmd.target_robot)
        if known is None or cmd.key > known.key:
            self.service[cmd.target_robot] = cmd
        return True

    def out_of_service(self, name: str) -> bool:
        cmd = self.service.get(name)
        return cmd is not None and cmd.command == StaffCmd.OUT_OF_SERVICE

    def is_offline(self, name: str, now: float) -> bool:
        """True if robot ``name`` sent no status in the last ``offline_after`` s (or never)."""
        live = self.robots[name]
        return live.last_status is None or now - live.last_status > self.offline_after

    def ever_seen(self, name: str) -> bool:
        return self.robots[name].last_status is not None

    def seen_ago(self, name: str, now: float) -> float | None:
        last = self.robots[name].last_status
        return None if last is None else max(0.0, now - last)

    def views(self) -> dict[str, RobotView]:
        """What each robot broadcast (queue, wait, pose), to rank the robots that could serve a leg
        (:func:`~gidabot_navigation.guiding.trips.rank_candidates`); a robot's status stands in for a
        pending list not received yet."""
        out = {}
        for name, live in self.robots.items():
            pose = (live.pose[0], live.pose[1]) if live.pose is not None else None
            if live.pending is not None and finite(live.pending.wait_new):
                out[name] = RobotView(live.robot, live.pending.goals, max(0.0, live.pending.wait_new), pose,
                                      live.pending_at or 0.0)
            else:
                busy = live.status.busy_for if live.status is not None and finite(live.status.busy_for) else 0.0
                out[name] = RobotView(live.robot, (), max(0.0, busy), pose, live.last_status or 0.0)
        return out

    def wait_of(self, name: str, now: float) -> tuple[int, float | None] | None:
        """(pending requests, wait in s before a new request could start) or None if unknown.

        Uses PendingRequests when known, else the status' pending count and busy_for.
        """
        live = self.robots.get(name)
        if live is None or self.is_offline(name, now):
            return None
        if live.pending is not None:
            wait = live.pending.wait_new
            return live.pending.num, (wait if finite(wait) and wait >= 0 else None)
        if live.status is not None:
            busy = live.status.busy_for
            return live.status.pending, (busy if finite(busy) and busy >= 0 else None)
        return None
