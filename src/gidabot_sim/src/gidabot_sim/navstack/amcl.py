"""Localisation stand-in and pose tracking (ROS-free).

:class:`AmclCore` plays amcl: it turns the simulator's ground truth into an
estimate with plausible, slowly varying error (an Ornstein-Uhlenbeck process per
axis, like a particle filter's drifting mean) and a filled covariance, decides
when to publish it (amcl publishes after the robot moved ``update_min_d`` or
turned ``update_min_a``, and after a relocation), and computes the ``map -> odom``
transform from the estimate and the odometry at the same stamp.

:class:`PoseTracker` is what the move_base stand-in uses instead of a tf
listener: ``map -> base`` = ``map -> odom`` (from the latest estimate and the
odometry at its stamp) composed with the latest odometry.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from gidabot_navigation.building.geometry import Pose2D, wrap_angle
from gidabot_sim.errors import SimConfigError
from gidabot_sim.world.kinematics import ZERO, Twist2D, compose, inverse


@dataclass(frozen=True)
class AmclConfig:
    noise_xy: float = 0.03        # m, standard deviation of the position error
    noise_yaw: float = 0.02       # rad, standard deviation of the heading error
    noise_tau: float = 3.0        # s, correlation time of the error
    update_min_d: float = 0.1     # m moved before a new estimate is published (amcl: 0.2)
    update_min_a: float = 0.1     # rad turned before a new estimate is published (amcl: pi/6)
    jump_distance: float = 1.0    # m: a ground-truth jump larger than this is a relocation (initialpose)

    def __post_init__(self) -> None:
        for name in ("noise_xy", "noise_yaw", "update_min_d", "update_min_a"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise SimConfigError(f"amcl {name}: {value!r} must be a finite number >= 0")
        for name in ("noise_tau", "jump_distance"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SimConfigError(f"amcl {name}: {value!r} must be a finite number > 0")


@dataclass(frozen=True)
class Estimate:
    stamp: float                  # s (sim time)
    pose: Pose2D                  # map frame
    covariance: tuple[float, ...] # 36 values, row-major (x, y, z, roll, pitch, yaw)


class OdomHistory:
    """Recent odometry poses by stamp (for pairing with an estimate of the same time)."""

    def __init__(self, horizon: float = 5.0) -> None:
        self.horizon = horizon
        self._stamps: list[float] = []
        self._poses: list[Pose2D] = []

    def add(self, stamp: float, pose: Pose2D) -> None:
        if self._stamps and stamp < self._stamps[-1]:       # time went back (sim restarted): start over
            self._stamps.clear()
            self._poses.clear()
        self._stamps.append(stamp)
        self._poses.append(pose)
        cut = bisect.bisect_left(self._stamps, stamp - self.horizon)
        if cut > 0:
            del self._stamps[:cut], self._poses[:cut]

    def at(self, stamp: float) -> Pose2D | None:
        """The odometry pose whose stamp is closest to ``stamp`` (None if empty)."""
        if not self._stamps:
            return None
        k = bisect.bisect_left(self._stamps, stamp)
        best = min((j for j in (k - 1, k) if 0 <= j < len(self._stamps)),
                   key=lambda j: abs(self._stamps[j] - stamp))
        return self._poses[best]

    @property
    def latest(self) -> tuple[float, Pose2D] | None:
        return (self._stamps[-1], self._poses[-1]) if self._stamps else None


class AmclCore:
    """Ground truth + correlated noise -> amcl_pose; ``map -> odom`` from estimate and odometry."""

    def __init__(self, config: AmclConfig, rng: np.random.Generator | None = None) -> None:
        self.config = config
        self.rng = rng if rng is not None else np.random.default_rng()
        self.error = np.zeros(3)              # current (x, y, yaw) error
        self._error_time: float | None = None
        self.last: Estimate | None = None     # last published estimate
        self._last_truth: Pose2D | None = None
        self.last_truth_at_publish = Pose2D(0.0, 0.0, 0.0)
        self.odom = OdomHistory()
        self.relocations = 0

    def covariance(self) -> tuple[float, ...]:
        cov = [0.0] * 36
        cov[0] = cov[7] = max(self.config.noise_xy, 1e-3) ** 2
        cov[35] = max(self.config.noise_yaw, 1e-3) ** 2
        return tuple(cov)

    def _advance_error(self, stamp: float) -> None:
        if self._error_time is None:
            self.error = self.rng.normal(0.0, 1.0, 3) * self._sigmas()
        elif stamp > self._error_time:
            decay = math.exp(-(stamp - self._error_time) / self.config.noise_tau)
            self.error = self.error * decay + self.rng.normal(0.0, 1.0, 3) * self._sigmas() * math.sqrt(
                1.0 - decay * decay)
        self._error_time = stamp

    def _sigmas(self) -> np.ndarray:
        return np.array([self.config.noise_xy, self.config.noise_xy, self.config.noise_yaw])

    def on_odom(self, stamp: float, pose: Pose2D) -> None:
        self.odom.add(stamp, pose)

    def on_truth(self, stamp: float, truth: Pose2D) -> Estimate | None:
        """A ground-truth pose; returns an estimate to publish, or None when the robot has not moved enough."""
        last = self._last_truth
        jumped = last is not None and math.hypot(truth.x - last.x, truth.y - last.y) > self.config.jump_distance
        if jumped:
            self.relocations += 1
        due = (self.last is None or jumped or last is None
               or math.hypot(truth.x - self.last_truth_at_publish.x, truth.y - self.last_truth_at_publish.y)
               >= self.config.update_min_d
               or abs(wrap_angle(truth.yaw - self.last_truth_at_publish.yaw)) >= self.config.update_min_a)
        self._last_truth = truth
        if not due:
            return None
        self._advance_error(stamp)
        ex, ey, eyaw = (float(v) for v in self.error)
        estimate = Estimate(stamp, Pose2D(truth.x + ex, truth.y + ey, wrap_angle(truth.yaw + eyaw)),
                            self.covariance())
        self.last = estimate
        self.last_truth_at_publish = truth
        return estimate

    def map_to_odom(self) -> Pose2D | None:
        """``map -> odom`` so that ``map -> odom -> base`` is the last estimate (None before both exist)."""
        if self.last is None:
            return None
        odom = self.odom.at(self.last.stamp)
        if odom is None:
            return None
        return compose(self.last.pose, inverse(odom))


class PoseTracker:
    """The robot's pose in the map from odometry (continuous) and localisation estimates (corrections)."""

    def __init__(self) -> None:
        self.odom = OdomHistory()
        self.velocity: Twist2D = ZERO
        self.map_to_odom: Pose2D | None = None
        self.stamp: float | None = None        # stamp of the latest odometry
        self._pending: tuple[float, Pose2D] | None = None   # an estimate newer than the odometry

    def on_odom(self, stamp: float, pose: Pose2D, velocity: Twist2D) -> None:
        self.odom.add(stamp, pose)
        self.velocity, self.stamp = velocity, stamp
        if self._pending is not None and stamp >= self._pending[0] - 1e-9:
            self._resolve()

    def on_estimate(self, stamp: float, pose: Pose2D) -> None:
        """A localisation estimate; paired with the odometry of the same stamp (waits for it if needed)."""
        self._pending = (stamp, pose)
        if self.stamp is not None and self.stamp >= stamp - 1e-9:
            self._resolve()

    def _resolve(self) -> None:
        if self._pending is None:
            return
        stamp, pose = self._pending
        odom = self.odom.at(stamp)
        if odom is not None:
            self.map_to_odom = compose(pose, inverse(odom))
            self._pending = None

    def pose(self) -> Pose2D | None:
        """The current map pose, or None until odometry and a first estimate arrived."""
        if self.map_to_odom is None:
            self._resolve()          # no odometry at the estimate's stamp yet: use the closest
        latest = self.odom.latest
        if latest is None or self.map_to_odom is None:
            return None
        return compose(self.map_to_odom, latest[1])
