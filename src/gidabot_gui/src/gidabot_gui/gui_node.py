"""ROS adapter of the touch-screen GUI: the ``gui`` node (one per robot, on the robot's own master).

Thin by design: it reads the parameters once, converts messages (the ones it shares with the robots'
nodes with :mod:`gidabot_navigation.ros.convert`, then :func:`~gidabot_gui.core.model.bounded`; its
initial pose here) and owns shutdown. Callbacks only convert and put the record in the
:class:`~gidabot_gui.core.inbox.Inbox`, which the Qt thread drains; they never touch a widget.
Publishing (``queue_size`` set) never blocks the UI.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseWithCovarianceStamped

import gidabot_msgs.msg as gidabot_msgs
from gidabot_gui.core.admin import LEGACY_SHA256, PasswordCheck
from gidabot_gui.core.i18n import Translator, check_language, package_locale_dir
from gidabot_gui.core.inbox import Inbox
from gidabot_gui.core.model import InitialPose, TourEdit, TourInfo, bounded, tour_info
from gidabot_gui.errors import ConfigError, GuiError
from gidabot_navigation.building.model import Building, load_building
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.guiding.messages import CommandData, base36
from gidabot_navigation.interface import Node, Topic
from gidabot_navigation.ros import convert
from gidabot_navigation.ros.adapter import diagnostics, refusal_values, sender, simulated
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.node_main import start_node
from gidabot_navigation.ros.params import param_number, param_text, robot_params
from gidabot_navigation.ros.replay import ReplayPublisher
from gidabot_navigation.senders import Claim, Gate, Senders, claim_of

# amcl's usual initial covariance: 0.5 m in x and y, pi/12 in yaw
INITIAL_COVARIANCE = (0.25, 0.25, (math.pi / 12.0) ** 2)
COMMAND_REPLAY_S = 10.0   # wall s of visitor commands replayed to a late subscriber
DIAG_PERIOD = 5.0         # s (ROS time) between two diagnostics


def catalog_tours(m: gidabot_msgs.TourCatalog) -> list[TourInfo]:
    """The catalog's tours the screen can show (a malformed one is left out)."""
    return [info for info in (tour_info(t) for t in convert.catalog_from_msg(m).tours) if info is not None]


def initial_pose_to_msg(p: InitialPose, stamp: float) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header.stamp = convert.ros_time(stamp)
    msg.header.frame_id = "map"
    msg.pose.pose = convert.pose_msg(p.x, p.y, p.yaw)
    cov = [0.0] * 36
    cov[0], cov[7], cov[35] = INITIAL_COVARIANCE
    msg.pose.covariance = cov
    return msg


# ---------------------------------------------------------------------- callbacks (no master needed)
class Receiver:
    """The subscribers' callbacks: convert, hand over to the Qt thread through the inbox, return.

    Messages that cannot be converted are counted and logged (throttled), never raised.
    """

    def __init__(self, inbox: Inbox, log: Callable[[str], None], gate: Gate) -> None:
        self.inbox = inbox
        self.log = log
        self.gate = gate      # whose events the screen takes (gidabot_navigation.senders)
        self.bad = 0

    def _convert(self, what: str, fn: Callable[[Any], Any], msg: Any) -> Any:
        try:
            return fn(msg)
        except (ValueError, TypeError, AttributeError, OverflowError) as err:
            self.bad += 1
            self.log(f"gui: unusable {what} message ignored ({err}); {self.bad} so far")
            return None

    def _state(self, kind: str, from_msg: Callable[[Any], Any], msg: Any) -> None:
        """A robot's latest state (status, pose, pending list): only the newest per robot is kept."""
        rec = self._convert(kind, lambda m: bounded(from_msg(m)), msg)
        if rec is not None:
            self.inbox.put_state(kind, rec.robot, rec)

    def _event(self, kind: str, from_msg: Callable[[Any], Any], msg: Any) -> None:
        """An event (NavEvent, edit result): every one, in order."""
        rec = self._convert(kind, lambda m: bounded(from_msg(m)), msg)
        if rec is not None:
            self.inbox.put_event(kind, rec)

    def values(self) -> dict[str, int]:
        """The diagnostics values: refusals by kind (``refused_<kind>``, ``refused``) and ``unusable`` messages."""
        return {**refusal_values(self.gate.refusals()), "unusable": self.bad}

    def status(self, m: gidabot_msgs.RobotStatus) -> None:
        self._state("status", convert.status_from_msg, m)

    def pose(self, m: gidabot_msgs.NavPose) -> None:
        self._state("pose", convert.pose_from_msg, m)

    def pending(self, m: gidabot_msgs.PendingRequests) -> None:
        self._state("pending", convert.pending_from_msg, m)

    def nav_event(self, m: gidabot_msgs.NavEvent) -> None:
        """A NavEvent, taken only when its publisher may speak for the robot it names, with a uid of that robot:
        a forged event never reaches the visitor (refused and counted: ``self.gate.refusals()``)."""
        rec = self._convert("nav_event", lambda msg: bounded(convert.event_from_msg(msg)), m)
        if rec is not None and self.gate.admit(sender(m), claim_of(Topic.NAV_EVENTS, rec) or Claim(""),
                                               "nav event") is not None:
            self.inbox.put_event("nav_event", rec)

    def staff(self, m: gidabot_msgs.StaffCommand) -> None:
        """A StaffCommand, taken only from the dashboard of the robot it speaks for (this robot's dashboard, or the
        relay end of the link from that robot), with a uid of that robot (refused and counted otherwise)."""
        rec = self._convert("staff", lambda msg: bounded(convert.staff_from_msg(msg)), m)
        if rec is not None and self.gate.admit(sender(m), claim_of(Topic.STAFF, rec) or Claim(""), "staff command",
                                               Topic.STAFF) is not None:
            self.inbox.put_event("staff", rec)

    def edit_result(self, m: gidabot_msgs.TourEditResult) -> None:
        self._event("edit_result", convert.edit_result_from_msg, m)

    def catalog(self, m: gidabot_msgs.TourCatalog) -> None:
        tours = self._convert("catalog", catalog_tours, m)
        if tours is not None:
            self.inbox.put_state("catalog", "", tours)


# ---------------------------------------------------------------------- parameters
@dataclass(frozen=True)
class Params:
    building: str
    robot: str
    language: str
    admin: bool
    admin_password_hash: str
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
        building, robot = robot_params()
        language = check_language(param_text("~language", "en"))
        sink = param_text("~speech_sink", "auto")
        if sink not in ("auto", "device", "null"):
            raise ConfigError(f"~speech_sink {sink!r} must be auto, device or null")
        return Params(building, robot, language, bool(rospy.get_param("~admin", False)),
                      str(rospy.get_param("~admin_password_hash", "")), bool(rospy.get_param("~speech", True)),
                      sink, int(param_number("~speech_rate", 150, 80, 400, strict=False)),
                      bool(rospy.get_param("~fullscreen", True)),
                      int(param_number("~width", 1280, 320, 8192, strict=False)),
                      int(param_number("~height", 800, 240, 8192, strict=False)),
                      param_number("~offline_after", 5.0, 0.5, 3600.0, strict=False),
                      param_number("~request_timeout", 20.0, 1.0, 3600.0, strict=False),
                      param_text("~locale_dir", ""))


class GuiNode:
    """The touch-screen GUI of one robot (paper section 4).

    Subscribed topics (callbacks only convert and enqueue):
      - ``/gidabot/status`` (gidabot_msgs/RobotStatus, every robot via the relays): Information tab,
        robots on the blueprints; a robot without status for ``~offline_after`` s (wall) is offline.
      - ``/gidabot/poses`` (gidabot_msgs/NavPose): live robot positions on the floor tabs.
      - ``/gidabot/pending`` (gidabot_msgs/PendingRequests): pending requests and waits (``wait_new``, s)
        shown before a request is confirmed and in the Information tab.
      - ``/gidabot/nav_events`` (gidabot_msgs/NavEvent): this robot's events become pop-ups and speech, and
        those of another robot of the floor that comes for a visitor waiting at this screen
        (:class:`~gidabot_gui.core.flow.VisitorFlow` picks them). Only an event its publisher may send is
        taken: this robot's own nodes speak for it, the relay end of its link to robot P for P
        (gidabot_navigation.senders); the others are refused and logged (rate-limited).
      - ``tour_store/catalog`` (gidabot_msgs/TourCatalog, latched): the Guided Tour tab.
      - ``tour_store/edit_result`` (gidabot_msgs/TourEditResult): outcome of admin tour edits.

    Published topics:
      - ``visitor/command`` (gidabot_msgs/VisitorCommand): REQUEST, CONTINUE, CANCEL, START_TOUR, SKIP;
        the commands of the last 10 s are sent again to a subscriber that connects late.
      - ``initialpose`` (geometry_msgs/PoseWithCovarianceStamped, frame ``map``): admin Set location.
      - ``tour_store/edit`` (gidabot_msgs/Tour): admin create / edit / delete (``deleted: true``).
      - ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): ``gui: screen <robot>`` every :data:`DIAG_PERIOD` s (ROS
        time): the events refused by kind (``refused_impostor``, ... and ``refused``; WARN once any was) and
        the ``unusable`` messages.

    Parameters:
      - ``~building`` (str, required), ``~robot`` (str, required).
      - ``~language`` (eu | en | es, default en): start language.
      - ``~admin`` (bool, default false) and ``~admin_password_hash`` (the password's salted hash record,
        ``scrypt:...``, from ``gidabot admin-passwd``): admin mode exists only with both; a malformed record, or
        only an unsalted ``~admin_password_sha256`` (no longer taken), is logged and admin mode stays off.
      - ``~speech`` (bool, default true): espeak-ng speech. ``~speech_sink`` (auto | device | null,
        default auto = null when there is no display), ``~speech_rate`` (words per minute, 150).
      - ``~fullscreen`` (bool, default true); ``~width``, ``~height`` (px, 1280x800) when not full screen.
      - ``~offline_after`` (s, wall time, default 5.0); ``~request_timeout`` (s, wall, default 20.0):
        a request without any answer is reported to the visitor.
      - ``~locale_dir`` (str, default the package's ``locale``): compiled gettext catalogs.
    """

    def __init__(self, params: Params, inbox: Inbox, building: Building) -> None:
        self.params = params
        self.receiver = Receiver(inbox, lambda m: rospy.logwarn_throttle(10.0, m),
                                 Gate(Senders.of_building(building, params.robot, simulated()), RosLog()))
        # a guiding node that connects late (starting, or respawned) still gets the commands of the last
        # few seconds; it ignores those it handled (uid and stamp). Shorter than the request timeout, so a
        # request the visitor was told got no answer is never acted on later.
        self.cmd_pub = ReplayPublisher(Topic.VISITOR_COMMAND, gidabot_msgs.VisitorCommand, queue_size=20,
                                       window=min(COMMAND_REPLAY_S, params.request_timeout / 2))
        self.pose_pub = rospy.Publisher(Topic.INITIALPOSE, PoseWithCovarianceStamped, queue_size=2)
        self.edit_pub = rospy.Publisher(Topic.TOUR_EDIT, gidabot_msgs.Tour, queue_size=10)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=2)
        self.diag_timer = rospy.Timer(rospy.Duration(DIAG_PERIOD), lambda _e: self.publish_diagnostics())
        r = self.receiver
        self.subs = [
            rospy.Subscriber(Topic.STATUS, gidabot_msgs.RobotStatus, r.status, queue_size=100),
            rospy.Subscriber(Topic.POSES, gidabot_msgs.NavPose, r.pose, queue_size=100),
            rospy.Subscriber(Topic.PENDING, gidabot_msgs.PendingRequests, r.pending, queue_size=50),
            rospy.Subscriber(Topic.NAV_EVENTS, gidabot_msgs.NavEvent, r.nav_event, queue_size=200),
            rospy.Subscriber(Topic.TOUR_CATALOG, gidabot_msgs.TourCatalog, r.catalog, queue_size=2),
            rospy.Subscriber(Topic.TOUR_EDIT_RESULT, gidabot_msgs.TourEditResult, r.edit_result, queue_size=20),
            rospy.Subscriber(Topic.STAFF, gidabot_msgs.StaffCommand, r.staff, queue_size=20),
        ]

    # Outputs (called in the Qt thread; rospy publishers with a queue never block)
    def send_command(self, cmd: CommandData) -> None:
        rospy.loginfo(f"gui: visitor command {cmd.command} goal={cmd.goal_id!r} way={cmd.way!r} "
                      f"goal_uid={cmd.goal_uid!r} tour={cmd.tour_file!r}/{cmd.tour_step}")
        self.cmd_pub.publish(convert.command_to_msg(replace(cmd, stamp=rospy.get_time())))

    def send_initial_pose(self, pose: InitialPose) -> None:
        rospy.loginfo(f"gui: set location x={pose.x:.2f} y={pose.y:.2f} yaw={pose.yaw:.2f}")
        self.pose_pub.publish(initial_pose_to_msg(pose, rospy.get_time()))

    def send_tour_edit(self, edit: TourEdit) -> None:
        rospy.loginfo(f"gui: tour {'delete' if edit.deleted else 'edit'} {edit.file_name}")
        self.edit_pub.publish(convert.tour_to_msg(edit.message(self.params.robot, rospy.get_time())))

    def publish_diagnostics(self) -> None:
        values = self.receiver.values()
        self.diag_pub.publish(diagnostics(f"gui: screen {self.params.robot}", self.params.robot, values,
                                          values["refused"] > 0, f"{values['refused']} refused, "
                                          f"{values['unusable']} unusable", rospy.get_time()))

    def shutdown(self) -> None:
        self.diag_timer.shutdown()
        for s in self.subs:
            s.unregister()
        for p in (self.cmd_pub, self.pose_pub, self.edit_pub, self.diag_pub):
            p.unregister()


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv if argv is None else argv)
    # SIGINT/SIGTERM: the Qt loop (polling the guard) quits, then the guard shuts rospy down in a thread of
    # its own and ends the process within 1 s of the signal, master frozen or not
    guard = start_node(Node.GUI, argv)
    try:
        params = Params.read()
        building = load_building(params.building)
        building.robot(params.robot)
        locale_dir = Path(params.locale_dir) if params.locale_dir else package_locale_dir()
    except (GuiError, GidaBotError, KeyError) as err:
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
            admin = PasswordCheck(params.admin_password_hash)
        except ConfigError as err:
            old = rospy.has_param("~admin_password_sha256") and not params.admin_password_hash
            rospy.logerr("gui: admin mode is off: " + (LEGACY_SHA256 if old else str(err)))
    inbox = Inbox()
    node = GuiNode(params, inbox, building)
    if params.speech:
        sink = "null" if params.speech_sink == "null" or (params.speech_sink == "auto" and headless) else ""
        speaker = EspeakSpeaker(rate_wpm=params.speech_rate, sink=sink, log=rospy.logwarn)
    else:
        speaker = NullSpeaker()
    visitor_id = "gui" + base36(time.time_ns() // 1_000_000)
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


