"""A small portrait building for the GUI tests: two floors of a tall, narrow tower (14 m x 40 m).

``make_tower(directory)`` writes ``building.yaml``, a map_server map and a blueprint per floor
(the blueprint 272 x 688 pixels: a portrait plan, room numbers written in it), one robot per
floor, a staircase at the south end and a lift in the middle. It passes ``gidabot check``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml
from PIL import Image, ImageDraw, ImageFont

RES, MARGIN = 0.05, 1.0          # m per cell, m of unknown space around the building
W, H = 14.0, 40.0                # m
CORR_X0, CORR_X1 = 5.5, 8.5      # the corridor runs south-north
WALL = 0.2
PX, BP_MARGIN = 16.0, 24         # blueprint pixels per metre, margin
ROOMS_Y = [(4.0, 9.0), (9.0, 14.0), (14.0, 19.0), (23.0, 28.0), (28.0, 33.0), (33.0, 38.0)]   # lift at 19-23


def _names(text: str) -> dict[str, str]:
    return {"eu": text, "en": text, "es": text}


def _rooms(floor: int) -> list[tuple[str, str, float, float]]:
    """(number, side W/E, y0, y1) of the rooms of ``floor``."""
    return [(f"{floor}{side}{k + 1}", side, y0, y1) for side in "WE" for k, (y0, y1) in enumerate(ROOMS_Y)]


def _grid(floor: int) -> np.ndarray:
    cols, rows = int(round((W + 2 * MARGIN) / RES)), int(round((H + 2 * MARGIN) / RES))
    grid = np.full((rows, cols), -1, dtype=np.int8)

    def rect(x0: float, y0: float, x1: float, y1: float, value: int) -> None:
        grid[int(round((y0 + MARGIN) / RES)):int(round((y1 + MARGIN) / RES)),
             int(round((x0 + MARGIN) / RES)):int(round((x1 + MARGIN) / RES))] = value

    rect(0, 0, W, H, 100)
    rect(CORR_X0, 1.0, CORR_X1, H - 1.0, 0)                       # corridor, stair landing at its south end
    for _, side, y0, y1 in _rooms(floor):
        x0, x1 = (WALL, CORR_X0 - WALL) if side == "W" else (CORR_X1 + WALL, W - WALL)
        rect(x0, y0 + WALL / 2, x1, y1 - WALL / 2, 0)
        wx0, wx1 = (CORR_X0 - WALL - 0.01, CORR_X0 + 0.01) if side == "W" else (CORR_X1 - 0.01, CORR_X1 + WALL + 0.01)
        rect(wx0, (y0 + y1) / 2 - 0.5, wx1, (y0 + y1) / 2 + 0.5, 0)   # a 1 m door
    return grid


def _blueprint(floor: int, path: Path) -> None:
    size = (int(W * PX + 2 * BP_MARGIN), int(H * PX + 2 * BP_MARGIN))
    img = Image.new("RGB", size, (250, 250, 248))
    d = ImageDraw.Draw(img)
    bold = ImageFont.truetype("/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf", 18)

    def px(x: float, y: float) -> tuple[float, float]:
        return BP_MARGIN + PX * x, BP_MARGIN + PX * (H - y)

    def box(x0: float, y0: float, x1: float, y1: float, fill: tuple[int, int, int]) -> None:
        (u0, v1), (u1, v0) = px(x0, y0), px(x1, y1)
        d.rectangle([u0, v0, u1, v1], fill=fill, outline=(70, 74, 82), width=2)

    box(0, 0, W, H, (214, 214, 210))
    box(CORR_X0, 1.0, CORR_X1, H - 1.0, (255, 255, 255))
    for number, side, y0, y1 in _rooms(floor):
        x0, x1 = (0.0, CORR_X0) if side == "W" else (CORR_X1, W)
        box(x0, y0, x1, y1, (214, 228, 240) if side == "W" else (220, 236, 214))
        d.text(px((x0 + x1) / 2, (y0 + y1) / 2), number, fill=(40, 44, 52), font=bold, anchor="mm")
    box(CORR_X1, 19.2, W - 1.0, 22.8, (176, 186, 210))
    d.text(px(11.0, 21.0), "lift", fill=(30, 40, 70), font=bold, anchor="mm")
    for k in range(1, 8):                                          # the stairs' steps, south end
        u0, v = px(CORR_X0, 1.0 + 2.0 * k / 8)
        u1, _ = px(CORR_X1, 1.0 + 2.0 * k / 8)
        d.line([u0, v, u1, v], fill=(120, 122, 130), width=1)
    img.save(path)


def make_tower(directory: Path) -> Path:
    """Write the tower into ``directory``; returns its building.yaml."""
    directory.mkdir(parents=True, exist_ok=True)
    floors, locations = [], []
    for floor in (0, 1):
        img = np.full(_grid(floor).shape, 205, dtype=np.uint8)
        img[_grid(floor) == 0] = 254
        img[_grid(floor) == 100] = 0
        Image.fromarray(np.flipud(img)).save(directory / f"floor{floor}.pgm")
        (directory / f"floor{floor}.yaml").write_text(yaml.safe_dump(
            {"image": f"floor{floor}.pgm", "resolution": RES, "origin": [-MARGIN, -MARGIN, 0.0], "negate": 0,
             "occupied_thresh": 0.65, "free_thresh": 0.196}), encoding="utf-8")
        _blueprint(floor, directory / f"floor{floor}.png")
        floors.append({"id": floor, "names": _names(f"Floor {floor}"), "map": f"floor{floor}.yaml",
                       "blueprint": f"floor{floor}.png",
                       "blueprint_transform": {"scale": PX, "origin_px": [BP_MARGIN, BP_MARGIN + PX * H]}})
        for number, side, y0, y1 in _rooms(floor):
            x, yaw = (CORR_X0 + 0.9, 3.1416) if side == "W" else (CORR_X1 - 0.9, 0.0)
            locations.append({"id": number, "floor": floor, "pose": [x, (y0 + y1) / 2, yaw],
                              "names": _names(f"Room {number}"), "category": "office",
                              "featured": number.endswith(("1", "4"))})
    doc = {
        "id": "tower", "name": "A tall, narrow tower",
        "floors": floors, "locations": locations,
        "connectors": [
            {"id": "stairs", "kind": "stairs", "names": _names("Stairs"),
             "meeting": [{"floor": f, "pose": [7.0, 3.5, -1.5708]} for f in (0, 1)]},
            {"id": "lift", "kind": "lift", "names": _names("Lift"),
             "meeting": [{"floor": f, "pose": [7.6, 21.0, 0.0]} for f in (0, 1)]},
        ],
        "robots": [{"name": name, "floor": f, "master_uri": f"http://127.0.0.{21 + f}:11311/", "drive": "differential",
                    "max_linear": 0.6, "max_angular": 1.0, "max_linear_accel": 0.5, "max_angular_accel": 1.5,
                    "radius": 0.3, "home": [7.0, 16.0, 1.5708]} for f, name in ((0, "Tower0"), (1, "Tower1"))],
    }
    out = directory / "building.yaml"
    out.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True), encoding="utf-8")
    return out
