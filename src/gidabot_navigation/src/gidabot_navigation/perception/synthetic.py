"""Synthetic laser scans of simple scenes (ROS-free): the people detector's and tracker's test bench.

A :class:`Scene` is discs (bodies, legs, round pillars) and line segments (walls, door jambs, square
pillars) in the map frame; :func:`scan` casts the beams of a laser at a pose on a robot, every beam
against every shape at once (numpy), and adds gaussian range noise and dropouts (beams without a
return). :func:`person` builds a person as one body disc or as two leg discs; :func:`box` a rectangle's
four sides. Used by the unit tests and :mod:`gidabot_navigation.perception.benchmark`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.perception.detector import Scan

BODY_RADIUS = 0.22          # m: a torso seen at the height of the laser, as a disc
LEG_RADIUS = 0.065          # m
LEG_SPREAD = 0.3            # m between the centres of the two legs (standing or in mid-stride)


@dataclass(frozen=True)
class Disc:
    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class Wall:
    """A line segment from (x0, y0) to (x1, y1): a wall's face, a door jamb, a side of a pillar."""

    x0: float
    y0: float
    x1: float
    y1: float


@dataclass(frozen=True)
class Scene:
    discs: tuple[Disc, ...] = ()
    walls: tuple[Wall, ...] = ()

    def __add__(self, other: Scene) -> Scene:
        return Scene(self.discs + other.discs, self.walls + other.walls)


@dataclass(frozen=True)
class Laser:
    """A laser as mounted on the robot: ``beams`` over ``fov`` rad centred on the mount's yaw."""

    beams: int = 360
    fov: float = 2.0 * math.pi
    range_min: float = 0.05
    range_max: float = 20.0
    noise: float = 0.01                 # m, standard deviation of the range noise
    dropout: float = 0.0                # probability that a beam has no return
    mount: Pose2D = field(default_factory=lambda: Pose2D(0.0, 0.0, 0.0))

    @property
    def full_circle(self) -> bool:
        return self.fov >= 2.0 * math.pi - 1e-9

    @property
    def angle_min(self) -> float:
        return -self.fov / 2.0

    @property
    def angle_increment(self) -> float:
        # a full circle does not repeat its first beam
        return self.fov / self.beams if self.full_circle else self.fov / max(self.beams - 1, 1)


def person(x: float, y: float, legs: bool = False, heading: float = 0.0, spread: float = LEG_SPREAD) -> Scene:
    """A person centred at (x, y): one body disc, or two leg discs ``spread`` apart across ``heading``."""
    if not legs:
        return Scene(discs=(Disc(x, y, BODY_RADIUS),))
    dx, dy = -math.sin(heading) * spread / 2.0, math.cos(heading) * spread / 2.0
    return Scene(discs=(Disc(x + dx, y + dy, LEG_RADIUS), Disc(x - dx, y - dy, LEG_RADIUS)))


def box(x: float, y: float, width: float, depth: float, yaw: float = 0.0) -> Scene:
    """The four sides of a ``width`` x ``depth`` rectangle centred at (x, y), turned by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    corners = [(x + c * u - s * v, y + s * u + c * v)
               for u, v in ((-width / 2, -depth / 2), (width / 2, -depth / 2), (width / 2, depth / 2),
                            (-width / 2, depth / 2))]
    return Scene(walls=tuple(Wall(*corners[i], *corners[(i + 1) % 4]) for i in range(4)))


def ranges(scene: Scene, origin: Pose2D, angles: np.ndarray, range_max: float) -> np.ndarray:
    """Exact range (m) along each beam from ``origin`` (angles relative to its yaw) to the nearest shape;
    ``inf`` where nothing is hit within ``range_max``."""
    theta = angles + origin.yaw
    dx, dy = np.cos(theta)[:, None], np.sin(theta)[:, None]           # (beams, 1)
    best = np.full(angles.shape, np.inf)
    if scene.discs:
        d = np.array([(c.x - origin.x, c.y - origin.y, c.radius) for c in scene.discs]).T   # (3, discs)
        along = dx * d[0] + dy * d[1]                                     # projection of the centre on the beam
        miss2 = d[0] ** 2 + d[1] ** 2 - along ** 2                        # squared distance of the centre to the ray
        inside = d[2] ** 2 - miss2
        t = along - np.sqrt(np.maximum(inside, 0.0))
        t = np.where((inside >= 0.0) & (t > 0.0), t, np.inf)
        best = np.minimum(best, t.min(axis=1))
    if scene.walls:
        w = np.array([(s.x0 - origin.x, s.y0 - origin.y, s.x1 - s.x0, s.y1 - s.y0) for s in scene.walls]).T
        denom = dx * w[3] - dy * w[2]                                     # cross(beam, segment)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[0] * w[3] - w[1] * w[2]) / denom                       # along the beam
            u = (w[0] * dy - w[1] * dx) / denom                           # along the segment, 0..1
        t = np.where((np.abs(denom) > 1e-12) & (t > 0.0) & (u >= 0.0) & (u <= 1.0), t, np.inf)
        best = np.minimum(best, t.min(axis=1))
    best[best > range_max] = np.inf
    return best


def scan(scene: Scene, robot: Pose2D, laser: Laser = Laser(), rng: np.random.Generator | None = None) -> Scan:
    """The scan ``laser`` on a robot at ``robot`` (map frame) returns in ``scene``: noise and dropouts from
    ``rng`` (none without one)."""
    c, s = math.cos(robot.yaw), math.sin(robot.yaw)
    m = laser.mount
    origin = Pose2D(robot.x + c * m.x - s * m.y, robot.y + s * m.x + c * m.y, robot.yaw + m.yaw)
    angles = laser.angle_min + laser.angle_increment * np.arange(laser.beams)
    out = ranges(scene, origin, angles, laser.range_max)
    if rng is not None:
        hit = np.isfinite(out)
        if laser.noise > 0:
            out[hit] += rng.normal(0.0, laser.noise, int(hit.sum()))
        if laser.dropout > 0:
            out[rng.random(out.shape) < laser.dropout] = np.inf
    out[np.isfinite(out)] = np.maximum(out[np.isfinite(out)], laser.range_min)
    return Scan(laser.angle_min, laser.angle_increment, out, laser.range_min, laser.range_max)
