"""The amcl node without a master (rospy faked): ground truth in; amcl_pose, tf and the lockstep answer out;
odometry subscribed only while /tf has listeners. Its main() on a real master: tests/sim/test_sim_system.py."""

from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped, Quaternion
from nav_msgs.msg import Odometry

from gidabot_navigation.interface import Topic
from gidabot_sim.navstack import amcl_node
from gidabot_sim.ros.convert import stamp


def odometry(t: float, x: float, y: float = 2.0) -> Odometry:
    msg = Odometry()
    msg.header.stamp = stamp(t)
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    msg.pose.pose.orientation = Quaternion(0, 0, 0, 1)
    return msg


@pytest.fixture
def node(fake_ros):
    fake_ros.params.update({"~noise_xy": 0.0, "~noise_yaw": 0.0, "~seed": 4, "~odom_frame_id": "robot_0/odom"})
    return amcl_node.AmclNode()


def test_each_ground_truth_gets_its_estimate_when_due_and_an_answer(node, fake_ros) -> None:
    steps = fake_ros.pubs[Topic.SIM_STEP_DONE].sent
    assert steps[0].idle and steps[0].inputs == ["/base_pose_ground_truth"]
    fake_ros.pubs[Topic.TF].connections = 0
    fake_ros.deliver(Topic.BASE_POSE_GROUND_TRUTH, odometry(1.0, 5.0))
    [estimate] = fake_ros.pubs[Topic.AMCL_POSE].sent
    assert isinstance(estimate, PoseWithCovarianceStamped) and estimate.header.frame_id == "map"
    assert estimate.pose.pose.position.x == pytest.approx(5.0) and estimate.header.stamp.to_sec() == 1.0
    assert steps[-1].done.to_sec() == 1.0 and not fake_ros.subscribed(Topic.ODOM) and fake_ros.pubs[Topic.TF].sent == []
    fake_ros.deliver(Topic.BASE_POSE_GROUND_TRUTH, odometry(1.1, math.nan))
    assert len(steps) == 3 and node.loop.rejected.counts == {"base_pose_ground_truth": 1}


def test_tf_map_to_odom_goes_out_while_somebody_listens(node, fake_ros) -> None:
    fake_ros.deliver(Topic.BASE_POSE_GROUND_TRUTH, odometry(0.0, 5.0))
    assert fake_ros.subscribed(Topic.ODOM)                         # /tf has a listener
    fake_ros.deliver(Topic.ODOM, odometry(0.5, 1.0, 0.0))
    fake_ros.deliver(Topic.BASE_POSE_GROUND_TRUTH, odometry(0.5, 6.0))
    [tf] = fake_ros.pubs[Topic.TF].sent[-1].transforms
    assert (tf.header.frame_id, tf.child_frame_id) == ("map", "robot_0/odom")
    assert (tf.transform.translation.x, tf.transform.translation.y) == pytest.approx((5.0, 2.0))
    assert tf.header.stamp.to_sec() == pytest.approx(0.6)          # transform_tolerance ahead
    fake_ros.pubs[Topic.TF].connections = 0
    fake_ros.deliver(Topic.BASE_POSE_GROUND_TRUTH, odometry(1.0, 7.0))
    assert not fake_ros.subscribed(Topic.ODOM)
