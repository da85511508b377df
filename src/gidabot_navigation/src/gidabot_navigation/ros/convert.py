"""The conversions between gidabot_msgs messages and their ROS-free forms: every message of gidabot_navigation,
each field carried both ways, in this one module.

Only message classes are imported here (no rospy): the conversions need no master and are tested one by one
(``test/ros/test_convert.py``, which also fails on a message field no conversion carries). Stamps are ROS
seconds (``header.stamp``); a stamp that is negative or not finite is sent as 0. Headers' ``frame_id`` is carried
where a form has one (RobotStatus, NavPose: the floor's map frame). Text is carried as received: the cores
validate what they act on (``guiding.messages.validate_*``, the tour store).

==================  ============================================================
gidabot_msgs        form
==================  ============================================================
Goal                :class:`~gidabot_navigation.guiding.messages.Trip`
Cancel              :class:`~gidabot_navigation.guiding.messages.CancelData`
NavEvent            :class:`~gidabot_navigation.guiding.messages.NavEventData`
VisitorCommand      :class:`~gidabot_navigation.guiding.messages.CommandData`
PendingRequests     :class:`~gidabot_navigation.guiding.messages.PendingData`
RobotStatus         :class:`~gidabot_navigation.guiding.messages.RobotStatusData`
NavPose             :class:`~gidabot_navigation.guiding.messages.PoseData`
MakeWay             :class:`~gidabot_navigation.guiding.messages.WayAsk`
Tour                :class:`~gidabot_navigation.tours.tour_store.TourMessage`
TourIndex           :class:`~gidabot_navigation.tours.tour_store.TourIndexData`
TourCatalog         :class:`~gidabot_navigation.tours.tour_store.CatalogData`
TourEditResult      :class:`~gidabot_navigation.tours.tour_store.EditResultData`
StaffCommand        :class:`~gidabot_navigation.guiding.messages.StaffCommandData`
LinkSummary         :class:`~gidabot_navigation.relay.links.LinkSummaryData` (its LinkState: ``LinkData``)
PersonArray         :class:`~gidabot_navigation.perception.people.PeopleData`
Person              :class:`~gidabot_navigation.perception.people.Track` (inside a PersonArray)
VisitorTrack        :class:`~gidabot_navigation.perception.people.VisitorTrackData`
==================  ============================================================

``diagnostic_msgs/DiagnosticStatus`` is read as :class:`~gidabot_navigation.relay.links.DiagnosticData` here too
(:func:`diagnostic_from_msg`).

The simulator's messages (Obstacle, ObstacleArray, StepDone) are converted in ``gidabot_sim``.
"""

from __future__ import annotations

import math

import genpy
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Point, Pose, Quaternion, Vector3

from gidabot_msgs.msg import (
    Cancel,
    Goal,
    LinkState,
    LinkSummary,
    MakeWay,
    NavEvent,
    NavPose,
    PendingRequests,
    Person,
    PersonArray,
    RobotStatus,
    StaffCommand,
    Tour,
    TourCatalog,
    TourEditResult,
    TourIndex,
    VisitorCommand,
    VisitorTrack,
)
from gidabot_navigation.building.geometry import Pose2D, quaternion_to_yaw, yaw_to_quaternion
from gidabot_navigation.guiding.messages import (
    MAX_DETAIL,
    MAX_WAY_POINTS,
    CancelData,
    CommandData,
    NavEventData,
    PendingData,
    PoseData,
    RobotStatusData,
    StaffCommandData,
    Trip,
    WayAsk,
)
from gidabot_navigation.interface import Sight
from gidabot_navigation.perception.people import LastSeen, PeopleData, Track, VisitorReport, VisitorTrackData
from gidabot_navigation.relay.links import DiagnosticData, LinkData, LinkSummaryData
from gidabot_navigation.tours.tour_store import (
    CatalogData,
    EditResultData,
    TourIndexData,
    TourMessage,
    index_entries,
)

MAX_LIST = 255          # PendingRequests.num is a uint8: at most this many goals are sent


# ---------------------------------------------------------------------------------- stamps and poses
def stamp_of(msg: object) -> float:
    """``msg.header.stamp`` in s (0.0 when the message has none)."""
    try:
        return float(msg.header.stamp.to_sec())  # type: ignore[attr-defined]
    except (AttributeError, TypeError, ValueError):
        return 0.0


def ros_time(seconds: float) -> genpy.Time:
    """A message stamp from s, to the nearest ns (0 for a negative or non-finite time: ROS time cannot be
    either)."""
    if not (isinstance(seconds, (int, float)) and math.isfinite(seconds) and seconds > 0.0):
        return genpy.Time(0, 0)
    secs = math.floor(seconds)
    nsecs = round((seconds - secs) * 1e9)
    return genpy.Time(secs + 1, 0) if nsecs >= 1_000_000_000 else genpy.Time(secs, nsecs)


def yaw_of(q: Quaternion) -> float:
    """The yaw (rad) of an orientation; NaN when a component is not a finite number."""
    values = (q.x, q.y, q.z, q.w)
    if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
        return math.nan
    return quaternion_to_yaw(*values)


def quaternion(yaw: float) -> Quaternion:
    """The orientation of ``yaw`` (rad) about z; NaN components for a yaw that is not finite (read back as NaN)."""
    if not math.isfinite(yaw):
        return Quaternion(0.0, 0.0, math.nan, math.nan)
    return Quaternion(*yaw_to_quaternion(yaw))


def pose_msg(x: float, y: float, yaw: float) -> Pose:
    """A geometry_msgs/Pose on the floor's plane (z = 0)."""
    return Pose(Point(x, y, 0.0), quaternion(yaw))


# ---------------------------------------------------------------------------------- guiding
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
    m.header.stamp = ros_time(t.stamp)
    m.uid, m.origin_robot, m.visitor_id = t.uid, t.origin_robot, t.visitor_id
    m.initial_floor, m.initial_pose = t.initial_floor, Point(t.initial_x, t.initial_y, 0.0)
    m.goal_floor, m.goal_pose = t.goal_floor, pose_msg(t.goal_x, t.goal_y, t.goal_yaw)
    m.way, m.connector, m.start_id, m.goal_id, m.language = t.way, t.connector, t.start_id, t.goal_id, t.language
    m.tour_file, m.tour_step = t.tour_file, t.tour_step
    m.start_robot, m.start_state, m.goal_robot, m.goal_state = t.start_robot, t.start_state, t.goal_robot, t.goal_state
    m.attempt = t.attempt
    return m


def event_from_msg(m: NavEvent) -> NavEventData:
    return NavEventData(uid=m.uid, robot=m.robot, floor=m.floor, goal_uid=m.goal_uid, phase=m.phase,
                        language=m.language, way=m.way, connector=m.connector, target_floor=m.target_floor,
                        location_id=m.location_id, tour_file=m.tour_file, tour_step=m.tour_step, detail=m.detail,
                        stamp=stamp_of(m), leg=m.leg, attempt=m.attempt, assignee=m.assignee, eta=m.eta,
                        x=m.x, y=m.y)


def event_to_msg(e: NavEventData) -> NavEvent:
    """The event as a message; its ``detail`` (free text for logs) cut to :data:`MAX_DETAIL` characters."""
    m = NavEvent()
    m.header.stamp = ros_time(e.stamp)
    m.uid, m.robot, m.floor, m.goal_uid, m.phase = e.uid, e.robot, e.floor, e.goal_uid, e.phase
    m.language, m.way, m.connector, m.target_floor = e.language, e.way, e.connector, e.target_floor
    m.location_id, m.tour_file, m.tour_step, m.detail = e.location_id, e.tour_file, e.tour_step, e.detail[:MAX_DETAIL]
    m.leg, m.attempt, m.assignee, m.eta = e.leg, e.attempt, e.assignee, e.eta
    m.x, m.y = e.x, e.y
    return m


def cancel_from_msg(m: Cancel) -> CancelData:
    return CancelData(uid=m.uid, goal_uid=m.goal_uid, origin_robot=m.origin_robot, reason=m.reason,
                      detail=m.detail, stamp=stamp_of(m))


def cancel_to_msg(c: CancelData) -> Cancel:
    """The cancel as a message; its ``detail`` cut to :data:`MAX_DETAIL` characters."""
    m = Cancel()
    m.header.stamp = ros_time(c.stamp)
    m.uid, m.goal_uid, m.origin_robot, m.reason = c.uid, c.goal_uid, c.origin_robot, c.reason
    m.detail = c.detail[:MAX_DETAIL]
    return m


def command_from_msg(m: VisitorCommand) -> CommandData:
    return CommandData(command=m.command, uid=m.uid, visitor_id=m.visitor_id, goal_id=m.goal_id, way=m.way,
                       language=m.language, goal_uid=m.goal_uid, tour_file=m.tour_file, tour_step=m.tour_step,
                       stamp=stamp_of(m))


def command_to_msg(c: CommandData) -> VisitorCommand:
    m = VisitorCommand()
    m.header.stamp = ros_time(c.stamp)
    m.uid, m.visitor_id, m.command, m.goal_id, m.way = c.uid, c.visitor_id, c.command, c.goal_id, c.way
    m.language, m.goal_uid, m.tour_file, m.tour_step = c.language, c.goal_uid, c.tour_file, c.tour_step
    return m


def pending_from_msg(m: PendingRequests) -> PendingData:
    return PendingData(robot=m.robot, floor=m.floor, num=m.num, wait_new=m.wait_new,
                       goals=tuple(trip_from_msg(g) for g in m.goals), eta=tuple(m.eta), stamp=stamp_of(m))


def pending_to_msg(p: PendingData) -> PendingRequests:
    """The pending list as a message: its first :data:`MAX_LIST` goals and their etas."""
    m = PendingRequests()
    m.header.stamp = ros_time(p.stamp)
    m.robot, m.floor, m.num, m.wait_new = p.robot, p.floor, min(p.num, MAX_LIST), p.wait_new
    m.goals = [trip_to_msg(t) for t in p.goals[:MAX_LIST]]
    m.eta = list(p.eta[:MAX_LIST])
    return m


def status_from_msg(m: RobotStatus) -> RobotStatusData:
    p = m.nav_pose.position
    return RobotStatusData(robot=m.robot, floor=m.floor, x=p.x, y=p.y, yaw=yaw_of(m.nav_pose.orientation),
                           linear=m.linear_velocity, angular=m.angular_velocity, battery=m.battery, state=m.state,
                           pending=m.pending, current_goal_uid=m.current_goal_uid, busy_for=m.busy_for,
                           stamp=stamp_of(m), frame_id=m.header.frame_id)


def status_to_msg(s: RobotStatusData) -> RobotStatus:
    m = RobotStatus()
    m.header.stamp, m.header.frame_id = ros_time(s.stamp), s.frame_id
    m.robot, m.floor, m.nav_pose = s.robot, s.floor, pose_msg(s.x, s.y, s.yaw)
    m.linear_velocity, m.angular_velocity, m.battery = s.linear, s.angular, s.battery
    m.state, m.pending, m.current_goal_uid, m.busy_for = s.state, s.pending, s.current_goal_uid, s.busy_for
    return m


def pose_from_msg(m: NavPose) -> PoseData:
    p = m.nav_pose.position
    return PoseData(robot=m.robot, floor=m.floor, x=p.x, y=p.y, yaw=yaw_of(m.nav_pose.orientation),
                    stamp=stamp_of(m), frame_id=m.header.frame_id)


def pose_to_msg(p: PoseData) -> NavPose:
    m = NavPose()
    m.header.stamp, m.header.frame_id = ros_time(p.stamp), p.frame_id
    m.robot, m.floor, m.nav_pose = p.robot, p.floor, pose_msg(p.x, p.y, p.yaw)
    return m


def make_way_from_msg(m: MakeWay) -> WayAsk:
    """At most :data:`MAX_WAY_POINTS` + 1 points are read (validation refuses more)."""
    return WayAsk(robot=m.robot, floor=m.floor, robots=tuple(m.robots),
                  way=tuple((p.x, p.y) for p in m.way[:MAX_WAY_POINTS + 1]), stamp=stamp_of(m),
                  frame_id=m.header.frame_id)


def make_way_to_msg(a: WayAsk) -> MakeWay:
    m = MakeWay()
    m.header.stamp, m.header.frame_id = ros_time(a.stamp), a.frame_id
    m.robot, m.floor, m.robots = a.robot, a.floor, list(a.robots)
    m.way = [Point(x, y, 0.0) for x, y in a.way]
    return m


# ---------------------------------------------------------------------------------- tours
def tour_from_msg(m: Tour) -> TourMessage:
    return TourMessage(uid=m.uid, origin_robot=m.origin_robot, editor_robot=m.editor_robot, version=m.version,
                       deleted=m.deleted, language=m.language, floor=m.floor, tour_name=m.tour_name,
                       file_name=m.file_name, tour_goals_info=tuple(m.tour_goals_info), stamp=stamp_of(m))


def tour_to_msg(t: TourMessage) -> Tour:
    m = Tour()
    m.header.stamp = ros_time(t.stamp)
    m.uid, m.origin_robot, m.editor_robot = t.uid, t.origin_robot, t.editor_robot
    m.version, m.deleted, m.language, m.floor = t.version, t.deleted, t.language, t.floor
    m.tour_name, m.file_name, m.tour_goals_info = t.tour_name, t.file_name, list(t.tour_goals_info)
    return m


def index_from_msg(m: TourIndex) -> TourIndexData:
    """The index as entries (:func:`~gidabot_navigation.tours.tour_store.index_entries`: ValueError when its
    arrays' lengths differ)."""
    return TourIndexData(robot=m.robot, entries=tuple(index_entries(m.file_names, m.versions, m.editor_robots,
                                                                    m.deleted)), stamp=stamp_of(m))


def index_to_msg(i: TourIndexData) -> TourIndex:
    m = TourIndex()
    m.header.stamp, m.robot = ros_time(i.stamp), i.robot
    m.file_names = [e.file_name for e in i.entries]
    m.versions = [e.version for e in i.entries]
    m.editor_robots = [e.editor_robot for e in i.entries]
    m.deleted = [e.deleted for e in i.entries]
    return m


def catalog_from_msg(m: TourCatalog) -> CatalogData:
    return CatalogData(robot=m.robot, tours=tuple(tour_from_msg(t) for t in m.tours), stamp=stamp_of(m))


def catalog_to_msg(c: CatalogData) -> TourCatalog:
    m = TourCatalog()
    m.header.stamp, m.robot = ros_time(c.stamp), c.robot
    m.tours = [tour_to_msg(t) for t in c.tours]
    return m


def edit_result_from_msg(m: TourEditResult) -> EditResultData:
    return EditResultData(uid=m.uid, file_name=m.file_name, deleted=m.deleted, ok=m.ok, version=m.version,
                          reason=m.reason, error=m.error, stamp=stamp_of(m))


def edit_result_to_msg(r: EditResultData) -> TourEditResult:
    m = TourEditResult()
    m.header.stamp = ros_time(r.stamp)
    m.uid, m.file_name, m.deleted, m.ok, m.version = r.uid, r.file_name, r.deleted, r.ok, r.version
    m.reason, m.error = r.reason, r.error
    return m


# ---------------------------------------------------------------------------------- the staff dashboard's
def staff_from_msg(m: StaffCommand) -> StaffCommandData:
    return StaffCommandData(uid=m.uid, robot=m.robot, user=m.user, command=m.command, target_robot=m.target_robot,
                            version=m.version, detail=m.detail, stamp=stamp_of(m))


def staff_to_msg(c: StaffCommandData) -> StaffCommand:
    m = StaffCommand()
    m.header.stamp = ros_time(c.stamp)
    m.uid, m.robot, m.user, m.command, m.target_robot = c.uid, c.robot, c.user, c.command, c.target_robot
    m.version, m.detail = c.version, c.detail
    return m


def link_from_msg(m: LinkState) -> LinkData:
    return LinkData(peer=m.peer, known=m.known, connected=m.connected, down_s=m.down_s, heard_s=m.heard_s,
                    rtt_ms=m.rtt_ms, queued=m.queued, resent=m.resent, dropped=m.dropped,
                    duplicates_suppressed=m.duplicates_suppressed, link_losses=m.link_losses,
                    peer_master_up=m.peer_master_up)


def link_to_msg(k: LinkData) -> LinkState:
    return LinkState(peer=k.peer, known=k.known, connected=k.connected, down_s=k.down_s, heard_s=k.heard_s,
                     rtt_ms=k.rtt_ms, queued=k.queued, resent=k.resent, dropped=k.dropped,
                     duplicates_suppressed=k.duplicates_suppressed, link_losses=k.link_losses,
                     peer_master_up=k.peer_master_up)


def links_from_msg(m: LinkSummary) -> LinkSummaryData:
    return LinkSummaryData(robot=m.robot, links=tuple(link_from_msg(k) for k in m.links), stamp=stamp_of(m))


def links_to_msg(s: LinkSummaryData) -> LinkSummary:
    m = LinkSummary()
    m.header.stamp = ros_time(s.stamp)
    m.robot, m.links = s.robot, [link_to_msg(k) for k in s.links]
    return m


def diagnostic_from_msg(s: DiagnosticStatus) -> DiagnosticData:
    """One status of a ``diagnostic_msgs/DiagnosticArray`` (its values as a mapping: the last of a key given twice)."""
    return DiagnosticData(name=s.name, level=int(s.level), message=s.message, hardware_id=s.hardware_id,
                          values={kv.key: kv.value for kv in s.values})


# ---------------------------------------------------------------------------------- the people the laser sees
def person_from_msg(m: Person) -> Track:
    """A published person: a confirmed track."""
    return Track(id=m.id, x=m.position.x, y=m.position.y, vx=m.velocity.x, vy=m.velocity.y,
                 confidence=m.confidence, unseen=m.unseen, confirmed=True, visitor=m.visitor)


def person_to_msg(t: Track) -> Person:
    m = Person()
    m.id, m.visitor, m.confidence, m.unseen = t.id, t.visitor, t.confidence, t.unseen
    m.position, m.velocity = Point(t.x, t.y, 0.0), Vector3(t.vx, t.vy, 0.0)
    return m


def people_from_msg(m: PersonArray) -> PeopleData:
    return PeopleData(tracks=tuple(person_from_msg(p) for p in m.people), stamp=stamp_of(m))


def people_to_msg(p: PeopleData) -> PersonArray:
    m = PersonArray()
    m.header.stamp, m.header.frame_id = ros_time(p.stamp), "map"
    m.people = [person_to_msg(t) for t in p.tracks]
    return m


def _value(x: float) -> float | None:
    return None if math.isnan(x) else x


def _number(x: float | None) -> float:
    return math.nan if x is None else x


def visitor_track_from_msg(m: VisitorTrack) -> VisitorTrackData:
    """The visitor report of a message; NaN is "no value" (None). An unknown ``sight`` raises ValueError."""
    try:
        sight = Sight(m.sight)
    except ValueError:
        raise ValueError(f"VisitorTrack sight {m.sight!r} is not one of {[int(s) for s in Sight]}") from None
    seen_t = m.last_seen_stamp.to_sec()
    last_seen = None
    if seen_t > 0:
        q = m.last_seen.orientation
        last_seen = LastSeen(Pose2D(m.last_seen.position.x, m.last_seen.position.y,
                                    quaternion_to_yaw(q.x, q.y, q.z, q.w)), seen_t)
    report = VisitorReport(sight=sight, track_id=m.id or None, x=_value(m.position.x), y=_value(m.position.y),
                           vx=_value(m.velocity.x), vy=_value(m.velocity.y), distance=_value(m.distance),
                           behind=_value(m.behind), bearing=_value(m.bearing), unseen=_value(m.unseen),
                           last_seen=last_seen, confidence=m.confidence)
    return VisitorTrackData(report=report, stamp=stamp_of(m))


def visitor_track_to_msg(d: VisitorTrackData) -> VisitorTrack:
    """The report as a message: NaN where the report has no value, a zero ``last_seen_stamp`` when never seen."""
    v, m = d.report, VisitorTrack()
    m.header.stamp, m.header.frame_id = ros_time(d.stamp), "map"
    m.sight, m.id, m.confidence = int(v.sight), v.track_id or 0, v.confidence
    m.position = Point(_number(v.x), _number(v.y), 0.0)
    m.velocity = Vector3(_number(v.vx), _number(v.vy), 0.0)
    m.distance, m.behind, m.bearing, m.unseen = _number(v.distance), _number(v.behind), _number(v.bearing), \
        _number(v.unseen)
    if v.last_seen is not None:
        seen = v.last_seen.pose
        m.last_seen = Pose(Point(seen.x, seen.y, 0.0), Quaternion(*yaw_to_quaternion(seen.yaw)))
        m.last_seen_stamp = ros_time(max(0.0, v.last_seen.t))
    else:
        m.last_seen = Pose(Point(math.nan, math.nan, 0.0), Quaternion(0.0, 0.0, 0.0, 1.0))
    return m
