"""ROS adapter of the simulated visitor (core: :mod:`gidabot_sim.visitor`)."""

from __future__ import annotations

import threading

import rospy

from gidabot_msgs.msg import NavEvent, RobotStatus, VisitorCommand
from gidabot_navigation.building import load_building
from gidabot_sim.visitor import Command, VisitorConfig, VisitorCore


class VisitorNode:
    """One floor's share of the simulated visitor, on that floor's robot's master.

    Subscribes:
      /gidabot/nav_events (gidabot_msgs/NavEvent)   every robot's events (relayed)
      /gidabot/status (gidabot_msgs/RobotStatus)    to start once every robot is up
    Publishes:
      visitor/command (gidabot_msgs/VisitorCommand) Continue / skip / start, as the GUI would
    Params:
      ~building (str)             building.yaml path;  ~robot (str) this floor's robot
      ~start_floor (float, 0)     where the visitor starts
      ~tour_file (str, "")        tour to start, or ~goal_id (str, "") a single target
      ~way (str, "stairs")        stairs | lift, for every floor change
      ~language (str, "en")       eu | en | es
      ~skips (list of [k, m], []) after tour step k is done, skip to step m
      ~think (float, 3.0 s)       time before pressing a button (sim time)
      ~stairs_s_per_floor (float, 20 s), ~lift_wait (float, 25 s), ~lift_s_per_floor (float, 5 s)
      ~start_delay (float, 2.0 s) after every robot reported status (sim time)
      ~rate (float, 5 Hz)         how often due commands are checked
    """

    def __init__(self) -> None:
        building = load_building(rospy.get_param("~building"))
        robot = building.robot(rospy.get_param("~robot"))
        skips = tuple((int(k), int(m)) for k, m in rospy.get_param("~skips", []))
        self.cfg = VisitorConfig(
            robot=robot.name, floor=robot.floor, start_floor=float(rospy.get_param("~start_floor", 0.0)),
            way=rospy.get_param("~way", "stairs"), language=rospy.get_param("~language", "en"),
            stairs_s_per_floor=float(rospy.get_param("~stairs_s_per_floor", 20.0)),
            lift_wait_s=float(rospy.get_param("~lift_wait", 25.0)),
            lift_s_per_floor=float(rospy.get_param("~lift_s_per_floor", 5.0)),
            think_s=float(rospy.get_param("~think", 3.0)),
            tour_file=rospy.get_param("~tour_file", ""), goal_id=rospy.get_param("~goal_id", ""), skips=skips)
        self.robots = {r.name for r in building.robots}
        self.start_delay = float(rospy.get_param("~start_delay", 2.0))
        self.core = VisitorCore(self.cfg)
        self._lock = threading.Lock()
        self._seen: set[str] = set()
        self._all_up_at: float | None = None
        self._seq = 0
        self.pub = rospy.Publisher("visitor/command", VisitorCommand, queue_size=10)
        rospy.Subscriber("/gidabot/nav_events", NavEvent, self._on_event, queue_size=100)
        rospy.Subscriber("/gidabot/status", RobotStatus, self._on_status, queue_size=50)
        self.timer = rospy.Timer(rospy.Duration(1.0 / float(rospy.get_param("~rate", 5.0))), self._tick)

    def _on_event(self, msg: NavEvent) -> None:
        with self._lock:
            self.core.on_event(rospy.get_time(), msg.uid, msg.robot, msg.phase, msg.goal_uid, msg.floor,
                               msg.target_floor, msg.tour_step)

    def _on_status(self, msg: RobotStatus) -> None:
        with self._lock:
            self._seen.add(msg.robot)
            if self._all_up_at is None and self.robots <= self._seen:
                self._all_up_at = rospy.get_time()

    def _tick(self, _event: object) -> None:
        now = rospy.get_time()
        with self._lock:
            commands = self.core.step(now)
            if self._all_up_at is not None and now >= self._all_up_at + self.start_delay:
                commands = self.core.start(now) + commands
        for cmd in commands:
            self._publish(cmd)

    def _publish(self, cmd: Command) -> None:
        self._seq += 1
        msg = VisitorCommand(uid=f"{self.cfg.robot}/{self.cfg.visitor_id}/cmd/{self._seq}",
                             visitor_id=self.cfg.visitor_id, command=cmd.command, goal_id=cmd.goal_id,
                             way=cmd.way, language=cmd.language, goal_uid=cmd.goal_uid, tour_file=cmd.tour_file,
                             tour_step=cmd.tour_step)
        msg.header.stamp = rospy.Time.now()
        rospy.loginfo("visitor on %s: command %d %s", self.cfg.robot, cmd.command, cmd)
        self.pub.publish(msg)


def main() -> None:
    rospy.init_node("visitor")
    VisitorNode()
    rospy.spin()
