"""ROS adapter of the touch-screen GUI: the ``gui`` node (one per robot, on the robot's own master).

Thin by design: it reads the parameters once, converts messages to the GUI's
plain records (and back), and owns shutdown. Callbacks only convert and put the
record in the :class:`~gidabot_gui.core.inbox.Inbox`, which the Qt thread drains;
they never touch a widget. Publishing (``queue_size`` set) never blocks the UI.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped

from gidabot_gui.core.admin import PasswordCheck
from gidabot_gui.core.i18n import Translator, check_language, package_locale_dir
from gidabot_gui.core.inbox import Inbox
from gidabot_gui.core.model import (
    EditResultData,
    InitialPose,
    PendingData,
    PoseData,
    RobotStatusData,
    TourEdit,
    TourInfo,
    clip,
)
from gidabot_gui.errors import ConfigError, GuiError
from gidabot_msgs.msg import (
    NavEvent,
    NavPose,
    PendingRequests,
    RobotStatus,
    Tour,
    TourCatalog,
    TourEditResult,
    VisitorCommand,
)
from gidabot_navigation.building.geometry import quaternion_to_yaw, yaw_to_quaternion
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import TourError, TourNameError
from gidabot_navigation.guiding.messages import CommandData, NavEventData
from gidabot_navigation.interface import Node, Topic
from gidabot_navigation.ros.exit_guard import rospy_exit_guard
from gidabot_navigation.ros.replay import ReplayPublisher
from gidabot_navigation.tours.tour_file import MAX_GOALS, tour_from_lines

# amcl's usual initial covariance: 0.5 m in x and y, pi/12 in yaw
INITIAL_COVARIANCE = (0.25, 0.25, (math.pi / 12.0) ** 2)
COMMAND_REPLAY_S = 10.0   # wall s of visitor commands replayed to a late subscriber


# ---------------------------------------------------------------------- conversions (no master needed)
def _yaw(q: object) -> float:
    return quaternion_to_yaw(q.x, q.y, q.z, q.w)  # type: ignore[attr-defined]


def status_from_msg(m: RobotStatus) -> RobotStatusData:
    p = m.nav_pose.position
    return RobotStatusData(robot=clip(m.robot, 64), floor=float(m.floor), x=float(p.x), y=float(p.y),
                           yaw=_yaw(m.nav_pose.orientation), linear=float(m.linear_velocity),
                           angular=float(m.angular_velocity), battery=float(m.battery), state=clip(m.state, 32),
                           pending=int(m.pending), current_goal_uid=clip(m.current_goal_uid),
                           busy_for=float(m.busy_for))


def pose_from_msg(m: NavPose) -> PoseData:
    p = m.nav_pose.position
    return PoseData(clip(m.robot, 64), float(m.floor), float(p.x), float(p.y), _yaw(m.nav_pose.orientation))


def pending_from_msg(m: PendingRequests) -> PendingData:
    return PendingData(clip(m.robot, 64), float(m.floor), int(m.num), float(m.wait_new),
                       tuple(clip(g.uid) for g in m.goals[:256]))


def event_from_msg(m: NavEvent) -> NavEventData:
    return NavEventData(uid=clip(m.uid), robot=clip(m.robot, 64), floor=float(m.floor), goal_uid=clip(m.goal_uid),
                        phase=int(m.phase), language=clip(m.language, 8), way=clip(m.way, 16),
                        connector=clip(m.connector, 64), target_floor=float(m.target_floor),
                        location_id=clip(m.location_id, 64), tour_file=clip(m.tour_file, 64),
                        tour_step=int(m.tour_step))


def tour_from_msg(t: Tour) -> TourInfo | None:
    """A catalog entry, its goal lines read exactly as a tour file's (``tour_file.tour_from_lines``: spacing
    and floors such as ``0.0`` tolerated), or None if they are malformed (the store validated them already)."""
    try:
        tour = tour_from_lines(t.file_name, t.tour_name.strip(), list(t.tour_goals_info[:MAX_GOALS]))
    except (TourError, TourNameError):
        return None
    return TourInfo(tour.file_name, clip(t.tour_name, 80), clip(t.language, 8),
                    tuple((g.floor, g.room, g.description) for g in tour.goals))


def catalog_from_msg(m: TourCatalog) -> list[TourInfo]:
    return [info for info in (tour_from_msg(t) for t in m.tours) if info is not None]


def edit_result_from_msg(m: TourEditResult) -> EditResultData:
    return EditResultData(uid=clip(m.uid), file_name=clip(m.file_name, 64), deleted=bool(m.deleted), ok=bool(m.ok),
                          version=int(m.version), reason=clip(m.reason, 32), error=clip(m.error, 400))


def command_to_msg(c: CommandData, stamp: rospy.Time) -> VisitorCommand:
    msg = VisitorCommand()
    msg.header.stamp = stamp
    msg.uid, msg.visitor_id, msg.command, msg.language = c.uid, c.visitor_id, c.command, c.language
    msg.goal_id, msg.way, msg.goal_uid = c.goal_id, c.way, c.goal_uid
    msg.tour_file, msg.tour_step = c.tour_file, c.tour_step
    return msg


def initial_pose_to_msg(p: InitialPose, stamp: rospy.Time) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header.stamp = stamp
    msg.header.frame_id = "map"
    msg.pose.pose.position.x, msg.pose.pose.position.y = p.x, p.y
    q = yaw_to_quaternion(p.yaw)
    o = msg.pose.pose.orientation
    o.x, o.y, o.z, o.w = q
    cov = [0.0] * 36
    cov[0], cov[7], cov[35] = INITIAL_COVARIANCE
    msg.pose.covariance = cov
    return msg


def tour_edit_to_msg(e: TourEdit, robot: str, stamp: rospy.Time) -> Tour:
    msg = Tour()
    msg.header.stamp = stamp
    msg.uid = e.uid
    msg.origin_robot = msg.editor_robot = robot
    msg.deleted = e.deleted
    msg.language = e.language
    msg.floor = e.floor
    msg.tour_name = e.tour_name
    msg.file_name = e.file_name
    msg.tour_goals_info = list(e.goal_lines)
    return msg


# ---------------------------------------------------------------------- callbacks (no master needed)
class Receiver:
    """The subscribers' callbacks: convert, hand over to the Qt thread through the inbox, return.

    Messages that cannot be converted are counted and logged (throttled), never raised.
    """

    def __init__(self, robot: str, inbox: Inbox, log: Callable[[str], None]) -> None:
        self.robot = robot
        self.inbox = inbox
        self.log = log
        self.bad = 0

    def _convert(self, what: str, fn: Callable[[Any], Any], msg: Any) -> Any:
        try:
            return fn(msg)
        except (ValueError, TypeError, AttributeError, OverflowError) as err:
            self.bad += 1
            self.log(f"gui: unusable {what} message ignored ({err}); {self.bad} so far")
            return None

    def status(self, m: RobotStatus) -> None:
        rec = self._convert("status", status_from_msg, m)
        if rec is not None:
            self.inbox.put_state("status", rec.robot, rec)

    def pose(self, m: NavPose) -> None:
        rec = self._convert("pose", pose_from_msg, m)
        if rec is not None:
            self.inbox.put_state("pose", rec.robot, rec)

    def pending(self, m: PendingRequests) -> None:
        rec = self._convert("pending", pending_from_msg, m)
        if rec is not None:
            self.inbox.put_state("pending", rec.robot, rec)

    def nav_event(self, m: NavEvent) -> None:
        if m.robot != self.robot:
            return                      # only this robot's events become pop-ups
        rec = self._convert("nav_event", event_from_msg, m)
        if rec is not None:
            self.inbox.put_event("nav_event", rec)

    def catalog(self, m: TourCatalog) -> None:
        rec = self._convert("catalog", catalog_from_msg, m)
        if rec is not None:
            self.inbox.put_state("catalog", "", rec)

    def edit_result(self, m: TourEditResult) -> None:
        rec = self._convert("edit_result", edit_result_from_msg, m)
        if rec is not None:
            self.inbox.put_event("edit_result", rec)


# ---------------------------------------------------------------------- parameters
@dataclass(frozen=True)
class Params:
    building: str
    robot: str
    language: str
    admin: bool
    admin_password_sha256: str
    speech: bool
    speech_sink: str
    speech_rate: int
    fullscreen: bool
    width: int
    height: int
    offline_after: float
    request_timeout: float
    locale_dir: str

    @staticmethod
    def read() -> Params:
        building = str(rospy.get_param("~building", ""))
        robot = str(rospy.get_param("~robot", ""))
        if not building or not robot:
            raise ConfigError("~building (building.yaml or its directory) and ~robot (robot name) are required")
        language = str(rospy.get_param("~language", "en"))
        check_language(language)

        def number(name: str, default: float, low: float, high: float) -> float:
            value = rospy.get_param(name, default)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high:
                raise ConfigError(f"{name} must be a number in [{low}, {high}], got {value!r}")
            return float(value)

        sink = str(rospy.get_param("~speech_sink", "auto"))
        if sink not in ("auto", "device", "null"):
            raise ConfigError(f"~speech_sink {sink!r} must be auto, device or null")
        return Params(building, robot, language, bool(rospy.get_param("~admin", False)),
                      str(rospy.get_param("~admin_password_sha256", "")), bool(rospy.get_param("~speech", True)),
                      sink, int(number("~speech_rate", 150, 80, 400)), bool(rospy.get_param("~fullscreen", True)),
                      int(number("~width", 1280, 320, 8192)), int(number("~height", 800, 240, 8192)),
                      number("~offline_after", 5.0, 0.5, 3600.0), number("~request_timeout", 20.0, 1.0, 3600.0),
                      str(rospy.get_param("~locale_dir", "")))


class GuiNode:
    """The touch-screen GUI of one robot (paper section 4).

    Subscribed topics (callbacks only convert and enqueue):
      - ``/gidabot/status`` (gidabot_msgs/RobotStatus, every robot via the relays): Information tab,
        robots on the blueprints; a robot without status for ``~offline_after`` s (wall) is offline.
      - ``/gidabot/poses`` (gidabot_msgs/NavPose): live robot positions on the floor tabs.
      - ``/gidabot/pending`` (gidabot_msgs/PendingRequests): pending requests and waits (``wait_new``, s)
        shown before a request is confirmed and in the Information tab.
      - ``/gidabot/nav_events`` (gidabot_msgs/NavEvent): the events whose ``robot`` is this robot become
        pop-ups and speech.
      - ``tour_store/catalog`` (gidabot_msgs/TourCatalog, latched): the Guided Tour tab.
      - ``tour_store/edit_result`` (gidabot_msgs/TourEditResult): outcome of admin tour edits.

    Published topics:
      - ``visitor/command`` (gidabot_msgs/VisitorCommand): REQUEST, CONTINUE, CANCEL, START_TOUR, SKIP;
        the commands of the last 10 s are sent again to a subscriber that connects late.
      - ``initialpose`` (geometry_msgs/PoseWithCovarianceStamped, frame ``map``): admin Set location.
      - ``tour_store/edit`` (gidabot_msgs/Tour): admin create / edit / delete (``deleted: true``).

    Parameters:
      - ``~building`` (str, required), ``~robot`` (str, required).
      - ``~language`` (eu | en | es, default en): start language.
      - ``~admin`` (bool, default false) and ``~admin_password_sha256`` (hex SHA-256 of the password):
        admin mode exists only with both; a malformed hash is logged and admin mode stays off.
      - ``~speech`` (bool, default true): espeak-ng speech. ``~speech_sink`` (auto | device | null,
        default auto = null when there is no display), ``~speech_rate`` (words per minute, 150).
      - ``~fullscreen`` (bool, default true); ``~width``, ``~height`` (px, 1280x800) when not full screen.
      - ``~offline_after`` (s, wall time, default 5.0); ``~request_timeout`` (s, wall, default 20.0):
        a request without any answer is reported to the visitor.
      - ``~locale_dir`` (str, default the package's ``locale``): compiled gettext catalogs.
    """

    def __init__(self, params: Params, inbox: Inbox) -> None:
        self.params = params
        self.receiver = Receiver(params.robot, inbox, lambda m: rospy.logwarn_throttle(10.0, m))
        # a guiding node that connects late (starting, or respawned) still gets the commands of the last
        # few seconds; it ignores those it handled (uid and stamp). Shorter than the request timeout, so a
        # request the visitor was told got no answer is never acted on later.
        self.cmd_pub = ReplayPublisher(Topic.VISITOR_COMMAND, VisitorCommand, queue_size=20,
                                       window=min(COMMAND_REPLAY_S, params.request_timeout / 2))
        self.pose_pub = rospy.Publisher(Topic.INITIALPOSE, PoseWithCovarianceStamped, queue_size=2)
        self.edit_pub = rospy.Publisher(Topic.TOUR_EDIT, Tour, queue_size=10)
        r = self.receiver
        self.subs = [
            rospy.Subscriber(Topic.STATUS, RobotStatus, r.status, queue_size=100),
            rospy.Subscriber(Topic.POSES, NavPose, r.pose, queue_size=100),
            rospy.Subscriber(Topic.PENDING, PendingRequests, r.pending, queue_size=50),
            rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, r.nav_event, queue_size=200),
            rospy.Subscriber(Topic.TOUR_CATALOG, TourCatalog, r.catalog, queue_size=2),
            rospy.Subscriber(Topic.TOUR_EDIT_RESULT, TourEditResult, r.edit_result, queue_size=20),
        ]

    # Outputs (called in the Qt thread; rospy publishers with a queue never block)
    def send_command(self, cmd: CommandData) -> None:
        rospy.loginfo(f"gui: visitor command {cmd.command} goal={cmd.goal_id!r} way={cmd.way!r} "
                      f"goal_uid={cmd.goal_uid!r} tour={cmd.tour_file!r}/{cmd.tour_step}")
        self.cmd_pub.publish(command_to_msg(cmd, rospy.Time.now()))

    def send_initial_pose(self, pose: InitialPose) -> None:
        rospy.loginfo(f"gui: set location x={pose.x:.2f} y={pose.y:.2f} yaw={pose.yaw:.2f}")
        self.pose_pub.publish(initial_pose_to_msg(pose, rospy.Time.now()))

    def send_tour_edit(self, edit: TourEdit) -> None:
        rospy.loginfo(f"gui: tour {'delete' if edit.deleted else 'edit'} {edit.file_name}")
        self.edit_pub.publish(tour_edit_to_msg(edit, self.params.robot, rospy.Time.now()))

    def shutdown(self) -> None:
        for s in self.subs:
            s.unregister()
        for p in (self.cmd_pub, self.pose_pub, self.edit_pub):
            p.unregister()


def _base36(n: int) -> str:
    digits = "0123456789abcdefghijklmnopqrstuvwxyz"
    out = ""
    while True:
        n, r = divmod(n, 36)
        out = digits[r] + out
        if n == 0:
            return out


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv if argv is None else argv)
    # SIGINT/SIGTERM: the Qt loop (polling the guard) quits, then the guard shuts rospy down in a thread of
    # its own and ends the process within 1 s of the signal, master frozen or not (issue 19.5)
    guard = rospy_exit_guard(Node.GUI, main_loop=True)
    rospy.init_node(Node.GUI, argv=argv, disable_signals=True)
    try:
        from gidabot_navigation.ros.master_watch import keep_registered
    except ImportError:
        rospy.logwarn("gui: gidabot_navigation.ros.master_watch is missing: the GUI will not survive a master restart")
    else:
        keep_registered()
    try:
        params = Params.read()
        building = load_building(params.building)
        building.robot(params.robot)
        locale_dir = Path(params.locale_dir) if params.locale_dir else package_locale_dir()
    except (GuiError, KeyError) as err:
        rospy.logfatal(f"gui: {err}")
        return 2
    headless = not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
                    or os.environ.get("QT_QPA_PLATFORM"))
    if headless:
        rospy.logwarn("gui: no display; drawing off screen (QT_QPA_PLATFORM=offscreen)")
        os.environ["QT_QPA_PLATFORM"] = "offscreen"

    # Qt is imported only now: the platform must be chosen first
    from PyQt5.QtCore import QTimer
    from PyQt5.QtWidgets import QApplication

    from gidabot_gui.qt.speech import EspeakSpeaker, NullSpeaker
    from gidabot_gui.qt.window import GuiConfig, MainWindow

    app = QApplication(argv[:1])
    tr = Translator(params.language, locale_dir)
    for lang in tr.missing:
        rospy.logwarn(f"gui: no compiled catalog for {lang} in {tr.locale_dir} (run tools/build-translations.sh); "
                      "texts fall back to English")
    admin = None
    if params.admin:
        try:
            admin = PasswordCheck(params.admin_password_sha256)
        except ConfigError as err:
            rospy.logerr(f"gui: admin mode is off: {err}")
    inbox = Inbox()
    node = GuiNode(params, inbox)
    if params.speech:
        sink = "null" if params.speech_sink == "null" or (params.speech_sink == "auto" and headless) else ""
        speaker = EspeakSpeaker(rate_wpm=params.speech_rate, sink=sink, log=rospy.logwarn)
    else:
        speaker = NullSpeaker()
    visitor_id = "gui" + _base36(time.time_ns() // 1_000_000)
    config = GuiConfig(params.robot, admin=admin, offline_after=params.offline_after,
                       request_timeout=params.request_timeout, visitor_id=visitor_id)
    window = MainWindow(building, config, tr, node, speaker, inbox=inbox, log=rospy.loginfo)
    if params.fullscreen and not headless:
        window.showFullScreen()
    else:
        window.resize(params.width, params.height)
        window.show()

    watchdog = QTimer()
    watchdog.timeout.connect(lambda: (guard.requested or rospy.is_shutdown()) and app.quit())
    watchdog.start(100)
    rospy.loginfo(f"gui: {params.robot} ready ({'admin mode available' if admin else 'visitor mode'}, "
                  f"language {params.language}, speech {'on' if params.speech else 'off'})")
    rc = 0 if guard.requested else app.exec_()
    speaker.stop()
    node.shutdown()
    guard.loop_stopped()
    if guard.requested:
        guard.spin(rospy.is_shutdown)     # the guard's thread shuts rospy down, never this one
    else:
        rospy.signal_shutdown("gui closed")
    return rc


