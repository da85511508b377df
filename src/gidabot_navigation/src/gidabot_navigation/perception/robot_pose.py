"""The robot's pose in the map at the time of a scan (ROS-free), from localisation and odometry.

Localisation (``amcl_pose``) comes only after the robot has moved some distance or turned some angle
(amcl: 0.2 m or 0.5 rad by default), so its latest pose is up to that much behind a scan taken while the
robot moves; a person 2 m away would be placed 0.2-1 m off. Odometry comes at the scan's rate and drifts
only slowly: :class:`RobotPose` keeps the map-from-odometry correction of the latest localisation
(``map pose`` composed with the inverse of the odometry pose of that time) and applies it to the
odometry pose of the scan's time, interpolated. Without odometry, it is the latest localised pose. A robot at rest
may publish its odometry less often (the simulator: 1 Hz): a scan after the latest odometry of a robot at rest
gets that odometry however old it is (it has not moved since), not the localisation of some time before.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from gidabot_navigation.building.geometry import Pose2D, wrap_angle

HISTORY = 5.0          # s of odometry kept
MAX_EXTRAPOLATION = 0.5  # s: beyond the odometry's ends by more, a time has no odometry pose


def _matrix(p: Pose2D) -> np.ndarray:
    c, s = math.cos(p.yaw), math.sin(p.yaw)
    return np.array([[c, -s, p.x], [s, c, p.y], [0.0, 0.0, 1.0]])


def _inverse(p: Pose2D) -> np.ndarray:
    """The inverse of :func:`_matrix` of ``p``, in closed form (a LAPACK inverse of a 3 x 3 costs far more)."""
    c, s = math.cos(p.yaw), math.sin(p.yaw)
    return np.array([[c, s, -(c * p.x + s * p.y)], [-s, c, s * p.x - c * p.y], [0.0, 0.0, 1.0]])


def _pose(m: np.ndarray) -> Pose2D:
    return Pose2D(float(m[0, 2]), float(m[1, 2]), math.atan2(m[1, 0], m[0, 0]))


class RobotPose:
    """Poses of the robot in the map, at any recent time (see the module's docstring)."""

    def __init__(self) -> None:
        self._odom_t: list[float] = []
        self._odom: list[Pose2D] = []
        self._correction: np.ndarray | None = None   # map <- odom, 3 x 3
        self._localised: Pose2D | None = None
        self._resting = False                         # the latest odometry said the robot stood still

    def odometry(self, t: float, pose: Pose2D, moving: bool = True) -> None:
        """The odometry pose (odom frame) at ``t`` s, and whether the robot was moving then (its twist). Older than
        the latest: history restarts (time went back)."""
        self._resting = not moving
        if self._odom_t and t < self._odom_t[-1]:
            self._odom_t.clear()
            self._odom.clear()
        self._odom_t.append(t)
        self._odom.append(pose)
        cut = bisect.bisect_left(self._odom_t, t - HISTORY)
        if cut:
            del self._odom_t[:cut], self._odom[:cut]

    def localised(self, t: float, pose: Pose2D) -> None:
        """The robot's pose in the map at ``t`` s (localisation)."""
        self._localised = pose
        odom = self._odom_at(t)
        self._correction = None if odom is None else _matrix(pose) @ _inverse(odom)

    def at(self, t: float) -> Pose2D | None:
        """The robot's pose in the map at ``t`` s; None before the first localisation."""
        if self._localised is None:
            return None
        odom = self._odom_at(t) if self._correction is not None else None
        if odom is None:
            return self._localised
        return _pose(self._correction @ _matrix(odom))

    def _odom_at(self, t: float) -> Pose2D | None:
        times = self._odom_t
        if not times or t < times[0] - MAX_EXTRAPOLATION:
            return None
        if t > times[-1] + MAX_EXTRAPOLATION:
            return self._odom[-1] if self._resting else None
        k = bisect.bisect_left(times, t)
        if k == 0:
            return self._odom[0]
        if k == len(times):
            return self._odom[-1]
        t0, t1 = times[k - 1], times[k]
        a, b = self._odom[k - 1], self._odom[k]
        f = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
        return Pose2D(a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), wrap_angle(a.yaw + f * wrap_angle(b.yaw - a.yaw)))
