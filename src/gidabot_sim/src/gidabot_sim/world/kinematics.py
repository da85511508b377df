"""Planar robot kinematics (ROS-free): velocity and acceleration limits, exact integration, SE(2) algebra.

Two drives, as in the building file (``drive``):

* ``differential``: body velocity (v, 0, w); a lateral component of a command is ignored.
* ``synchro`` (holonomic synchro-drive, MariSorgin's B21): the wheels steer together,
  so the base moves in any direction (vx, vy) while the body turns at w independently.
  ``max_linear`` bounds the speed |(vx, vy)|, ``max_linear_accel`` the norm of the
  acceleration vector.

Body velocities follow REP 103 (x forward, y left, w counter-clockwise), in m/s and rad/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gidabot_navigation.building.geometry import Pose2D, wrap_angle
from gidabot_sim.errors import CommandRejected, SimConfigError

DIFFERENTIAL = "differential"
SYNCHRO = "synchro"


@dataclass(frozen=True)
class Twist2D:
    """A body-frame velocity: vx, vy (m/s), wz (rad/s)."""

    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0

    @property
    def speed(self) -> float:
        """Linear speed |(vx, vy)| in m/s."""
        return math.hypot(self.vx, self.vy)

    def is_zero(self, eps: float = 1e-9) -> bool:
        return abs(self.vx) <= eps and abs(self.vy) <= eps and abs(self.wz) <= eps


ZERO = Twist2D()


@dataclass(frozen=True)
class Limits:
    """Velocity and acceleration limits of one robot (from the building file)."""

    max_linear: float          # m/s
    max_angular: float         # rad/s
    max_linear_accel: float    # m/s^2
    max_angular_accel: float   # rad/s^2
    drive: str = DIFFERENTIAL  # "differential" or "synchro"

    def __post_init__(self) -> None:
        for name in ("max_linear", "max_angular", "max_linear_accel", "max_angular_accel"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SimConfigError(f"{name}: {value!r} must be a finite number > 0")
        if self.drive not in (DIFFERENTIAL, SYNCHRO):
            raise SimConfigError(f"drive: {self.drive!r} must be {DIFFERENTIAL!r} or {SYNCHRO!r}")

    @property
    def holonomic(self) -> bool:
        return self.drive == SYNCHRO

    @classmethod
    def of_robot(cls, robot: object) -> Limits:
        """The limits of a :class:`gidabot_navigation.building.model.Robot`."""
        return cls(max_linear=robot.max_linear, max_angular=robot.max_angular,  # type: ignore[attr-defined]
                   max_linear_accel=robot.max_linear_accel,                      # type: ignore[attr-defined]
                   max_angular_accel=robot.max_angular_accel, drive=robot.drive)  # type: ignore[attr-defined]


def check_twist(vx: float, vy: float, wz: float) -> Twist2D:
    """A :class:`Twist2D` from raw numbers; :class:`CommandRejected` if any is not finite."""
    try:
        values = (float(vx), float(vy), float(wz))
    except (TypeError, ValueError) as err:
        raise CommandRejected(f"velocity command ({vx!r}, {vy!r}, {wz!r}) is not numeric") from err
    if not all(math.isfinite(v) for v in values):
        raise CommandRejected(f"velocity command (vx {values[0]!r}, vy {values[1]!r}, wz {values[2]!r}) "
                              "must be finite (m/s, rad/s)")
    return Twist2D(*values)


def clamp_velocity(cmd: Twist2D, limits: Limits) -> Twist2D:
    """``cmd`` within the velocity limits (a differential drive drops vy; the speed is clamped as a vector)."""
    vy = cmd.vy if limits.holonomic else 0.0
    vx = cmd.vx
    speed = math.hypot(vx, vy)
    if speed > limits.max_linear:
        k = limits.max_linear / speed
        vx, vy = vx * k, vy * k
    wz = max(-limits.max_angular, min(limits.max_angular, cmd.wz))
    return Twist2D(vx, vy, wz)


def accelerate(current: Twist2D, target: Twist2D, limits: Limits, dt: float) -> Twist2D:
    """The velocity after ``dt`` seconds moving from ``current`` towards ``target`` at the acceleration limits."""
    dvx, dvy = target.vx - current.vx, target.vy - current.vy
    dv = math.hypot(dvx, dvy)
    max_dv = limits.max_linear_accel * dt
    if dv > max_dv:
        k = max_dv / dv
        dvx, dvy = dvx * k, dvy * k
    dw = target.wz - current.wz
    max_dw = limits.max_angular_accel * dt
    dw = max(-max_dw, min(max_dw, dw))
    return Twist2D(current.vx + dvx, current.vy + dvy, current.wz + dw)


def integrate(pose: Pose2D, vel: Twist2D, dt: float) -> Pose2D:
    """Pose after moving ``dt`` seconds at the constant body velocity ``vel`` (exact: an arc of SE(2))."""
    wdt = vel.wz * dt
    if abs(wdt) < 1e-9:
        bx, by = vel.vx * dt, vel.vy * dt
    else:
        s, c = math.sin(wdt) / vel.wz, (1.0 - math.cos(wdt)) / vel.wz
        bx, by = s * vel.vx - c * vel.vy, c * vel.vx + s * vel.vy
    cy, sy = math.cos(pose.yaw), math.sin(pose.yaw)
    return Pose2D(pose.x + cy * bx - sy * by, pose.y + sy * bx + cy * by, wrap_angle(pose.yaw + wdt))


def compose(a: Pose2D, b: Pose2D) -> Pose2D:
    """a * b: pose ``b`` (expressed in frame ``a``) expressed in ``a``'s parent frame."""
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    return Pose2D(a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrap_angle(a.yaw + b.yaw))


def inverse(a: Pose2D) -> Pose2D:
    """The inverse transform of ``a`` (so that compose(a, inverse(a)) is the identity)."""
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    return Pose2D(-c * a.x - s * a.y, s * a.x - c * a.y, wrap_angle(-a.yaw))


def stopping_distance(speed: float, accel: float) -> float:
    """Distance (m) to stop from ``speed`` at deceleration ``accel``."""
    return speed * speed / (2.0 * accel) if accel > 0 else math.inf
