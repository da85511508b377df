"""People in one planar laser scan (ROS-free): a scan as plain data in, person detections in the map out.

A person cut by a laser is one convex arc (a torso, 0.3-0.6 m wide) or two narrow arcs (legs,
0.05-0.25 m wide) less than about half a metre apart. :meth:`Detector.detect` finds them in four
passes, each over every beam or every segment of the scan at once (numpy):

1. **Points**: the beams with a return in ``[range_min, min(range_max, max_range))``, in the laser's frame.
2. **Segments**: consecutive points, split where two neighbours are further apart than the jump
   distance (``jump_distance``, or ``jump_beams`` beam spacings at that range when that is more: far
   away the beams fan out) or where more than ``max_gap_beams`` beams have no return. In a full-circle
   scan the last segment and the first one join when they touch.
3. **Features** (sums per segment by ``np.add.reduceat``): the number of points, the width (first point
   to last), the *bulge* (mean distance of the points from that chord, towards the laser: an arc facing
   the laser bulges towards it by about 0.39 of its width, a wall or a jamb seen face-on by nothing),
   for body-sized arcs only, the residual of a circle fit (an L-shaped corner of a wall or a square
   pillar bulges too, but fits two lines better than a circle), and what the laser sees past each end.
4. **Classes** (:class:`Kind`): too few points or narrower than a leg -> ``NOISE``; wider than a body ->
   ``TOO_WIDE`` (walls, wall corners, big pillars); bulge below ``min_bulge`` or ``min_bulge_ratio`` of
   the width -> ``STRAIGHT`` (walls, door jambs, the grazing wall a beam sweeps along); more bulge than
   an arc has, or a body-sized segment that fits no body-sized circle -> ``SHAPE``; nothing farther (or
   no return) past either end, or the same surface going on past a few missing beams -> ``FRAGMENT`` (a
   piece of wall cut out by stray returns in front of it or by dropouts: a person stands out); at least
   ``static_fraction`` of its points on occupied cells of the static map (an optional lookup, see
   :func:`occupied_lookup`) -> ``STATIC`` (pillars, furniture the map holds); then ``BODY`` or ``LEG``,
   and legs are paired, nearest first, within ``leg_pair``: a leg left alone is ``LEG_UNPAIRED`` and
   gives no detection.

A detection's position is the centre of the body (or the midpoint of the two legs' centres): an arc's
points lie on the near side of the person, so its centroid is pushed away from the laser by pi/4 of
its half-width (the mean depth of a disc's near half). Its confidence (0..1) grows with how much the
shape looks like an arc (bulge ratio, circle fit) and, for legs, how plausible their spacing is; it is
halved for a body with one end hidden by something nearer (a partial arc: its centre is off).

What geometry alone cannot tell: a round pillar the size of a torso is a ``BODY`` unless the static
map holds it; the tracker's confirmation (a person moves, is seen for several scans) and the map are
the other filters.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from gidabot_navigation.building.geometry import Pose2D, wrap_angle
from gidabot_navigation.building.occupancy import OCCUPIED, OccupancyMap
from gidabot_navigation.errors import PerceptionError, ScanError

MAX_BEAMS = 10000
ARC_DEPTH = math.pi / 4.0      # mean depth of a disc's near half, in radii, as its points lie across it

# a body-sized segment is a corner when two lines fit its points this much better (in squares) than a circle:
# an arc's points fit two lines worse than a circle by 2-3 times in rms, an L's better by as much
CORNER_TEST = 0.5
SHADOW_MARGIN = 0.3       # m: a return this much nearer than a person hides it
PARTIAL_BODY = 0.5        # confidence factor of a body with one end hidden by something nearer
# missing beams more than a segment bridges, behind which the same surface may still go on (dropouts)
CONTINUATION_BEAMS = 3
# (xs, ys) map coordinates (m) -> True where the static map is occupied there
OccupiedLookup = Callable[[np.ndarray, np.ndarray], np.ndarray]


class Kind(IntEnum):
    """What a segment of a scan was taken for."""

    NOISE = 0           # too few points, or narrower than a leg
    TOO_WIDE = 1        # wider than a body: walls, wall corners, large pillars
    STRAIGHT = 2        # no bulge towards the laser: a wall, a door jamb
    SHAPE = 3           # bulges, but not as an arc of a person does (a corner, a square pillar)
    FRAGMENT = 4        # stands out on no side: a piece of a wall between nearer returns or missing beams
    STATIC = 5          # lies on occupied cells of the static map
    LEG_UNPAIRED = 6    # a leg-sized arc with no other leg close enough
    LEG = 7             # one of a pair of legs: a person
    BODY = 8            # a body-sized arc: a person


@dataclass(frozen=True)
class Scan:
    """One planar laser scan as plain data (sensor_msgs/LaserScan's fields): beam i points at
    ``angle_min + i * angle_increment`` rad in the laser's frame; ``ranges`` in m, ``inf`` or NaN or
    out of ``[range_min, range_max]``: no return."""

    angle_min: float
    angle_increment: float
    ranges: np.ndarray
    range_min: float
    range_max: float

    @staticmethod
    def checked(angle_min: float, angle_increment: float, ranges: object, range_min: float,
                range_max: float) -> Scan:
        """A scan from untrusted values (a message off the bus); :class:`ScanError` lists every problem."""
        problems = []
        for name, value in (("angle_min", angle_min), ("angle_increment", angle_increment),
                            ("range_min", range_min), ("range_max", range_max)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                problems.append(f"{name}: {value!r} is not a finite number")
        try:
            data = np.asarray(ranges, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            problems.append(f"ranges: not a sequence of numbers ({type(ranges).__name__})")
            data = np.zeros(0)
        if not problems:
            if angle_increment <= 0:
                problems.append(f"angle_increment: {angle_increment!r} must be > 0 (rad)")
            elif len(data) * angle_increment > 2 * math.pi + angle_increment / 2:
                problems.append(f"{len(data)} beams of {angle_increment:g} rad cover more than a full circle")
            if not 0 <= range_min < range_max:
                problems.append(f"range_min {range_min!r}, range_max {range_max!r}: must satisfy "
                                "0 <= range_min < range_max (m)")
        if not 1 <= len(data) <= MAX_BEAMS:
            problems.append(f"ranges: {len(data)} beams, expected 1..{MAX_BEAMS}")
        if problems:
            raise ScanError("malformed scan: " + "; ".join(problems))
        return Scan(float(angle_min), float(angle_increment), data, float(range_min), float(range_max))

    @property
    def beams(self) -> int:
        return len(self.ranges)

    @property
    def angle_max(self) -> float:
        return self.angle_min + (self.beams - 1) * self.angle_increment

    @property
    def full_circle(self) -> bool:
        """The beams go all round: the last one is next to the first."""
        return self.beams * self.angle_increment >= 2 * math.pi - self.angle_increment / 2


@dataclass(frozen=True)
class FieldOfView:
    """Where a laser mounted at ``mount`` on the robot sees: bearings ``angle_min..angle_max`` (rad, in
    the laser's frame), up to ``range_max`` m; all round when ``full_circle``."""

    angle_min: float
    angle_max: float
    range_max: float
    mount: Pose2D
    full_circle: bool

    @staticmethod
    def of(scan: Scan, mount: Pose2D, max_range: float = math.inf) -> FieldOfView:
        return FieldOfView(scan.angle_min, scan.angle_max, min(scan.range_max, max_range), mount, scan.full_circle)

    @property
    def width(self) -> float:
        """rad"""
        return 2 * math.pi if self.full_circle else self.angle_max - self.angle_min

    def sees(self, robot: Pose2D, x: float, y: float, margin: float = 0.0) -> bool:
        """True when map point (x, y) is at least ``margin`` m inside the field of view of the laser on a robot
        at ``robot``: within its range, at a bearing it covers (see :meth:`covers`)."""
        sensor = sensor_pose(robot, self.mount)
        return math.hypot(x - sensor.x, y - sensor.y) <= self.range_max - margin and self.covers(robot, x, y, margin)

    def covers(self, robot: Pose2D, x: float, y: float, margin: float = 0.0) -> bool:
        """True when the bearing of map point (x, y) from the laser is covered, ``margin`` m (as an angle at the
        point's distance) inside both edges; however far the point is."""
        if self.full_circle:
            return True
        sensor = sensor_pose(robot, self.mount)
        dx, dy = x - sensor.x, y - sensor.y
        rng = math.hypot(dx, dy)
        off = abs(wrap_angle(math.atan2(dy, dx) - sensor.yaw - (self.angle_min + self.angle_max) / 2.0))
        slack = math.asin(min(1.0, margin / rng)) if rng > 0 else 0.0
        return off <= (self.angle_max - self.angle_min) / 2.0 - slack


def fov_mismatch(declared: float, scan: Scan) -> str:
    """What is wrong with a laser declared to cover ``declared`` rad (the building file's ``sensors.laser.fov``)
    whose scans cover another angle (more than two beams apart); "" when they agree."""
    covered = scan.beams * scan.angle_increment if scan.full_circle else scan.angle_max - scan.angle_min
    if abs(covered - declared) <= 2 * scan.angle_increment:
        return ""
    return (f"the scans cover {math.degrees(covered):.0f} deg, the building file declares {math.degrees(declared):.0f}"
            " deg (sensors.laser.fov): the scans' angles are used")


@dataclass(frozen=True)
class DetectorParams:
    max_range: float = 8.0                          # m: farther returns are ignored
    jump_distance: float = 0.15                     # m between neighbouring points of one segment, at most
    jump_beams: float = 2.5                         # ... or this many beam spacings at their range, if more
    max_gap_beams: int = 1                          # beams without a return inside one segment, at most
    min_points: int = 3                             # points of a leg or a body, at least
    leg_shape_points: int = 5                       # a leg with fewer points is taken on its width alone
    leg_width: tuple[float, float] = (0.05, 0.25)   # m, chord of a leg's arc
    body_width: tuple[float, float] = (0.25, 0.6)   # m, chord of a body's arc
    min_bulge: float = 0.012                        # m: less is straight (the range noise is about 0.01 m)
    min_bulge_ratio: float = 0.1                    # bulge / width: less is straight
    max_bulge_ratio: float = 0.6                    # bulge / width: more is no arc of a convex body
    body_radius: tuple[float, float] = (0.1, 0.45)  # m, circle fitted to a body's arc
    max_fit_residual: float = 0.025                 # m, rms distance of a body's points to that circle
    leg_pair: tuple[float, float] = (0.08, 0.55)    # m between the centres of a person's two legs
    static_fraction: float = 0.5                    # of a segment's points on occupied map cells: static

    def __post_init__(self) -> None:
        problems = []
        for name in ("max_range", "jump_distance", "jump_beams", "min_bulge", "min_bulge_ratio", "max_bulge_ratio",
                     "max_fit_residual", "static_fraction"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                problems.append(f"{name}: {value!r} must be a finite number > 0")
        for name in ("leg_width", "body_width", "body_radius", "leg_pair"):
            low, high = getattr(self, name)
            if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
                problems.append(f"{name}: ({low!r}, {high!r}) must satisfy 0 <= low < high (m)")
        for name in ("min_points", "leg_shape_points"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 2):
                problems.append(f"{name}: {getattr(self, name)!r} must be an integer >= 2")
        if not (isinstance(self.max_gap_beams, int) and self.max_gap_beams >= 0):
            problems.append(f"max_gap_beams: {self.max_gap_beams!r} must be an integer >= 0")
        if problems:
            raise PerceptionError("detector parameters: " + "; ".join(problems))


@dataclass(frozen=True)
class Detection:
    """A person in one scan: centre (m, map frame), confidence 0..1, ``kind`` BODY or LEG (a pair)."""

    x: float
    y: float
    confidence: float
    kind: Kind
    width: float            # m: the body's chord, or the distance between the legs' centres


@dataclass(frozen=True)
class Detections:
    """What one scan shows: the people, the field of view it covered, and every segment's class; with the
    scan and where the robot was, whether a person could have been seen somewhere (:meth:`visible`)."""

    people: tuple[Detection, ...]
    fov: FieldOfView
    kinds: np.ndarray = field(repr=False)       # Kind of every segment, in scan order
    scan: Scan | None = field(default=None, repr=False)
    robot: Pose2D | None = None

    def count(self, kind: Kind) -> int:
        return int(np.count_nonzero(self.kinds == kind))

    def visible(self, x: float, y: float, margin: float = SHADOW_MARGIN) -> bool:
        """True when a person at map point (x, y) would have been in sight: inside the field of view and not
        behind something nearer (the beam towards it returned short of it by more than ``margin`` m). True
        when unknown (no scan)."""
        if self.scan is None or self.robot is None:
            return True
        if not self.fov.sees(self.robot, x, y):
            return False
        sensor = sensor_pose(self.robot, self.fov.mount)
        bearing = wrap_angle(math.atan2(y - sensor.y, x - sensor.x) - sensor.yaw - self.scan.angle_min)
        if bearing < 0:
            bearing += 2 * math.pi
        beam = int(round(bearing / self.scan.angle_increment))
        if not 0 <= beam < self.scan.beams:
            return False
        near = self.scan.ranges[max(beam - 1, 0):beam + 2]
        near = near[(near >= self.scan.range_min) & (near <= self.scan.range_max)]
        return not (len(near) and float(near.max()) < math.hypot(x - sensor.x, y - sensor.y) - margin)


def sensor_pose(robot: Pose2D, mount: Pose2D) -> Pose2D:
    """The laser's pose in the map: ``mount`` (on the robot) composed with the robot's pose."""
    c, s = math.cos(robot.yaw), math.sin(robot.yaw)
    return Pose2D(robot.x + c * mount.x - s * mount.y, robot.y + s * mount.x + c * mount.y,
                  wrap_angle(robot.yaw + mount.yaw))


def occupied_lookup(grid: OccupancyMap, margin: float = 0.1) -> OccupiedLookup:
    """A lookup of the occupied cells of ``grid`` grown by ``margin`` m (the localisation's error): points
    off the grid are not occupied."""
    from scipy import ndimage

    occupied = grid.cells == OCCUPIED
    cells = int(math.ceil(margin / grid.resolution))
    if cells > 0:
        yy, xx = np.mgrid[-cells:cells + 1, -cells:cells + 1]
        occupied = ndimage.binary_dilation(occupied, structure=xx * xx + yy * yy <= cells * cells)
    c, s = math.cos(grid.origin_yaw), math.sin(grid.origin_yaw)
    height, width = occupied.shape

    def lookup(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        dx, dy = xs - grid.origin_x, ys - grid.origin_y
        cols = np.floor((c * dx + s * dy) / grid.resolution).astype(np.int64)
        rows = np.floor((-s * dx + c * dy) / grid.resolution).astype(np.int64)
        inside = (rows >= 0) & (rows < height) & (cols >= 0) & (cols < width)
        out = np.zeros(xs.shape, dtype=bool)
        out[inside] = occupied[rows[inside], cols[inside]]
        return out

    return lookup


def _ramp(value: np.ndarray | float, low: float, high: float) -> np.ndarray:
    """0 at ``low``, 1 at ``high``, linear between, clipped."""
    return np.minimum(np.maximum((value - low) / (high - low), 0.0), 1.0)


def _line_residual2(prefix: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Sum of the squared distances of points ``low..high`` (inclusive) to the line that fits them best, from
    the ``prefix`` sums (rows) of 1, x, y, x^2, y^2, xy."""
    k, sx, sy, sxx, syy, sxy = prefix[:, high + 1] - prefix[:, low]
    cxx, cyy, cxy = sxx - sx * sx / k, syy - sy * sy / k, sxy - sx * sy / k
    return np.maximum((cxx + cyy) / 2 - np.hypot((cxx - cyy) / 2, cxy), 0.0)


class Detector:
    """Finds people in scans of one laser, mounted at ``mount`` on the robot (see the module's docstring)."""

    def __init__(self, params: DetectorParams | None = None, mount: Pose2D | None = None,
                 occupied: OccupiedLookup | None = None) -> None:
        self.params = params or DetectorParams()
        self.mount = mount or Pose2D(0.0, 0.0, 0.0)
        self.occupied = occupied
        self._trig_key: tuple[float, float, int] | None = None
        self._cos = self._sin = np.zeros(0)

    def _trig(self, scan: Scan) -> tuple[np.ndarray, np.ndarray]:
        key = (scan.angle_min, scan.angle_increment, scan.beams)
        if key != self._trig_key:
            angles = scan.angle_min + scan.angle_increment * np.arange(scan.beams)
            self._cos, self._sin, self._trig_key = np.cos(angles), np.sin(angles), key
        return self._cos, self._sin

    def detect(self, scan: Scan, robot: Pose2D) -> Detections:
        """The people in ``scan``, taken by the laser on a robot at ``robot`` (map frame)."""
        with np.errstate(divide="ignore", invalid="ignore"):     # NaN ranges; degenerate segments give NaN
            return self._detect(scan, robot)

    def _detect(self, scan: Scan, robot: Pose2D) -> Detections:
        p = self.params
        fov = FieldOfView.of(scan, self.mount, p.max_range)
        none = Detections((), fov, np.zeros(0, dtype=np.int8), scan, robot)
        cos, sin = self._trig(scan)
        r = scan.ranges
        valid = (r >= scan.range_min) & (r < min(scan.range_max, p.max_range))
        beam = np.flatnonzero(valid)
        if len(beam) < p.min_points:
            return none
        rng = r[beam]
        xs, ys = rng * cos[beam], rng * sin[beam]

        # segments: split at jumps and at gaps of missing beams
        gap = np.diff(beam)
        step = np.hypot(np.diff(xs), np.diff(ys))
        limit = np.maximum(p.jump_distance, p.jump_beams * np.minimum(rng[:-1], rng[1:]) * scan.angle_increment * gap)
        breaks = (gap > p.max_gap_beams + 1) | (step > limit)
        starts = np.concatenate(([0], np.flatnonzero(breaks) + 1))
        if scan.full_circle and len(starts) > 1:
            wrap_gap = beam[0] + scan.beams - beam[-1]
            wrap_step = math.hypot(xs[0] - xs[-1], ys[0] - ys[-1])
            wrap_limit = max(p.jump_distance, p.jump_beams * min(rng[0], rng[-1]) * scan.angle_increment * wrap_gap)
            if wrap_gap <= p.max_gap_beams + 1 and wrap_step <= wrap_limit:
                # the first segment continues the last one: start the points at the second segment
                order = np.concatenate((np.arange(starts[1], len(beam)), np.arange(starts[1])))
                xs, ys, rng, beam = xs[order], ys[order], rng[order], beam[order]
                starts = starts[1:] - starts[1]
        counts = np.diff(np.concatenate((starts, [len(xs)])))
        first, last = starts, starts + counts - 1

        # features of every segment, from sums over its points (centred on the segment's mean)
        seg = np.repeat(np.arange(len(starts)), counts)
        n = counts.astype(np.float64)
        mx, my = np.add.reduceat(xs, starts) / n, np.add.reduceat(ys, starts) / n
        x, y = xs - mx[seg], ys - my[seg]
        sxx, syy, sxy = np.add.reduceat(x * x, starts), np.add.reduceat(y * y, starts), np.add.reduceat(x * y, starts)
        # length along the main axis (exact for points spread evenly along a line or across an arc): the chord
        # alone would call a closed loop of walls (a full-circle scan of a room) narrow
        extent = np.sqrt(12.0 * ((sxx + syy) / 2 + np.hypot((sxx - syy) / 2, sxy)) / n)
        ux, uy = xs[last] - xs[first], ys[last] - ys[first]
        width = np.hypot(ux, uy)
        toward = np.sign(ux * -ys[first] - uy * -xs[first])          # side of the chord the laser is on
        bulge = np.where(width > 0, toward * (ux * (my - ys[first]) - uy * (mx - xs[first])) / width, 0.0)
        ratio = np.where(width > 0, bulge / width, 0.0)

        kinds = np.full(len(starts), Kind.SHAPE, dtype=np.int8)
        leg_size = (width >= p.leg_width[0]) & (width <= p.leg_width[1])
        body_size = (width > p.leg_width[1]) & (width >= p.body_width[0]) & (width <= p.body_width[1])
        shaped = body_size | (counts >= p.leg_shape_points)       # enough points to tell an arc from a line
        kinds[leg_size & (bulge > -p.min_bulge)] = Kind.LEG
        kinds[body_size] = Kind.BODY
        kinds[(kinds >= Kind.LEG) & shaped & (ratio > p.max_bulge_ratio)] = Kind.SHAPE
        kinds[body_size & ((bulge < p.min_bulge) | (ratio < p.min_bulge_ratio))] = Kind.STRAIGHT
        # a leg's arc bulges by little more than the range noise: only a clearly flat one is a wall's
        kinds[leg_size & shaped & (bulge < p.min_bulge / 2)] = Kind.STRAIGHT
        kinds[np.maximum(width, extent) > p.body_width[1]] = Kind.TOO_WIDE
        kinds[(counts < p.min_points) | (width < p.leg_width[0])] = Kind.NOISE
        # a person stands out: past at least one of its edges the laser sees farther (or nothing), and past
        # neither does the same surface go on behind a few missing beams
        total = len(xs)
        free = np.zeros(len(starts), dtype=bool)
        goes_on = np.zeros(len(starts), dtype=bool)
        occluded = np.zeros(len(starts), dtype=bool)      # something nearer hides one end: a partial arc
        for edge, other in ((first, first - 1), (last, last + 1)):
            known = np.full(len(starts), True) if scan.full_circle else (other >= 0) & (other < total)
            other = other % total                   # cyclic in a full circle; else masked by known
            nearer = rng[other] < rng[edge] - p.jump_distance / 2
            missing = np.abs(beam[other] - beam[edge])                      # beams between them, and one
            if scan.full_circle:
                missing = np.minimum(missing, scan.beams - missing)
            close = (missing <= p.max_gap_beams + 1 + CONTINUATION_BEAMS) & \
                (np.hypot(xs[other] - xs[edge], ys[other] - ys[edge]) <=
                 np.maximum(p.jump_distance, p.jump_beams * rng[edge] * scan.angle_increment * missing))
            free |= ~known | ~(nearer | close)
            goes_on |= known & close & ~nearer
            occluded |= known & nearer
        kinds[(kinds >= Kind.LEG) & (goes_on | ~free)] = Kind.FRAGMENT
        if not np.any(kinds >= Kind.LEG):
            return Detections((), fov, kinds, scan, robot)

        fit = np.ones(len(starts))
        body = kinds == Kind.BODY
        if body.any():
            fit = self._body_fit(x, y, seg, starts, n, (sxx, syy, sxy), ux, uy, first)
            kinds[body & (fit <= 0)] = Kind.SHAPE
        sensor = sensor_pose(robot, self.mount)
        c, s = math.cos(sensor.yaw), math.sin(sensor.yaw)
        if self.occupied is not None:
            mine = kinds[seg] >= Kind.LEG
            on_map = self.occupied(sensor.x + c * xs[mine] - s * ys[mine], sensor.y + s * xs[mine] + c * ys[mine])
            static = np.bincount(seg[mine], weights=on_map.astype(np.float64), minlength=len(starts))
            kinds[(kinds >= Kind.LEG) & (static >= p.static_fraction * n)] = Kind.STATIC

        # centres: the centroid pushed away from the laser by the mean depth of the arc
        dist = np.hypot(mx, my)
        push = ARC_DEPTH * width / 2.0
        cx_l, cy_l = mx + push * mx / dist, my + push * my / dist
        cx, cy = sensor.x + c * cx_l - s * cy_l, sensor.y + s * cx_l + c * cy_l
        shape = 0.5 + 0.5 * _ramp(ratio, p.min_bulge_ratio, 0.3)
        # a body partly hidden shows a narrower arc whose centre is off: less confident
        shape[(kinds == Kind.BODY) & occluded] *= PARTIAL_BODY

        people: list[Detection] = []
        for k in np.flatnonzero(kinds == Kind.BODY):
            people.append(Detection(float(cx[k]), float(cy[k]), float(shape[k] * fit[k]), Kind.BODY, float(width[k])))
        legs = np.flatnonzero(kinds == Kind.LEG)
        kinds[legs] = Kind.LEG_UNPAIRED
        if len(legs) >= 2:
            for i, j, gap_m in self._pairs(cx[legs], cy[legs]):
                a, b = legs[i], legs[j]
                kinds[a] = kinds[b] = Kind.LEG
                spacing = 1.0 - 0.5 * float(_ramp(gap_m, 0.35, p.leg_pair[1]))
                people.append(Detection(float(cx[a] + cx[b]) / 2.0, float(cy[a] + cy[b]) / 2.0,
                                        float((shape[a] + shape[b]) / 2.0 * spacing), Kind.LEG, gap_m))
        return Detections(tuple(people), fov, kinds, scan, robot)

    def _body_fit(self, x: np.ndarray, y: np.ndarray, seg: np.ndarray, starts: np.ndarray, n: np.ndarray,
                  moments: tuple[np.ndarray, np.ndarray, np.ndarray], ux: np.ndarray, uy: np.ndarray,
                  first: np.ndarray) -> np.ndarray:
        """How well each segment's points (``x``, ``y``: centred on the segment's mean; ``seg``: the segment of each
        point) fit a circle of a body's size: 1 (within the noise) .. 0 (not at all, not a body's radius, or
        better as two straight lines meeting at a corner: a square pillar, a wall's edge). Algebraic (Kasa)
        fit; the corner is the point farthest from the chord (``ux``, ``uy`` from point ``first``)."""
        p = self.params
        sxx, syy, sxy = moments
        z = x * x + y * y
        sxz, syz = np.add.reduceat(x * z, starts), np.add.reduceat(y * z, starts)
        det = sxx * syy - sxy * sxy
        ox, oy = (syy * sxz - sxy * syz) / det / 2.0, (sxx * syz - sxy * sxz) / det / 2.0
        radius = np.sqrt((sxx + syy) / n + ox * ox + oy * oy)
        off = np.hypot(x - ox[seg], y - oy[seg]) - radius[seg]
        residual2 = np.add.reduceat(off * off, starts) / n
        # two lines, each side of the corner: sums over index ranges by prefix sums
        dev = np.abs(ux[seg] * (y - y[first][seg]) - uy[seg] * (x - x[first][seg]))
        peak = np.flatnonzero(dev == np.maximum.reduceat(dev, starts)[seg])
        corner = peak[np.concatenate(([True], seg[peak][1:] != seg[peak][:-1]))]     # each segment's first
        last = np.append(starts[1:], len(x)) - 1
        prefix = np.zeros((6, len(x) + 1))
        np.cumsum(np.stack((np.ones_like(x), x, y, x * x, y * y, x * y)), axis=1, out=prefix[:, 1:])
        two_lines = _line_residual2(prefix, starts, corner) + _line_residual2(prefix, corner, last)
        round_ = (radius >= p.body_radius[0]) & (radius <= p.body_radius[1]) & \
            (two_lines >= CORNER_TEST * residual2 * (n + 1))
        return np.where(round_, 1.0 - _ramp(np.sqrt(residual2), p.max_fit_residual / 2.0, p.max_fit_residual), 0.0)

    def _pairs(self, x: np.ndarray, y: np.ndarray) -> list[tuple[int, int, float]]:
        """Pairs of legs (indices into x, y and their distance), nearest pairs first, each leg in one pair."""
        low, high = self.params.leg_pair
        d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
        i, j = np.nonzero(np.triu((d >= low) & (d <= high), k=1))
        used: set[int] = set()
        out = []
        for k in np.argsort(d[i, j], kind="stable"):
            a, b = int(i[k]), int(j[k])
            if a not in used and b not in used:
                used.update((a, b))
                out.append((a, b, float(d[a, b])))
        return out
