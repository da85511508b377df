"""Ray casting: exact ranges against walls, map origin and rotation, corners, discs, no-return, the faculty."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.occupancy import FREE, OCCUPIED, OccupancyMap
from gidabot_navigation.building.planning import cells_of
from gidabot_sim.world.raycast import RayCaster, beam_angles

RES = 0.05
REPO_FACULTY = __import__("pathlib").Path(__file__).resolve().parents[4] / "maps" / "faculty"


def room(width: int = 200, height: int = 100) -> np.ndarray:
    """A solid mask: a closed room of width x height cells with 1-cell walls."""
    solid = np.zeros((height, width), dtype=bool)
    solid[0, :] = solid[-1, :] = solid[:, 0] = solid[:, -1] = True
    return solid


def test_axis_aligned_and_diagonal_ranges_are_exact() -> None:
    caster = RayCaster(room(), RES, (0.0, 0.0, 0.0))      # walls' inner faces at x 0.05, 9.95; y 0.05, 4.95
    ranges = caster.cast(3.0, 2.0, np.array([0.0, math.pi / 2, math.pi, -math.pi / 2]), 20.0)
    assert ranges == pytest.approx([6.95, 2.95, 2.95, 1.95], abs=1e-6)
    diag = caster.cast(3.0, 2.0, np.array([math.atan2(2.95, 2.95)]), 20.0)[0]
    assert diag == pytest.approx(math.hypot(2.95, 2.95), abs=1e-6)


def test_a_ray_along_a_cell_boundary_near_a_wall_hits_it_at_once() -> None:
    """-pi from a point on a row boundary (y 6.0 m: row 120): the ray's tiny y component (-1.2e-16) must not make
    it step 0 cells to the row boundary at every iteration once it is near the wall (no return, 1000x slower)."""
    caster = RayCaster(room(200, 300), RES, (0.0, 0.0, 0.0))
    angles = np.array([-math.pi, math.pi, -math.pi / 2, 1.5 * math.pi, 0.0])
    ranges = caster.cast(2.0, 6.0, angles, 20.0)
    assert ranges == pytest.approx([1.95, 1.95, 5.95, 5.95, 7.95], abs=1e-6)
    assert caster.cast(2.0, 6.0, np.linspace(-math.pi, math.pi, 360), 20.0).max() < 20.0    # a closed room


def test_map_origin_and_rotation_are_honoured() -> None:
    caster = RayCaster(room(), RES, (-5.0, 10.0, math.pi / 2))   # grid x axis points along map +y
    # grid-local (3, 2) is map (-5 - 2, 10 + 3); grid +x is map +y
    ranges = caster.cast(-7.0, 13.0, np.array([math.pi / 2, 0.0]), 20.0)
    assert ranges == pytest.approx([6.95, 1.95], abs=1e-6)
    assert caster.clearance(-7.0, 13.0) == pytest.approx(2.0, abs=RES)
    assert caster.clearance(100.0, 100.0) == 0.0


def test_range_max_and_leaving_the_grid_give_no_return() -> None:
    solid = np.zeros((100, 100), dtype=bool)
    solid[50, 80] = True
    caster = RayCaster(solid, RES, (0.0, 0.0, 0.0))
    ranges = caster.cast(1.0, 2.525, np.array([0.0, math.pi]), 20.0)
    assert ranges[0] == pytest.approx(3.0, abs=1e-6) and ranges[1] == math.inf   # a lone cell; off the grid
    assert caster.cast(1.0, 2.525, np.array([0.0]), 2.5)[0] == math.inf          # beyond range_max
    empty = RayCaster(np.zeros((10, 10), dtype=bool), RES, (0.0, 0.0, 0.0))
    assert empty.cast(0.2, 0.2, beam_angles(-1, 1, 5), 5.0).tolist() == [math.inf] * 5


def test_a_ray_clipping_the_corner_of_a_cell_hits_it() -> None:
    solid = np.zeros((40, 40), dtype=bool)
    solid[20, 20] = True               # cell spanning x 1.00..1.05, y 1.00..1.05
    caster = RayCaster(solid, RES, (0.0, 0.0, 0.0))
    slope = math.tan(0.3)
    # rising at 0.3 rad, passing 2 mm above the cell's lower-right corner: inside the cell for ~7 mm
    y0 = 1.002 - 1.05 * slope
    hit = caster.cast(0.0, y0, np.array([0.3]), 5.0)[0]
    entry_x = 1.05 - 0.002 / slope                   # where it crosses the cell's bottom edge
    assert hit == pytest.approx(entry_x / math.cos(0.3), abs=1e-6)
    # 2 mm below the corner: a miss
    assert caster.cast(0.0, y0 - 0.004, np.array([0.3]), 5.0)[0] == math.inf


def test_discs_are_hit_exactly() -> None:
    caster = RayCaster(np.zeros((100, 100), dtype=bool), RES, (0.0, 0.0, 0.0))
    ranges = caster.cast(1.0, 1.0, np.array([0.0, math.pi / 2]), 10.0, discs=[(3.0, 1.0, 0.5)])
    assert ranges[0] == pytest.approx(1.5) and ranges[1] == math.inf
    inside = caster.cast(3.0, 1.2, np.array([0.0]), 10.0, discs=[(3.0, 1.0, 0.5)])
    assert inside[0] == 0.0


def brute_force(grid: OccupancyMap, solid: np.ndarray, x: float, y: float, angle: float, rmax: float) -> float:
    ts = np.arange(0.0, rmax, 0.001)
    rows, cols = cells_of(grid, x + ts * math.cos(angle), y + ts * math.sin(angle))
    inside = (rows >= 0) & (rows < grid.height) & (cols >= 0) & (cols < grid.width)
    stop = ~inside
    stop[inside] = solid[rows[inside], cols[inside]]
    k = int(np.argmax(stop))
    return float(ts[k]) if stop[k] and inside[k] else math.inf


def test_faculty_scans_match_a_brute_force_march() -> None:
    grid = load_building(REPO_FACULTY).floor(2).map
    solid = grid.cells != FREE
    caster = RayCaster(solid, grid.resolution, (grid.origin_x, grid.origin_y, grid.origin_yaw))
    rng = np.random.default_rng(7)
    checked = 0
    while checked < 12:
        x, y = rng.uniform(0, 72), rng.uniform(0, 24)
        if caster.clearance(x, y) < 0.3:
            continue
        angles = rng.uniform(-math.pi, math.pi, 25)
        got = caster.cast(x, y, angles, 20.0)
        for a, r in zip(angles, got, strict=True):
            ref = brute_force(grid, solid, x, y, float(a), 20.0)
            assert math.isfinite(ref) == math.isfinite(r), (x, y, a, ref, r)
            if math.isfinite(ref):
                assert r == pytest.approx(ref, abs=0.0015), (x, y, a)
        checked += 1


def test_occupied_cells_of_a_map_block_and_beam_angles() -> None:
    cells = np.full((20, 20), FREE, dtype=np.int8)
    cells[:, 15] = OCCUPIED
    grid = OccupancyMap(cells, RES, 0.0, 0.0)
    caster = RayCaster(grid.cells != FREE, RES, (0.0, 0.0, 0.0))
    assert caster.cast(0.25, 0.5, np.array([0.0]), 5.0)[0] == pytest.approx(0.5)
    assert beam_angles(-1.0, 1.0, 3).tolist() == [-1.0, 0.0, 1.0]
    with pytest.raises(ValueError, match="beams"):
        beam_angles(0, 1, 0)


def test_a_cast_from_the_same_pose_reuses_the_walls_but_not_the_discs_nor_an_old_mask() -> None:
    """A robot at rest casts the same rays scan after scan: the walls' ranges are kept, the discs (people walking
    past it) intersected anew, and a new mask (an obstacle put down) is cast again."""
    solid = room()
    caster = RayCaster(solid, RES, (0.0, 0.0, 0.0))
    angles = beam_angles(-math.pi, math.pi, 360)
    first = caster.cast(3.0, 2.0, angles, 20.0)
    again = caster.cast(3.0, 2.0, angles, 20.0, discs=[(5.0, 2.0, 0.25)])
    assert (caster.casts, caster.cached) == (2, 1)
    ahead = int(np.argmin(np.abs(angles)))
    assert again[ahead] == pytest.approx(1.75, abs=0.01) and first[ahead] == pytest.approx(6.95, abs=0.01)
    assert caster.cast(3.0, 2.0, angles, 20.0).tolist() == first.tolist()      # the disc is not kept
    caster.cast(3.0, 2.0, angles, 20.0)[:] = 0.0                                 # a caller's copy, not the kept one
    assert caster.cast(3.0, 2.0, angles, 20.0).tolist() == first.tolist()
    moved = caster.cast(3.0 + 1e-9, 2.0, angles, 20.0)                           # another pose: cast
    assert caster.cached == 4 and moved[ahead] == pytest.approx(first[ahead], abs=1e-6)
    blocked = solid.copy()
    blocked[:, 120] = True                                                       # a wall at x 6.0-6.05 m
    caster.update(blocked)
    assert caster.cast(3.0, 2.0, angles, 20.0)[ahead] == pytest.approx(3.0, abs=0.01)
    assert caster.cached == 4
    for k in range(12):                                                          # at most CACHE_SIZE kept
        caster.cast(1.0 + 0.1 * k, 2.0, angles, 20.0)
    assert len(caster._walls) <= 8
