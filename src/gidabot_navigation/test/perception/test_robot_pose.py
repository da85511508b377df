"""The robot's pose at a scan's time: the latest localisation carried forward by odometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.perception.robot_pose import RobotPose, _inverse, _matrix


def test_no_pose_before_the_first_localisation() -> None:
    poses = RobotPose()
    poses.odometry(0.0, Pose2D(0.0, 0.0, 0.0))
    assert poses.at(0.0) is None


def test_without_odometry_the_latest_localisation() -> None:
    poses = RobotPose()
    poses.localised(1.0, Pose2D(3.0, 4.0, 0.5))
    assert poses.at(7.0) == Pose2D(3.0, 4.0, 0.5)


def test_odometry_carries_the_localisation_to_the_scan_time() -> None:
    """Odometry drifted (its frame is off the map by a shift and a turn); localisation at t = 1 s puts the robot
    at (10, 5) facing +y; the robot then drives 1 m forward by t = 3 s: at the map's (10, 6)."""
    poses = RobotPose()

    def odom(t: float) -> Pose2D:                        # 0.5 m/s along the odometry frame's x from t = 1 s
        return Pose2D(2.0 + 0.5 * max(t - 1.0, 0.0), -1.0, 0.0)
    for k in range(31):
        poses.odometry(k / 10, odom(k / 10))
        if k == 10:
            poses.localised(1.0, Pose2D(10.0, 5.0, math.pi / 2))
    at = poses.at(3.0)
    assert (at.x, at.y, at.yaw) == pytest.approx((10.0, 6.0, math.pi / 2))
    between = poses.at(2.05)                             # interpolated between two odometry poses
    assert (between.x, between.y) == pytest.approx((10.0, 5.525))


def test_a_time_beyond_the_odometry_falls_back_to_the_localisation() -> None:
    poses = RobotPose()
    poses.odometry(0.0, Pose2D(0.0, 0.0, 0.0))
    poses.odometry(0.1, Pose2D(0.05, 0.0, 0.0))
    poses.localised(0.1, Pose2D(1.0, 1.0, 0.0))
    assert poses.at(5.0) == Pose2D(1.0, 1.0, 0.0)
    poses.odometry(0.05, Pose2D(9.0, 9.0, 0.0))          # time went back: the history starts again
    again = poses.at(0.05)                               # with the correction of the latest localisation
    assert (again.x, again.y, again.yaw) == pytest.approx((9.95, 10.0, 0.0))


def test_a_robot_at_rest_keeps_its_latest_odometry_however_old() -> None:
    """The robot turned 0.08 rad after its latest localisation (too little for a new one) and rests; its odometry
    comes at 1 Hz: a scan 0.7 s after the latest still gets the exact pose, not the localisation of before the
    turn. Moving, a time that far beyond the odometry falls back to the localisation as before."""
    poses = RobotPose()
    poses.odometry(0.0, Pose2D(0.0, 0.0, 0.0))
    poses.localised(0.0, Pose2D(5.0, 5.0, 0.0))
    poses.odometry(1.0, Pose2D(0.0, 0.0, 0.08), moving=False)
    at = poses.at(1.7)
    assert (at.x, at.y, at.yaw) == pytest.approx((5.0, 5.0, 0.08))
    poses.odometry(2.0, Pose2D(0.0, 0.0, 0.08), moving=True)
    assert poses.at(2.7) == Pose2D(5.0, 5.0, 0.0)


def test_the_closed_form_inverse_undoes_the_pose() -> None:
    for pose in (Pose2D(0.0, 0.0, 0.0), Pose2D(3.2, -1.5, 2.9), Pose2D(-7.0, 4.0, -math.pi), Pose2D(1e3, 2e3, 0.3)):
        product = _matrix(pose) @ _inverse(pose)
        assert np.allclose(product, np.eye(3), atol=1e-9)
        assert np.allclose(_inverse(pose), np.linalg.inv(_matrix(pose)), atol=1e-9)
