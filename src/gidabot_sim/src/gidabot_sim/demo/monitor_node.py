"""Progress monitor for the simulated building: writes what it sees as JSON lines.

Runs on one robot's master (every shared event reaches every master through the
relays) and appends one JSON object per line to ``~out``: every NavEvent, Goal
and Cancel, each with the node that published it on this master (``callerid``: a
robot's own guiding nodes, or the relay end from another robot), so that
:mod:`gidabot_sim.demo.progress` can tell the visit's messages from anyone else's.
``gidabot demo`` reads this file to show progress; it is not part of a robot's stack.
It does not subscribe to the state topics (status, poses): at 10x and more they are
the bulk of the traffic, and the rosbags record them.
"""

from __future__ import annotations

import json
import threading
import time
from dataclasses import asdict

import rospy

from gidabot_msgs.msg import Cancel, Goal, NavEvent, RobotStatus
from gidabot_navigation.interface import Node, Topic
from gidabot_navigation.ros.adapter import sender
from gidabot_navigation.ros.convert import trip_from_msg
from gidabot_navigation.ros.exit_guard import rospy_exit_guard
from gidabot_navigation.ros.master_watch import keep_registered


class MonitorNode:
    """Subscribes /gidabot/nav_events, /gidabot/goals, /gidabot/cancels, and /gidabot/status until every
    robot of ``~robots`` was heard once (a line of kind ``up`` per robot).

    Params: ~out (str) JSON-lines file to append to; ~robots (list of str, []) robots to wait for.
    Every line has ``kind``, ``wall`` (s since epoch) and ``sim`` (ROS time, s: sim time, since the
    building runner sets ``/use_sim_time`` on the master before it starts this node).
    """

    def __init__(self) -> None:
        self._file = open(rospy.get_param("~out"), "a", encoding="utf-8")  # noqa: SIM115 - closed on shutdown
        self._lock = threading.Lock()
        rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, self._on_event, queue_size=200)
        rospy.Subscriber(Topic.GOALS, Goal, self._on_goal, queue_size=200)
        rospy.Subscriber(Topic.CANCELS, Cancel, self._on_cancel, queue_size=200)
        self._waiting = {str(r) for r in rospy.get_param("~robots", [])}
        self._status_sub = (rospy.Subscriber(Topic.STATUS, RobotStatus, self._on_status, queue_size=20)
                            if self._waiting else None)
        rospy.on_shutdown(self._file.close)

    def _write(self, kind: str, **data: object) -> None:
        line = json.dumps({"kind": kind, "wall": time.time(), "sim": rospy.get_time(), **data})
        with self._lock:
            if not self._file.closed:
                self._file.write(line + "\n")
                self._file.flush()

    def _on_event(self, m: NavEvent) -> None:
        self._write("event", callerid=sender(m), uid=m.uid[:200], robot=m.robot[:64], floor=m.floor,
                    goal_uid=m.goal_uid[:200], phase=m.phase, way=m.way[:16], connector=m.connector[:64],
                    target_floor=m.target_floor, location_id=m.location_id[:64], tour_file=m.tour_file[:64],
                    tour_step=m.tour_step, detail=m.detail[:200], stamp=m.header.stamp.to_sec(), leg=m.leg[:16],
                    attempt=m.attempt, assignee=m.assignee[:64], eta=m.eta)

    def _on_goal(self, m: Goal) -> None:
        trip = {k: v[:200] if isinstance(v, str) else v for k, v in asdict(trip_from_msg(m)).items()}
        self._write("goal", callerid=sender(m), **trip)

    def _on_cancel(self, m: Cancel) -> None:
        self._write("cancel", callerid=sender(m), uid=m.uid[:200], goal_uid=m.goal_uid[:200],
                    origin=m.origin_robot[:64], reason=m.reason[:32])

    def _on_status(self, m: RobotStatus) -> None:
        with self._lock:
            if m.robot not in self._waiting:
                return
            self._waiting.discard(m.robot)
            done = not self._waiting
        self._write("up", robot=m.robot, floor=m.floor, state=m.state)
        if done and self._status_sub is not None:
            self._status_sub.unregister()   # 2 Hz of sim time per robot: not needed any more
            self._status_sub = None


def main() -> None:
    guard = rospy_exit_guard(Node.MONITOR)   # exit within 1 s of SIGINT/SIGTERM, master frozen or not
    rospy.init_node(Node.MONITOR, anonymous=True, disable_signals=True)
    keep_registered()
    MonitorNode()
    guard.spin(rospy.is_shutdown)
