"""Progress monitor for the simulated building: writes what it sees as JSON lines.

Runs on one robot's master (every shared event reaches every master through the
relays) and appends one JSON object per line to ``~out``: every NavEvent, Goal
and Cancel. ``gidabot demo`` reads this file to show progress; it is not part of
a robot's stack. It does not subscribe to the state topics (status, poses): at
10x and more they are the bulk of the traffic, and the rosbags record them.
"""

from __future__ import annotations

import json
import threading
import time

import rospy

from gidabot_msgs.msg import Cancel, Goal, NavEvent, RobotStatus
from gidabot_navigation.interface import Node, Topic
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
        self._write("event", uid=m.uid, robot=m.robot, floor=m.floor, goal_uid=m.goal_uid, phase=m.phase,
                    way=m.way, connector=m.connector, target_floor=m.target_floor, location_id=m.location_id,
                    tour_file=m.tour_file, tour_step=m.tour_step, detail=m.detail[:200],
                    stamp=m.header.stamp.to_sec())

    def _on_goal(self, m: Goal) -> None:
        self._write("goal", uid=m.uid, origin=m.origin_robot, initial_floor=m.initial_floor,
                    goal_floor=m.goal_floor, goal_id=m.goal_id, way=m.way, connector=m.connector,
                    tour_file=m.tour_file, tour_step=m.tour_step)

    def _on_cancel(self, m: Cancel) -> None:
        self._write("cancel", uid=m.uid, goal_uid=m.goal_uid, origin=m.origin_robot, reason=m.reason)

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
    rospy.init_node(Node.MONITOR, anonymous=True)
    keep_registered()
    MonitorNode()
    rospy.spin()
