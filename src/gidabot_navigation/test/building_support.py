"""Helpers shared by the building tests: changing a copy of the faculty's maps."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import yaml
from PIL import Image

FACULTY = Path(__file__).resolve().parents[3] / "maps" / "faculty"
GLASS = [[43.0, 11.9], [47.0, 11.9], [47.0, 13.6], [43.0, 13.6]]   # keep-out: north half of floor 1's corridor


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


def faculty_with_keep_out(dest: Path, floor: int, zone_id: str, polygon: list[list[float]]) -> Path:
    """A copy of the faculty in ``dest`` (a new directory) whose floor ``floor`` (its index) has one keep-out zone,
    ``polygon`` in metres; returns ``dest``."""
    shutil.copytree(FACULTY, dest)
    file = dest / "building.yaml"
    doc = yaml.safe_load(file.read_text())
    doc["floors"][floor]["keep_out"] = [{"id": zone_id, "polygon": polygon}]
    file.write_text(yaml.safe_dump(doc, sort_keys=False))
    return dest
