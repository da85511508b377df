"""Data the GUI receives and sends (ROS-free), and the live state of every robot.

The ROS adapter converts messages to these plain records (and back), so the
core, the widgets and their tests need no master. NavEvents and visitor commands
use the guiding nodes' forms (:class:`~gidabot_navigation.guiding.messages.NavEventData`,
:class:`~gidabot_navigation.guiding.messages.CommandData`). :class:`Fleet` keeps the
latest status, pose and pending list of every robot of the building and decides
which robots are offline, in WALL time (monotonic seconds passed in): liveness
is a network property, a starved CPU at 10x sim speed must not hide robots.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

from gidabot_navigation.building.model import Building, Robot
from gidabot_navigation.errors import GoalRejected
from gidabot_navigation.guiding.messages import CommandData, Trip, validate_trip
from gidabot_navigation.guiding.trips import RobotView, TripPlanner
from gidabot_navigation.tours.tour_file import Tour as TourFile

MAX_TEXT = 256          # longer strings from other nodes are cut (hostile or broken input)
OFFLINE_AFTER = 5.0     # s (wall) without a status before a robot is shown offline


def clip(text: object, limit: int = MAX_TEXT) -> str:
    """``text`` as a str of at most ``limit`` characters (control characters removed)."""
    s = text if isinstance(text, str) else str(text)
    s = "".join(ch for ch in s[: limit * 2] if ch.isprintable())
    return s[:limit]


def finite(*values: float) -> bool:
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)


# ---------------------------------------------------------------- inputs
@dataclass(frozen=True)
class RobotStatusData:
    """gidabot_msgs/RobotStatus."""

    robot: str
    floor: float
    x: float
    y: float
    yaw: float
    linear: float           # m/s
    angular: float          # rad/s
    battery: float          # 0..1
    state: str
    pending: int
    current_goal_uid: str = ""
    busy_for: float = 0.0   # s


@dataclass(frozen=True)
class PoseData:
    """gidabot_msgs/NavPose."""

    robot: str
    floor: float
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class PendingData:
    """gidabot_msgs/PendingRequests (what the GUI needs of it)."""

    robot: str
    floor: float
    num: int
    wait_new: float         # s before this robot could start a new request
    goals: tuple[Trip, ...] = ()   # its queue (who serves which leg: where it will be when done)


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


@dataclass(frozen=True)
class EditResultData:
    """gidabot_msgs/TourEditResult."""

    uid: str
    file_name: str
    deleted: bool
    ok: bool
    version: int = 0
    reason: str = ""
    error: str = ""


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
        live.pending = PendingData(p.robot, p.floor, p.num, p.wait_new, tuple(goals))
        live.pending_at = now
        return True

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
