#!/usr/bin/env python3
"""A tiny stand-in for move_base + amcl + odom + battery, for the guiding node tests (one master).

The robot "drives" in a straight line at ``~speed`` m/s (wall time) towards each
move_base goal, publishing ``amcl_pose`` (latched) and ``odom`` on the way; a goal within
0.5 m of a point of ``~abort_at`` is ABORTED after ``~abort_after`` s (a blocked
corridor). A new goal preempts the current one, a cancel stops it (PREEMPTED).

Parameters: ``~start`` [x, y, yaw], ``~speed`` (m/s, 10), ``~abort_at`` ([[x, y], ...]),
``~abort_after`` (s, 0.3).
"""

from __future__ import annotations

import math
import threading

import actionlib
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped, Quaternion
from move_base_msgs.msg import MoveBaseAction, MoveBaseResult
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState

from gidabot_navigation.interface import Topic


def quat(yaw: float) -> Quaternion:
    return Quaternion(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


class FakeNav:
    def __init__(self) -> None:
        x, y, yaw = rospy.get_param("~start", [30.0, 12.0, 0.0])
        self.pose = [float(x), float(y), float(yaw)]
        self.speed = float(rospy.get_param("~speed", 10.0))
        self.abort_at = [tuple(p) for p in rospy.get_param("~abort_at", [])]
        self.abort_after = float(rospy.get_param("~abort_after", 0.3))
        self.lock = threading.Lock()
        self.amcl = rospy.Publisher(Topic.AMCL_POSE, PoseWithCovarianceStamped, queue_size=2, latch=True)
        self.odom = rospy.Publisher(Topic.ODOM, Odometry, queue_size=2)
        self.battery = rospy.Publisher(Topic.BATTERY, BatteryState, queue_size=1, latch=True)
        self.goals = 0
        self.server = actionlib.SimpleActionServer(Topic.MOVE_BASE, MoveBaseAction, self.execute, auto_start=False)
        self.server.start()
        self.publish(0.0)
        b = BatteryState()
        b.percentage = 0.8
        self.battery.publish(b)

    def publish(self, speed: float) -> None:
        msg = PoseWithCovarianceStamped()
        msg.header.stamp = rospy.Time.now()
        msg.header.frame_id = "map"
        msg.pose.pose.position.x, msg.pose.pose.position.y = self.pose[0], self.pose[1]
        msg.pose.pose.orientation = quat(self.pose[2])
        self.amcl.publish(msg)
        od = Odometry()
        od.header.stamp = msg.header.stamp
        od.twist.twist.linear.x = speed
        self.odom.publish(od)

    def execute(self, goal) -> None:
        self.goals += 1
        gx, gy = goal.target_pose.pose.position.x, goal.target_pose.pose.position.y
        q = goal.target_pose.pose.orientation
        gyaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
        rospy.loginfo(f"fake move_base: goal {self.goals} to ({gx:.2f}, {gy:.2f})")
        if any(math.hypot(gx - ax, gy - ay) < 0.5 for ax, ay in self.abort_at):
            rospy.sleep(self.abort_after)
            self.server.set_aborted(MoveBaseResult(), "Failed to find a valid plan")
            return
        rate = rospy.Rate(20)
        while not rospy.is_shutdown():
            if self.server.is_preempt_requested():
                self.publish(0.0)
                self.server.set_preempted()
                return
            dx, dy = gx - self.pose[0], gy - self.pose[1]
            d = math.hypot(dx, dy)
            step = self.speed / 20.0
            if d <= step:
                self.pose = [gx, gy, gyaw]
                self.publish(0.0)
                self.server.set_succeeded(MoveBaseResult())
                return
            self.pose = [self.pose[0] + dx / d * step, self.pose[1] + dy / d * step, math.atan2(dy, dx)]
            self.publish(self.speed)
            rate.sleep()


def main() -> None:
    rospy.init_node("move_base_fake")
    FakeNav()
    rospy.spin()


if __name__ == "__main__":
    main()
