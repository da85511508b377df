"""The move_base node without a master (rospy and actionlib's server faked): goals, odometry and estimates in;
commands, answers, results, the goal, plans and services out. Its main() on a real master: the rostest
src/gidabot_sim/test/sim_navigation.test and tests/sim/test_sim_system.py."""

from __future__ import annotations

from pathlib import Path

import pytest
import rospy
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, Quaternion
from move_base_msgs.msg import MoveBaseActionGoal, MoveBaseGoal
from nav_msgs.msg import Odometry
from nav_msgs.srv import GetPlanRequest
from sim_support import FakeActionServer

from gidabot_msgs.msg import Obstacle, ObstacleArray, StepDone
from gidabot_navigation.interface import Service, Topic
from gidabot_sim.navstack import move_base_node
from gidabot_sim.ros.convert import stamp

FACULTY = str(Path(__file__).resolve().parents[4] / "maps" / "faculty")



def goal(x: float, y: float, frame: str = "map") -> MoveBaseGoal:
    msg = MoveBaseGoal()
    msg.target_pose.header.frame_id = frame
    msg.target_pose.pose.position.x, msg.target_pose.pose.position.y = x, y
    msg.target_pose.pose.orientation = Quaternion(0, 0, 0, 1)
    return msg


@pytest.fixture
def node(fake_ros, monkeypatch):
    fake_ros.params.update({"~building": FACULTY, "~robot": "Kbot"})
    monkeypatch.setattr(move_base_node.actionlib, "SimpleActionServer", FakeActionServer)
    return move_base_node.MoveBaseNode()


def odometry(t: float, x: float = 0.0) -> Odometry:
    msg = Odometry()
    msg.header.stamp = stamp(t)
    msg.pose.pose.position.x = x
    msg.pose.pose.orientation = Quaternion(0, 0, 0, 1)
    return msg


def estimate(t: float, x: float, y: float) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header.stamp, msg.header.frame_id = stamp(t), "map"
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation = Quaternion(0, 0, 0, 1)
    return msg


def answers(fake_ros) -> list[StepDone]:
    return fake_ros.pubs[Topic.SIM_STEP_DONE].sent


def test_a_goal_is_answered_at_once_then_driven_on_the_odometry_of_each_step(node, fake_ros) -> None:
    assert node.server.started and fake_ros.subscribed(Topic.MOVE_BASE_SIMPLE_GOAL)
    assert {Service.MAKE_PLAN, Service.CLEAR_COSTMAPS} <= set(fake_ros.services)
    fake_ros.deliver(Topic.ODOM, odometry(0.0))
    fake_ros.deliver(Topic.AMCL_POSE, estimate(0.0, 30.0, 12.0))
    node.server.send(goal(40.0, 12.0))
    [owed] = answers(fake_ros)
    assert (owed.node, owed.idle, owed.inputs, owed.done.to_sec()) == ("/test_node", False, ["/odom"], 0.0)
    fake_ros.deliver(Topic.ODOM, odometry(0.1))
    current = fake_ros.pubs[Topic.MOVE_BASE_CURRENT_GOAL].sent[-1]
    assert isinstance(current, PoseStamped) and current.header.frame_id == "map" and current.pose.position.x == 40.0
    cmd = fake_ros.pubs[Topic.CMD_VEL].sent[-1]
    assert cmd.linear.x > 0.0 or cmd.angular.z != 0.0
    assert fake_ros.pubs[Topic.MOVE_BASE_PLAN].sent[-1].poses[-1].pose.position.x == pytest.approx(40.0, abs=0.1)
    step = answers(fake_ros)[-1]
    assert (step.done.to_sec(), step.idle, step.commands) == (pytest.approx(0.1), False, 1)
    assert node.server.feedbacks[-1].base_position.pose.position.x == pytest.approx(30.0)


def test_a_goal_in_another_frame_is_aborted(node, fake_ros) -> None:
    fake_ros.deliver(Topic.ODOM, odometry(0.0))
    node.server.send(goal(40.0, 12.0, frame="odom"))
    fake_ros.deliver(Topic.ODOM, odometry(0.1))
    [(kind, text)] = node.server.results
    assert kind == "aborted" and "not the map frame" in text
    assert answers(fake_ros)[-1].idle and node.loop.rejected.counts == {"goal": 1}


def test_obstacles_and_robots_seen_reach_the_costmap(node, fake_ros) -> None:
    array = ObstacleArray(obstacles=[Obstacle(id="p", shape=Obstacle.CIRCLE, x=40.0, y=12.0, radius=0.3),
                                     Obstacle(id="bad", shape=Obstacle.CIRCLE, x=40.0, y=12.0, radius=-1.0)])
    fake_ros.deliver(Topic.SIM_OBSTACLES, array)
    fake_ros.deliver(Topic.ROBOTS_SEEN, ObstacleArray(obstacles=[Obstacle(id="Tartalo", x=20.0, y=12.0, radius=0.3)]))
    node.loop.idle_turn()
    assert list(node.loop.nav._obstacles) == ["p"] and list(node.loop.nav._robots) == ["Tartalo"]


def test_make_plan_answers_a_plan_an_empty_one_or_refuses_while_a_goal_runs(node, fake_ros) -> None:
    req = GetPlanRequest()
    req.start.header.frame_id = req.goal.header.frame_id = "map"
    req.start.pose.position.x, req.start.pose.position.y = 30.0, 12.0
    req.goal.pose.position.x, req.goal.pose.position.y = 40.0, 12.0
    req.start.pose.orientation = req.goal.pose.orientation = Quaternion(0, 0, 0, 1)
    plan = fake_ros.services[Service.MAKE_PLAN](req).plan
    assert plan.header.frame_id == "map" and len(plan.poses) > 100
    req.goal.pose.position.y = 10.35                                  # in the wall
    assert fake_ros.services[Service.MAKE_PLAN](req).plan.poses == []
    node.server.active = True
    with pytest.raises(rospy.ServiceException, match="inactive state"):
        fake_ros.services[Service.MAKE_PLAN](req)
    fake_ros.services[Service.CLEAR_COSTMAPS](None)


def test_a_simple_goal_is_sent_again_as_an_action_goal(node, fake_ros) -> None:
    simple = PoseStamped()
    simple.header.frame_id = "map"
    fake_ros.deliver(Topic.MOVE_BASE_SIMPLE_GOAL, simple)
    [sent] = fake_ros.pubs[Topic.MOVE_BASE_GOAL].sent
    assert isinstance(sent, MoveBaseActionGoal) and sent.goal.target_pose is simple


def test_the_loop_says_it_is_idle_then_turns_until_a_signal(node, fake_ros, monkeypatch) -> None:
    class Guard:
        requested = False

        def set_wake(self, wake) -> None:
            self.wake = wake

        def loop_stopped(self) -> None:
            self.stopped = True

    guard, shutdown = Guard(), iter([False, True])
    monkeypatch.setattr(move_base_node.rospy, "is_shutdown", lambda: next(shutdown))
    array = ObstacleArray(obstacles=[Obstacle(id="p", shape=Obstacle.CIRCLE, x=40.0, y=12.0, radius=0.3)])
    fake_ros.deliver(Topic.SIM_OBSTACLES, array)         # idle: taken by the loop's turn
    node.run(guard)
    assert guard.stopped and guard.wake == node.wake.set
    assert [a.idle for a in answers(fake_ros)] == [True] and list(node.loop.nav._obstacles) == ["p"]
