#!/usr/bin/env python3
"""The rostest of sim_navigation.test: MoveBaseAction semantics of the move_base stand-in on floor 1.

Waits use wall-clock deadlines (the floor runs at 10x); the cases run in name order on one robot.
"""

from __future__ import annotations

import math
import threading
import time
import unittest

import actionlib
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from move_base_msgs.msg import (
    MoveBaseAction,
    MoveBaseActionFeedback,
    MoveBaseActionResult,
    MoveBaseFeedback,
    MoveBaseGoal,
)
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.srv import GetMap, GetPlan, GetPlanRequest
from sensor_msgs.msg import BatteryState, LaserScan
from std_srvs.srv import Empty
from tf2_msgs.msg import TFMessage

from gidabot_msgs.msg import Obstacle
from gidabot_navigation.building.geometry import Pose2D, quaternion_to_yaw
from gidabot_navigation.interface import Node, Service, Topic, global_name
from gidabot_sim.ros.convert import pose_msg

NAME = "sim_navigation"
SIM, MOVE_BASE = global_name(Node.SIM), global_name(Node.MOVE_BASE)   # subscribers of what the test publishes


def wait_for(predicate, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s (wall) waiting for {what}")
        time.sleep(0.02)


def goal_msg(x: float, y: float, yaw: float) -> MoveBaseGoal:
    goal = MoveBaseGoal()
    goal.target_pose.header.frame_id = "map"
    goal.target_pose.header.stamp = rospy.Time.now()
    goal.target_pose.pose = pose_msg(Pose2D(x, y, yaw))
    return goal


class SimNavigation(unittest.TestCase):
    lock = threading.Lock()
    truth: Odometry | None = None
    odom: Odometry | None = None
    diag: dict[str, str] = {}
    feedback: list[MoveBaseFeedback] = []

    @classmethod
    def setUpClass(cls) -> None:
        rospy.init_node("sim_navigation_test")
        rospy.Subscriber(Topic.BASE_POSE_GROUND_TRUTH, Odometry, cls._on_truth, queue_size=5)
        rospy.Subscriber(Topic.ODOM, Odometry, cls._on_odom, queue_size=5)
        rospy.Subscriber(Topic.DIAGNOSTICS, DiagnosticArray, cls._on_diag, queue_size=5)
        cls.obstacles = rospy.Publisher(Topic.SIM_OBSTACLE, Obstacle, queue_size=10)
        cls.initialpose = rospy.Publisher(Topic.INITIALPOSE, PoseWithCovarianceStamped, queue_size=5)
        cls.client = actionlib.SimpleActionClient(Topic.MOVE_BASE, MoveBaseAction)
        deadline = time.monotonic() + 60
        while not cls.client.wait_for_server(rospy.Duration(0.5)):
            assert time.monotonic() < deadline, "no move_base action server"
        rospy.wait_for_message(Topic.AMCL_POSE, PoseWithCovarianceStamped, timeout=60)
        wait_for(lambda: cls.truth is not None and cls.obstacles.impl.has_connection(SIM)
                 and cls.initialpose.impl.has_connection(SIM), 60, "the simulator")

    @classmethod
    def _on_truth(cls, msg: Odometry) -> None:
        with cls.lock:
            cls.truth = msg

    @classmethod
    def _on_odom(cls, msg: Odometry) -> None:
        with cls.lock:
            cls.odom = msg

    @classmethod
    def _on_diag(cls, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.name.startswith("sim: "):
                with cls.lock:
                    cls.diag = {kv.key: kv.value for kv in status.values}

    def pose(self) -> Pose2D:
        with self.lock:
            p = self.truth.pose.pose
        return Pose2D(p.position.x, p.position.y,
                      quaternion_to_yaw(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w))

    def speed(self) -> float:
        with self.lock:
            t = self.odom.twist.twist
        return math.hypot(t.linear.x, t.linear.y) + abs(t.angular.z)

    def drive(self, x: float, y: float, yaw: float, timeout: float = 60.0) -> int:
        self.client.send_goal(goal_msg(x, y, yaw))
        self.assertTrue(self.client.wait_for_result(rospy.Duration(timeout * 10)), "no result")
        return self.client.get_state()

    def obstacle(self, action: int, oid: str = "", **shape: float) -> None:
        msg = Obstacle(action=action, id=oid, **shape)
        msg.header.frame_id = "map"
        self.obstacles.publish(msg)

    # -- the cases, in name order ---------------------------------------------------------
    def test_1_a_goal_on_the_floor_succeeds(self) -> None:
        state = self.drive(40.0, 11.4, -math.pi / 2)
        self.assertEqual(state, GoalStatus.SUCCEEDED, self.client.get_goal_status_text())
        wait_for(lambda: self.speed() < 0.02, 10, "the robot to stand still")
        p = self.pose()
        self.assertLess(math.hypot(p.x - 40.0, p.y - 11.4), 0.4)
        self.assertLess(abs(math.remainder(p.yaw + math.pi / 2, 2 * math.pi)), 0.3)

    def test_2_a_goal_into_a_wall_aborts(self) -> None:
        t0 = time.monotonic()
        state = self.drive(30.0, 10.35, 0.0)          # the corridor's south wall
        self.assertEqual(state, GoalStatus.ABORTED)
        self.assertIn("inside a wall", self.client.get_goal_status_text())
        self.assertLess(time.monotonic() - t0, 5.0)
        bad = goal_msg(35.0, 12.0, 0.0)
        bad.target_pose.pose.orientation.w = 0.0                    # a zero quaternion, as move_base checks
        self.client.send_goal(bad)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(50)))
        self.assertEqual(self.client.get_state(), GoalStatus.ABORTED)
        self.assertIn("zero length", self.client.get_goal_status_text())

    def test_3_a_goal_behind_a_corridor_closed_while_driving_aborts(self) -> None:
        start = self.pose()
        self.client.send_goal(goal_msg(62.0, 12.0, 0.0))
        wait_for(lambda: self.pose().x > start.x + 2.0, 30, "the robot to drive east")
        door_x = self.pose().x + 5.0
        self.obstacle(Obstacle.ADD, "closed_door", shape=Obstacle.RECTANGLE, x=door_x, y=12.0, width=0.2,
                      height=3.6)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(600)))
        self.assertEqual(self.client.get_state(), GoalStatus.ABORTED, self.client.get_goal_status_text())
        self.assertIn("Failed to find a valid plan", self.client.get_goal_status_text())
        wait_for(lambda: self.speed() < 0.02, 10, "the robot to stop")
        self.assertLess(self.pose().x, door_x - 0.1 - 0.3)
        # and a new goal behind the door is refused too (after the planner's patience)
        self.assertEqual(self.drive(62.0, 12.0, 0.0), GoalStatus.ABORTED)
        self.obstacle(Obstacle.CLEAR)

    def test_4_cancel_preempts_and_stops_the_robot(self) -> None:
        start = self.pose()
        self.client.send_goal(goal_msg(10.0, 12.0, math.pi))
        wait_for(lambda: self.speed() > 0.3 and abs(self.pose().x - start.x) > 1.0, 30, "the robot to drive")
        self.client.cancel_goal()
        wait_for(lambda: self.client.get_state() == GoalStatus.PREEMPTED, 10, "PREEMPTED")
        wait_for(lambda: self.speed() < 0.02, 5, "the robot to stop")      # 0.7 m/s at 0.6 m/s^2: ~1.2 s sim
        stopped, t_stop = self.pose(), rospy.get_time()
        wait_for(lambda: rospy.get_time() >= t_stop + 5.0, 30, "5 s of sim time standing still")
        self.assertLess(math.hypot(self.pose().x - stopped.x, self.pose().y - stopped.y), 0.01)

    def test_5_a_new_goal_preempts_the_current_one(self) -> None:
        client = actionlib.ActionClient(Topic.MOVE_BASE, MoveBaseAction)
        self.assertTrue(client.wait_for_server(rospy.Duration(50)))
        first = client.send_goal(goal_msg(60.0, 12.0, 0.0))
        wait_for(lambda: first.get_goal_status() == GoalStatus.ACTIVE, 10, "the first goal to run")
        second = client.send_goal(goal_msg(35.5, 12.6, math.pi / 2))
        wait_for(lambda: first.get_goal_status() == GoalStatus.PREEMPTED, 10, "the first goal PREEMPTED")
        wait_for(lambda: second.get_goal_status() == GoalStatus.SUCCEEDED, 60, "the second goal SUCCEEDED")

    def test_6_make_plan_and_clear_costmaps(self) -> None:
        rospy.wait_for_service(Service.MAKE_PLAN, 10)
        make_plan = rospy.ServiceProxy(Service.MAKE_PLAN, GetPlan)
        req = GetPlanRequest()
        req.goal.header.frame_id = "map"
        req.goal.pose = pose_msg(Pose2D(60.0, 12.0, 0.0))
        plan = make_plan(req).plan
        self.assertGreater(len(plan.poses), 100)
        length = sum(math.hypot(b.pose.position.x - a.pose.position.x, b.pose.position.y - a.pose.position.y)
                     for a, b in zip(plan.poses, plan.poses[1:], strict=False))
        p = self.pose()
        self.assertAlmostEqual(length, math.hypot(60.0 - p.x, 12.0 - p.y), delta=1.5)
        req.goal.pose = pose_msg(Pose2D(30.0, 10.35, 0.0))
        self.assertEqual(make_plan(req).plan.poses, [])                       # no plan: empty
        rospy.ServiceProxy(Service.CLEAR_COSTMAPS, Empty)()

    def test_7_initialpose_relocates_and_bad_ones_are_refused(self) -> None:
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = "map"
        msg.pose.pose = pose_msg(Pose2D(20.0, 12.0, math.pi))
        self.initialpose.publish(msg)
        wait_for(lambda: math.hypot(self.pose().x - 20.0, self.pose().y - 12.0) < 0.01, 10, "the relocation")
        amcl = rospy.wait_for_message(Topic.AMCL_POSE, PoseWithCovarianceStamped, timeout=10)
        self.assertLess(math.hypot(amcl.pose.pose.position.x - 20.0, amcl.pose.pose.position.y - 12.0), 0.2)
        self.assertEqual(amcl.header.frame_id, "map")
        self.assertGreater(amcl.pose.covariance[0], 0.0)
        for x, y in ((math.nan, 12.0), (30.0, 10.35), (500.0, 12.0)):
            bad = PoseWithCovarianceStamped()
            bad.header.frame_id = "map"
            bad.pose.pose = pose_msg(Pose2D(20.0, 12.0, 0.0))
            bad.pose.pose.position.x, bad.pose.pose.position.y = x, y
            self.initialpose.publish(bad)
        wait_for(lambda: self.diag.get("rejected_initialpose") == "3", 20, "3 rejected initial poses")
        self.assertLess(math.hypot(self.pose().x - 20.0, self.pose().y - 12.0), 0.01)
        self.assertEqual(self.drive(25.0, 12.0, 0.0), GoalStatus.SUCCEEDED)  # and it drives from there


    def test_8_map_laser_battery_and_frames(self) -> None:
        grid = rospy.wait_for_message(Topic.MAP, OccupancyGrid, timeout=10)      # latched, as map_server
        self.assertEqual((grid.info.width, grid.info.height, grid.header.frame_id), (1480, 520, "map"))
        self.assertAlmostEqual(grid.info.resolution, 0.05, places=6)
        self.assertEqual((grid.info.origin.position.x, grid.info.origin.position.y), (-1.0, -1.0))
        self.assertEqual(len(grid.data), 1480 * 520)
        served = rospy.ServiceProxy(Service.STATIC_MAP, GetMap)().map
        self.assertEqual(served.info.width, grid.info.width)
        scan = rospy.wait_for_message(Topic.BASE_SCAN, LaserScan, timeout=10)
        self.assertEqual((len(scan.ranges), scan.header.frame_id), (360, "base_laser_link"))
        self.assertTrue(all(scan.range_min <= r <= scan.range_max or math.isinf(r) for r in scan.ranges))
        self.assertGreater(sum(1 for r in scan.ranges if math.isfinite(r)), 300)
        battery = rospy.wait_for_message(Topic.BATTERY, BatteryState, timeout=10)
        self.assertTrue(0.0 < battery.percentage < 1.0 and battery.present)
        statics = rospy.wait_for_message(Topic.TF_STATIC, TFMessage, timeout=10)
        pairs = {(t.header.frame_id, t.child_frame_id) for t in statics.transforms}
        self.assertEqual(pairs, {("base_footprint", "base_link"), ("base_link", "base_laser_link")})
        tf = rospy.wait_for_message(Topic.TF, TFMessage, timeout=10)            # odom -> base and map -> odom
        seen = {(t.header.frame_id, t.child_frame_id) for t in tf.transforms}
        deadline = time.monotonic() + 10
        while not {("odom", "base_footprint"), ("map", "odom")} <= seen and time.monotonic() < deadline:
            seen |= {(t.header.frame_id, t.child_frame_id)
                     for t in rospy.wait_for_message(Topic.TF, TFMessage, timeout=10).transforms}
        self.assertLessEqual({("odom", "base_footprint"), ("map", "odom")}, seen)


    def test_9_move_base_simple_goal_and_feedback(self) -> None:
        results: list[MoveBaseActionResult] = []
        feedback: list[MoveBaseActionFeedback] = []
        subs = [rospy.Subscriber(Topic.MOVE_BASE_RESULT, MoveBaseActionResult, results.append),
                rospy.Subscriber(Topic.MOVE_BASE_FEEDBACK, MoveBaseActionFeedback, feedback.append)]
        simple = rospy.Publisher(Topic.MOVE_BASE_SIMPLE_GOAL, PoseStamped, queue_size=1)
        wait_for(lambda: simple.impl.has_connection(MOVE_BASE) and all(s.get_num_connections() for s in subs), 30,
                 "connections")
        goal = PoseStamped()
        goal.header.frame_id = "map"
        goal.pose = pose_msg(Pose2D(28.0, 12.0, 0.0))
        simple.publish(goal)
        wait_for(lambda: any(r.status.status == GoalStatus.SUCCEEDED for r in results), 30, "SUCCEEDED")
        self.assertTrue(feedback and feedback[-1].feedback.base_position.header.frame_id == "map")
        self.assertLess(math.hypot(self.pose().x - 28.0, self.pose().y - 12.0), 0.4)
        for sub in subs:
            sub.unregister()


if __name__ == "__main__":
    rostest.rosrun("gidabot_sim", NAME, SimNavigation)
