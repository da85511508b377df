"""Occupancy maps in the map_server format (ROS-free).

A map is a YAML file (``image``, ``resolution``, ``origin``, ``negate``,
``occupied_thresh``, ``free_thresh``, optional ``mode``) next to a PGM/PNG image,
interpreted exactly as ROS map_server does:

* the colour of a pixel is the mean of its colour channels (alpha ignored);
  with ``negate`` it is inverted; ``p = (255 - colour) / 255`` is its occupancy
  probability;
* ``trinary`` mode (default): ``p > occupied_thresh`` -> 100 (occupied),
  ``p < free_thresh`` -> 0 (free), otherwise -1 (unknown); ``scale`` mode keeps
  the intermediate values as 1..99; ``raw`` mode stores the colour itself;
* image row 0 is the top of the map: grid row 0 (``cells[0]``) is the bottom
  row, whose lower-left corner is at ``origin`` (x, y, yaw) in the map frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from gidabot_navigation.building.yaml_text import DuplicateKeyError, load_yaml
from gidabot_navigation.errors import MapError

OCCUPIED = 100
FREE = 0
UNKNOWN = -1


@dataclass
class OccupancyMap:
    """A 2D occupancy grid: ``cells[row, col]`` in {-1, 0..100}, row 0 at the bottom."""

    cells: np.ndarray        # int8, shape (height, width)
    resolution: float        # m per cell
    origin_x: float          # m, map-frame x of the lower-left corner of cell (0, 0)
    origin_y: float          # m
    origin_yaw: float = 0.0  # rad
    source: str = ""         # file it was loaded from, for messages

    @property
    def width(self) -> int:
        return int(self.cells.shape[1])

    @property
    def height(self) -> int:
        return int(self.cells.shape[0])

    @property
    def size_m(self) -> tuple[float, float]:
        """Width and height in metres."""
        return (self.width * self.resolution, self.height * self.resolution)

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell containing map point (x, y); may lie outside the grid."""
        dx, dy = x - self.origin_x, y - self.origin_y
        c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        return (int(math.floor(ly / self.resolution)), int(math.floor(lx / self.resolution)))

    def cell_to_world(self, row: int, col: int) -> tuple[float, float]:
        """Map point (x, y) at the centre of cell (row, col)."""
        lx, ly = (col + 0.5) * self.resolution, (row + 0.5) * self.resolution
        c, s = math.cos(self.origin_yaw), math.sin(self.origin_yaw)
        return (self.origin_x + c * lx - s * ly, self.origin_y + s * lx + c * ly)

    def contains(self, x: float, y: float) -> bool:
        """True when (x, y) lies on the grid."""
        row, col = self.world_to_cell(x, y)
        return 0 <= row < self.height and 0 <= col < self.width

    def value_at(self, x: float, y: float) -> int:
        """Cell value at (x, y); UNKNOWN outside the grid."""
        row, col = self.world_to_cell(x, y)
        if not (0 <= row < self.height and 0 <= col < self.width):
            return UNKNOWN
        return int(self.cells[row, col])

    def is_free(self, x: float, y: float) -> bool:
        """True when (x, y) is on the grid and its cell is free."""
        return self.value_at(x, y) == FREE

    def occupied_mask(self) -> np.ndarray:
        """Boolean mask of cells a robot may not enter (occupied or unknown)."""
        return self.cells != FREE

    def to_ros_data(self) -> list[int]:
        """Row-major cell values as nav_msgs/OccupancyGrid.data expects."""
        return self.cells.reshape(-1).astype(np.int8).tolist()


def _require(doc: dict, key: str, path: Path) -> object:
    if key not in doc:
        raise MapError(f"{path}: key '{key}' is missing (map_server map YAML needs image, resolution, origin)")
    return doc[key]


def _number(value: object, key: str, path: Path) -> float:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError) as err:
        raise MapError(f"{path}: {key}: {value!r} is not a number") from err
    if not math.isfinite(number):
        raise MapError(f"{path}: {key}: {value!r} is not a finite number")
    return number


def pixels_to_cells(pixels: np.ndarray, negate: bool, occupied_thresh: float,
                    free_thresh: float, mode: str = "trinary") -> np.ndarray:
    """Convert an image array (rows top-first; grey, RGB or RGBA) to grid cells (rows bottom-first)."""
    if pixels.ndim == 3:
        channels = pixels.shape[2]
        colour = pixels[:, :, : 3 if channels >= 3 else 1].astype(np.float64).mean(axis=2)
    else:
        colour = pixels.astype(np.float64)
    if mode == "raw":
        cells = colour.round().astype(np.int16)
    else:
        if negate:
            colour = 255.0 - colour
        occ = (255.0 - colour) / 255.0
        cells = np.full(occ.shape, UNKNOWN, dtype=np.int16)
        cells[occ > occupied_thresh] = OCCUPIED
        cells[occ < free_thresh] = FREE
        if mode == "scale":
            mid = (occ >= free_thresh) & (occ <= occupied_thresh)
            span = max(occupied_thresh - free_thresh, 1e-9)
            cells[mid] = np.clip(1 + np.round(98 * (occ[mid] - free_thresh) / span), 1, 99)
    return np.flipud(cells).astype(np.int8)


def load_map(yaml_path: str | Path) -> OccupancyMap:
    """Load a map_server map YAML and its image; raises :class:`MapError` naming file and key."""
    from PIL import Image, UnidentifiedImageError

    path = Path(yaml_path)
    try:
        doc = load_yaml(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise MapError(f"{path}: cannot read map YAML: {err.strerror}") from err
    except DuplicateKeyError as err:
        raise MapError(f"{path}: {err}") from err
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise MapError(f"{path}: not valid YAML: {err}") from err
    if not isinstance(doc, dict):
        raise MapError(f"{path}: expected a mapping with image, resolution, origin; got {type(doc).__name__}")
    image_name = _require(doc, "image", path)
    resolution = _number(_require(doc, "resolution", path), "resolution", path)
    if resolution <= 0:
        raise MapError(f"{path}: resolution: {resolution} must be > 0 (m per cell)")
    origin = _require(doc, "origin", path)
    if not isinstance(origin, list) or len(origin) != 3:
        raise MapError(f"{path}: origin: {origin!r} must be a list [x, y, yaw]")
    ox, oy, oyaw = (_number(v, "origin", path) for v in origin)
    negate = doc.get("negate", 0)
    if negate not in (0, 1, True, False):
        raise MapError(f"{path}: negate: {negate!r} must be 0 or 1")
    occ_t = _number(doc.get("occupied_thresh", 0.65), "occupied_thresh", path)
    free_t = _number(doc.get("free_thresh", 0.196), "free_thresh", path)
    if not 0.0 <= free_t < occ_t <= 1.0:
        raise MapError(f"{path}: thresholds free_thresh={free_t}, occupied_thresh={occ_t} "
                       "must satisfy 0 <= free_thresh < occupied_thresh <= 1")
    mode = str(doc.get("mode", "trinary"))
    if mode not in ("trinary", "scale", "raw"):
        raise MapError(f"{path}: mode: {mode!r} must be trinary, scale or raw")
    image_path = Path(str(image_name))
    if not image_path.is_absolute():
        image_path = path.parent / image_path
    try:
        with Image.open(image_path) as img:
            pixels = np.asarray(img.convert("RGBA") if img.mode in ("P", "PA") else img)
    except FileNotFoundError as err:
        raise MapError(f"{path}: image: {image_name!r} not found at {image_path}") from err
    except (OSError, UnidentifiedImageError) as err:
        raise MapError(f"{path}: image: {image_name!r} is not a readable image: {err}") from err
    cells = pixels_to_cells(pixels, bool(negate), occ_t, free_t, mode)
    return OccupancyMap(cells=cells, resolution=resolution, origin_x=ox, origin_y=oy,
                        origin_yaw=oyaw, source=str(path))


def save_map(grid: OccupancyMap, yaml_path: str | Path, image_name: str | None = None) -> None:
    """Write ``grid`` as map_server YAML + PGM (trinary: 0 black occupied, 254 free, 205 unknown)."""
    from PIL import Image

    path = Path(yaml_path)
    image_name = image_name or path.with_suffix(".pgm").name
    img = np.full(grid.cells.shape, 205, dtype=np.uint8)
    img[grid.cells == FREE] = 254
    img[grid.cells == OCCUPIED] = 0
    Image.fromarray(np.flipud(img)).save(path.parent / image_name)
    doc = {
        "image": image_name,
        "resolution": grid.resolution,
        "origin": [grid.origin_x, grid.origin_y, grid.origin_yaw],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
