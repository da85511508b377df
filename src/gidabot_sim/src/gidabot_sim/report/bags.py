"""A run folder's recordings, read (ROS-free): ``run.json`` and every robot's rosbag parts.

:func:`load_run` reads the run folder ``gidabot demo`` / ``gidabot chaos`` wrote: ``run.json`` and one rosbag
per robot (``<robot>.bag``, recorded on that robot's master; after a restart of its master the recording goes
on in further parts, ``run.json`` lists them as ``bags``, and every part is read: a message in two parts
counts once). Bags are read with the ``rosbags`` library, which takes the message definitions from the bags
themselves. Each robot's bag becomes a :class:`RobotRecord`: the goals it validated and kept (hostile input
counted apart), the events its own guiding nodes published, its poses, when its move_base took each goal and
its floor's timing statuses.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gidabot_navigation.building.geometry import quaternion_to_yaw
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.guiding.messages import Trip, validate_trip
from gidabot_navigation.interface import (
    GUIDING_CALLERIDS,
    LEG_GOAL,
    LEG_START,
    Phase,
    Topic,
    global_name,
    relay_end_name,
)
from gidabot_sim.errors import ReportError

SIM_STATUS = "sim: floor "                         # a floor simulator's /diagnostics status (its name's start)
TIMING_STATUSES = (SIM_STATUS, "guiding: ")          # the /diagnostics statuses the timing report reads


@dataclass(frozen=True)
class EventSample:
    t: float            # s, header stamp (sim time)
    robot: str
    goal_uid: str
    phase: int
    tour_step: int = -1
    leg: str = ""          # the leg of the trip the robot acted on (docs/guiding.md, who serves a leg)
    assignee: str = ""     # ASSIGNED: the robot that serves ``leg``


@dataclass(frozen=True)
class PoseSample:
    t: float
    x: float
    y: float


@dataclass(frozen=True)
class GoalInfo:
    """Where a goal ends (for the plots)."""

    goal_id: str
    floor: float
    x: float
    y: float
    tour_step: int
    yaw: float = 0.0    # rad: the robot stops facing the door, so the room is that way


@dataclass(frozen=True)
class DiagSample:
    """One status of the floor's ``/diagnostics`` (the simulator's, a guiding node's)."""

    t: float                 # s, header stamp (the floor's sim time)
    name: str
    values: tuple[tuple[str, str], ...]

    def get(self, key: str, default: str = "") -> str:
        return dict(self.values).get(key, default)

    def number(self, key: str) -> float:
        """The value of ``key`` as a number (NaN: absent, or not a number)."""
        try:
            value = float(self.get(key, "nan"))
        except ValueError:
            return math.nan
        return value


@dataclass
class RobotRecord:
    """What one robot's bag says."""

    name: str
    floor: float
    goal_uids: set[str] = field(default_factory=set)      # goals it validated and kept (received)
    events: list[EventSample] = field(default_factory=list)      # events emitted by this robot's guiding nodes
    accepted: set[str] = field(default_factory=set)        # goals its goal manager accepted
    navigated: set[str] = field(default_factory=set)       # goals its navigation worked on
    poses: list[PoseSample] = field(default_factory=list)  # this robot's /gidabot/poses, time-ordered
    local_poses: list[PoseSample] = field(default_factory=list)  # its /amcl_pose (local), time-ordered
    goals: dict[str, GoalInfo] = field(default_factory=dict)     # goal uid -> where it ends
    bad: dict[str, int] = field(default_factory=dict)            # topic -> messages that cannot be read
    rejected_goals: int = 0                                      # messages on /gidabot/goals that are no goal
    diagnostics: list[DiagSample] = field(default_factory=list)  # its floor's timing statuses, time-ordered
    assignments: set[tuple[str, str, str, int]] = field(default_factory=set)  # (goal uid, leg, robot, state)
    goal_starts: list[float] = field(default_factory=list)  # when its move_base took each goal (current_goal)

    @property
    def track(self) -> list[PoseSample]:
        """The robot's path: its own localisation if recorded, else its shared poses."""
        return self.local_poses or self.poses


def _stamp(msg: object, fallback_ns: int) -> float:
    header = getattr(msg, "header", None)
    if header is not None:
        t = header.stamp.sec + header.stamp.nanosec * 1e-9
        if t > 0:
            return t
    return fallback_ns * 1e-9


_UID = re.compile(r"^[A-Za-z0-9_.:/@+-]{1,160}\Z")
GOAL_MANAGER, NAVIGATION = GUIDING_CALLERIDS


def plausible_goal(msg: Any, building: Any | None) -> bool:
    """A goal message as a robot could have sent it. With the building: exactly the goal manager's check
    (``validate_trip``); without: a valid uid, finite numbers, short printable text."""
    if building is not None:
        try:
            validate_trip(building, _trip(msg))
        except (GidaBotError, AttributeError, TypeError, ValueError):
            return False
        return True
    try:
        texts = (msg.origin_robot, msg.visitor_id, msg.way, msg.connector, msg.start_id, msg.goal_id,
                 msg.language, msg.tour_file)
        numbers = (msg.initial_floor, msg.goal_floor, msg.initial_pose.x, msg.initial_pose.y,
                   msg.goal_pose.position.x, msg.goal_pose.position.y, msg.goal_pose.orientation.z,
                   msg.goal_pose.orientation.w)
        if not _UID.match(msg.uid):
            return False
    except (AttributeError, TypeError):
        return False
    if not all(isinstance(t, str) and len(t) <= 64 and t.isprintable() for t in texts):
        return False
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in numbers)


def _trip(msg: Any) -> Trip:
    """A Goal read from a bag (rosbags) as the goal manager sees it."""
    q = msg.goal_pose.orientation
    return Trip(uid=msg.uid, origin_robot=msg.origin_robot, visitor_id=msg.visitor_id,
                initial_floor=msg.initial_floor, initial_x=msg.initial_pose.x, initial_y=msg.initial_pose.y,
                goal_floor=msg.goal_floor, goal_x=msg.goal_pose.position.x, goal_y=msg.goal_pose.position.y,
                goal_yaw=quaternion_to_yaw(q.x, q.y, q.z, q.w), way=msg.way, connector=msg.connector,
                start_id=msg.start_id, goal_id=msg.goal_id, language=msg.language, tour_file=msg.tour_file,
                tour_step=msg.tour_step, start_robot=msg.start_robot, start_state=msg.start_state,
                goal_robot=msg.goal_robot, goal_state=msg.goal_state, attempt=msg.attempt)


def _callerid(conn: Any) -> str | None:
    """The node that published a bag connection's messages (None: the bag does not say)."""
    return getattr(getattr(conn, "ext", None), "callerid", None) or None


def _from_robot(callerid: str | None, robot: str, recorder: str, building: Any | None) -> bool:
    """Whether a message published on ``recorder``'s master by ``callerid`` can come from ``robot``'s guiding
    nodes: their own node names on its own master, the relay end of the pair on another."""
    if callerid is None:
        return True
    if robot == recorder:
        return callerid in GUIDING_CALLERIDS
    if building is None or building.find_robot(robot) is None or building.find_robot(recorder) is None:
        return False
    names = [r.name for r in building.robots]
    return callerid == relay_end_name(*sorted((robot, recorder), key=names.index))


def read_robot_bag(path: Path, name: str, floor: float, rec: RobotRecord | None = None,
                   building: Any | None = None) -> RobotRecord:
    """Extract goals, this robot's events and poses from one robot's bag (added to ``rec``: bag parts)."""
    from rosbags.highlevel import AnyReader

    rec = rec or RobotRecord(name, floor)
    try:
        with AnyReader([path]) as reader:
            wanted = [c for c in reader.connections
                      if c.topic in (Topic.GOALS, Topic.NAV_EVENTS, Topic.POSES, global_name(Topic.AMCL_POSE),
                                     Topic.DIAGNOSTICS, global_name(Topic.MOVE_BASE_CURRENT_GOAL))]
            for conn, t_ns, raw in reader.messages(connections=wanted):
                try:
                    msg = reader.deserialize(raw, conn.msgtype)
                except Exception:  # noqa: BLE001 - rosbags raises several types; one bad message is skipped
                    rec.bad[conn.topic] = rec.bad.get(conn.topic, 0) + 1
                    continue
                caller = _callerid(conn)
                if conn.topic == Topic.GOALS:
                    if not (plausible_goal(msg, building) and _from_robot(caller, msg.origin_robot, name, building)):
                        rec.rejected_goals += 1
                        continue
                    rec.goal_uids.add(msg.uid)
                    rec.assignments.update({(msg.uid, LEG_START, msg.start_robot, int(msg.start_state)),
                                            (msg.uid, LEG_GOAL, msg.goal_robot, int(msg.goal_state))})
                    gp, q = msg.goal_pose.position, msg.goal_pose.orientation
                    rec.goals[msg.uid] = GoalInfo(msg.goal_id, float(msg.goal_floor), gp.x, gp.y,
                                                  int(msg.tour_step), 2.0 * math.atan2(q.z, q.w))
                elif conn.topic == Topic.DIAGNOSTICS:
                    t = _stamp(msg, t_ns)
                    rec.diagnostics.extend(DiagSample(t, st.name, tuple((kv.key, kv.value) for kv in st.values))
                                           for st in msg.status if st.name.startswith(TIMING_STATUSES))
                elif conn.topic == global_name(Topic.MOVE_BASE_CURRENT_GOAL):
                    rec.goal_starts.append(_stamp(msg, t_ns))
                elif conn.topic == global_name(Topic.AMCL_POSE):
                    p = msg.pose.pose.position
                    rec.local_poses.append(PoseSample(_stamp(msg, t_ns), p.x, p.y))
                elif conn.topic == Topic.NAV_EVENTS:
                    if msg.robot == name and _from_robot(caller, name, name, building):
                        rec.events.append(EventSample(_stamp(msg, t_ns), msg.robot, msg.goal_uid, int(msg.phase),
                                                      int(msg.tour_step), msg.leg, msg.assignee))
                        if msg.phase == Phase.ACCEPTED and caller in (None, GOAL_MANAGER):
                            rec.accepted.add(msg.goal_uid)
                        elif caller in (None, NAVIGATION) and msg.goal_uid:
                            rec.navigated.add(msg.goal_uid)
                elif msg.robot == name:
                    p = msg.nav_pose.position
                    rec.poses.append(PoseSample(_stamp(msg, t_ns), p.x, p.y))
    except Exception as err:  # rosbags raises several unrelated types for damaged bags
        raise ReportError(f"{path}: cannot read bag: {err}") from err
    # parts overlap (two recorders ran for a while): keep each event and sample once
    rec.events = sorted(dict.fromkeys(rec.events), key=lambda e: e.t)
    rec.poses = sorted(set(rec.poses), key=lambda p: p.t)
    rec.local_poses = sorted(set(rec.local_poses), key=lambda p: p.t)
    rec.diagnostics = sorted(set(rec.diagnostics), key=lambda d: d.t)
    rec.goal_starts = sorted(set(rec.goal_starts))
    return rec


def load_run(folder: Path) -> tuple[dict, list[RobotRecord]]:
    run_file = folder / "run.json"
    try:
        run = json.loads(run_file.read_text(encoding="utf-8"))
    except OSError as err:
        raise ReportError(f"{run_file}: cannot read ({err.strerror}); is {folder} a run folder?") from err
    except json.JSONDecodeError as err:
        raise ReportError(f"{run_file}: not valid JSON: {err}") from err
    building = run_building(folder, run)
    records = []
    for robot in run.get("robots", []):
        parts = robot.get("bags") or [robot.get("bag", f"{robot['name']}.bag")]
        rec = RobotRecord(robot["name"], float(robot.get("floor", 0)))
        for part in parts:
            bag = folder / part
            if not bag.exists():
                raise ReportError(f"{bag}: missing bag of robot {robot['name']}")
            read_robot_bag(bag, rec.name, rec.floor, rec, building)
        records.append(rec)
    return run, records


def run_building(folder: Path, run: dict) -> Any | None:
    """The run's building, to tell goals from hostile messages (None when it cannot be loaded)."""
    from gidabot_navigation.building.model import load_building

    path = Path(run.get("building", "building/building.yaml"))
    path = path if path.is_absolute() else folder / path
    try:
        return load_building(path)
    except (GidaBotError, OSError):
        return None

