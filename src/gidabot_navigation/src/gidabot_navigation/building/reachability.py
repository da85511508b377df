"""Can every robot reach the places of its floor? (ROS-free; part of ``gidabot check``.)

For every robot, every location and every connector meeting point on its floor must be
reachable from the robot's home for the robot's radius, on the costmap guiding plans
trips with (:class:`~gidabot_navigation.building.planning.GridPlanner` on the floor's
map, inscribed radius = the robot's radius, a goal inside the inscribed zone moved up
to the planner's goal tolerance). A place that is not is reported by id with where the
way is blocked:

- *walled off* (no free path at all, e.g. a closed door in the map): the point the robot
  can reach that is closest to the place;
- *too narrow* (a free path exists, but no path wide enough for the robot): the
  narrowest point of the widest free path, with its clearance and the robot's radius;
- *against a wall*: the place is closer to a wall than the robot's radius and no cell
  within the goal tolerance is free of it.

The costmap and the cells reachable from a home are computed once per floor and radius
(several robots of one size on a floor share them), and a place costs a lookup, so the
faculty's four floors are checked in well under a second. Only an unreachable place
costs more (a search for its bottleneck).
"""

from __future__ import annotations

import numpy as np
import pyastar2d
from scipy import ndimage

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building, Floor, Robot, format_floor
from gidabot_navigation.building.planning import GridPlanner
from gidabot_navigation.errors import PlanningError, Problem

WALL_COST = 1000.0    # a wall cell on the way, in free cells: the way found crosses as few as it can
ZONE_COST = 100.0     # a keep-out cell: drawn over free space, so the way crosses a zone before a wall


def reachability_problems(building: Building, planners: PlannerCache | None = None) -> list[Problem]:
    """Every place on a robot's floor that the robot cannot reach from its home, one problem each.

    ``planners``: a cache of costmaps kept between calls (the building editor checks after every change; a
    costmap is made again only for a new map, radius or keep-out zones)."""
    cache = planners if planners is not None else PlannerCache()
    problems: list[Problem] = []
    for robot in building.robots:
        floor = building.floor(robot.floor)
        problems += _robot_problems(building, floor, robot, cache.planner(floor, robot.radius))
    return problems


class PlannerCache:
    """Planners by (map, radius, keep-out zones): one costmap per floor and robot size."""

    def __init__(self, size: int = 32) -> None:
        self.size = size
        self._planners: dict[tuple, tuple[object, GridPlanner]] = {}

    def planner(self, floor: Floor, radius: float) -> GridPlanner:
        zones = floor.keep_out_zones
        key = (id(floor.map), radius, tuple((k, z.points) for k, z in zones.items()))
        if key not in self._planners:
            while len(self._planners) >= self.size:
                self._planners.pop(next(iter(self._planners)))
            # the map is kept with its planner: its id() stays its own while the entry lives
            self._planners[key] = (floor.map, GridPlanner(floor.map, radius, keep_out=zones))
        return self._planners[key][1]


def _places(building: Building, floor: Floor) -> list[tuple[str, Pose2D]]:
    places = [(f"location {loc.id}", loc.pose) for loc in building.locations if loc.floor == floor.id]
    places += [(f"connector {c.id} (meeting point on floor {floor.label})", c.meeting[floor.id])
               for c in building.connectors if floor.id in c.meeting]
    return places


def _robot_problems(building: Building, floor: Floor, robot: Robot, planner: GridPlanner) -> list[Problem]:
    home = (robot.home.x, robot.home.y)
    source = str(building.path)
    try:
        reachable = planner.reachable_mask(home)
    except PlanningError as err:
        return [Problem(source, f"robot {robot.name}", f"home {err}", floor.id, ((home[0], home[1], "place"),))]
    problems = []
    for what, pose in _places(building, floor):
        try:
            planner.check_reachable(home, (pose.x, pose.y))
        except PlanningError as err:
            why, marks = _where_blocked(planner, reachable, home, (pose.x, pose.y), str(err))
            problems.append(Problem(source, what, f"({pose.x:g}, {pose.y:g}) on floor {format_floor(floor.id)} "
                                                  f"is not reachable by {robot.name} (radius {robot.radius:g} m) "
                                                  f"from its home ({robot.home.x:g}, {robot.home.y:g}): {why}",
                                    floor.id, ((pose.x, pose.y, "place"), *marks)))
    return problems


def _where_blocked(planner: GridPlanner, reachable: np.ndarray, home: tuple[float, float],
                   goal: tuple[float, float], error: str) -> tuple[str, tuple[tuple[float, float, str], ...]]:
    """Why the way to ``goal`` is blocked, and the points that show it (where it closes and the last point
    reached, or the narrowest point)."""
    grid = planner.grid
    try:
        target = planner.goal_cell(*goal)
    except PlanningError as err:             # inside a wall, or against one with no room around
        return str(err), ()
    start = grid.world_to_cell(*home)
    if not reachable[start]:                 # the home is in the inscribed zone: start from where it escapes to
        start = _closest(reachable, start)
    if start is None:
        return error, ()
    labels, _ = ndimage.label(~planner.lethal)
    if labels[start] != labels[target]:
        last, wall = _closed_at(planner.lethal, planner.keep_out_cells, reachable, start, target)
        (lx, ly), (wx, wy) = grid.cell_to_world(*last), grid.cell_to_world(*wall)
        zone = planner.keep_out_at(wx, wy)
        what = f"keep-out zone {zone}" if zone is not None else "a closed door or a wall without its gap?"
        return (f"walled off (no free way at all): the way closes at ({wx:.2f}, {wy:.2f}) ({what}); the last point "
                f"the robot reaches on it is ({lx:.2f}, {ly:.2f})", ((wx, wy, "closed"), (lx, ly, "reached")))
    clearance, cell = _bottleneck(planner.static_distance, start, target, planner.robot_radius)
    x, y = grid.cell_to_world(*cell)
    return (f"the way is too narrow: at ({x:.2f}, {y:.2f}) the robot's centre keeps at most {clearance:.2f} m "
            f"from the walls, it needs {planner.robot_radius:g} m (its radius)", ((x, y, "narrow"),))


def _closest(mask: np.ndarray, cell: tuple[int, int]) -> tuple[int, int] | None:
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return None
    k = int(np.argmin((rows - cell[0]) ** 2 + (cols - cell[1]) ** 2))
    return int(rows[k]), int(cols[k])


def _closed_at(lethal: np.ndarray, zones: np.ndarray, reachable: np.ndarray, start: tuple[int, int],
               target: tuple[int, int]) -> tuple[tuple[int, int], tuple[int, int]]:
    """Where the way through the fewest wall cells leaves what the robot reaches: (last reachable
    cell, first wall cell). Crossing a wall (or unknown space) cell costs as much as 1000 free ones, a keep-out
    zone's as much as 100."""
    weights = np.where(lethal, np.where(zones, ZONE_COST, WALL_COST), 1.0).astype(np.float32)
    path = pyastar2d.astar_path(weights, start, target, allow_diagonal=False)
    out = int(np.argmin(reachable[path[:, 0], path[:, 1]]))        # the first cell not reached
    closed = int(np.argmax(lethal[path[:, 0], path[:, 1]]))         # the first wall cell
    last = path[max(out - 1, 0)]
    return (int(last[0]), int(last[1])), (int(path[closed, 0]), int(path[closed, 1]))


def _bottleneck(clearance: np.ndarray, start: tuple[int, int], target: tuple[int, int],
                radius: float) -> tuple[float, tuple[int, int]]:
    """The widest free way between two cells the robot may stand on: its least clearance (m) and that cell.

    The largest clearance c such that the cells with clearance >= c still join the two
    (a binary search over the clearances below ``radius`` that occur in the map: the
    cells with clearance >= ``radius`` do not join them, the free cells do), then a
    shortest path through those cells: its least clearance is c, where it is met is the
    narrowest point.
    """
    levels = np.unique(clearance[(clearance > 0) & (clearance < radius)])
    if levels.size == 0:                     # pragma: no cover - then the robot fits wherever it is free
        return 0.0, start

    def joined(level: float) -> bool:
        labels, _ = ndimage.label(clearance >= level)
        return labels[start] != 0 and labels[start] == labels[target]

    lo, hi = 0, len(levels) - 1              # levels[0] joins them (free space does)
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if joined(float(levels[mid])):
            lo = mid
        else:
            hi = mid - 1
    level = float(levels[lo])
    path = pyastar2d.astar_path(np.where(clearance >= level, 1.0, np.inf).astype(np.float32), start, target,
                                allow_diagonal=False)
    k = int(np.argmin(clearance[path[:, 0], path[:, 1]]))
    return float(clearance[path[k, 0], path[k, 1]]), (int(path[k, 0]), int(path[k, 1]))
