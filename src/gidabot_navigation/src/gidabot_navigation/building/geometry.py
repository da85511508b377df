"""Planar geometry helpers (ROS-free): 2D poses, yaw <-> quaternion, angle wrapping, the blueprint transform,
polygons (keep-out zones).

Frames follow REP 103/105: x forward/east, y left/north, yaw counter-clockwise
in radians, poses in a floor's ``map`` frame in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MAX_POLYGON_VERTICES = 500
MIN_POLYGON_AREA = 1e-4     # m^2: less is a line drawn twice, not an area


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


def polygon_problem(points: object) -> str | None:
    """Why ``points`` is not a simple polygon (a list of at least 3 finite [x, y] pairs, with an area, whose edges
    do not cross), or None when it is one."""
    if not isinstance(points, (list, tuple)) or not 3 <= len(points) <= MAX_POLYGON_VERTICES:
        return f"must be a list of 3 to {MAX_POLYGON_VERTICES} points [x, y] (m)"
    for i, pt in enumerate(points):
        if not (isinstance(pt, (list, tuple)) and len(pt) == 2
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pt)):
            return f"point {i}: {pt!r} must be [x, y], two finite numbers (m)"
    pts = [(float(x), float(y)) for x, y in points]
    crossing = _crossing_edges(pts)
    if crossing is not None:
        i, j = crossing
        return (f"edges {i}-{(i + 1) % len(pts)} and {j}-{(j + 1) % len(pts)} cross: the outline must not cross "
                "itself (draw its points in order around the zone)")
    if abs(_signed_area(pts)) < MIN_POLYGON_AREA:
        return "has no area (its points lie on one line)"
    return None


def _signed_area(pts: list[tuple[float, float]]) -> float:
    return 0.5 * sum(ax * by - bx * ay for (ax, ay), (bx, by) in zip(pts, pts[1:] + pts[:1], strict=True))


def _cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _segments_touch(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float],
                    d: tuple[float, float]) -> bool:
    d1, d2, d3, d4 = _cross(c, d, a), _cross(c, d, b), _cross(a, b, c), _cross(a, b, d)
    if ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and 0 not in (d1, d2, d3, d4):
        return True

    def on(p: tuple[float, float], q: tuple[float, float], r: tuple[float, float]) -> bool:
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(p[1], q[1])

    return ((d1 == 0 and on(c, d, a)) or (d2 == 0 and on(c, d, b)) or (d3 == 0 and on(a, b, c))
            or (d4 == 0 and on(a, b, d)))


def _crossing_edges(pts: list[tuple[float, float]]) -> tuple[int, int] | None:
    """The first pair of non-adjacent edges that touch, or None (a simple polygon)."""
    n = len(pts)
    for i in range(n):
        a, b = pts[i], pts[(i + 1) % n]
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):
                continue                                # adjacent edges share a vertex
            if _segments_touch(a, b, pts[j], pts[(j + 1) % n]):
                return i, j
    return None


@dataclass(frozen=True)
class Polygon:
    """A simple polygon in map metres (a keep-out zone): its vertices in order around it, either way round,
    not repeating the first. :class:`ValueError` (the reason of :func:`polygon_problem`) when it is not one.

    Used like the planner's obstacle shapes (``contains`` with a margin, ``bounds``) to rasterise it onto a map.
    """

    points: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        problem = polygon_problem(self.points)
        if problem is not None:
            raise ValueError(f"polygon {problem}")
        object.__setattr__(self, "points", tuple((float(x), float(y)) for x, y in self.points))

    @property
    def area(self) -> float:
        """m^2."""
        return abs(_signed_area(list(self.points)))

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) in metres."""
        xs, ys = [p[0] for p in self.points], [p[1] for p in self.points]
        return (min(xs), min(ys), max(xs), max(ys))

    def contains(self, px: np.ndarray, py: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Mask of the points (px, py) inside the polygon (even-odd rule) or within ``margin`` of its outline."""
        px, py = np.asarray(px, dtype=np.float64), np.asarray(py, dtype=np.float64)
        inside = np.zeros(np.broadcast(px, py).shape, dtype=bool)
        near = np.zeros_like(inside)
        pts = self.points
        for (ax, ay), (bx, by) in zip(pts, pts[1:] + pts[:1], strict=True):
            crosses = (ay > py) != (by > py)
            with np.errstate(divide="ignore", invalid="ignore"):
                x_at = ax + (py - ay) * (bx - ax) / (by - ay)
            inside ^= crosses & (px < x_at)
            if margin > 0:
                ex, ey = bx - ax, by - ay
                t = np.clip(((px - ax) * ex + (py - ay) * ey) / max(ex * ex + ey * ey, 1e-18), 0.0, 1.0)
                near |= (px - ax - t * ex) ** 2 + (py - ay - t * ey) ** 2 <= margin * margin
        return inside | near

    def contains_point(self, x: float, y: float) -> bool:
        """True when map point (x, y) lies inside the polygon."""
        return bool(self.contains(np.array(x), np.array(y)))
