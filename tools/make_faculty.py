#!/usr/bin/env python3
"""Authoring tool: (re)generate maps/faculty/ — the Faculty of Informatics (UPV/EHU, San Sebastian) —
and its variants with other robots (maps/faculty6/, maps/faculty3/).

Writes, per floor, a map_server occupancy map (PGM + YAML, 0.05 m/cell) and a
blueprint PNG, and the building description ``building.yaml``; a variant is only a
``building.yaml`` that uses the faculty's map and blueprint files. The generated
files are committed; the system only ever reads the data files (a new building
needs no code). Run from the repository root: ``bin/gidabot-python tools/make_faculty.py``.

Layout shared by the four floors (72 m x 24 m, map frame origin at the building's
south-west corner): a 3 m east-west corridor (y 10.5..13.5), a staircase at each
end, the lift in the middle of the north side, rooms on both sides with 1 m doors.
Locations are the corridor poses in front of each door (robots do not enter rooms,
paper section 6.1).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import yaml
from PIL import Image, ImageDraw, ImageFont

RES = 0.05            # m per cell
W, H = 72.0, 24.0     # building footprint, m
MARGIN = 1.0          # m of unknown space around the building in the map
WALL = 0.2            # m, wall thickness
CORR_Y0, CORR_Y1 = 10.5, 13.5
STAIR_X = 6.0         # the corridor runs x 6..66; stair halls lie at both ends
FLIGHT_X = 3.0        # stair flights (obstacles) from the outer wall to x = 3
STAIR_Y0, STAIR_Y1 = 7.5, 16.5
PX_PER_M = 16.0       # blueprint scale
BP_MARGIN = 24        # px

FLOOR_NAMES = {
    0: {"eu": "Beheko solairua", "en": "Ground floor", "es": "Planta baja"},
    1: {"eu": "Lehen solairua", "en": "First floor", "es": "Primera planta"},
    2: {"eu": "Bigarren solairua", "en": "Second floor", "es": "Segunda planta"},
    3: {"eu": "Hirugarren solairua", "en": "Third floor", "es": "Tercera planta"},
}


def office(person: str) -> dict[str, str]:
    return {"eu": f"{person} bulegoa", "en": f"{person}'s Office", "es": f"Despacho de {person}"}


def gen_office(number: str) -> dict[str, str]:
    return {"eu": f"{number} bulegoa", "en": f"Office {number}", "es": f"Despacho {number}"}


def n(eu: str, en: str, es: str) -> dict[str, str]:
    return {"eu": eu, "en": en, "es": es}


# Rooms: (number, side N/S, x0, x1, category, names, featured[, door x]).
# North rooms lie in x 6..33.5 and 38..66 (the lift core is between), south rooms in x 6..66.
ROOMS: dict[int, list[tuple]] = {
    0: [
        ("001", "S", 6.0, 12.0, "service", n("Kopiategia", "Copy Shop", "Reprografía"), True),
        ("003", "S", 12.0, 18.0, "lab", n("0.1 laborategia", "Laboratory 0.1", "Laboratorio 0.1"), False),
        ("005", "S", 18.0, 24.0, "service", n("Ikasleen Kontseilua", "Student Council", "Consejo de Estudiantes"), True),
        ("000", "S", 24.0, 40.0, "entrance", n("Sarrera nagusia", "Main Entrance", "Entrada principal"), True, 32.0),
        ("008", "S", 40.0, 46.0, "service", n("Atezainen bulegoa", "Caretakers' Office", "Conserjería"), True),
        ("010", "S", 46.0, 56.0, "lecture", n("0.1 ikasgela", "Lecture Room 0.1", "Aula 0.1"), False),
        ("012", "S", 56.0, 66.0, "lecture", n("0.2 ikasgela", "Lecture Room 0.2", "Aula 0.2"), False),
        ("014", "N", 6.0, 14.0, "lab", n("Teknikarien laborategia 1", "Computer Technicians 1", "Técnicos informáticos 1"), True),
        ("016", "N", 14.0, 22.0, "lab", n("Teknikarien laborategia 2", "Computer Technicians 2", "Técnicos informáticos 2"), False),
        ("018", "N", 22.0, 33.5, "lab", n("0.2 laborategia", "Laboratory 0.2", "Laboratorio 0.2"), False),
        ("020", "N", 38.0, 46.0, "service", n("Wi-Fi gela", "Wi-Fi Room", "Sala Wi-Fi"), True),
        ("022", "N", 46.0, 56.0, "service", n("Kafetegia", "Cafeteria", "Cafetería"), True),
        ("024", "N", 56.0, 66.0, "lab", n("0.3 laborategia", "Laboratory 0.3", "Laboratorio 0.3"), False),
    ],
    1: [
        ("101", "S", 6.0, 14.0, "service", n("Idazkaritza", "Secretary's Office", "Secretaría"), True),
        ("103", "S", 14.0, 20.0, "office", n("Dekanotza", "Dean's Office", "Decanato"), True),
        ("104", "S", 20.0, 36.0, "lecture", n("Ada Lovelace aretoa", "Ada Lovelace Auditorium", "Auditorio Ada Lovelace"), True, 28.0),
        ("106", "S", 36.0, 46.0, "meeting", n("Batzar gela", "Board Room", "Sala de Juntas"), False),
        ("108", "S", 46.0, 56.0, "lecture", n("1.1 ikasgela", "Lecture Room 1.1", "Aula 1.1"), False),
        ("110", "S", 56.0, 66.0, "lecture", n("1.2 ikasgela", "Lecture Room 1.2", "Aula 1.2"), False),
        ("111", "N", 6.0, 14.0, "lab", n("1.1 laborategia", "Laboratory 1.1", "Laboratorio 1.1"), False),
        ("112", "N", 14.0, 22.0, "lab", n("1.2 laborategia", "Laboratory 1.2", "Laboratorio 1.2"), False),
        ("113", "N", 22.0, 33.5, "lab", n("1.3 laborategia", "Laboratory 1.3", "Laboratorio 1.3"), True),
        ("115", "N", 38.0, 46.0, "office", n("Dekanordetza", "Vice-Dean's Office", "Vicedecanato"), False),
        ("117", "N", 46.0, 56.0, "service", n("Nazioarteko harremanak", "International Office", "Relaciones Internacionales"), True),
        ("119", "N", 56.0, 66.0, "lab", n("1.4 laborategia", "Laboratory 1.4", "Laboratorio 1.4"), False),
    ],
    2: [
        ("201", "S", 6.0, 11.0, "office", gen_office("201"), False),
        ("203", "S", 11.0, 16.0, "office", office("C. Rodriguez"), True),
        ("205", "S", 16.0, 21.0, "office", office("J. Abascal"), True),
        ("207", "S", 21.0, 28.0, "meeting", n("2.3 mintegia", "Seminar Room 2.3", "Seminario 2.3"), True),
        ("209", "S", 28.0, 34.0, "office", gen_office("209"), False),
        ("223", "S", 34.0, 40.0, "office", office("M. Larrea"), True),
        ("225", "S", 40.0, 46.0, "office", gen_office("225"), False),
        ("227", "S", 46.0, 53.0, "office", office("O. Arbelaitz"), True),
        ("229", "S", 53.0, 60.0, "office", gen_office("229"), False),
        ("231", "S", 60.0, 66.0, "office", gen_office("231"), False),
        ("250", "N", 6.0, 14.0, "service", n("Saileko idazkaritza", "Department Office", "Secretaría del departamento"), False),
        ("252", "N", 14.0, 22.0, "office", gen_office("252"), False),
        ("254", "N", 22.0, 33.5, "meeting", n("2.1 mintegia", "Seminar Room 2.1", "Seminario 2.1"), False),
        ("270", "N", 38.0, 44.0, "office", gen_office("270"), False),
        ("274", "N", 44.0, 50.0, "office", office("K. Sarasola"), True),
        ("276", "N", 50.0, 56.0, "office", gen_office("276"), False),
        ("278", "N", 56.0, 61.0, "office", gen_office("278"), False),
        ("280", "N", 61.0, 66.0, "office", gen_office("280"), False),
    ],
    3: [
        ("301", "S", 6.0, 14.0, "lab", n("IXA laborategia", "IXA Lab", "Laboratorio IXA"), True),
        ("303", "S", 14.0, 20.0, "office", office("B. Sierra"), True),
        ("305", "S", 20.0, 34.0, "lab", n("RSAIT laborategia", "RSAIT Lab", "Laboratorio RSAIT"), True, 27.0),
        ("307", "S", 34.0, 44.0, "lab", n("Galan laborategia", "Galan Lab", "Laboratorio Galan"), False),
        ("309", "S", 44.0, 52.0, "office", gen_office("309"), False),
        ("311", "S", 52.0, 66.0, "lab", n("ALDAPA laborategia", "ALDAPA Lab", "Laboratorio ALDAPA"), True),
        ("320", "N", 6.0, 12.0, "office", gen_office("320"), False),
        ("322", "N", 12.0, 18.0, "office", gen_office("322"), False),
        ("325", "N", 18.0, 24.0, "office", office("I. Irigoien"), True),
        ("326", "N", 24.0, 33.5, "office", gen_office("326"), False),
        ("327", "N", 38.0, 46.0, "meeting", n("3.1 mintegia", "Seminar Room 3.1", "Seminario 3.1"), False),
        ("329", "N", 46.0, 56.0, "office", gen_office("329"), False),
        ("331", "N", 56.0, 66.0, "lab", n("Doktoregaien gela", "PhD Students' Room", "Sala de doctorandos"), False),
    ],
}

ROBOTS = [
    # name, floor, drive, max_linear, max_angular, lin acc, ang acc, radius, home (x, y, yaw)
    ("Tartalo", 0, "differential", 0.6, 1.0, 0.5, 1.5, 0.33, (30.0, 12.0, 0.0)),     # PeopleBot
    ("Kbot", 1, "differential", 0.7, 1.2, 0.6, 2.0, 0.30, (30.0, 12.0, 0.0)),        # Neobotix
    ("Galtxagorri", 2, "differential", 0.6, 1.2, 0.6, 2.0, 0.27, (30.0, 12.0, 0.0)), # Pioneer-3DX
    ("MariSorgin", 3, "synchro", 0.5, 0.9, 0.4, 1.2, 0.27, (30.0, 12.0, 0.0)),       # B21, synchro-drive
]

# Variants: the same floors with other robots (id, display name, header line, robots).
EXTRA_ROBOTS = [
    ("Basajaun", 1, "differential", 0.6, 1.2, 0.6, 2.0, 0.27, (54.0, 12.0, math.pi)),   # a second Pioneer-3DX
    ("Lamia", 2, "differential", 0.7, 1.2, 0.6, 2.0, 0.30, (54.0, 12.0, math.pi)),      # a second Neobotix
]
VARIANTS = {
    "faculty6": ("Faculty of Informatics, two robots on floors 1 and 2",
                 "six robots: two on floors 1 and 2 (15 relays)",
                 sorted(ROBOTS + EXTRA_ROBOTS, key=lambda r: r[1])),
    "faculty3": ("Faculty of Informatics, no robot on floor 2",
                 "three robots: floor 2 has none (visitors find its rooms alone)",
                 [r for r in ROBOTS if r[1] != 2]),
}

CONNECTORS = [
    ("stairs_west", "stairs", n("Mendebaldeko eskailerak", "West staircase", "Escalera oeste"), (4.4, 12.0, math.pi)),
    ("lift", "lift", n("Igogailua", "Lift", "Ascensor"), (35.5, 12.6, math.pi / 2)),
    ("stairs_east", "stairs", n("Ekialdeko eskailerak", "East staircase", "Escalera este"), (67.6, 12.0, 0.0)),
]

COLOURS = {
    "office": (214, 228, 240), "lab": (220, 236, 214), "lecture": (244, 232, 204),
    "service": (240, 220, 228), "entrance": (250, 246, 226), "meeting": (230, 222, 242), "other": (230, 230, 230),
}


def rect(grid: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: int) -> None:
    """Fill the map rectangle [x0,x1]x[y0,y1] (building metres) of ``grid`` (rows bottom-first)."""
    c0 = int(round((x0 + MARGIN) / RES))
    c1 = int(round((x1 + MARGIN) / RES))
    r0 = int(round((y0 + MARGIN) / RES))
    r1 = int(round((y1 + MARGIN) / RES))
    grid[max(r0, 0):max(r1, 0), max(c0, 0):max(c1, 0)] = value


def door_x(room: tuple) -> float:
    return room[7] if len(room) > 7 else 0.5 * (room[2] + room[3])


def build_grid(floor: int) -> np.ndarray:
    """Occupancy values (0 free, 100 occupied, -1 unknown), rows bottom-first.

    The floor starts solid and free space is carved: corridor, stair landings,
    room interiors (leaving WALL-thick partitions) and doors.
    """
    cols, rows = int(round((W + 2 * MARGIN) / RES)), int(round((H + 2 * MARGIN) / RES))
    grid = np.full((rows, cols), -1, dtype=np.int8)
    rect(grid, 0, 0, W, H, 100)
    rect(grid, STAIR_X, CORR_Y0, W - STAIR_X, CORR_Y1, 0)                 # corridor
    for x0, x1 in ((FLIGHT_X, STAIR_X), (W - STAIR_X, W - FLIGHT_X)):       # stair landings
        rect(grid, x0, STAIR_Y0, x1, STAIR_Y1, 0)
    for room in ROOMS[floor]:
        _, side, x0, x1, category = room[:5]
        y0, y1 = (WALL, CORR_Y0 - WALL) if side == "S" else (CORR_Y1 + WALL, H - WALL)
        rect(grid, x0 + WALL / 2, y0, x1 - WALL / 2, y1, 0)
        dx = door_x(room)
        width = 2.0 if category in ("entrance", "lecture") and x1 - x0 > 12 else 1.0
        wy0, wy1 = (CORR_Y0 - WALL, CORR_Y0) if side == "S" else (CORR_Y1, CORR_Y1 + WALL)
        rect(grid, dx - width / 2, wy0 - 0.01, dx + width / 2, wy1 + 0.01, 0)
    if floor == 0:
        rect(grid, 26.0, CORR_Y0 - WALL - 0.01, 38.0, CORR_Y0 + 0.01, 0)   # the hall opens onto the corridor
        for cx in (28.0, 32.0, 36.0):                                     # columns in the hall
            rect(grid, cx - 0.2, 5.0, cx + 0.2, 5.4, 100)
    return grid


def save_pgm(grid: np.ndarray, path: Path) -> None:
    img = np.full(grid.shape, 205, dtype=np.uint8)
    img[grid == 0] = 254
    img[grid == 100] = 0
    Image.fromarray(np.flipud(img)).save(path)


def font(size: int, bold: bool = False) -> ImageFont.FreeTypeFont:
    name = "DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf"
    return ImageFont.truetype(f"/usr/share/fonts/truetype/dejavu/{name}", size)


def to_px(x: float, y: float) -> tuple[float, float]:
    return (BP_MARGIN + PX_PER_M * x, BP_MARGIN + PX_PER_M * (H - y))


def draw_blueprint(floor: int, path: Path) -> None:
    size = (int(W * PX_PER_M + 2 * BP_MARGIN), int(H * PX_PER_M + 2 * BP_MARGIN))
    img = Image.new("RGB", size, (250, 250, 248))
    d = ImageDraw.Draw(img)

    def box(x0: float, y0: float, x1: float, y1: float, fill, outline=(70, 74, 82), width: int = 2) -> None:
        u0, v1 = to_px(x0, y0)
        u1, v0 = to_px(x1, y1)
        d.rectangle([u0, v0, u1, v1], fill=fill, outline=outline, width=width)

    box(0, 0, W, H, (214, 214, 210), width=4)                       # structure, services
    box(STAIR_X, CORR_Y0, W - STAIR_X, CORR_Y1, (255, 255, 255), outline=None, width=0)
    for room in ROOMS[floor]:
        number, side, x0, x1, category = room[:5]
        y0, y1 = (0, CORR_Y0) if side == "S" else (CORR_Y1, H)
        box(x0, y0, x1, y1, COLOURS.get(category, COLOURS["other"]))
        cu, cv = to_px(0.5 * (x0 + x1), 0.5 * (y0 + y1))
        d.text((cu, cv), number, fill=(40, 44, 52), font=font(20, bold=True), anchor="mm")
        dx = door_x(room)
        wy = CORR_Y0 if side == "S" else CORR_Y1
        du0, dv = to_px(dx - 0.5, wy)
        du1, _ = to_px(dx + 0.5, wy)
        d.line([du0, dv, du1, dv], fill=(255, 255, 255), width=5)
    if floor == 0:
        u0, v = to_px(26.0, CORR_Y0)
        u1, _ = to_px(38.0, CORR_Y0)
        d.line([u0, v, u1, v], fill=COLOURS["entrance"], width=5)
    for x0, x1, xl0, xl1 in ((0.0, FLIGHT_X, FLIGHT_X, STAIR_X), (W - FLIGHT_X, W, W - STAIR_X, W - FLIGHT_X)):
        box(xl0, STAIR_Y0, xl1, STAIR_Y1, (255, 255, 255), outline=None, width=0)
        box(x0, STAIR_Y0, x1, STAIR_Y1, (196, 198, 204))
        for k in range(1, 14):
            ys = STAIR_Y0 + (STAIR_Y1 - STAIR_Y0) * k / 14
            u0, v = to_px(x0, ys)
            u1, _ = to_px(x1, ys)
            d.line([u0, v, u1, v], fill=(120, 122, 130), width=1)
    box(34.0, CORR_Y1 + 0.2, 37.0, 16.5, (176, 186, 210))
    cu, cv = to_px(35.5, 15.1)
    d.text((cu, cv), "⇅", fill=(30, 40, 70), font=font(26, bold=True), anchor="mm")
    img.save(path, optimize=True)


def building_doc(robot_list: list[tuple] = ROBOTS, files: str = "") -> dict:
    """The faculty's building.yaml with ``robot_list``; map and blueprint paths prefixed with ``files``."""
    floors = []
    locations = []
    for floor in sorted(ROOMS):
        floors.append({
            "id": floor,
            "names": FLOOR_NAMES[floor],
            "map": f"{files}floor{floor}.yaml",
            "blueprint": f"{files}floor{floor}.png",
            "blueprint_transform": {"scale": PX_PER_M, "origin_px": [BP_MARGIN, BP_MARGIN + PX_PER_M * H]},
        })
        for room in ROOMS[floor]:
            number, side, _, _, category, names, featured = room[:7]
            y, yaw = (CORR_Y0 + 0.9, -math.pi / 2) if side == "S" else (CORR_Y1 - 0.9, math.pi / 2)
            locations.append({
                "id": number, "floor": floor, "pose": [round(door_x(room), 2), round(y, 2), round(yaw, 4)],
                "names": names, "category": category, "featured": featured,
            })
    connectors = [{
        "id": cid, "kind": kind, "names": names,
        "meeting": [{"floor": f, "pose": [pose[0], pose[1], round(pose[2], 4)]} for f in sorted(ROOMS)],
    } for cid, kind, names, pose in CONNECTORS]
    robots = [{
        "name": name, "floor": floor, "master_uri": f"http://127.0.0.{11 + i}:11311/",
        "drive": drive, "max_linear": vl, "max_angular": va, "max_linear_accel": al,
        "max_angular_accel": aa, "radius": radius, "home": list(home),
    } for i, (name, floor, drive, vl, va, al, aa, radius, home) in enumerate(robot_list)]
    return {
        "id": "faculty",
        "name": "Faculty of Informatics, UPV/EHU, San Sebastian",
        "floors": floors, "locations": locations, "connectors": connectors, "robots": robots,
    }


class _FlowListDumper(yaml.SafeDumper):
    """Writes lists of scalars (poses, pixels) on one line."""


def _represent_list(dumper: yaml.SafeDumper, data: list) -> yaml.Node:
    flow = all(not isinstance(x, (list, dict)) for x in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


_FlowListDumper.add_representer(list, _represent_list)


def write_doc(doc: dict, header: str, path: Path) -> None:
    text = yaml.dump(doc, Dumper=_FlowListDumper, sort_keys=False, allow_unicode=True, width=120)
    path.write_text(header + text, encoding="utf-8")


def main(out: Path) -> None:
    """Write the faculty into ``out`` and each variant into a sibling directory named after it."""
    out.mkdir(parents=True, exist_ok=True)
    for floor in sorted(ROOMS):
        grid = build_grid(floor)
        save_pgm(grid, out / f"floor{floor}.pgm")
        (out / f"floor{floor}.yaml").write_text(yaml.safe_dump({
            "image": f"floor{floor}.pgm", "resolution": RES, "origin": [-MARGIN, -MARGIN, 0.0],
            "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196,
        }, sort_keys=False), encoding="utf-8")
        draw_blueprint(floor, out / f"floor{floor}.png")
    header = ("# The Faculty of Informatics (UPV/EHU, San Sebastian): 4 floors, one lift, two staircases.\n"
              "# Format: docs/building-format.md. Generated by tools/make_faculty.py; edit there and re-run.\n")
    write_doc(building_doc(), header, out / "building.yaml")
    for variant, (name, what, robots) in VARIANTS.items():
        doc = building_doc(robots, files=f"../{out.name}/")
        doc.update(id=variant, name=name)
        (out.parent / variant).mkdir(exist_ok=True)
        write_doc(doc, f"# The Faculty of Informatics ({out.name}/) with {what}.\n"
                       "# Format: docs/building-format.md. Generated by tools/make_faculty.py; edit there and re-run.\n",
                  out.parent / variant / "building.yaml")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent / "maps" / "faculty")
