"""ROS adapter of the simulated visitor (core: :mod:`gidabot_sim.visitor.visitor`)."""

from __future__ import annotations

import threading

import rospy

from gidabot_msgs.msg import NavEvent, RobotStatus, TourCatalog, VisitorCommand
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.interface import DEFAULT_LANGUAGE, WAY_STAIRS, WAYS, Node, Topic
from gidabot_navigation.ros.exit_guard import rospy_exit_guard
from gidabot_navigation.ros.master_watch import keep_registered
from gidabot_navigation.ros.params import param_number
from gidabot_navigation.ros.replay import ReplayPublisher
from gidabot_sim.errors import SimConfigError
from gidabot_sim.visitor.visitor import ButtonPress, VisitorConfig, VisitorCore


def _skips_param(raw: object) -> tuple[tuple[int, int], ...]:
    try:
        return tuple((int(k), int(m)) for k, m in raw)  # type: ignore[union-attr]
    except (TypeError, ValueError) as err:
        raise SimConfigError(f"~skips: {raw!r} must be a list of [k, m] step pairs") from err


class VisitorNode:
    """One floor's share of the simulated visitor, on that floor's robot's master.

    Subscribes:
      /gidabot/nav_events (gidabot_msgs/NavEvent)   every robot's events (relayed)
      /gidabot/status (gidabot_msgs/RobotStatus)    to start once every robot is up (then unsubscribed)
      tour_store/catalog (gidabot_msgs/TourCatalog) start floor, tour mode: start once the tour is stored here
    Publishes:
      visitor/command (gidabot_msgs/VisitorCommand) Continue / skip / start, as the GUI would (the last 60 s
                                                    are sent again to a late subscriber: a restarted node)
    Params:
      ~building (str)             building.yaml path;  ~robot (str) this floor's robot
      ~start_floor (float, 0)     where the visitor starts (only that floor's node starts the visit)
      ~tour_file (str, "")        tour to start, or ~goal_id (str, "") a single target
      ~way (str, "stairs")        stairs | lift, for every floor change
      ~language (str, "en")       eu | en | es
      ~skips (list of [k, m], []) after tour step k (0-based) is done, skip to step m
      ~think (float, 3.0 s)       time before pressing a button (sim time)
      ~stairs_s_per_floor (float, 20 s), ~lift_wait (float, 25 s), ~lift_s_per_floor (float, 5 s):
                                  walking time between floors (sim time)
      ~retry (float, 30 s), ~retry_for (float, 1800 s): a request of this visitor refused with
                                  PARTNER_OFFLINE is asked again after ~retry, for at most ~retry_for
      ~start_delay (float, 2.0 s) after every robot reported status (sim time)
      ~rate (float, 1 Hz)         how often due commands are checked (sim time)
    """

    def __init__(self) -> None:
        building = load_building(str(rospy.get_param("~building")))
        robot = building.robot(str(rospy.get_param("~robot")))
        self.cfg = VisitorConfig(
            robot=robot.name, floor=robot.floor, start_floor=param_number("~start_floor", 0.0, -1e6, strict=False),
            way=str(rospy.get_param("~way", WAY_STAIRS)), language=str(rospy.get_param("~language", DEFAULT_LANGUAGE)),
            stairs_s_per_floor=param_number("~stairs_s_per_floor", 20.0, strict=False),
            lift_wait_s=param_number("~lift_wait", 25.0, strict=False),
            lift_s_per_floor=param_number("~lift_s_per_floor", 5.0, strict=False),
            think_s=param_number("~think", 3.0, strict=False),
            tour_file=str(rospy.get_param("~tour_file", "")), goal_id=str(rospy.get_param("~goal_id", "")),
            skips=_skips_param(rospy.get_param("~skips", [])),
            retry_s=param_number("~retry", 30.0, strict=False),
            retry_for_s=param_number("~retry_for", 1800.0, strict=False))
        if self.cfg.way not in WAYS:
            raise SimConfigError(f"~way: {self.cfg.way!r} must be one of {', '.join(WAYS)}")
        self.robots = {r.name for r in building.robots}
        self.start_delay = param_number("~start_delay", 2.0, strict=False)
        rate = param_number("~rate", 1.0)
        self.core = VisitorCore(self.cfg)
        self._lock = threading.Lock()
        self._seen: set[str] = set()
        self._all_up_at: float | None = None
        # tour mode: wait until the tour store of this robot holds the tour (START_TOUR reads it there)
        self._tour_ready = not (self.cfg.tour_file and self.core.on_start_floor)
        self._seq = 0
        # a restarted guiding node gets the commands of the last minute again (it ignores those it handled)
        self.pub = ReplayPublisher(Topic.VISITOR_COMMAND, VisitorCommand, queue_size=50)
        rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, self._on_event, queue_size=100)
        self._status_sub = rospy.Subscriber(Topic.STATUS, RobotStatus, self._on_status, queue_size=50)
        self._catalog_sub = None
        if not self._tour_ready:
            self._catalog_sub = rospy.Subscriber(Topic.TOUR_CATALOG, TourCatalog, self._on_catalog, queue_size=2)
        self.timer = rospy.Timer(rospy.Duration(1.0 / rate), self._tick)

    def _on_event(self, msg: NavEvent) -> None:
        # the visitor sees what a robot does when it happens (the event's stamp), not when its message got here:
        # the messages' wall latency would otherwise add sim time, the more the faster the run (never later than
        # now: another floor's clock may be a little ahead)
        now, happened = rospy.get_time(), msg.header.stamp.to_sec()
        seen = min(happened, now) if happened > 0 else now
        with self._lock:
            self.core.on_event(seen, msg.uid, msg.robot, msg.phase, msg.goal_uid, msg.floor, msg.target_floor,
                               msg.tour_step, tour_file=msg.tour_file, location_id=msg.location_id)

    def _on_catalog(self, msg: TourCatalog) -> None:
        with self._lock:
            if any(t.file_name == self.cfg.tour_file for t in msg.tours):
                self._tour_ready = True

    def _on_status(self, msg: RobotStatus) -> None:
        with self._lock:
            self._seen.add(msg.robot)
            if self._all_up_at is None and self.robots <= self._seen:
                self._all_up_at = rospy.get_time()

    def _tick(self, _event: object) -> None:
        now = rospy.get_time()
        if self._all_up_at is not None and self._status_sub is not None:
            self._status_sub.unregister()    # statuses are 4 x 2 Hz of sim time: only needed until all are up
            self._status_sub = None
        if self._tour_ready and self._catalog_sub is not None:
            self._catalog_sub.unregister()
            self._catalog_sub = None
        with self._lock:
            commands = self.core.step(now)
            if (self._all_up_at is not None and self._tour_ready and not self.core.started
                    and now >= self._all_up_at + self.start_delay):
                commands = self.core.start(now) + commands
                if self.core.started:
                    rospy.loginfo("visitor on %s: every robot is up; starting the visit", self.cfg.robot)
        for cmd in commands:
            self._publish(cmd)

    def _publish(self, cmd: ButtonPress) -> None:
        self._seq += 1
        msg = VisitorCommand(uid=f"{self.cfg.robot}/{self.cfg.visitor_id}/cmd/{self._seq}",
                             visitor_id=self.cfg.visitor_id, command=cmd.command, goal_id=cmd.goal_id,
                             way=cmd.way, language=cmd.language, goal_uid=cmd.goal_uid, tour_file=cmd.tour_file,
                             tour_step=cmd.tour_step)
        msg.header.stamp = rospy.Time.now()
        rospy.loginfo("visitor on %s: command %d %s", self.cfg.robot, cmd.command, cmd)
        self.pub.publish(msg)


def main() -> None:
    guard = rospy_exit_guard(Node.VISITOR)   # exit within 1 s of SIGINT/SIGTERM, master frozen or not (issue 19.5)
    rospy.init_node(Node.VISITOR, disable_signals=True)
    keep_registered()
    try:
        VisitorNode()
    except (GidaBotError, KeyError) as err:
        rospy.logfatal("visitor: %s", err)
        raise SystemExit(2) from err
    guard.spin(rospy.is_shutdown)
