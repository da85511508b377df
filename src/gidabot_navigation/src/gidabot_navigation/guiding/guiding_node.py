"""Conversions between gidabot_msgs messages and the guiding cores' dataclasses, and shared
adapter helpers (diagnostics, master watch) of the goal_manager and multirobot_navigation nodes."""

from __future__ import annotations

import math

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, Pose, Quaternion

from gidabot_msgs.msg import Cancel, Goal, NavEvent, TourCatalog, VisitorCommand
from gidabot_navigation.building.geometry import quaternion_to_yaw, yaw_to_quaternion
from gidabot_navigation.guiding.messages import CancelData, CommandData, NavEventData, Trip
from gidabot_navigation.guiding.tour_mode import CatalogEntry
from gidabot_navigation.interface import is_relay_end


def sender(msg: object) -> str:
    """The node that published ``msg`` (its callerid), "" if unknown."""
    header = getattr(msg, "_connection_header", None) or {}
    return str(header.get("callerid", ""))


def from_relay(msg: object) -> bool:
    """True when ``msg`` was published by a relay, i.e. it came from another robot."""
    return is_relay_end(sender(msg))


def stamp_of(msg: object) -> float:
    try:
        return float(msg.header.stamp.to_sec())  # type: ignore[attr-defined]
    except (AttributeError, TypeError, ValueError):
        return 0.0


def yaw_of(q: Quaternion) -> float:
    values = (q.x, q.y, q.z, q.w)
    if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
        return math.nan
    return quaternion_to_yaw(*values)


def quaternion(yaw: float) -> Quaternion:
    x, y, z, w = yaw_to_quaternion(yaw)
    return Quaternion(x, y, z, w)


def trip_from_msg(m: Goal) -> Trip:
    return Trip(uid=m.uid, origin_robot=m.origin_robot, visitor_id=m.visitor_id, initial_floor=m.initial_floor,
                initial_x=m.initial_pose.x, initial_y=m.initial_pose.y, goal_floor=m.goal_floor,
                goal_x=m.goal_pose.position.x, goal_y=m.goal_pose.position.y,
                goal_yaw=yaw_of(m.goal_pose.orientation), way=m.way, connector=m.connector, start_id=m.start_id,
                goal_id=m.goal_id, language=m.language, tour_file=m.tour_file, tour_step=m.tour_step,
                stamp=stamp_of(m), start_robot=m.start_robot, start_state=m.start_state, goal_robot=m.goal_robot,
                goal_state=m.goal_state, attempt=m.attempt)


def trip_to_msg(t: Trip) -> Goal:
    m = Goal()
    m.header.stamp = rospy.Time.from_sec(max(0.0, t.stamp))
    m.uid, m.origin_robot, m.visitor_id = t.uid, t.origin_robot, t.visitor_id
    m.initial_floor = t.initial_floor
    m.initial_pose = Point(t.initial_x, t.initial_y, 0.0)
    m.goal_floor = t.goal_floor
    m.goal_pose = Pose(Point(t.goal_x, t.goal_y, 0.0), quaternion(t.goal_yaw))
    m.way, m.connector, m.start_id, m.goal_id, m.language = t.way, t.connector, t.start_id, t.goal_id, t.language
    m.tour_file, m.tour_step = t.tour_file, t.tour_step
    m.start_robot, m.start_state, m.goal_robot, m.goal_state = t.start_robot, t.start_state, t.goal_robot, t.goal_state
    m.attempt = t.attempt
    return m


def event_from_msg(m: NavEvent) -> NavEventData:
    return NavEventData(uid=m.uid, robot=m.robot, floor=m.floor, goal_uid=m.goal_uid, phase=m.phase,
                        language=m.language, way=m.way, connector=m.connector, target_floor=m.target_floor,
                        location_id=m.location_id, tour_file=m.tour_file, tour_step=m.tour_step, detail=m.detail,
                        stamp=stamp_of(m), leg=m.leg, attempt=m.attempt, assignee=m.assignee, eta=m.eta)


def event_to_msg(e: NavEventData) -> NavEvent:
    m = NavEvent()
    m.header.stamp = rospy.Time.from_sec(max(0.0, e.stamp))
    m.uid, m.robot, m.floor, m.goal_uid, m.phase = e.uid, e.robot, e.floor, e.goal_uid, e.phase
    m.language, m.way, m.connector, m.target_floor = e.language, e.way, e.connector, e.target_floor
    m.location_id, m.tour_file, m.tour_step, m.detail = e.location_id, e.tour_file, e.tour_step, e.detail[:400]
    m.leg, m.attempt, m.assignee, m.eta = e.leg, e.attempt, e.assignee, e.eta
    return m


def cancel_from_msg(m: Cancel) -> CancelData:
    return CancelData(uid=m.uid, goal_uid=m.goal_uid, origin_robot=m.origin_robot, reason=m.reason,
                      detail=m.detail, stamp=stamp_of(m))


def cancel_to_msg(c: CancelData) -> Cancel:
    m = Cancel()
    m.header.stamp = rospy.Time.from_sec(max(0.0, c.stamp))
    m.uid, m.goal_uid, m.origin_robot, m.reason, m.detail = c.uid, c.goal_uid, c.origin_robot, c.reason, c.detail[:400]
    return m


def command_from_msg(m: VisitorCommand) -> CommandData:
    return CommandData(command=m.command, uid=m.uid, visitor_id=m.visitor_id, goal_id=m.goal_id, way=m.way,
                       language=m.language, goal_uid=m.goal_uid, tour_file=m.tour_file, tour_step=m.tour_step,
                       stamp=stamp_of(m))


def catalog_entries(m: TourCatalog) -> list[CatalogEntry]:
    return [CatalogEntry(t.file_name, t.tour_name, tuple(t.tour_goals_info)) for t in m.tours]


def diagnostics(name: str, robot: str, stats: dict, level_warn: bool, message: str) -> DiagnosticArray:
    status = DiagnosticStatus()
    status.name = name
    status.hardware_id = robot
    status.level = DiagnosticStatus.WARN if level_warn else DiagnosticStatus.OK
    status.message = message
    status.values = [KeyValue(str(k), str(v)) for k, v in sorted(stats.items())]
    arr = DiagnosticArray()
    arr.header.stamp = rospy.Time.now()
    arr.status = [status]
    return arr

