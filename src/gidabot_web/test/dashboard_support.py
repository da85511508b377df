"""Helpers of gidabot_web's tests: messages of the faculty (Tartalo 0, Kbot 1, Galtxagorri 2, MariSorgin 3) as
the dashboard's core receives them, and the core on a history in a temporary directory."""

from __future__ import annotations

from pathlib import Path

from gidabot_navigation.building.model import Building
from gidabot_navigation.guiding.messages import (
    CancelData,
    NavEventData,
    PendingData,
    RobotStatusData,
    StaffCommandData,
    Trip,
)
from gidabot_navigation.interface import LEG_COMMITTED, LEG_NONE, WAY_STAIRS, Phase, RobotState, StaffCmd
from gidabot_navigation.relay.links import DiagnosticData
from gidabot_web.dashboard.dashboard import DashboardConfig, DashboardCore
from gidabot_web.dashboard.history import History

WALL0 = 1_800_000_000.0        # the wall clock when a test's core starts (2027-01-15)


def make_core(building: Building, tmp: Path, me: str = "Kbot", now: float = 0.0, **cfg: object) -> DashboardCore:
    return DashboardCore(building, DashboardConfig(me, **cfg), History(tmp / "history.sqlite"), now, WALL0 + now)


def status(building: Building, robot: str, battery: float = 0.9, state: str = RobotState.IDLE,
           x: float | None = None, y: float | None = None, current: str = "") -> RobotStatusData:
    r = building.robot(robot)
    return RobotStatusData(robot, r.floor, r.home.x if x is None else x, r.home.y if y is None else y, r.home.yaw,
                           0.0, 0.0, battery, state, 0, current, 0.0)


def cross_trip(uid: str = "Tartalo/v1/gm.a.1", attempt: int = 2, stamp: float = 100.0) -> Trip:
    """Tartalo (floor 0) to room 305 (floor 3) by the west stairs: Tartalo the start leg, MariSorgin the goal leg."""
    return Trip(uid=uid, origin_robot="Tartalo", visitor_id="v1", initial_floor=0.0, initial_x=30.0, initial_y=12.0,
                goal_floor=3.0, goal_x=27.0, goal_y=11.4, goal_yaw=-1.5708, way=WAY_STAIRS, connector="stairs_west",
                start_id="robot", goal_id="305", language="en", stamp=stamp, start_robot="Tartalo",
                start_state=LEG_COMMITTED, goal_robot="MariSorgin", goal_state=LEG_COMMITTED, attempt=attempt)


def local_trip(uid: str = "Kbot/v2/gm.b.1", goal: str = "113", stamp: float = 50.0) -> Trip:
    return Trip(uid=uid, origin_robot="Kbot", visitor_id="v2", initial_floor=1.0, initial_x=30.0, initial_y=12.0,
                goal_floor=1.0, goal_x=27.75, goal_y=12.6, goal_yaw=1.5708, way=WAY_STAIRS, connector="",
                start_id="robot", goal_id=goal, language="en", stamp=stamp, start_robot="Kbot",
                start_state=LEG_COMMITTED, goal_robot="", goal_state=LEG_NONE, attempt=1)


_N = [0]


def event(robot: str, phase: Phase, goal_uid: str, leg: str = "start", stamp: float = 0.0, uid: str = "",
          **fields: object) -> NavEventData:
    _N[0] += 1
    return NavEventData(uid=uid or f"{robot}/event/nav.t.{_N[0]}", robot=robot, floor=0.0, goal_uid=goal_uid,
                        phase=int(phase), leg=leg, stamp=stamp, **fields)


def cancel(origin: str, goal_uid: str, reason: str = "visitor", uid: str = "") -> CancelData:
    _N[0] += 1
    return CancelData(uid=uid or f"{origin}/cancel/gm.t.{_N[0]}", goal_uid=goal_uid, origin_robot=origin, reason=reason)


def pending(robot: str, floor: float, *trips: Trip) -> PendingData:
    """A pending list, 30 s per goal."""
    return PendingData(robot, floor, len(trips), 0.0, tuple(trips), tuple(30.0 * (i + 1) for i in range(len(trips))))


def staff(robot: str, target: str, out: bool, version: int, uid: str = "") -> StaffCommandData:
    _N[0] += 1
    return StaffCommandData(uid=uid or f"{robot}/staff/dash.t.{_N[0]}", robot=robot, user="ana",
                            command=int(StaffCmd.OUT_OF_SERVICE if out else StaffCmd.BACK_IN_SERVICE),
                            target_robot=target, version=version)


def relay_diag(a: str, b: str, me: str, connected: bool = True, peer_master_up: bool = True, **values: str
               ) -> DiagnosticData:
    v = {"connected": str(connected), "peer_master_up": str(peer_master_up), "rtt_ms": "1.5", "queue_depth": "0",
         "link_down_s": "" if connected else "3.0", **values}
    return DiagnosticData(f"relay {a}-{b}: {me}", 0 if connected else 2, "", f"/gidabot_relay_{a}_{b}", v)
