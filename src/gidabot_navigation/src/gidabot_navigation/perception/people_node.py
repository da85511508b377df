"""ROS adapter of the people tracker: the ``people`` node (one per robot, on the robot's own master).

The detector and the tracker live in :mod:`gidabot_navigation.perception.detector` and
:mod:`gidabot_navigation.perception.people`, the robot's pose at a scan's time in
:mod:`gidabot_navigation.perception.robot_pose` (all ROS-free). This module reads the parameters once,
converts messages, and runs one loop that owns the tracker: callbacks only enqueue.
"""

from __future__ import annotations

import contextlib
import math
import queue
import time
from dataclasses import dataclass

import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Pose, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import LaserScan
from std_msgs.msg import Bool

from gidabot_msgs.msg import PersonArray, VisitorTrack
from gidabot_navigation.building.geometry import Pose2D, all_finite, quaternion_to_yaw
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import ParamError, ScanError
from gidabot_navigation.interface import SIGHT_NAMES, Node, Topic
from gidabot_navigation.perception.detector import Detector, DetectorParams, Scan, fov_mismatch, occupied_lookup
from gidabot_navigation.perception.people import (
    PeopleData,
    PeopleReport,
    PeopleTracker,
    TrackerParams,
    VisitorTrackData,
)
from gidabot_navigation.perception.robot_pose import RobotPose
from gidabot_navigation.ros import convert
from gidabot_navigation.ros.adapter import refusal_values, sender, simulated
from gidabot_navigation.ros.exit_guard import ExitGuard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.node_main import run_node
from gidabot_navigation.ros.params import param_number, param_text
from gidabot_navigation.senders import Gate, Senders

# messages waiting for the loop (scans, poses, lock wishes); more are dropped. Scans, odometry and amcl come at
# about 25 Hz of sim time: at a 10x simulation 250 a wall second, so this absorbs a 0.8 s stall of the loop
QUEUE_SIZE = 200


@dataclass(frozen=True)
class Params:
    building: str
    robot: str
    use_map: bool
    map_margin: float
    max_range: float
    tracker: TrackerParams
    diagnostics_rate: float

    @staticmethod
    def read() -> Params:
        use_map = rospy.get_param("~use_map", True)
        if not isinstance(use_map, bool):
            raise ParamError(f"{rospy.resolve_name('~use_map')} must be true or false, got {use_map!r}")
        d = TrackerParams()
        tracker = TrackerParams(
            lock_bearing=param_number("~lock_bearing", d.lock_bearing, -2 * math.pi, 2 * math.pi, strict=False),
            lock_half_angle=param_number("~lock_half_angle", d.lock_half_angle, 0.0, math.pi),
            lock_distance=param_number("~lock_distance", d.lock_distance),
            lock_window=param_number("~lock_window", d.lock_window),
            relock_radius=param_number("~relock_radius", d.relock_radius),
            relock_speed=param_number("~relock_speed", d.relock_speed),
            relock_max=param_number("~relock_max", d.relock_max),
            visitor_lost_after=param_number("~visitor_lost_after", d.visitor_lost_after),
            out_of_view_lost_after=param_number("~out_of_view_lost_after", d.out_of_view_lost_after),
            track_rate=param_number("~track_rate", d.track_rate))
        return Params(param_text("~building", required=True), param_text("~robot", required=True), use_map,
                      param_number("~map_margin", 0.1, strict=False), param_number("~max_range", 8.0), tracker,
                      param_number("~diagnostics_rate", 1.0))


def pose_of(pose: Pose) -> Pose2D | None:
    """The planar pose of a geometry_msgs/Pose; None when not finite or the quaternion is not a rotation."""
    p, q = pose.position, pose.orientation
    if not all_finite(p.x, p.y, q.x, q.y, q.z, q.w) or abs(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1.0) > 0.01:
        return None
    return Pose2D(p.x, p.y, quaternion_to_yaw(q.x, q.y, q.z, q.w))


class PeopleNode:
    """Tracks the people this robot's laser sees and the visitor it guides.

    The laser is read only while the guiding core wants people watched or the visitor locked (a trip is on):
    a robot standing idle costs its simulator no scans and this node no tracking.

    Subscribed topics:
      - ``base_scan`` (sensor_msgs/LaserScan: angles rad in the laser's frame, ranges m), only while needed:
        its scans are detected and tracked, at the time of their stamps, at most ``~track_rate`` a second (the
        others are skipped and counted); a malformed one is dropped and counted.
      - ``amcl_pose`` (geometry_msgs/PoseWithCovarianceStamped, map frame: m, unit quaternion): the robot's
        pose; scans before the first one are dropped.
      - ``odom`` (nav_msgs/Odometry): carries the latest ``amcl_pose`` to each scan's time (optional).
      - ``people/visitor_lock`` (std_msgs/Bool; latch it): the guiding core's wish. A change to true locks
        the visitor (the confirmed track in the lock cone, behind the robot by default; the node keeps
        looking for ``~lock_window`` s), false lets it go; the same value again changes nothing (publish
        false, then true, to lock anew).
      - ``people/watch`` (std_msgs/Bool; latch it): the guiding core's wish to have people watched at all
        (during a trip); false, with no visitor wanted, stops reading the laser and drops the tracks.
      The two wishes are heard only from this robot's ``/multirobot_navigation``; from anyone else they are
      refused and counted.

    Published topics (this robot's own: never in the relays' shared list):
      - ``people/tracks`` (gidabot_msgs/PersonArray, map frame: m, m/s) after each scan: the confirmed tracks.
      - ``people/visitor`` (gidabot_msgs/VisitorTrack) after each scan and at each lock or unlock: SEEN,
        HIDDEN, OUT_OF_VIEW (turn to look), LOST...; position (m), velocity (m/s), distance and how far behind
        the robot (m), bearing (rad), time unseen (s), where and when last seen, confidence (0..1).
      - ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): ``people: <robot>`` at ``~diagnostics_rate``:
        scans tracked and dropped (malformed, no pose yet, queue full), the mean and largest time a scan
        took (ms), the largest gap between two tracked scans and how far behind ROS time a scan was tracked,
        both in sim s over the period (``scan_gap_max_s``, ``scan_lag_max_s``: a node short of CPU), people
        tracked, the visitor's sight, whether the laser is read, refused wishes (``refused_<kind>``), and a
        warning when the scans' field of view differs from the building file's ``sensors.laser.fov``.

    Parameters:
      - ``~building`` (str, required): building.yaml or its directory; ``~robot`` (str, required).
      - ``~use_map`` (bool, default true): reject segments lying on occupied cells of the robot's floor map,
        grown by ``~map_margin`` (m, default 0.1).
      - ``~max_range`` (m, default 8): farther returns are ignored.
      - ``~lock_bearing`` (rad, default pi: behind), ``~lock_half_angle`` (rad, default 1.2),
        ``~lock_distance`` (m, default 2.5), ``~lock_window`` (s, default 5): the lock cone and how long a
        lock waits for someone in it; ``~relock_radius`` (m, default 1.5): a lock asked anew (false then true)
        first takes the track nearest where the visitor was last seen, within this, growing by
        ``~relock_speed`` (m/s, default 0.5) for every second since, up to ``~relock_max`` (m, default 3).
      - ``~visitor_lost_after`` (s, default 3): unseen in view this long, the visitor is LOST;
        ``~out_of_view_lost_after`` (s, default 20): unseen this long in all, LOST too.
      - ``~track_rate`` (Hz, default 5): scans tracked at most.
      - ``~diagnostics_rate`` (Hz, default 1).
    """

    def __init__(self, params: Params) -> None:
        self.params = params
        building = load_building(params.building)
        robot = building.robot(params.robot)
        self.robot, self.laser = robot.name, robot.laser
        floor = building.floor(robot.floor)
        occupied = occupied_lookup(floor.map, params.map_margin) if params.use_map else None
        detector = Detector(DetectorParams(max_range=params.max_range), mount=robot.laser.mount, occupied=occupied)
        self.tracker = PeopleTracker(detector, params.tracker)
        self.poses = RobotPose()
        self.inbox: queue.Queue[tuple[str, object]] = queue.Queue(QUEUE_SIZE)
        self.counts = {"scans": 0, "skipped": 0, "malformed": 0, "no_pose": 0, "dropped": 0, "bad_pose": 0}
        self.step_ms: list[float] = []
        self.tracked_t: float | None = None       # sim s of the latest scan tracked (None: the laser not read)
        self.gap_max = self.lag_max = 0.0         # sim s, over the diagnostics period
        self.last_error = ""
        self.fov_problem = ""
        self.last: PeopleReport | None = None
        self.tracks_pub = rospy.Publisher(Topic.PEOPLE_TRACKS, PersonArray, queue_size=5)
        self.visitor_pub = rospy.Publisher(Topic.PEOPLE_VISITOR, VisitorTrack, queue_size=5)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=2)
        self.gate = Gate(Senders.of_building(building, robot.name, simulated()), RosLog())
        self.scan_sub: rospy.Subscriber | None = None       # while the tracker needs scans
        self.subs = [rospy.Subscriber(Topic.AMCL_POSE, PoseWithCovarianceStamped, self._enqueue, "amcl", queue_size=5),
                     rospy.Subscriber(Topic.ODOM, Odometry, self._enqueue, "odom", queue_size=20),
                     rospy.Subscriber(Topic.PEOPLE_VISITOR_LOCK, Bool, self._enqueue, "lock", queue_size=5),
                     rospy.Subscriber(Topic.PEOPLE_WATCH, Bool, self._enqueue, "watch", queue_size=5)]

    # -- callbacks: enqueue, return --------------------------------------------------------------
    def _enqueue(self, msg: object, kind: str) -> None:
        try:
            self.inbox.put_nowait((kind, msg))
        except queue.Full:
            self.counts["dropped"] += 1

    def _wake(self) -> None:
        """End the loop's wait at once (from the exit guard's thread)."""
        with contextlib.suppress(queue.Full):
            self.inbox.put_nowait(("wake", None))

    # -- the loop that owns the tracker ----------------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """Handle what comes in, in order, until shutdown or the guard's signal (which wakes it); diagnostics at
        their rate."""
        guard.set_wake(self._wake)
        period = 1.0 / self.params.diagnostics_rate
        due = time.monotonic() + period
        try:
            while not rospy.is_shutdown() and not guard.requested:
                with contextlib.suppress(queue.Empty):
                    self.handle(*self.inbox.get(timeout=min(0.2, max(0.0, due - time.monotonic()))))
                if time.monotonic() >= due:
                    due = max(due + period, time.monotonic())
                    self._publish_diagnostics()
        finally:
            guard.loop_stopped()

    def handle(self, kind: str, msg: object) -> None:
        if kind == "scan":
            if self.tracker.needs_scans:      # a scan queued before the laser stopped being read is dropped
                self._scan(msg)  # type: ignore[arg-type]
        elif kind in ("amcl", "odom"):
            pose = pose_of(msg.pose.pose)  # type: ignore[attr-defined]
            stamp = msg.header.stamp.to_sec()  # type: ignore[attr-defined]
            if pose is None or not all_finite(stamp):
                self.counts["bad_pose"] += 1
            elif kind == "amcl":
                self.poses.localised(stamp, pose)
            else:
                twist = msg.twist.twist  # type: ignore[attr-defined]
                self.poses.odometry(stamp, pose, moving=bool(twist.linear.x or twist.linear.y or twist.angular.z))
        elif kind == "lock" and self.gate.only(sender(msg), Node.MULTIROBOT_NAVIGATION, "visitor lock"):
            if self.tracker.want_visitor(bool(msg.data)):  # type: ignore[attr-defined]
                rospy.loginfo(f"people: visitor {'lock' if msg.data else 'unlock'}: "  # type: ignore[attr-defined]
                              f"{SIGHT_NAMES[self.tracker.visitor.sight]}")
                self.visitor_pub.publish(convert.visitor_track_to_msg(VisitorTrackData(self.tracker.visitor,
                                                                                       rospy.get_time())))
            self._read_laser(self.tracker.needs_scans)
        elif kind == "watch" and self.gate.only(sender(msg), Node.MULTIROBOT_NAVIGATION, "people watch"):
            self.tracker.want_people(bool(msg.data))  # type: ignore[attr-defined]
            self._read_laser(self.tracker.needs_scans)

    def _read_laser(self, read: bool) -> None:
        """Subscribe to the laser, or let it go (the simulator then stops casting its rays)."""
        if read and self.scan_sub is None:
            self.scan_sub = rospy.Subscriber(Topic.BASE_SCAN, LaserScan, self._enqueue, "scan", queue_size=5)
            rospy.loginfo("people: reading the laser")
        elif not read and self.scan_sub is not None:
            self.scan_sub.unregister()
            self.scan_sub = None
            self.last = self.tracked_t = None
            rospy.loginfo("people: not reading the laser (nobody needs people now)")

    def _scan(self, msg: LaserScan) -> None:
        t = msg.header.stamp.to_sec()
        if not self.tracker.wants_scan(t):
            self.counts["skipped"] += 1
            return
        try:
            scan = Scan.checked(msg.angle_min, msg.angle_increment, msg.ranges, msg.range_min, msg.range_max)
        except ScanError as err:
            self.counts["malformed"] += 1
            self.last_error = str(err)[:300]
            return
        robot = self.poses.at(t)
        if robot is None:
            self.counts["no_pose"] += 1
            return
        if not self.counts["scans"]:
            self.fov_problem = fov_mismatch(self.laser.fov, scan)
            if self.fov_problem:
                rospy.logwarn(f"people: {self.fov_problem}")
        start = time.thread_time()
        report = self.tracker.step(scan, robot, t)
        self.step_ms.append((time.thread_time() - start) * 1e3)
        if self.tracked_t is not None and t > self.tracked_t:
            self.gap_max = max(self.gap_max, t - self.tracked_t)
        self.tracked_t = t
        self.lag_max = max(self.lag_max, rospy.get_time() - t)
        self.counts["scans"] += 1
        self.last = report
        stamp = msg.header.stamp.to_sec()
        self.tracks_pub.publish(convert.people_to_msg(PeopleData(report.tracks, stamp)))
        self.visitor_pub.publish(convert.visitor_track_to_msg(VisitorTrackData(report.visitor, stamp)))

    def _publish_diagnostics(self) -> None:
        status = DiagnosticStatus()
        status.name, status.hardware_id = f"people: {self.robot}", self.robot
        sight = SIGHT_NAMES[self.tracker.visitor.sight]
        people = len(self.last.tracks) if self.last is not None else 0
        status.level = DiagnosticStatus.WARN if self.fov_problem or self.last_error else DiagnosticStatus.OK
        status.message = f"{people} people, visitor {sight}" + (f"; {self.fov_problem}" if self.fov_problem else "")
        values = {**self.counts, "people": people, "visitor": sight, "laser": self.scan_sub is not None,
                  **refusal_values(self.gate.counts)}
        if self.step_ms:
            values |= {"step_ms_mean": f"{sum(self.step_ms) / len(self.step_ms):.3f}",
                       "step_ms_max": f"{max(self.step_ms):.3f}",
                       "scan_gap_max_s": f"{self.gap_max:.2f}", "scan_lag_max_s": f"{self.lag_max:.2f}"}
            self.step_ms.clear()
            self.gap_max = self.lag_max = 0.0
        if self.last_error:
            values["last_error"] = self.last_error
            self.last_error = ""          # warned once
        status.values = [KeyValue(k, str(v)) for k, v in values.items()]
        arr = DiagnosticArray()
        arr.header.stamp = rospy.Time.now()
        arr.status = [status]
        self.diag_pub.publish(arr)


def main(argv: list[str] | None = None) -> int:
    return run_node(Node.PEOPLE, lambda: PeopleNode(Params.read()),
                    lambda n: f"people of {n.robot}: laser {math.degrees(n.laser.fov):.0f} deg declared", argv)
