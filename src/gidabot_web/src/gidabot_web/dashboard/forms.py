"""ROS-free forms of the messages the dashboard reads besides the guiding and tour forms of gidabot_navigation
(:class:`~gidabot_navigation.guiding.messages.Trip`, ``NavEventData``, ``CancelData``, ``StaffCommandData``;
:class:`~gidabot_navigation.tours.tour_store.TourMessage`; :mod:`gidabot_navigation.relay.links`)."""

from __future__ import annotations

from dataclasses import dataclass

from gidabot_navigation.guiding.messages import Trip


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
    state: str                     # a RobotStatus state (as received: untrusted)
    pending: int
    current_goal_uid: str = ""
    busy_for: float = 0.0          # s until the queue is empty
    stamp: float = 0.0


@dataclass(frozen=True)
class PoseData:
    """A gidabot_msgs/NavPose: one robot's pose in its floor's map frame."""

    robot: str
    floor: float
    x: float
    y: float
    yaw: float
    stamp: float = 0.0


@dataclass(frozen=True)
class PendingData:
    """A gidabot_msgs/PendingRequests: one robot's queue, head first, with the eta (s) of each goal."""

    robot: str
    floor: float
    num: int
    wait_new: float
    goals: tuple[Trip, ...] = ()
    eta: tuple[float, ...] = ()
    stamp: float = 0.0


@dataclass(frozen=True)
class EditResultData:
    """A gidabot_msgs/TourEditResult: the tour store's answer to one edit."""

    uid: str
    file_name: str
    deleted: bool
    ok: bool
    version: int = 0
    reason: str = ""
    error: str = ""
    stamp: float = 0.0
