"""Global path planning on an inflated occupancy grid (ROS-free).

Used by the move_base stand-in (``gidabot_sim``) to drive, and by guiding to
estimate trip lengths (which staircase minimises the whole trip, wait times).

The costmap follows ROS costmap_2d's static + inflation layers:

* *lethal* cells: occupied or unknown map cells (unknown space is never
  entered), the floor's keep-out zones (polygons the building file draws: the top of a
  staircase, a glass wall the laser does not see; ``keep_out``), cells covered by
  obstacles added with :meth:`GridPlanner.add_obstacle` and cells marked by a sensor
  (:meth:`GridPlanner.set_sensor_marks`);
* *inscribed* cells: closer than ``robot_radius`` to a lethal cell (the robot's
  centre may not go there: its disc would touch the obstacle);
* an exponential cost decay out to ``inflation_radius`` like costmap_2d's
  ``cost_scaling_factor``, so paths keep to the middle of corridors:
  ``weight = 1 + inflation_cost * exp(-cost_scaling * (d - robot_radius))``
  for ``d < inflation_radius`` (``d`` = distance in metres to the nearest lethal
  cell, from :func:`scipy.ndimage.distance_transform_edt`), 1 beyond.

Search is A* over 4-connected cells (pyastar2d, C++), then the cell path is
shortened by line of sight ("string pulling"): a stretch of the path becomes a
straight line when the line's integrated cost is not higher than the stretch's,
so the path stays as far from walls as the costs ask and :attr:`Path.length`
is close to the length a robot actually drives.

Start and goal: outside the map or inside a lethal cell -> :class:`PlanningError`.
A start inside the inscribed zone is allowed (the robot escapes, as move_base
clears the robot's own footprint); a goal inside the inscribed zone is moved to
the nearest free cell outside it within ``goal_tolerance`` (like navfn's
``default_tolerance``), else :class:`PlanningError`.

Changes (obstacles, sensor marks) only re-inflate the window around the
changed cells, so a person stepping into a corridor costs a few milliseconds.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np
import pyastar2d
from scipy import ndimage

from gidabot_navigation.building.geometry import Polygon
from gidabot_navigation.building.occupancy import FREE, OccupancyMap
from gidabot_navigation.errors import ObstacleError, PlanningError

MAX_OBSTACLE_SIZE = 1000.0  # m: anything larger is a typo, not a person or a door
ESCAPE_WEIGHT = 50.0        # cost of a cell of the inscribed zone around the start


# ---------------------------------------------------------------------------
# Obstacle shapes (map metres)
# ---------------------------------------------------------------------------

def _finite(name: str, value: float) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError) as err:
        raise ObstacleError(f"{name}: {value!r} is not a number") from err
    if not math.isfinite(number):
        raise ObstacleError(f"{name}: {value!r} is not a finite number")
    return number


def _size(name: str, value: float) -> float:
    number = _finite(name, value)
    if not 0.0 < number <= MAX_OBSTACLE_SIZE:
        raise ObstacleError(f"{name}: {number:g} m must be > 0 and <= {MAX_OBSTACLE_SIZE:g} m")
    return number


@dataclass(frozen=True)
class Circle:
    """A disc centred at (x, y) with ``radius`` (m): a person, a bin."""

    x: float
    y: float
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "x", _finite("circle x", self.x))
        object.__setattr__(self, "y", _finite("circle y", self.y))
        object.__setattr__(self, "radius", _size("circle radius", self.radius))

    def contains(self, px: np.ndarray, py: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Mask of the points (px, py) inside the disc grown by ``margin``."""
        return (px - self.x) ** 2 + (py - self.y) ** 2 <= (self.radius + margin) ** 2

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) in metres."""
        return (self.x - self.radius, self.y - self.radius, self.x + self.radius, self.y + self.radius)


@dataclass(frozen=True)
class Rectangle:
    """A rectangle centred at (x, y), ``width`` along its own x axis, ``height`` along its y,
    rotated by ``yaw`` (rad): a closed door, a trolley across a corridor."""

    x: float
    y: float
    width: float
    height: float
    yaw: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "x", _finite("rectangle x", self.x))
        object.__setattr__(self, "y", _finite("rectangle y", self.y))
        object.__setattr__(self, "width", _size("rectangle width", self.width))
        object.__setattr__(self, "height", _size("rectangle height", self.height))
        object.__setattr__(self, "yaw", _finite("rectangle yaw", self.yaw))

    def contains(self, px: np.ndarray, py: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Mask of the points (px, py) inside the rectangle grown by ``margin`` on every side."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = px - self.x, py - self.y
        u, v = c * dx + s * dy, -s * dx + c * dy
        return (np.abs(u) <= self.width / 2 + margin) & (np.abs(v) <= self.height / 2 + margin)

    def bounds(self) -> tuple[float, float, float, float]:
        c, s = abs(math.cos(self.yaw)), abs(math.sin(self.yaw))
        hx = (c * self.width + s * self.height) / 2
        hy = (s * self.width + c * self.height) / 2
        return (self.x - hx, self.y - hy, self.x + hx, self.y + hy)


Shape = Circle | Rectangle


def rasterize(shape: Shape | Polygon, grid: OccupancyMap) -> tuple[tuple[slice, slice], np.ndarray] | None:
    """Cells covered by ``shape``: ((row slice, col slice), mask) or None if off the grid.

    Conservative: a cell is covered when its centre lies within half a cell of the
    shape, so thin shapes (a 2 cm door) still block.
    """
    x0, y0, x1, y1 = shape.bounds()
    corners = [grid.world_to_cell(x, y) for x in (x0, x1) for y in (y0, y1)]
    r0 = max(min(r for r, _ in corners) - 1, 0)
    r1 = min(max(r for r, _ in corners) + 2, grid.height)
    c0 = max(min(c for _, c in corners) - 1, 0)
    c1 = min(max(c for _, c in corners) + 2, grid.width)
    if r0 >= r1 or c0 >= c1:
        return None
    rows, cols = np.mgrid[r0:r1, c0:c1]
    lx, ly = (cols + 0.5) * grid.resolution, (rows + 0.5) * grid.resolution
    c, s = math.cos(grid.origin_yaw), math.sin(grid.origin_yaw)
    px, py = grid.origin_x + c * lx - s * ly, grid.origin_y + s * lx + c * ly
    mask = shape.contains(px, py, margin=grid.resolution / 2)
    if not mask.any():
        return None
    return (slice(r0, r1), slice(c0, c1)), mask


def keep_out_mask(grid: OccupancyMap, zones: Iterable[Polygon]) -> np.ndarray:
    """Cells covered by the keep-out ``zones`` (bool, grid shape; rasterised as :func:`rasterize` does)."""
    mask = np.zeros(grid.cells.shape, dtype=bool)
    for zone in zones:
        cells = rasterize(zone, grid)
        if cells is not None:
            mask[cells[0]] |= cells[1]
    return mask


# ---------------------------------------------------------------------------
# Paths
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Path:
    """A planned path in the map frame: ``points`` [(x, y), ...] from start to goal, ``length`` in m.

    ``goal`` is where the path ends: the requested goal, or the nearest safe point
    within the goal tolerance when the requested goal was too close to an obstacle.
    """

    points: list[tuple[float, float]]
    length: float
    goal: tuple[float, float] = field(default=(0.0, 0.0))

    def densified(self, step: float) -> list[tuple[float, float]]:
        """The path with a point at least every ``step`` metres (as navfn returns it)."""
        if step <= 0 or not math.isfinite(step):
            raise ValueError(f"step: {step!r} must be a positive number of metres")
        out = [self.points[0]]
        for (ax, ay), (bx, by) in zip(self.points, self.points[1:], strict=False):
            n = max(1, math.ceil(math.hypot(bx - ax, by - ay) / step))
            out.extend((ax + (bx - ax) * k / n, ay + (by - ay) * k / n) for k in range(1, n + 1))
        return out


def polyline_length(points: list[tuple[float, float]]) -> float:
    """Sum of the segment lengths of ``points`` (m)."""
    return float(sum(math.hypot(bx - ax, by - ay)
                     for (ax, ay), (bx, by) in zip(points, points[1:], strict=False)))


# ---------------------------------------------------------------------------
# The planner
# ---------------------------------------------------------------------------

class GridPlanner:
    """A* planner on the inflated costmap of one floor.

    ``grid``: the floor's occupancy map; ``robot_radius`` (m): the footprint radius
    (inscribed radius); ``inflation_radius`` (m, >= robot_radius): where the cost
    decay ends; ``cost_scaling`` (1/m) and ``inflation_cost`` (weight of a cell at the
    inscribed radius, on top of 1) shape the decay; ``goal_tolerance`` (m): how far a
    goal inside the inscribed zone may be moved; ``keep_out``: the floor's keep-out zones by id (lethal, as walls).

    Obstacles (:meth:`add_obstacle`, :meth:`remove_obstacle`) and sensor marks
    (:meth:`set_sensor_marks`) update the costmap; :attr:`version` increases with
    every change so users know when to re-check a path (:meth:`path_blocked`).
    """

    def __init__(self, grid: OccupancyMap, robot_radius: float, inflation_radius: float | None = None,
                 cost_scaling: float = 3.0, inflation_cost: float = 4.0, goal_tolerance: float = 0.5,
                 keep_out: Mapping[str, Polygon] | None = None) -> None:
        for name, value in (("robot_radius", robot_radius), ("cost_scaling", cost_scaling),
                            ("inflation_cost", inflation_cost), ("goal_tolerance", goal_tolerance)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise PlanningError(f"{name}: {value!r} must be a finite number >= 0")
        if inflation_radius is None:
            inflation_radius = robot_radius + 0.7
        if not (math.isfinite(inflation_radius) and inflation_radius >= robot_radius):
            raise PlanningError(f"inflation_radius: {inflation_radius!r} must be >= robot_radius ({robot_radius:g} m)")
        self.grid = grid
        self.robot_radius = float(robot_radius)
        self.inflation_radius = float(inflation_radius)
        self.cost_scaling = float(cost_scaling)
        self.inflation_cost = float(inflation_cost)
        self.goal_tolerance = float(goal_tolerance)
        self.version = 0
        self.keep_out = dict(keep_out or {})
        self._static = grid.cells != FREE                       # occupied or unknown
        self._keep_out = keep_out_mask(grid, self.keep_out.values())
        self._fixed = self._static | self._keep_out             # what no run-time change clears
        self._obstacles: dict[str, Shape] = {}
        self._obstacle_mask = np.zeros_like(self._static)
        self._marks = np.zeros_like(self._static)
        self._marks_box: tuple[int, int, int, int] | None = None    # (r0, r1, c0, c1) holding every mark
        self._lethal = self._fixed.copy()
        self._dist = np.zeros(self._static.shape, dtype=np.float32)   # m to the nearest lethal cell
        self._weights = np.zeros(self._static.shape, dtype=np.float32)
        self._labels: np.ndarray | None = None
        self._update_region(None)

    # -- costmap -------------------------------------------------------------
    @property
    def weights(self) -> np.ndarray:
        """Cell weights (float32, inf = not traversable), row 0 at the bottom. Do not modify."""
        return self._weights

    @property
    def lethal(self) -> np.ndarray:
        """Mask of lethal cells (map obstacles, unknown space, keep-out zones, obstacles, sensor marks). Do not
        modify."""
        return self._lethal

    @property
    def keep_out_cells(self) -> np.ndarray:
        """Mask of the cells of the keep-out zones. Do not modify."""
        return self._keep_out

    @property
    def static_distance(self) -> np.ndarray:
        """Distance (m) of every cell to the nearest occupied/unknown *map* cell or keep-out zone (computed
        once)."""
        if not hasattr(self, "_static_dist"):
            self._static_dist = (ndimage.distance_transform_edt(~self._fixed) * self.grid.resolution
                                 ).astype(np.float32)
        return self._static_dist

    @property
    def obstacles(self) -> dict[str, Shape]:
        """A copy of the obstacles added by id."""
        return dict(self._obstacles)

    def add_obstacle(self, obstacle_id: str, shape: Shape) -> None:
        """Add (or replace) obstacle ``obstacle_id`` covering ``shape`` (map metres)."""
        if not isinstance(shape, (Circle, Rectangle)):
            raise ObstacleError(f"obstacle {obstacle_id!r}: {shape!r} is not a Circle or Rectangle")
        self._obstacles[obstacle_id] = shape
        self._rebuild_obstacles()

    def remove_obstacle(self, obstacle_id: str) -> bool:
        """Remove obstacle ``obstacle_id``; False when there was none."""
        if self._obstacles.pop(obstacle_id, None) is None:
            return False
        self._rebuild_obstacles()
        return True

    def clear_obstacles(self) -> None:
        """Remove every obstacle."""
        self._obstacles.clear()
        self._rebuild_obstacles()

    def set_obstacles(self, obstacles: dict[str, Shape]) -> bool:
        """Replace every obstacle by ``obstacles`` (id -> shape) with one costmap update; True if any changed."""
        for obstacle_id, shape in obstacles.items():
            if not isinstance(shape, (Circle, Rectangle)):
                raise ObstacleError(f"obstacle {obstacle_id!r}: {shape!r} is not a Circle or Rectangle")
        if obstacles == self._obstacles:
            return False
        self._obstacles = dict(obstacles)
        self._rebuild_obstacles()
        return True

    def set_sensor_marks(self, marks: np.ndarray) -> bool:
        """Replace the sensor-marked lethal cells (bool mask, grid shape). True when anything changed."""
        if marks.shape != self._static.shape:
            raise PlanningError(f"sensor marks: shape {marks.shape} does not match the map {self._static.shape}")
        marks = marks.astype(bool)
        changed = marks != self._marks
        if not changed.any():
            return False
        self._marks = marks.copy()
        rows, cols = np.nonzero(marks)
        self._marks_box = (int(rows.min()), int(rows.max()) + 1, int(cols.min()), int(cols.max()) + 1) \
            if rows.size else None
        self._apply_lethal(changed)
        return True

    def set_sensor_mark_cells(self, cells: Iterable[tuple[tuple[slice, slice], np.ndarray]]) -> bool:
        """Replace the sensor-marked lethal cells by the union of ``cells`` (each as :func:`rasterize` returns it),
        as :meth:`set_sensor_marks` does, touching only the window that holds the old and the new marks: a person
        walking past costs the costmap a few square metres, not the whole map. True when anything changed."""
        cells = list(cells)
        boxes = [(rs.start, rs.stop, cs.start, cs.stop) for (rs, cs), _mask in cells]
        new_box = (min(b[0] for b in boxes), max(b[1] for b in boxes), min(b[2] for b in boxes),
                   max(b[3] for b in boxes)) if boxes else None
        if self._marks_box is not None:
            boxes.append(self._marks_box)
        if not boxes:
            return False
        r0, r1 = min(b[0] for b in boxes), max(b[1] for b in boxes)
        c0, c1 = min(b[2] for b in boxes), max(b[3] for b in boxes)
        window = np.zeros((r1 - r0, c1 - c0), dtype=bool)
        for (rs, cs), mask in cells:
            window[rs.start - r0:rs.stop - r0, cs.start - c0:cs.stop - c0] |= mask
        marks = self._marks[r0:r1, c0:c1]
        changed = window != marks
        if not changed.any():
            return False
        marks[...] = window                          # this planner's own array: changed in place
        self._marks_box = new_box
        self._lethal = self._lethal.copy()           # a mask handed out (lethal) is never changed under its holder
        self._lethal[r0:r1, c0:c1] = self._fixed[r0:r1, c0:c1] | self._obstacle_mask[r0:r1, c0:c1] | window
        rows, cols = np.nonzero(changed)
        self._update_region((r0 + int(rows.min()), r0 + int(rows.max()) + 1,
                             c0 + int(cols.min()), c0 + int(cols.max()) + 1))
        return True

    def _rebuild_obstacles(self) -> None:
        mask = np.zeros_like(self._static)
        for shape in self._obstacles.values():
            cells = rasterize(shape, self.grid)
            if cells is not None:
                mask[cells[0]] |= cells[1]
        changed = mask != self._obstacle_mask
        self._obstacle_mask = mask
        if changed.any():
            self._apply_lethal(changed)

    def _apply_lethal(self, changed: np.ndarray) -> None:
        self._lethal = self._fixed | self._obstacle_mask | self._marks
        rows, cols = np.nonzero(changed)
        self._update_region((int(rows.min()), int(rows.max()) + 1, int(cols.min()), int(cols.max()) + 1))

    def _update_region(self, box: tuple[int, int, int, int] | None) -> None:
        """Re-inflate around the changed cells ``box`` (r0, r1, c0, c1); the whole map if None."""
        h, w = self._static.shape
        pad = int(math.ceil(self.inflation_radius / self.grid.resolution)) + 2
        if box is None or (box[1] - box[0] + 4 * pad) * (box[3] - box[2] + 4 * pad) > h * w // 3:
            out = (0, h, 0, w)
            win = out
        else:
            r0, r1, c0, c1 = box
            out = (max(r0 - pad, 0), min(r1 + pad, h), max(c0 - pad, 0), min(c1 + pad, w))
            win = (max(r0 - 2 * pad, 0), min(r1 + 2 * pad, h), max(c0 - 2 * pad, 0), min(c1 + 2 * pad, w))
        free = ~self._lethal[win[0]:win[1], win[2]:win[3]]
        if free.all():
            dist = np.full(free.shape, np.inf, dtype=np.float32)
        else:
            dist = (ndimage.distance_transform_edt(free) * self.grid.resolution).astype(np.float32)
        inner = dist[out[0] - win[0]:out[1] - win[0], out[2] - win[2]:out[3] - win[2]]
        self._dist[out[0]:out[1], out[2]:out[3]] = inner
        self._weights[out[0]:out[1], out[2]:out[3]] = self._weigh(inner)
        self._labels = None
        self.version += 1

    def _weigh(self, dist: np.ndarray) -> np.ndarray:
        with np.errstate(over="ignore", invalid="ignore"):
            decay = 1.0 + self.inflation_cost * np.exp(-self.cost_scaling * (dist - self.robot_radius))
        weights = np.where(dist < self.inflation_radius, decay, 1.0).astype(np.float32)
        weights[dist < self.robot_radius] = np.inf
        return weights

    def _components(self) -> np.ndarray:
        if self._labels is None:
            self._labels, _ = ndimage.label(np.isfinite(self._weights))
        return self._labels

    # -- queries -------------------------------------------------------------
    def _cell(self, x: float, y: float, what: str) -> tuple[int, int]:
        if not (isinstance(x, (int, float)) and isinstance(y, (int, float))
                and math.isfinite(x) and math.isfinite(y)):
            raise PlanningError(f"{what} ({x!r}, {y!r}) is not a pair of finite numbers (m)")
        row, col = self.grid.world_to_cell(x, y)
        if not (0 <= row < self.grid.height and 0 <= col < self.grid.width):
            w, h = self.grid.size_m
            raise PlanningError(f"{what} ({x:g}, {y:g}) is outside the map "
                                f"(x {self.grid.origin_x:g}..{self.grid.origin_x + w:g}, "
                                f"y {self.grid.origin_y:g}..{self.grid.origin_y + h:g} m)")
        if self._lethal[row, col]:
            kind = ("a wall or unknown space" if self._static[row, col]
                    else f"keep-out zone {self.keep_out_at(x, y)}" if self._keep_out[row, col]
                    else "an obstacle" if self._obstacle_mask[row, col] else "an obstacle seen by the sensors")
            raise PlanningError(f"{what} ({x:g}, {y:g}) is inside {kind}")
        return row, col

    def keep_out_at(self, x: float, y: float) -> str | None:
        """The id of the keep-out zone whose cells cover (x, y), or None."""
        row, col = self.grid.world_to_cell(x, y)
        if not (0 <= row < self.grid.height and 0 <= col < self.grid.width and self._keep_out[row, col]):
            return None
        return next((zone_id for zone_id, zone in self.keep_out.items()
                     if zone.contains(np.array(x), np.array(y), margin=self.grid.resolution)), "?")

    def clearance(self, x: float, y: float) -> float:
        """Distance (m) from (x, y) to the nearest lethal cell; 0 off the map."""
        row, col = self.grid.world_to_cell(x, y)
        if not (0 <= row < self.grid.height and 0 <= col < self.grid.width):
            return 0.0
        return float(self._dist[row, col])

    def _disc(self, row: int, col: int, radius: float) -> tuple[tuple[slice, slice], np.ndarray]:
        n = int(math.ceil(radius / self.grid.resolution))
        r0, r1 = max(row - n, 0), min(row + n + 1, self.grid.height)
        c0, c1 = max(col - n, 0), min(col + n + 1, self.grid.width)
        rr, cc = np.mgrid[r0:r1, c0:c1]
        mask = (rr - row) ** 2 + (cc - col) ** 2 <= n * n
        return (slice(r0, r1), slice(c0, c1)), mask

    def _goal_cell(self, row: int, col: int, x: float, y: float) -> tuple[int, int]:
        if np.isfinite(self._weights[row, col]):
            return row, col
        box, disc = self._disc(row, col, self.goal_tolerance)
        ok = disc & np.isfinite(self._weights[box])
        if not ok.any():
            raise PlanningError(f"goal ({x:g}, {y:g}) is closer than the robot radius "
                                f"{self.robot_radius:g} m to an obstacle and no free cell lies within "
                                f"the goal tolerance {self.goal_tolerance:g} m")
        rr, cc = np.nonzero(ok)
        rr, cc = rr + box[0].start, cc + box[1].start
        best = int(np.argmin((rr - row) ** 2 + (cc - col) ** 2))
        return int(rr[best]), int(cc[best])

    def _start_labels(self, start: tuple[int, int]) -> tuple[set[int], np.ndarray]:
        """Components the robot at ``start`` can enter, and the weights to search with: from inside the
        inscribed zone it escapes through its own footprint (as move_base clears the robot's footprint)."""
        weights = self._weights
        labels = self._components()
        if np.isfinite(weights[start]):
            return {int(labels[start])}, weights
        weights = weights.copy()
        box, disc = self._disc(*start, self.robot_radius + self.grid.resolution)
        escape = disc & ~self._lethal[box] & ~np.isfinite(weights[box])
        weights[box][escape] = ESCAPE_WEIGHT
        return {int(v) for v in np.unique(labels[box][disc])} - {0}, weights

    def _endpoints(self, start_xy: tuple[float, float], goal_xy: tuple[float, float]
                   ) -> tuple[tuple[int, int], tuple[int, int], np.ndarray]:
        """Start cell, goal cell (moved out of the inscribed zone) and search weights; raises
        :class:`PlanningError` when either is unusable or no path joins them."""
        sx, sy = start_xy
        gx, gy = goal_xy
        start = self._cell(sx, sy, "start")
        goal = self.goal_cell(gx, gy)
        start_labels, weights = self._start_labels(start)
        if int(self._components()[goal]) not in start_labels:
            raise PlanningError(f"no path from ({sx:g}, {sy:g}) to ({gx:g}, {gy:g}): "
                                "the goal is not reachable (walls or obstacles in the way)")
        return start, goal, weights

    def goal_cell(self, x: float, y: float) -> tuple[int, int]:
        """The cell a goal at (x, y) is planned to: moved out of the inscribed zone up to the goal
        tolerance; raises :class:`PlanningError` when it is off the map, in a wall or without such a cell."""
        return self._goal_cell(*self._cell(x, y, "goal"), x, y)

    def check_reachable(self, start_xy: tuple[float, float], goal_xy: tuple[float, float]) -> None:
        """Raise :class:`PlanningError` exactly when :meth:`plan` would, without searching a path
        (connected components of the costmap: cheap enough to check every place of a building)."""
        self._endpoints(start_xy, goal_xy)

    def reachable_mask(self, start_xy: tuple[float, float]) -> np.ndarray:
        """Mask of the cells a robot at ``start_xy`` can reach (grid shape); raises :class:`PlanningError`."""
        start_labels, _ = self._start_labels(self._cell(*start_xy, "start"))
        return np.isin(self._components(), list(start_labels))

    def plan(self, start_xy: tuple[float, float], goal_xy: tuple[float, float]) -> Path:
        """Plan from ``start_xy`` to ``goal_xy`` (map metres); raises :class:`PlanningError` with the reason."""
        start, goal, weights = self._endpoints(start_xy, goal_xy)
        sx, sy = start_xy
        gx, gy = goal_xy
        goal_xy_out = (float(gx), float(gy)) if goal == self.grid.world_to_cell(gx, gy) \
            else self.grid.cell_to_world(*goal)
        if start == goal:
            points = [(float(sx), float(sy)), goal_xy_out]
            return Path(points, polyline_length(points), goal_xy_out)
        cells = pyastar2d.astar_path(weights, start, goal, allow_diagonal=False)
        if cells is None:  # pragma: no cover - the component check above catches this
            raise PlanningError(f"no path from ({sx:g}, {sy:g}) to ({gx:g}, {gy:g})")
        cells = self._shortcut(np.asarray(cells), weights)
        mid = [self.grid.cell_to_world(int(r), int(c)) for r, c in cells[1:-1]]
        points = [(float(sx), float(sy)), *mid, goal_xy_out]
        return Path(points, polyline_length(points), goal_xy_out)

    def reachable(self, start_xy: tuple[float, float]) -> np.ndarray:
        """Mask of the cells a robot at ``start_xy`` can reach (finite weight, connected to it; from inside the
        inscribed zone, through its own footprint as :meth:`plan` lets it); :class:`PlanningError` as :meth:`plan`."""
        start = self._cell(*start_xy, "start")
        labels = self._components()
        box, disc = self._disc(*start, self.robot_radius + self.grid.resolution)
        ids = {int(labels[start])} if labels[start] else {int(v) for v in np.unique(labels[box][disc])}
        return np.isin(labels, sorted(ids - {0}))

    def path_length(self, a: tuple[float, float], b: tuple[float, float]) -> float:
        """Length (m) of the planned path from ``a`` to ``b``; raises :class:`PlanningError`."""
        return self.plan(a, b).length

    @staticmethod
    def _line_costs(weights: np.ndarray, a: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Integrated cost (weight x cells, midpoint rule) of the straight line from cell ``a`` to each of
        the cells ``ends`` (one row each), all in one pass: a line of span ``s`` cells is sampled at the
        midpoints of ``max(2, 2 ceil(s))`` equal pieces; its cost is their mean weight times ``s``."""
        a0, a1 = int(a[0]), int(a[1])
        d0 = ends[:, 0].astype(np.int64) - a0
        d1 = ends[:, 1].astype(np.int64) - a1
        spans = np.array([math.hypot(x, y) for x, y in zip(d0.tolist(), d1.tolist(), strict=True)])
        n = np.maximum(2, 2 * np.ceil(spans).astype(np.int64))
        first = np.concatenate([[0], np.cumsum(n)[:-1]])
        line = np.repeat(np.arange(len(n)), n)                  # which line each sample belongs to
        t = (np.arange(int(n.sum())) - first[line] + 0.5) / n[line]
        rows = np.rint(a0 + d0[line] * t).astype(np.intp)
        cols = np.rint(a1 + d1[line] * t).astype(np.intp)
        sums = np.add.reduceat(weights[rows, cols].astype(np.float64), first)
        return sums / n * spans

    def _shortcut(self, cells: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """String pulling: replace a stretch of the cell path by a straight line when the line's
        integrated cost is not higher (so it never cuts closer to walls than the costs allow).

        From vertex ``i`` the line is tried to every ``stride``-th vertex (and the last) while it is
        not costlier than the stretch; if even the first fails, to the vertices in between, farthest
        first. The candidates are judged in batches (8, 16, 32, ... lines at once, in numpy): the path
        is the one the vertex-by-vertex search would find, at a fraction of its Python calls."""
        if len(cells) <= 2:
            return cells
        # cost of the cell path up to vertex k, in the same (trapezoid) measure as the line's
        w = weights[cells[:, 0], cells[:, 1]].astype(np.float64)
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]))])
        stride = 4
        keep = [0]
        i = 0
        last = len(cells) - 1

        def fits(ks: list[int]) -> np.ndarray:
            idx = np.asarray(ks)
            return self._line_costs(weights, cells[i], cells[idx]) <= (cum[idx] - cum[i]) * (1.0 + 1e-3)

        while i < last:
            best = i + 1
            candidates = [*range(i + stride, last, stride), last]
            batch = 8
            while candidates:
                ks, candidates = candidates[:batch], candidates[batch:]
                good = fits(ks)
                fail = int(np.argmin(good)) if not good.all() else len(ks)
                if fail:
                    best = ks[fail - 1]
                if fail < len(ks):
                    break
                batch *= 2
            if best == i + 1:
                # the first stride failed: try the vertices in between, farthest first
                between = list(range(min(i + stride - 1, last), i + 1, -1))
                if between:
                    good = fits(between)
                    best = between[int(np.argmax(good))] if good.any() else i + 1
            keep.append(best)
            i = best
        return cells[keep]

    def path_blocked(self, points: list[tuple[float, float]], skip: float = 1.0) -> bool:
        """True when the polyline ``points`` crosses a cell the robot may not enter (inscribed or lethal).

        The first ``skip`` metres are ignored (the robot may stand in its own inscribed zone).
        """
        if len(points) < 2:
            return False
        xs, ys = sample_polyline(points, self.grid.resolution / 2)
        along = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xs), np.diff(ys)))])
        rows, cols = cells_of(self.grid, xs[along >= skip], ys[along >= skip])
        inside = (rows >= 0) & (rows < self.grid.height) & (cols >= 0) & (cols < self.grid.width)
        if not inside.all():
            return True
        return not bool(np.isfinite(self._weights[rows, cols]).all())


def cells_of(grid: OccupancyMap, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised :meth:`OccupancyMap.world_to_cell`: (rows, cols) of the points (may lie off the grid)."""
    dx, dy = np.asarray(xs) - grid.origin_x, np.asarray(ys) - grid.origin_y
    c, s = math.cos(grid.origin_yaw), math.sin(grid.origin_yaw)
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    return (np.floor(ly / grid.resolution).astype(np.intp), np.floor(lx / grid.resolution).astype(np.intp))


def sample_polyline(points: list[tuple[float, float]], step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``step`` metres (or closer) along the polyline, both ends included."""
    pts = np.asarray(points, dtype=np.float64)
    xs, ys = [pts[:1, 0]], [pts[:1, 1]]
    for a, b in zip(pts, pts[1:], strict=False):
        n = max(1, int(math.ceil(math.hypot(*(b - a)) / step)))
        t = np.arange(1, n + 1) / n
        xs.append(a[0] + (b[0] - a[0]) * t)
        ys.append(a[1] + (b[1] - a[1]) * t)
    return np.concatenate(xs), np.concatenate(ys)
