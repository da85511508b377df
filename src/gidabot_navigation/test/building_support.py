"""Helpers shared by the building tests: changing a copy of the faculty's maps."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image


def paint(building_dir: Path, floor: int, x0: float, x1: float, y0: float, y1: float) -> None:
    """Make the map cells of the rectangle x0..x1, y0..y1 (m) occupied (black) on ``floor`` of a copy of
    the faculty (map origin (-1, -1), 0.05 m per cell, image row 0 at the top: maps/faculty/floor*.yaml)."""
    path = building_dir / f"floor{floor}.pgm"
    img = np.array(Image.open(path))
    top = img.shape[0] * 0.05 - 1.0
    rows = slice(round((top - y1) / 0.05), round((top - y0) / 0.05))
    cols = slice(round((x0 + 1.0) / 0.05), round((x1 + 1.0) / 0.05))
    img[rows, cols] = 0
    Image.fromarray(img).save(path)
