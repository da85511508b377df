"""Kinematics: velocity and acceleration limits of both drives, exact integration, SE(2) algebra."""

from __future__ import annotations

import math

import pytest

from gidabot_navigation.building.geometry import Pose2D
from gidabot_sim.errors import CommandRejected, SimConfigError
from gidabot_sim.world import kinematics as kin
from gidabot_sim.world.kinematics import Limits, Twist2D

DIFF = Limits(0.6, 1.0, 0.5, 1.5, "differential")
SYNC = Limits(0.5, 0.9, 0.4, 1.2, "synchro")


def close(a: Pose2D, b: Pose2D, tol: float = 1e-9) -> bool:
    return (abs(a.x - b.x) < tol and abs(a.y - b.y) < tol
            and abs(math.remainder(a.yaw - b.yaw, 2 * math.pi)) < tol)


def test_differential_drops_lateral_velocity_and_clamps() -> None:
    assert kin.clamp_velocity(Twist2D(2.0, 0.3, -5.0), DIFF) == Twist2D(0.6, 0.0, -1.0)
    assert kin.clamp_velocity(Twist2D(-0.2, 0.0, 0.5), DIFF) == Twist2D(-0.2, 0.0, 0.5)


def test_synchro_drive_is_holonomic_with_a_speed_limit_on_the_vector() -> None:
    cmd = kin.clamp_velocity(Twist2D(0.4, 0.4, 0.2), SYNC)
    assert cmd.speed == pytest.approx(0.5) and cmd.vx == pytest.approx(cmd.vy) and cmd.wz == 0.2
    pose = kin.integrate(Pose2D(1.0, 2.0, math.pi / 2), Twist2D(0.0, 0.5, 0.0), 2.0)   # sideways = -x in the map
    assert close(pose, Pose2D(0.0, 2.0, math.pi / 2))


def test_acceleration_limits_ramp_the_velocity() -> None:
    v = Twist2D()
    for _ in range(10):
        v = kin.accelerate(v, Twist2D(0.6, 0.0, 1.0), DIFF, 0.1)
    assert v.vx == pytest.approx(0.5) and v.wz == pytest.approx(1.0)   # 0.5 m/s^2 x 1 s; 1.5 rad/s^2 caps at 1
    v = kin.accelerate(Twist2D(0.6, 0.0, 0.0), Twist2D(), DIFF, 0.2)
    assert v.vx == pytest.approx(0.5)
    # holonomic: the acceleration limit holds for the vector
    v = kin.accelerate(Twist2D(), Twist2D(0.3, 0.4, 0.0), SYNC, 0.5)
    assert v.speed == pytest.approx(0.2) and v.vy / v.vx == pytest.approx(0.4 / 0.3)


def test_integration_is_exact_on_arcs() -> None:
    start = Pose2D(1.0, -1.0, 0.3)
    half = kin.integrate(start, Twist2D(0.5, 0.0, 0.5), 2 * math.pi)     # radius 1 m, a half circle
    c, s = math.cos(0.3), math.sin(0.3)
    assert close(half, Pose2D(1.0 - 2 * s, -1.0 + 2 * c, 0.3 + math.pi))
    full = start
    for _ in range(100):
        full = kin.integrate(full, Twist2D(0.5, 0.0, 0.5), 4 * math.pi / 100)
    assert close(full, start, 1e-9)
    assert close(kin.integrate(start, Twist2D(1.0, 0.0, 0.0), 2.0), Pose2D(1.0 + 2 * c, -1.0 + 2 * s, 0.3))


def test_compose_and_inverse() -> None:
    a, b = Pose2D(1.0, 2.0, 0.7), Pose2D(-0.5, 3.0, -2.0)
    assert close(kin.compose(a, kin.inverse(a)), Pose2D(0, 0, 0))
    assert close(kin.compose(kin.inverse(a), kin.compose(a, b)), b)
    assert close(kin.compose(Pose2D(1, 0, math.pi / 2), Pose2D(1, 0, 0)), Pose2D(1, 1, math.pi / 2))


def test_bad_commands_and_limits() -> None:
    for bad in ((math.nan, 0, 0), (0, math.inf, 0), (0, 0, -math.inf)):
        with pytest.raises(CommandRejected, match="finite"):
            kin.check_twist(*bad)
    with pytest.raises(CommandRejected, match="numeric"):
        kin.check_twist("fast", 0, 0)
    with pytest.raises(SimConfigError, match="max_linear"):
        Limits(0.0, 1.0, 1.0, 1.0)
    with pytest.raises(SimConfigError, match="drive"):
        Limits(1.0, 1.0, 1.0, 1.0, "tracked")
    assert kin.stopping_distance(0.6, 0.5) == pytest.approx(0.36)
