"""The global planner: inflation, A*, string pulling, obstacles, errors; the faculty floors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gidabot_navigation.building.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap
from gidabot_navigation.building.planning import Circle, GridPlanner, Path, Rectangle, polyline_length, rasterize
from gidabot_navigation.errors import ObstacleError, PlanningError

RES = 0.05


def box_map(width_m: float = 10.0, height_m: float = 6.0) -> OccupancyMap:
    """A walled rectangle (1-cell walls), origin (-1, -2)."""
    cells = np.full((int(height_m / RES), int(width_m / RES)), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = OCCUPIED
    cells[:, 0] = cells[:, -1] = OCCUPIED
    return OccupancyMap(cells=cells, resolution=RES, origin_x=-1.0, origin_y=-2.0)


def wall_with_gap(gap_y: tuple[float, float]) -> OccupancyMap:
    """box_map with a wall at x = 4 m (map), open only for y in ``gap_y``."""
    grid = box_map()
    col = int((4.0 - grid.origin_x) / RES)
    for row in range(grid.height):
        y = grid.origin_y + (row + 0.5) * RES
        if not gap_y[0] <= y <= gap_y[1]:
            grid.cells[row, col:col + 4] = OCCUPIED
    return grid


def test_straight_line_in_open_space() -> None:
    planner = GridPlanner(box_map(), robot_radius=0.3)
    path = planner.plan((0.0, 1.0), (7.0, 1.0))
    assert path.points[0] == (0.0, 1.0) and path.points[-1] == (7.0, 1.0)
    assert path.length == pytest.approx(7.0, abs=0.01)
    assert path.goal == (7.0, 1.0)
    diag = planner.plan((0.0, -1.0), (7.0, 3.0))
    assert diag.length == pytest.approx(math.hypot(7.0, 4.0), rel=0.03)   # string pulling: nearly straight


def test_path_goes_through_the_gap_and_keeps_clear_of_walls() -> None:
    grid = wall_with_gap((2.0, 3.5))
    planner = GridPlanner(grid, robot_radius=0.3)
    path = planner.plan((1.0, -1.0), (7.0, -1.0))
    assert path.length > 9.0            # detour through the gap at y 2..3.5 (straight: 6 m)
    assert all(planner.clearance(x, y) >= 0.3 for x, y in path.densified(0.05)[1:-1])
    # the path crosses the wall's x inside the gap
    crossing = [y for x, y in path.densified(0.02) if abs(x - 4.1) < 0.02]
    assert crossing and all(2.3 <= y <= 3.2 for y in crossing)
    assert planner.path_length((1.0, -1.0), (7.0, -1.0)) == pytest.approx(path.length)


def test_gap_narrower_than_the_robot_is_no_path() -> None:
    planner = GridPlanner(wall_with_gap((2.0, 2.4)), robot_radius=0.3)
    with pytest.raises(PlanningError, match="not reachable"):
        planner.plan((1.0, -1.0), (7.0, -1.0))


def test_inflation_keeps_to_the_middle_of_a_corridor() -> None:
    grid = box_map(10.0, 3.0)   # a 3 m corridor: y -2..1, middle -0.5
    planner = GridPlanner(grid, robot_radius=0.3, inflation_radius=1.5)
    path = planner.plan((0.0, -1.4), (8.0, -1.4))
    mid = [y for x, y in path.densified(0.05) if 2.0 < x < 6.0]
    assert mid and max(abs(y + 0.5) for y in mid) < 0.3
    assert path.length > 8.0


@pytest.mark.parametrize("start, goal, message", [
    ((-5.0, 0.0), (3.0, 0.0), "start .* outside the map"),
    ((0.0, 0.0), (3.0, 50.0), "goal .* outside the map"),
    ((0.0, 0.0), (-0.98, 0.0), "goal .* inside a wall"),
    ((math.nan, 0.0), (3.0, 0.0), "start .* finite"),
    ((0.0, 0.0), (3.0, math.inf), "goal .* finite"),
])
def test_bad_start_or_goal(start, goal, message) -> None:
    with pytest.raises(PlanningError, match=message):
        GridPlanner(box_map(), robot_radius=0.3).plan(start, goal)


def test_unknown_space_is_never_entered() -> None:
    grid = box_map()
    grid.cells[:, 100:110] = UNKNOWN
    planner = GridPlanner(grid, robot_radius=0.2)
    with pytest.raises(PlanningError, match="not reachable"):
        planner.plan((0.0, 0.0), (7.0, 0.0))
    with pytest.raises(PlanningError, match="wall or unknown"):
        planner.plan((0.0, 0.0), (4.2, 0.0))


def test_start_inside_the_inscribed_zone_escapes() -> None:
    planner = GridPlanner(box_map(), robot_radius=0.4)
    start = (-0.85, 0.0)                  # 0.1 m from the west wall
    assert planner.clearance(*start) < 0.4
    path = planner.plan(start, (5.0, 0.0))
    assert path.points[0] == start and path.length == pytest.approx(5.85, abs=0.1)


def test_goal_inside_the_inscribed_zone_moves_within_tolerance() -> None:
    planner = GridPlanner(box_map(), robot_radius=0.4, goal_tolerance=0.5)
    path = planner.plan((3.0, 0.0), (-0.85, 0.0))
    gx, gy = path.goal
    assert path.points[-1] == path.goal
    assert planner.clearance(gx, gy) >= 0.4
    assert math.hypot(gx + 0.85, gy) <= 0.5
    strict = GridPlanner(box_map(), robot_radius=0.4, goal_tolerance=0.0)
    with pytest.raises(PlanningError, match="closer than the robot radius"):
        strict.plan((3.0, 0.0), (-0.85, 0.0))


def test_obstacles_block_and_unblock() -> None:
    grid = wall_with_gap((2.0, 3.5))
    planner = GridPlanner(grid, robot_radius=0.3)
    path = planner.plan((1.0, -1.0), (7.0, -1.0))
    version = planner.version
    planner.add_obstacle("door", Rectangle(4.1, 2.75, 0.4, 2.0))
    assert planner.version > version
    assert planner.path_blocked(path.points)
    with pytest.raises(PlanningError, match="not reachable"):
        planner.plan((1.0, -1.0), (7.0, -1.0))
    with pytest.raises(PlanningError, match="inside an obstacle"):
        planner.plan((1.0, -1.0), (4.1, 2.75))
    assert planner.obstacles == {"door": Rectangle(4.1, 2.75, 0.4, 2.0)}
    assert planner.remove_obstacle("door") and not planner.remove_obstacle("door")
    assert not planner.path_blocked(path.points)
    assert planner.plan((1.0, -1.0), (7.0, -1.0)).length == pytest.approx(path.length)


def test_set_obstacles_replaces_them_all_at_once() -> None:
    planner = GridPlanner(wall_with_gap((2.0, 3.5)), robot_radius=0.3)
    version = planner.version
    shapes = {f"p{k}": Circle(1.0 + 0.3 * k, 0.0, 0.05) for k in range(10)}
    shapes["gap"] = Rectangle(4.1, 2.75, 0.6, 2.0)
    assert planner.set_obstacles(shapes) and planner.version == version + 1
    assert planner.obstacles == shapes and not planner.set_obstacles(dict(shapes))
    with pytest.raises(PlanningError, match="not reachable"):
        planner.plan((1.0, -1.0), (7.0, -1.0))
    assert planner.set_obstacles({})
    assert planner.plan((1.0, -1.0), (7.0, -1.0)).length > 9.0
    with pytest.raises(ObstacleError):
        planner.set_obstacles({"bad": (1.0, 2.0)})


def test_a_person_in_the_way_is_walked_around() -> None:
    planner = GridPlanner(box_map(), robot_radius=0.3)
    planner.add_obstacle("person", Circle(3.0, 1.0, 0.3))
    path = planner.plan((0.0, 1.0), (6.0, 1.0))
    assert path.length > 6.0
    assert all(planner.clearance(x, y) >= 0.3 for x, y in path.densified(0.05))
    planner.clear_obstacles()
    assert planner.plan((0.0, 1.0), (6.0, 1.0)).length == pytest.approx(6.0, abs=0.01)


def test_local_reinflation_matches_a_full_computation() -> None:
    grid = wall_with_gap((2.0, 3.5))
    planner = GridPlanner(grid, robot_radius=0.3, inflation_radius=0.8)
    shapes = {"a": Circle(1.0, 0.0, 0.25), "b": Rectangle(6.0, 1.0, 1.0, 0.3, yaw=0.6)}
    for name, shape in shapes.items():
        planner.add_obstacle(name, shape)
    baked = OccupancyMap(cells=grid.cells.copy(), resolution=RES, origin_x=grid.origin_x, origin_y=grid.origin_y)
    for shape in shapes.values():
        box, mask = rasterize(shape, grid)
        baked.cells[box][mask] = OCCUPIED
    fresh = GridPlanner(baked, robot_radius=0.3, inflation_radius=0.8)
    np.testing.assert_allclose(planner.weights, fresh.weights, rtol=1e-6)
    planner.remove_obstacle("a")
    planner.remove_obstacle("b")
    np.testing.assert_allclose(planner.weights, GridPlanner(grid, 0.3, 0.8).weights, rtol=1e-6)


def test_sensor_marks() -> None:
    planner = GridPlanner(box_map(), robot_radius=0.3)
    marks = np.zeros(planner.lethal.shape, dtype=bool)
    assert not planner.set_sensor_marks(marks)
    row, col = planner.grid.world_to_cell(3.0, 0.0)
    marks[:, col] = True
    assert planner.set_sensor_marks(marks)
    with pytest.raises(PlanningError, match="not reachable"):
        planner.plan((0.0, 0.0), (6.0, 0.0))
    with pytest.raises(PlanningError, match="seen by the sensors"):
        planner.plan((0.0, 0.0), (3.01, 0.0))
    with pytest.raises(PlanningError, match="shape"):
        planner.set_sensor_marks(np.zeros((3, 3), dtype=bool))


def test_sensor_marks_by_cells_give_the_costmap_of_the_whole_mask() -> None:
    """People walking past, marked by their cells in the window of the old and new marks, leave the costmap
    exactly as marking the whole map would, also when they leave it (no marks) and when nothing changed."""
    windowed, whole = GridPlanner(box_map(), robot_radius=0.3), GridPlanner(box_map(), robot_radius=0.3)
    grid = windowed.grid
    steps = [[(1.0, 0.0), (4.0, 1.0)], [(1.2, 0.1), (4.0, 1.0)], [(1.2, 0.1)], [], [(5.0, -1.0), (2.0, 2.0)],
             [(5.0, -1.0), (2.0, 2.0)]]
    for k, people in enumerate(steps):
        cells = [c for c in (rasterize(Circle(x, y, 0.35), grid) for x, y in people) if c is not None]
        mask = np.zeros(whole.lethal.shape, dtype=bool)
        for box, m in cells:
            mask[box] |= m
        before = windowed.lethal
        changed = windowed.set_sensor_mark_cells(cells)
        assert changed == whole.set_sensor_marks(mask), k
        assert changed == (k != 5), k                    # the last step repeats the one before
        np.testing.assert_array_equal(windowed.lethal, whole.lethal)
        np.testing.assert_array_equal(windowed.weights, whole.weights)
        if changed:
            assert before is not windowed.lethal          # a mask handed out is not changed under its holder
    assert windowed.set_sensor_mark_cells([])            # everybody gone: their marks cleared
    np.testing.assert_array_equal(windowed.lethal, GridPlanner(box_map(), robot_radius=0.3).lethal)
    assert not windowed.set_sensor_mark_cells([])        # no marks before nor now: nothing to do


def test_thin_obstacles_still_block() -> None:
    planner = GridPlanner(box_map(), robot_radius=0.2)
    planner.add_obstacle("sheet", Rectangle(3.0, 1.0, 0.01, 7.0))   # 1 cm, thinner than a cell
    with pytest.raises(PlanningError, match="not reachable"):
        planner.plan((0.0, 0.0), (6.0, 0.0))


@pytest.mark.parametrize("make, message", [
    (lambda: Circle(0.0, 0.0, -1.0), "radius"),
    (lambda: Circle(math.nan, 0.0, 1.0), "x"),
    (lambda: Rectangle(0.0, 0.0, 1e9, 1.0), "width"),
    (lambda: Rectangle(0.0, 0.0, 1.0, 1.0, yaw=math.inf), "yaw"),
    (lambda: Circle("a", 0.0, 1.0), "not a number"),
])
def test_bad_shapes(make, message) -> None:
    with pytest.raises(ObstacleError, match=message):
        make()


def test_obstacle_off_the_map_changes_nothing() -> None:
    planner = GridPlanner(box_map(), robot_radius=0.3)
    version = planner.version
    planner.add_obstacle("far", Circle(500.0, 500.0, 1.0))
    assert planner.version == version and "far" in planner.obstacles


def test_bad_parameters() -> None:
    with pytest.raises(PlanningError, match="robot_radius"):
        GridPlanner(box_map(), robot_radius=math.nan)
    with pytest.raises(PlanningError, match="inflation_radius"):
        GridPlanner(box_map(), robot_radius=0.5, inflation_radius=0.2)


def test_path_helpers() -> None:
    path = Path([(0.0, 0.0), (3.0, 4.0)], 5.0, (3.0, 4.0))
    dense = path.densified(0.5)
    assert dense[0] == (0.0, 0.0) and dense[-1] == pytest.approx((3.0, 4.0)) and len(dense) == 11
    assert polyline_length(dense) == pytest.approx(5.0)
    with pytest.raises(ValueError, match="step"):
        path.densified(0.0)


# -- the faculty ---------------------------------------------------------------

def test_every_place_is_reachable_on_every_faculty_floor(faculty) -> None:
    for floor in faculty.floors:
        [robot] = faculty.robots_on(floor.id)
        planner = GridPlanner(floor.map, robot.radius)
        places = [loc.pose for loc in faculty.locations_on(floor.id)]
        places += [c.meeting[floor.id] for c in faculty.connectors if floor.id in c.meeting]
        for place in places:
            path = planner.plan((robot.home.x, robot.home.y), (place.x, place.y))
            straight = math.hypot(place.x - robot.home.x, place.y - robot.home.y)
            assert straight - 1e-6 <= path.length <= 1.3 * straight + 2.0, (floor.id, place)
            assert path.goal == (place.x, place.y)
            assert not planner.path_blocked(path.points, skip=0.0)


def test_closing_the_faculty_corridor_cuts_the_floor(faculty) -> None:
    floor = faculty.floor(1)
    planner = GridPlanner(floor.map, faculty.robots_on(1)[0].radius)
    west, east = faculty.connectors_between(1, 0, "stairs")[0].meeting[1], (60.0, 12.0)
    length = planner.path_length((west.x, west.y), east)
    assert length == pytest.approx(math.hypot(60.0 - west.x, 12.0 - west.y), rel=0.05)
    planner.add_obstacle("closed", Rectangle(45.0, 12.0, 0.2, 3.4))   # across the 3 m corridor
    with pytest.raises(PlanningError, match="not reachable"):
        planner.plan((west.x, west.y), east)


def _shortcut_one_by_one(cells: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The string pulling of GridPlanner._shortcut, one line and one vertex at a time (the reference)."""
    w = weights[cells[:, 0], cells[:, 1]].astype(np.float64)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]))])

    def ok(i: int, k: int) -> bool:
        a, b = cells[i], cells[k]
        span = math.hypot(int(b[0]) - int(a[0]), int(b[1]) - int(a[1]))
        n = max(2, 2 * math.ceil(span))
        t = (np.arange(n) + 0.5) / n
        rows = np.rint(a[0] + (int(b[0]) - int(a[0])) * t).astype(np.intp)
        cols = np.rint(a[1] + (int(b[1]) - int(a[1])) * t).astype(np.intp)
        cost = float(weights[rows, cols].astype(np.float64).sum()) / n * span
        return cost <= (cum[k] - cum[i]) * (1.0 + 1e-3)

    keep, i, last = [0], 0, len(cells) - 1
    while i < last:
        best, j = i + 1, min(i + 4, last)
        while ok(i, j):
            best = j
            if j == last:
                break
            j = min(j + 4, last)
        if best == i + 1:
            best = next((k for k in range(min(i + 3, last), i + 1, -1) if ok(i, k)), i + 1)
        keep.append(best)
        i = best
    return cells[keep]


def test_the_batched_string_pulling_keeps_the_vertices_the_one_by_one_search_keeps(faculty) -> None:
    """_shortcut judges many candidate lines per numpy pass; the path must be the one a search trying one
    line at a time finds, on every faculty floor between every pair of places (long corridors included)."""
    import pyastar2d

    checked = 0
    for floor in faculty.floors:
        planner = GridPlanner(floor.map, faculty.robots_on(floor.id)[0].radius)
        places = [loc.pose for loc in faculty.locations_on(floor.id)][::3]
        places += [c.meeting[floor.id] for c in faculty.connectors if floor.id in c.meeting]
        for a in places:
            for b in places:
                if a == b:
                    continue
                start, goal, w = planner._endpoints((a.x, a.y), (b.x, b.y))
                if start == goal:
                    continue
                cells = np.asarray(pyastar2d.astar_path(w, start, goal, allow_diagonal=False))
                assert np.array_equal(planner._shortcut(cells, w), _shortcut_one_by_one(cells, w))
                checked += 1
    assert checked > 100
