"""Localisation stand-in and pose tracking (ROS-free).

:class:`AmclCore` plays amcl: it turns the simulator's ground truth into an
estimate with plausible, slowly varying error (an Ornstein-Uhlenbeck process per
axis, like a particle filter's drifting mean) and a filled covariance, decides
when to publish it (amcl publishes after the robot moved ``update_min_d`` or
turned ``update_min_a``, and after a relocation), and computes the ``map -> odom``
transform from the estimate and the odometry at the same stamp.

:class:`AmclLoop` is what the ``/amcl`` node runs: it feeds the core every ground truth of the simulator
(and the odometry, needed only for tf), and says what to publish for it and that the step is answered.

:class:`PoseTracker` is what the move_base stand-in uses instead of a tf
listener: ``map -> base`` = ``map -> odom`` (from the latest estimate and the
odometry at its stamp) composed with the latest odometry.
"""

from __future__ import annotations

import bisect
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gidabot_navigation.building.geometry import Pose2D, wrap_angle
from gidabot_navigation.interface import Topic
from gidabot_navigation.logs import Logger
from gidabot_sim.errors import SimConfigError
from gidabot_sim.world.clock import Periodic
from gidabot_sim.world.kinematics import ZERO, Twist2D, compose, inverse
from gidabot_sim.world.rejections import CountingLog


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


@dataclass(frozen=True)
class TruthAnswer:
    """What the amcl node does for one ground truth: publish ``estimate`` (None: none is due), tf ``map -> odom``
    = ``map_odom`` stamped ``tf_stamp`` (None: none), subscribe to odometry or not (``follow_odom``: only tf
    needs it), then answer the simulator through ``done``."""

    estimate: Estimate | None
    map_odom: Pose2D | None
    tf_stamp: float
    follow_odom: bool
    done: float


class AmclLoop:
    """The amcl stand-in as its node runs it: :class:`AmclCore` on the simulator's ground truth (a lockstep
    participant, idle, answering every ground truth once its estimate is out), tf at ``tf_rate`` (Hz, sim time)
    and with every estimate, stamped ``tolerance`` s ahead as amcl does. Odometry and ground truth arrive in
    different threads."""

    def __init__(self, core: AmclCore, log: Logger, tf_rate: float = 10.0, tolerance: float = 0.1) -> None:
        self.core = core
        self.tf_due = Periodic(tf_rate)
        self.tolerance = tolerance
        self.rejected = CountingLog(log.error)
        self.lock = threading.Lock()

    def on_odom(self, read: Callable[[], tuple[float, Pose2D]]) -> None:
        """An odometry message (``read()``: stamp and pose in the odom frame)."""
        odom = self.rejected.read(Topic.ODOM, "amcl: ignoring", read)
        if odom is not None:
            with self.lock:
                self.core.on_odom(*odom)

    def on_truth(self, t: float, read: Callable[[], Pose2D], tf_listeners: bool) -> TruthAnswer:
        """The ground truth stamped ``t`` (``read()``: the true pose); ``tf_listeners``: somebody listens to /tf."""
        truth = self.rejected.read(Topic.BASE_POSE_GROUND_TRUTH, "amcl: ignoring", read)
        if truth is None:
            return TruthAnswer(None, None, t, tf_listeners, t)
        with self.lock:
            estimate = self.core.on_truth(t, truth)
            tf_due = self.tf_due.due(t) or estimate is not None
            map_odom = self.core.map_to_odom() if tf_due and tf_listeners else None
        return TruthAnswer(estimate, map_odom, t + self.tolerance, tf_listeners, t)


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
