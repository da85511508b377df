"""map_server conventions: origin, thresholds, negate, row flip, modes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from gidabot_navigation.building.occupancy import FREE, OCCUPIED, UNKNOWN, load_map, pixels_to_cells, save_map
from gidabot_navigation.errors import MapError


def write_map(tmp_path: Path, pixels: np.ndarray, **doc) -> Path:
    Image.fromarray(pixels.astype(np.uint8)).save(tmp_path / "m.pgm")
    base = {"image": "m.pgm", "resolution": 0.5, "origin": [-1.0, 2.0, 0.0], "negate": 0,
            "occupied_thresh": 0.65, "free_thresh": 0.196}
    base.update(doc)
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump(base))
    return path


def test_thresholds_and_row_flip(tmp_path: Path) -> None:
    # image row 0 is the TOP of the map: black top-left pixel is the last grid row
    pixels = np.array([[0, 254, 205], [254, 254, 254]])
    grid = load_map(write_map(tmp_path, pixels))
    assert grid.cells.shape == (2, 3)
    assert grid.cells[1, 0] == OCCUPIED      # top-left pixel -> top row (row 1)
    assert grid.cells[1, 2] == UNKNOWN       # 205 -> p = 0.196..: between thresholds
    assert (grid.cells[0] == FREE).all()


def test_origin_and_resolution(tmp_path: Path) -> None:
    pixels = np.full((4, 6), 254)
    pixels[0, 5] = 0  # top-right
    grid = load_map(write_map(tmp_path, pixels))
    # lower-left corner of cell (0, 0) is the origin (-1, 2); cells are 0.5 m
    assert grid.world_to_cell(-1.0 + 0.01, 2.0 + 0.01) == (0, 0)
    assert grid.cell_to_world(0, 0) == pytest.approx((-0.75, 2.25))
    x, y = grid.cell_to_world(3, 5)
    assert grid.value_at(x, y) == OCCUPIED
    assert not grid.contains(-1.01, 2.0)
    assert grid.value_at(100.0, 100.0) == UNKNOWN
    assert grid.size_m == pytest.approx((3.0, 2.0))


def test_negate_inverts(tmp_path: Path) -> None:
    pixels = np.array([[0, 255]])
    grid = load_map(write_map(tmp_path, pixels, negate=1))
    assert grid.cells[0, 0] == FREE and grid.cells[0, 1] == OCCUPIED


def test_scale_and_raw_modes() -> None:
    pixels = np.array([[128]])
    scaled = pixels_to_cells(pixels, False, 0.65, 0.196, "scale")
    assert 1 <= scaled[0, 0] <= 99
    raw = pixels_to_cells(pixels, False, 0.65, 0.196, "raw")
    assert raw[0, 0] == np.int8(128 - 256)  # raw values are stored as they are (int8 wraps)


def test_rgb_mean_and_alpha_ignored() -> None:
    rgba = np.zeros((1, 1, 4), dtype=np.uint8)
    rgba[0, 0] = (254, 254, 254, 0)
    assert pixels_to_cells(rgba, False, 0.65, 0.196)[0, 0] == FREE


def test_save_then_load_round_trip(tmp_path: Path) -> None:
    pixels = np.array([[0, 254, 205], [254, 0, 254]])
    grid = load_map(write_map(tmp_path, pixels))
    save_map(grid, tmp_path / "copy.yaml")
    again = load_map(tmp_path / "copy.yaml")
    assert (again.cells == grid.cells).all()
    assert (again.origin_x, again.origin_y, again.resolution) == (grid.origin_x, grid.origin_y, grid.resolution)


@pytest.mark.parametrize("doc, expected", [
    ({"resolution": 0}, "resolution: 0.0 must be > 0"),
    ({"resolution": "fine"}, "resolution: 'fine' is not a number"),
    ({"origin": [0, 0]}, "origin: [0, 0] must be a list [x, y, yaw]"),
    ({"image": "missing.pgm"}, "image: 'missing.pgm' not found"),
    ({"free_thresh": 0.9}, "must satisfy 0 <= free_thresh < occupied_thresh <= 1"),
    ({"mode": "fancy"}, "mode: 'fancy' must be trinary, scale or raw"),
    ({"negate": 2}, "negate: 2 must be 0 or 1"),
])
def test_bad_map_yaml(tmp_path: Path, doc: dict, expected: str) -> None:
    path = write_map(tmp_path, np.full((2, 2), 254), **doc)
    with pytest.raises(MapError, match=expected.replace("[", r"\[").replace("]", r"\]")):
        load_map(path)


def test_faculty_maps_are_office_buildings(faculty) -> None:
    for floor in faculty.floors:
        grid = floor.map
        assert grid.resolution == pytest.approx(0.05)
        width, height = grid.size_m
        assert 50 < width < 100 and 15 < height < 40
        free = (grid.cells == FREE).mean()
        assert 0.3 < free < 0.9, f"floor {floor.label}: {free:.0%} free"
