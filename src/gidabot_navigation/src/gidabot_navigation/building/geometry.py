"""Planar geometry helpers (ROS-free): 2D poses, yaw <-> quaternion, angle wrapping.

Frames follow REP 103/105: x forward/east, y left/north, yaw counter-clockwise
in radians, poses in a floor's ``map`` frame in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def wrap_angle(angle: float) -> float:
    """Return ``angle`` wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def yaw_to_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion (x, y, z, w) of a rotation by ``yaw`` about z."""
    half = 0.5 * yaw
    return (0.0, 0.0, math.sin(half), math.cos(half))


def quaternion_to_yaw(x: float, y: float, z: float, w: float) -> float:
    """Yaw (rotation about z) of the quaternion (x, y, z, w)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def all_finite(*values: float) -> bool:
    """True when every value is a finite float (no NaN, no infinity)."""
    return all(math.isfinite(v) for v in values)


@dataclass(frozen=True)
class Pose2D:
    """A planar pose: x, y in metres, yaw in radians."""

    x: float
    y: float
    yaw: float = 0.0

    def distance_to(self, other: Pose2D) -> float:
        """Euclidean distance in metres between the two positions."""
        return math.hypot(other.x - self.x, other.y - self.y)

    def is_finite(self) -> bool:
        """True when x, y and yaw are all finite."""
        return all_finite(self.x, self.y, self.yaw)


@dataclass(frozen=True)
class BlueprintTransform:
    """Map metres -> blueprint pixels (image u right, v down).

    u = origin_u + scale * (cos(r) * x - sin(r) * y)
    v = origin_v - scale * (sin(r) * x + cos(r) * y)
    """

    scale: float          # pixels per metre
    origin_u: float       # pixel column of the map point (0, 0)
    origin_v: float       # pixel row of the map point (0, 0)
    rotation: float = 0.0 # rad, rotation of the map frame on the blueprint

    def to_pixel(self, x: float, y: float) -> tuple[float, float]:
        """Blueprint pixel (u, v) of map point (x, y)."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        return (self.origin_u + self.scale * (c * x - s * y),
                self.origin_v - self.scale * (s * x + c * y))

    def to_map(self, u: float, v: float) -> tuple[float, float]:
        """Map point (x, y) of blueprint pixel (u, v) (inverse of :meth:`to_pixel`)."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        a = (u - self.origin_u) / self.scale
        b = (self.origin_v - v) / self.scale
        return (c * a + s * b, -s * a + c * b)

    def yaw_to_pixel_angle(self, yaw: float) -> float:
        """Angle on the image (radians, counter-clockwise from +u with v pointing up)."""
        return wrap_angle(yaw + self.rotation)
