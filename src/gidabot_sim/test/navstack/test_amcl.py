"""The amcl stand-in's core, its node's loop and the pose tracker: noise, publishing policy, relocation,
map -> odom, tf only for listeners, every ground truth answered."""

from __future__ import annotations

import math

import numpy as np
import pytest
from sim_support import ListLog

from gidabot_navigation.building.geometry import Pose2D
from gidabot_sim.errors import PoseRejected, SimConfigError
from gidabot_sim.navstack.amcl import AmclConfig, AmclCore, AmclLoop, OdomHistory, PoseTracker
from gidabot_sim.world.kinematics import Twist2D, compose


def close(a: Pose2D, b: Pose2D, tol: float = 1e-9) -> bool:
    return abs(a.x - b.x) < tol and abs(a.y - b.y) < tol and abs(math.remainder(a.yaw - b.yaw, 2 * math.pi)) < tol


def test_estimates_have_plausible_correlated_error_and_a_filled_covariance() -> None:
    core = AmclCore(AmclConfig(noise_xy=0.03, noise_yaw=0.02, noise_tau=3.0, update_min_d=0.0),
                    np.random.default_rng(1))
    errors = []
    for k in range(20000):
        t = k * 0.1
        truth = Pose2D(0.01 * k, 2.0, 0.0)
        est = core.on_truth(t, truth)
        assert est is not None and est.stamp == t
        errors.append((est.pose.x - truth.x, est.pose.y - truth.y, est.pose.yaw))
    e = np.array(errors)
    assert e[:, 0].std() == pytest.approx(0.03, rel=0.15) and e[:, 2].std() == pytest.approx(0.02, rel=0.15)
    lag1 = np.corrcoef(e[:-1, 0], e[1:, 0])[0, 1]
    assert lag1 == pytest.approx(math.exp(-0.1 / 3.0), abs=0.03)      # slowly varying, like a filter's mean
    cov = est.covariance
    assert cov[0] == cov[7] == pytest.approx(0.03 ** 2) and cov[35] == pytest.approx(0.02 ** 2)
    assert sum(1 for v in cov if v) == 3


def test_published_after_moving_or_turning_enough_and_after_a_relocation() -> None:
    core = AmclCore(AmclConfig(update_min_d=0.1, update_min_a=0.1), np.random.default_rng(2))
    assert core.on_truth(0.0, Pose2D(1.0, 1.0, 0.0)) is not None       # the first one
    assert core.on_truth(0.1, Pose2D(1.05, 1.0, 0.0)) is None
    assert core.on_truth(0.2, Pose2D(1.11, 1.0, 0.0)) is not None
    assert core.on_truth(0.3, Pose2D(1.11, 1.0, 0.05)) is None
    assert core.on_truth(0.4, Pose2D(1.11, 1.0, 0.12)) is not None
    est = core.on_truth(0.5, Pose2D(20.0, 5.0, 3.0))                   # initialpose moved the robot
    assert est is not None and core.relocations == 1
    assert math.hypot(est.pose.x - 20.0, est.pose.y - 5.0) < 0.2
    with pytest.raises(SimConfigError):
        AmclConfig(noise_tau=0.0)


def test_map_to_odom_makes_the_tf_chain_give_the_estimate() -> None:
    core = AmclCore(AmclConfig(), np.random.default_rng(3))
    assert core.map_to_odom() is None
    odom = Pose2D(0.7, -0.2, 0.4)
    core.on_odom(1.0, Pose2D(0.0, 0.0, 0.0))
    core.on_odom(2.0, odom)
    est = core.on_truth(2.0, Pose2D(12.0, 5.0, 1.0))
    assert close(compose(core.map_to_odom(), odom), est.pose)


def test_pose_tracker_pairs_estimates_with_odometry_of_the_same_stamp() -> None:
    tracker = PoseTracker()
    assert tracker.pose() is None
    tracker.on_odom(1.0, Pose2D(0.0, 0.0, 0.0), Twist2D())
    tracker.on_estimate(2.0, Pose2D(10.0, 5.0, 0.0))       # arrives before the odometry of t = 2
    tracker.on_odom(2.0, Pose2D(1.0, 0.0, 0.0), Twist2D(0.5, 0.0, 0.0))
    assert close(tracker.pose(), Pose2D(10.0, 5.0, 0.0))
    tracker.on_odom(3.0, Pose2D(1.5, 0.0, 0.0), Twist2D(0.5, 0.0, 0.0))
    assert close(tracker.pose(), Pose2D(10.5, 5.0, 0.0)) and tracker.velocity.vx == 0.5
    tracker.on_estimate(3.0, Pose2D(30.0, 5.0, math.pi))    # relocated
    assert close(tracker.pose(), Pose2D(30.0, 5.0, math.pi))
    history = OdomHistory(horizon=1.0)
    for k in range(30):
        history.add(k * 0.1, Pose2D(k, 0, 0))
    assert history.at(2.86) == Pose2D(29, 0, 0) and history.at(0.0).x in (19, 20)   # older ones dropped
    history.add(0.5, Pose2D(-1, 0, 0))                      # time went back: start over
    assert history.latest == (0.5, Pose2D(-1, 0, 0))



def test_the_node_loop_answers_every_ground_truth_and_sends_tf_only_to_listeners() -> None:
    log = ListLog()
    loop = AmclLoop(AmclCore(AmclConfig(noise_xy=0.0, noise_yaw=0.0), np.random.default_rng(3)), log, tf_rate=1.0,
                    tolerance=0.1)
    first = loop.on_truth(0.0, lambda: Pose2D(5.0, 2.0, 0.0), tf_listeners=False)
    assert first.estimate is not None and first.map_odom is None and not first.follow_odom and first.done == 0.0
    same = loop.on_truth(0.2, lambda: Pose2D(5.0, 2.0, 0.0), tf_listeners=True)
    assert same.estimate is None and same.follow_odom and same.map_odom is None     # no odometry yet
    loop.on_odom(lambda: (0.3, Pose2D(1.0, 0.0, 0.0)))
    moved = loop.on_truth(0.3, lambda: Pose2D(6.0, 2.0, 0.0), tf_listeners=True)
    assert moved.estimate is not None and close(moved.map_odom, Pose2D(5.0, 2.0, 0.0), 1e-6)
    assert moved.tf_stamp == pytest.approx(0.4) and moved.done == 0.3
    quiet = loop.on_truth(0.5, lambda: Pose2D(6.0, 2.0, 0.0), tf_listeners=True)
    assert quiet.estimate is None and quiet.map_odom is None                       # tf at 1 Hz, or with an estimate

    def bad() -> Pose2D:
        raise PoseRejected("base_pose_ground_truth: non-finite values (nan, ...)")

    rejected = loop.on_truth(0.6, bad, tf_listeners=True)
    assert (rejected.estimate, rejected.map_odom, rejected.done) == (None, None, 0.6)
    loop.on_odom(bad)
    assert loop.rejected.counts == {"base_pose_ground_truth": 1, "odom": 1} and len(log.lines) == 2
