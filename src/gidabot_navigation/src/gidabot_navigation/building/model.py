"""The building model (ROS-free): floors, locations, connectors and robots.

One YAML file per building, ``maps/<building>/building.yaml``; its format is
documented in ``docs/building-format.md``. :func:`load_building` validates
everything and raises one :class:`BuildingError` listing every problem with
file, key and value, so a new building needs only data files, no code.
:func:`building_from_doc` does the same for a document already read (the
building editor checks the one being edited); a building saved as a draft
(``draft: true``) is refused unless ``allow_draft``.
"""

from __future__ import annotations

import ipaddress
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from urllib.parse import urlparse

import yaml

from gidabot_navigation.building.geometry import BlueprintTransform, Polygon, Pose2D, polygon_problem
from gidabot_navigation.building.occupancy import OccupancyMap, load_map
from gidabot_navigation.building.yaml_text import DuplicateKeyError, load_yaml
from gidabot_navigation.errors import BuildingError, MapError, Problem
from gidabot_navigation.interface import DEFAULT_LANGUAGE, LANGUAGES, WAYS

DRIVE_TYPES = ("differential", "synchro")
DEFAULT_RELAY_PORT = 11411       # a robot's first relay link port (building file key relay_port)
CATEGORIES = ("office", "lab", "lecture", "service", "entrance", "meeting", "other")
FLOOR_TOLERANCE = 1e-3
FULL_CIRCLE = 2.0 * math.pi
FOV_TOLERANCE = 1e-3     # rad: a laser's fov written as 6.2832 is the full circle
# ids of the building, its locations and connectors; robot names (they name ROS nodes). \Z, not $: "$" would
# also match before a trailing newline ("faculty\n")
_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,31}\Z")
_ROBOT_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,31}\Z")


def format_floor(floor: float) -> str:
    """'0' for 0.0, '0.5' for 0.5: how floors are written in files and shown."""
    return str(int(floor)) if float(floor).is_integer() else f"{floor:g}"


@dataclass(frozen=True)
class KeepOut:
    """A zone of a floor robots never enter (building file key ``keep_out``): lethal for the planner, solid for the
    simulated robots, invisible to the simulated laser."""

    id: str
    polygon: Polygon


@dataclass(frozen=True)
class FloorAlignment:
    """Where a floor's map frame lies in another floor's map frame (building file key ``aligned_to``, set by the
    building editor): lets the editor show one floor over the other."""

    floor: float
    pose: Pose2D

    def to_other(self, x: float, y: float) -> tuple[float, float]:
        """A point of this floor's map in the other floor's map (m)."""
        c, s = math.cos(self.pose.yaw), math.sin(self.pose.yaw)
        return (self.pose.x + c * x - s * y, self.pose.y + s * x + c * y)


@dataclass(frozen=True)
class Floor:
    id: float
    names: dict[str, str]
    map_file: Path
    blueprint_file: Path
    transform: BlueprintTransform
    map: OccupancyMap = field(repr=False, compare=False)
    blueprint_size: tuple[int, int] = (0, 0)   # pixels (width, height) of the blueprint image
    keep_out: tuple[KeepOut, ...] = ()
    aligned_to: FloorAlignment | None = None

    @property
    def label(self) -> str:
        return format_floor(self.id)

    @property
    def keep_out_zones(self) -> dict[str, Polygon]:
        """The keep-out zones by id (what :class:`~gidabot_navigation.building.planning.GridPlanner` takes)."""
        return {z.id: z.polygon for z in self.keep_out}

    def keep_out_at(self, x: float, y: float) -> KeepOut | None:
        """The keep-out zone (x, y) lies in, or None."""
        return next((z for z in self.keep_out if z.polygon.contains_point(x, y)), None)


@dataclass(frozen=True)
class Location:
    id: str
    floor: float
    pose: Pose2D
    names: dict[str, str]
    category: str
    featured: bool = False

    def name(self, language: str) -> str:
        return self.names.get(language) or self.names[DEFAULT_LANGUAGE]


@dataclass(frozen=True)
class Connector:
    id: str
    kind: str                       # one of WAYS: "lift" or "stairs"
    names: dict[str, str]
    meeting: dict[float, Pose2D]    # floor id -> meeting pose on that floor
    serves: tuple[float, ...]       # floor ids it serves (= the floors of its meeting poses)

    def name(self, language: str) -> str:
        return self.names.get(language) or self.names[DEFAULT_LANGUAGE]


@dataclass(frozen=True)
class LaserSensor:
    """A robot's planar laser (``base_scan``): it sees ``fov`` rad centred on its mount's yaw (all round by
    default), from ``range_min`` to ``range_max`` m, mounted at ``mount`` (x, y in m, yaw in rad) on base_link."""

    fov: float = FULL_CIRCLE
    range_min: float = 0.05
    range_max: float = 20.0
    mount: Pose2D = Pose2D(0.0, 0.0, 0.0)

    @property
    def full_circle(self) -> bool:
        return self.fov >= FULL_CIRCLE


@dataclass(frozen=True)
class Robot:
    name: str
    floor: float
    master_uri: str
    drive: str                 # "differential" or "synchro"
    max_linear: float          # m/s
    max_angular: float         # rad/s
    max_linear_accel: float    # m/s^2
    max_angular_accel: float   # rad/s^2
    radius: float              # m
    home: Pose2D
    relay_port: int = DEFAULT_RELAY_PORT   # first TCP port of its listening relay ends (relay_ports)
    laser: LaserSensor = LaserSensor()     # building file key sensors.laser

    @property
    def ip(self) -> str:
        """IP address of the robot's master (ROS_IP of its nodes)."""
        return urlparse(self.master_uri).hostname or ""

    @property
    def port(self) -> int:
        return urlparse(self.master_uri).port or 11311


@dataclass(frozen=True)
class Building:
    id: str
    name: str
    path: Path
    floors: tuple[Floor, ...]
    locations: tuple[Location, ...]
    connectors: tuple[Connector, ...]
    robots: tuple[Robot, ...]
    draft: bool = False          # saved by the editor while its checks failed: only the editor loads it

    # -- lookups --------------------------------------------------------
    def floor_ids(self) -> list[float]:
        return [f.id for f in self.floors]

    def find_floor(self, value: float) -> Floor | None:
        """The floor whose id is ``value`` (within float32 rounding), or None."""
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            return None
        for f in self.floors:
            if abs(f.id - value) < FLOOR_TOLERANCE:
                return f
        return None

    def floor(self, value: float) -> Floor:
        found = self.find_floor(value)
        if found is None:
            raise KeyError(f"unknown floor {value!r}; the building has floors "
                           f"{', '.join(f.label for f in self.floors)}")
        return found

    def find_location(self, location_id: str) -> Location | None:
        return next((loc for loc in self.locations if loc.id == location_id), None)

    def location(self, location_id: str) -> Location:
        found = self.find_location(location_id)
        if found is None:
            raise KeyError(f"unknown location {location_id!r}")
        return found

    def locations_on(self, floor: float) -> list[Location]:
        f = self.floor(floor)
        return [loc for loc in self.locations if loc.floor == f.id]

    def find_connector(self, connector_id: str) -> Connector | None:
        return next((c for c in self.connectors if c.id == connector_id), None)

    def connectors_between(self, a: float, b: float, kind: str | None = None) -> list[Connector]:
        """Connectors of ``kind`` (any if None) that serve both floors."""
        fa, fb = self.floor(a).id, self.floor(b).id
        return [c for c in self.connectors
                if fa in c.serves and fb in c.serves and (kind is None or c.kind == kind)]

    def find_robot(self, name: str) -> Robot | None:
        return next((r for r in self.robots if r.name == name), None)

    def robot(self, name: str) -> Robot:
        found = self.find_robot(name)
        if found is None:
            raise KeyError(f"unknown robot {name!r}; the building has "
                           f"{', '.join(r.name for r in self.robots)}")
        return found

    def robots_on(self, floor: float) -> list[Robot]:
        """The robots serving ``floor``, in the building's order; none: the visitor finds the place alone."""
        f = self.find_floor(floor)
        if f is None:
            return []
        return [r for r in self.robots if r.floor == f.id]

    def has_robot(self, floor: float) -> bool:
        """True when at least one robot serves ``floor``."""
        return bool(self.robots_on(floor))

    def relay_pairs(self) -> list[tuple[Robot, Robot]]:
        """Every pair (a, b) with a before b in the robot list: n(n-1)/2 relays."""
        return [(a, b) for i, a in enumerate(self.robots) for b in self.robots[i + 1:]]

    def relay_link_port(self, a: str, b: str) -> int:
        """TCP port of the relay link of the pair (a, b), a listed before b: b's end listens on b's
        address, port ``b.relay_port + <index of a>``; a's end connects there (docs/deploy.md)."""
        names = [r.name for r in self.robots]
        if names.index(a) >= names.index(b):
            raise KeyError(f"relay pair ({a}, {b}): {a} must be listed before {b}")
        return self.robot(b).relay_port + names.index(a)

    def relay_ports(self, robot: str) -> list[int]:
        """The TCP ports robot ``robot`` listens on for its relay links (one per robot listed before it)."""
        names = [r.name for r in self.robots]
        return [self.relay_link_port(a, robot) for a in names[:names.index(robot)]]

    def with_master_uris(self, uris: dict[str, str]) -> Building:
        """A copy whose robots use the given master URIs (tests and the simulated building)."""
        robots = tuple(_replace_robot(r, uris.get(r.name, r.master_uri)) for r in self.robots)
        return Building(self.id, self.name, self.path, self.floors, self.locations,
                        self.connectors, robots)


def relocate_building(src: str | Path, dest_dir: str | Path, master_uris: dict[str, str],
                      relay_ports: dict[str, int] | None = None) -> Path:
    """Write a copy of building ``src`` into ``dest_dir`` with other master URIs (and relay ports);
    return its path.

    Map and blueprint paths become absolute so the copy needs no other file. Used by
    tests, benchmarks and the demo to run a building on free loopback ports.
    """
    src_path = Path(src)
    if src_path.is_dir():
        src_path = src_path / "building.yaml"
    doc = yaml.safe_load(src_path.read_text(encoding="utf-8"))
    for floor in doc.get("floors", []):
        for key in ("map", "blueprint"):
            if isinstance(floor.get(key), str):
                floor[key] = str((src_path.parent / floor[key]).resolve())
    for robot in doc.get("robots", []):
        if robot.get("name") in master_uris:
            robot["master_uri"] = master_uris[robot["name"]]
        if robot.get("name") in (relay_ports or {}):
            robot["relay_port"] = relay_ports[robot["name"]]  # type: ignore[index]
    dest = Path(dest_dir)
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / "building.yaml"
    out.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True), encoding="utf-8")
    return out


def _replace_robot(robot: Robot, uri: str) -> Robot:
    return replace(robot, master_uri=uri)


# ---------------------------------------------------------------------------
# Loading and validation
# ---------------------------------------------------------------------------

class _Checker:
    """Collects problems while reading one building file."""

    def __init__(self, path: Path, files: FloorFiles) -> None:
        self.path = path
        self.files = files
        self.problems: list[Problem] = []

    def problem(self, where: str, message: str, floor: float | None = None,
                marks: tuple[tuple[float, float, str], ...] = ()) -> None:
        self.problems.append(Problem(str(self.path), where, message, floor, marks))

    def mapping(self, value: object, where: str) -> dict:
        if isinstance(value, dict):
            return value
        self.problem(where, f"expected a mapping, got {_show(value)}")
        return {}

    def seq(self, value: object, where: str) -> list:
        if isinstance(value, list):
            return value
        self.problem(where, f"expected a list, got {_show(value)}")
        return []

    def keys(self, doc: dict, where: str, required: tuple[str, ...], optional: tuple[str, ...] = ()) -> bool:
        ok = True
        for key in required:
            if key not in doc:
                self.problem(f"{where}.{key}" if where else key, "is missing")
                ok = False
        for key in doc:
            if key not in required and key not in optional:
                allowed = ", ".join(required + optional)
                self.problem(f"{where}.{key}" if where else str(key), f"unknown key (expected one of: {allowed})")
        return ok

    def number(self, value: object, where: str, positive: bool = False) -> float | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.problem(where, f"{_show(value)} is not a number")
            return None
        number = float(value)
        if not math.isfinite(number):
            self.problem(where, f"{_show(value)} is not a finite number")
            return None
        if positive and number <= 0:
            self.problem(where, f"{_show(value)} must be > 0")
            return None
        return number

    def text(self, value: object, where: str) -> str | None:
        if not isinstance(value, str) or not value.strip():
            self.problem(where, f"{_show(value)} must be a non-empty string")
            return None
        return value

    def names(self, value: object, where: str) -> dict[str, str]:
        doc = self.mapping(value, where)
        out: dict[str, str] = {}
        for lang in LANGUAGES:
            if lang not in doc:
                self.problem(f"{where}.{lang}", "is missing (names are needed in eu, en and es)")
                continue
            name = self.text(doc[lang], f"{where}.{lang}")
            if name is not None:
                out[lang] = name
        for lang in doc:
            if lang not in LANGUAGES:
                self.problem(f"{where}.{lang}", f"unknown language (expected {', '.join(LANGUAGES)})")
        return out

    def pose(self, value: object, where: str) -> Pose2D | None:
        if not isinstance(value, list) or len(value) != 3:
            self.problem(where, f"{_show(value)} must be a list [x, y, yaw] (m, m, rad)")
            return None
        nums = [self.number(v, f"{where}[{i}]") for i, v in enumerate(value)]
        if any(n is None for n in nums):
            return None
        return Pose2D(*nums)  # type: ignore[arg-type]

    def file(self, value: object, where: str) -> Path | None:
        name = self.text(value, where)
        if name is None:
            return None
        path = Path(name)
        if not path.is_absolute():
            path = self.path.parent / path
        if not path.is_file():
            self.problem(where, f"{name!r}: file not found ({path})")
            return None
        return path


def _show(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


DRAFT_MESSAGE = ("true: the building editor saved this building as a draft (its checks failed); open it with "
                 "`gidabot edit {dir}`, fix the problems it lists and save it again")


class FloorFiles:
    """Reads the floors' map and blueprint files for :func:`building_from_doc`: each time they are asked for
    (every node, ``gidabot check``), or, with ``cache``, again only when a file changed on disk (its size or
    modification time: the building editor checks after every change)."""

    def __init__(self, cache: bool = False) -> None:
        self.cache = cache
        self._maps: dict[tuple[str, int, int], OccupancyMap] = {}
        self._sizes: dict[tuple[str, int, int], tuple[int, int]] = {}

    @staticmethod
    def _key(path: Path) -> tuple[str, int, int]:
        st = path.stat()
        return (str(path.resolve()), st.st_mtime_ns, st.st_size)

    def load_map(self, path: Path) -> OccupancyMap:
        """The map_server map at ``path`` (:class:`MapError`); with the cache, keyed by the map YAML's and its
        image's stamps."""
        if not self.cache:
            return load_map(path)
        try:
            image = load_yaml(path.read_text(encoding="utf-8"))
            image_path = path.parent / str(image.get("image", "")) if isinstance(image, dict) else path
            key = (*self._key(path), *self._key(image_path))
        except (OSError, UnicodeDecodeError, yaml.YAMLError):
            return load_map(path)                        # it reports what is wrong
        if key not in self._maps:
            self._maps = {k: v for k, v in self._maps.items() if k[0] != key[0]}
            self._maps[key] = load_map(path)
        return self._maps[key]

    def image_size(self, path: Path) -> tuple[int, int]:
        """(width, height) of the image at ``path`` once it decoded completely (OSError, ValueError or PIL's
        UnidentifiedImageError when it does not)."""
        key = self._key(path) if self.cache else None
        if key is not None and key in self._sizes:
            return self._sizes[key]
        from PIL import Image

        with Image.open(path) as img:
            img.load()
            size = img.size
        if key is not None:
            self._sizes[key] = size
        return size


def load_building(path: str | Path, allow_draft: bool = False) -> Building:
    """Load and validate ``building.yaml`` (or a directory holding one).

    Raises :class:`BuildingError` listing every problem found; a draft (``draft: true``) is one of them unless
    ``allow_draft``.
    """
    path = Path(path)
    if path.is_dir():
        path = path / "building.yaml"
    return building_from_doc(read_building_doc(path), path, allow_draft)


def read_building_doc(path: Path) -> object:
    """The YAML document of building file ``path`` (:class:`BuildingError` when it cannot be read or parsed, or
    gives a key twice in one mapping)."""
    try:
        raw = path.read_text(encoding="utf-8")
    except OSError as err:
        raise BuildingError([Problem(str(path), "file", f"cannot read: {err.strerror}")]) from err
    except UnicodeDecodeError as err:
        raise BuildingError([Problem(str(path), "file", f"not UTF-8 text: {err}")]) from err
    try:
        return load_yaml(raw)
    except DuplicateKeyError as err:
        raise BuildingError([Problem(str(path), f"line {err.line}", err.problem)]) from err
    except yaml.YAMLError as err:
        raise BuildingError([Problem(str(path), "file", f"not valid YAML: {err}")]) from err


def building_from_doc(doc: object, path: Path, allow_draft: bool = False, files: FloorFiles | None = None) -> Building:
    """Validate the building document ``doc`` (plain YAML data) of the building file ``path`` (files it names are
    relative to its directory); :class:`BuildingError` listing every problem."""
    chk = _Checker(path, files or FloorFiles())
    doc = chk.mapping(doc, "(top level)")
    chk.keys(doc, "", ("id", "name", "floors", "locations", "connectors", "robots"), ("draft",))
    draft = doc.get("draft", False)
    if not isinstance(draft, bool):
        chk.problem("draft", f"{_show(draft)} must be true or false")
        draft = False
    elif draft and not allow_draft:
        chk.problem("draft", DRAFT_MESSAGE.format(dir=path.parent))
    building_id = doc.get("id", "x")
    if not isinstance(building_id, str) or not _ID_RE.match(building_id):
        chk.problem("id", f"{_show(building_id)} must be 1-32 letters, digits, '_', '.', '-' starting with a letter "
                          "or digit (a short identifier: no '/', no spaces)")
        building_id = ""
    building_name = chk.text(doc.get("name", "x"), "name") or ""

    floors, unusable = _load_floors(chk, doc.get("floors", []))
    by_floor = _Floors({f.id: f for f in floors}, unusable)
    locations = _load_locations(chk, doc.get("locations", []), by_floor)
    if doc.get("locations") == []:
        chk.problem("locations", "[]: a building needs at least one location (no visitor or tour has anywhere "
                                 "to go without one)")
    connectors = _load_connectors(chk, doc.get("connectors", []), by_floor, {loc.id for loc in locations})
    robots = _load_robots(chk, doc.get("robots", []), by_floor)
    if doc.get("robots") == []:
        chk.problem("robots", "[]: a building needs at least one robot (every node runs as one of them)")

    if chk.problems:
        raise BuildingError(chk.problems)
    return Building(building_id, building_name, path, tuple(floors), tuple(locations),
                    tuple(connectors), tuple(robots), draft=draft)


def _image_size(chk: _Checker, path: Path, where: str) -> tuple[int, int] | None:
    """(width, height) of the image at ``path`` once it decoded completely, else a problem."""
    from PIL import UnidentifiedImageError

    try:
        return chk.files.image_size(path)
    except (OSError, UnidentifiedImageError, ValueError) as err:
        chk.problem(where, f"{path.name!r} is not a readable image (PNG, JPEG, PGM...): {err}")
        return None


def _on_blueprint(chk: _Checker, floor: Floor, pose: Pose2D, where: str) -> None:
    """A problem if ``pose`` falls outside the floor's blueprint image (the GUI could not show it)."""
    u, v = floor.transform.to_pixel(pose.x, pose.y)
    w, h = floor.blueprint_size
    if not (0 <= u < w and 0 <= v < h):
        chk.problem(where, f"({pose.x:g}, {pose.y:g}) is at pixel ({u:.0f}, {v:.0f}) of the blueprint "
                           f"{floor.blueprint_file.name}, outside its {w}x{h} pixels: check blueprint_transform "
                           f"of floor {floor.label}", floor.id, ((pose.x, pose.y, "place"),))


def _in_free_space(chk: _Checker, floor: Floor, pose: Pose2D, where: str, what: str) -> None:
    _on_blueprint(chk, floor, pose, where)
    grid = floor.map
    at = ((pose.x, pose.y, "place"),)
    if not grid.contains(pose.x, pose.y):
        w, h = grid.size_m
        x0, y0 = grid.origin_x, grid.origin_y
        chk.problem(where, f"({pose.x:g}, {pose.y:g}) is outside the map of floor {floor.label} "
                           f"(x {x0:g}..{x0 + w:g}, y {y0:g}..{y0 + h:g} m)", floor.id, at)
    elif not grid.is_free(pose.x, pose.y):
        chk.problem(where, f"({pose.x:g}, {pose.y:g}) is inside a wall or unknown space on floor "
                           f"{floor.label}; {what} must be in free space", floor.id, at)
    elif (zone := floor.keep_out_at(pose.x, pose.y)) is not None:
        chk.problem(where, f"({pose.x:g}, {pose.y:g}) is inside keep-out zone {zone.id} of floor {floor.label}, "
                           f"where robots never go; {what} must be outside it", floor.id, at)


class _Floors(dict):
    """The floors that loaded, by id; ``unusable``: ids of floors declared but not loaded (their map or
    blueprint has a problem, already reported): a place on one is not checked further, and not reported again
    as on an unknown floor."""

    def __init__(self, floors: dict[float, Floor], unusable: set[float]) -> None:
        super().__init__(floors)
        self.unusable = unusable


def _load_floors(chk: _Checker, value: object) -> tuple[list[Floor], set[float]]:
    floors: list[Floor] = []
    unusable: set[float] = set()
    alignments: dict[float, tuple[str, object]] = {}
    for i, item in enumerate(chk.seq(value, "floors")):
        where = f"floors[{i}]"
        doc = chk.mapping(item, where)
        if not chk.keys(doc, where, ("id", "names", "map", "blueprint", "blueprint_transform"),
                        ("keep_out", "aligned_to")):
            continue
        fid = chk.number(doc["id"], f"{where}.id")
        names = chk.names(doc["names"], f"{where}.names")
        map_file = chk.file(doc["map"], f"{where}.map")
        blueprint = chk.file(doc["blueprint"], f"{where}.blueprint")
        tdoc = chk.mapping(doc["blueprint_transform"], f"{where}.blueprint_transform")
        transform = None
        if chk.keys(tdoc, f"{where}.blueprint_transform", ("scale", "origin_px"), ("rotation",)):
            scale = chk.number(tdoc["scale"], f"{where}.blueprint_transform.scale", positive=True)
            origin = tdoc["origin_px"]
            rot = chk.number(tdoc.get("rotation", 0.0), f"{where}.blueprint_transform.rotation")
            if not (isinstance(origin, list) and len(origin) == 2):
                chk.problem(f"{where}.blueprint_transform.origin_px", f"{_show(origin)} must be [u, v] pixels")
            else:
                u = chk.number(origin[0], f"{where}.blueprint_transform.origin_px[0]")
                v = chk.number(origin[1], f"{where}.blueprint_transform.origin_px[1]")
                if None not in (scale, u, v, rot):
                    transform = BlueprintTransform(scale, u, v, rot)  # type: ignore[arg-type]
        if fid is not None and any(abs(f.id - fid) < FLOOR_TOLERANCE for f in floors):
            chk.problem(f"{where}.id", f"duplicate floor id {format_floor(fid)}")
            continue
        grid = None
        if map_file is not None:
            try:
                grid = chk.files.load_map(map_file)
            except MapError as err:
                chk.problem(f"{where}.map", str(err))
        zones = _keep_out(chk, doc.get("keep_out", []), f"{where}.keep_out", grid, fid)
        size = _image_size(chk, blueprint, f"{where}.blueprint") if blueprint is not None else None
        if None in (fid, map_file, blueprint, transform, grid, size, zones) or len(names) != len(LANGUAGES):
            if fid is not None:
                unusable.add(fid)
            continue
        if "aligned_to" in doc:
            alignments[fid] = (f"{where}.aligned_to", doc["aligned_to"])  # type: ignore[index]
        floors.append(Floor(fid, names, map_file, blueprint, transform, grid,  # type: ignore[arg-type]
                            blueprint_size=size, keep_out=zones))  # type: ignore[arg-type]
    if not floors and not chk.problems:
        chk.problem("floors", "a building needs at least one floor")
    floors = _aligned(chk, floors, unusable, alignments)
    return floors, unusable


def _keep_out(chk: _Checker, value: object, where: str, grid: OccupancyMap | None,
              floor: float | None) -> tuple[KeepOut, ...] | None:
    """A floor's ``keep_out`` zones: ``[{id, polygon: [[x, y], ...]}]`` (None when one is wrong: reported)."""
    n = len(chk.problems)
    zones: list[KeepOut] = []
    for j, item in enumerate(chk.seq(value, where)):
        zwhere = f"{where}[{j}]"
        doc = chk.mapping(item, zwhere)
        if not chk.keys(doc, zwhere, ("id", "polygon")):
            continue
        zid = doc["id"]
        if not isinstance(zid, str) or not _ID_RE.match(zid):
            chk.problem(f"{zwhere}.id", f"{_show(zid)} must be a string of letters, digits, '_', '.', '-'")
            continue
        if any(z.id == zid for z in zones):
            chk.problem(f"{zwhere}.id", f"duplicate keep-out zone id {zid!r} on this floor")
            continue
        problem = polygon_problem(doc["polygon"])
        if problem is not None:
            chk.problem(f"{zwhere}.polygon", f"{_show(doc['polygon'])}: {problem}")
            continue
        zone = KeepOut(zid, Polygon(tuple(tuple(pt) for pt in doc["polygon"])))
        if grid is not None:
            x0, y0, x1, y1 = zone.polygon.bounds()
            w, h = grid.size_m
            if x1 < grid.origin_x or y1 < grid.origin_y or x0 > grid.origin_x + w or y0 > grid.origin_y + h:
                chk.problem(f"{zwhere}.polygon", f"keep-out zone {zid} ({x0:g}..{x1:g}, {y0:g}..{y1:g} m) lies "
                                                 f"outside the map (x {grid.origin_x:g}..{grid.origin_x + w:g}, "
                                                 f"y {grid.origin_y:g}..{grid.origin_y + h:g} m)", floor,
                            tuple((x, y, "zone") for x, y in zone.polygon.points))
                continue
        zones.append(zone)
    return None if len(chk.problems) > n else tuple(zones)


def _aligned(chk: _Checker, floors: list[Floor], unusable: set[float],
             alignments: dict[float, tuple[str, object]]) -> list[Floor]:
    """The floors with their ``aligned_to: {floor, pose}`` (another floor; no chain of them may come back)."""
    found: dict[float, FloorAlignment] = {}
    by_floor = _Floors({f.id: f for f in floors}, unusable)
    for fid, (where, value) in alignments.items():
        doc = chk.mapping(value, where)
        if not chk.keys(doc, where, ("floor", "pose")):
            continue
        other = _floor_ref(chk, doc["floor"], f"{where}.floor", by_floor)
        pose = chk.pose(doc["pose"], f"{where}.pose")
        if other is not None and other.id == fid:
            chk.problem(f"{where}.floor", f"floor {format_floor(fid)} is aligned to itself; name another floor")
        elif other is not None and pose is not None:
            found[fid] = FloorAlignment(other.id, pose)
    for fid in list(found):
        seen, at = {fid}, found[fid].floor
        while at in found:
            if at in seen:
                chk.problem(alignments[fid][0], f"floor {format_floor(fid)}: the floors' aligned_to come back to "
                                                "it in a loop; one floor of each group is aligned to none")
                del found[fid]
                break
            seen.add(at)
            at = found[at].floor
    return [replace(f, aligned_to=found.get(f.id)) for f in floors]


def _floor_ref(chk: _Checker, value: object, where: str, by_floor: _Floors) -> Floor | None:
    number = chk.number(value, where)
    if number is None:
        return None
    for fid, floor in by_floor.items():
        if abs(fid - number) < FLOOR_TOLERANCE:
            return floor
    if any(abs(fid - number) < FLOOR_TOLERANCE for fid in by_floor.unusable):
        return None                 # the floor's own problem is reported: nothing more to say here
    known = ", ".join(format_floor(f) for f in sorted([*by_floor, *by_floor.unusable])) or "none"
    chk.problem(where, f"unknown floor {_show(value)} (floors: {known})")
    return None


def _load_locations(chk: _Checker, value: object, by_floor: _Floors) -> list[Location]:
    locations: list[Location] = []
    seen: set[str] = set()
    for i, item in enumerate(chk.seq(value, "locations")):
        where = f"locations[{i}]"
        doc = chk.mapping(item, where)
        if not chk.keys(doc, where, ("id", "floor", "pose", "names", "category"), ("featured",)):
            continue
        lid = doc["id"]
        if not isinstance(lid, str) or not _ID_RE.match(lid):
            chk.problem(f"{where}.id", f"{_show(lid)} must be a string of letters, digits, '_', '.', '-' "
                                       "(quote room numbers: '014')")
            continue
        if lid in seen:
            chk.problem(f"{where}.id", f"duplicate location id {lid!r}")
            continue
        seen.add(lid)
        floor = _floor_ref(chk, doc["floor"], f"{where}.floor", by_floor)
        pose = chk.pose(doc["pose"], f"{where}.pose")
        names = chk.names(doc["names"], f"{where}.names")
        category = doc["category"]
        if category not in CATEGORIES:
            chk.problem(f"{where}.category", f"{_show(category)} is not one of {', '.join(CATEGORIES)}")
        featured = doc.get("featured", False)
        if not isinstance(featured, bool):
            chk.problem(f"{where}.featured", f"{_show(featured)} must be true or false")
        if floor is None or pose is None:
            continue
        _in_free_space(chk, floor, pose, f"{where}.pose", f"location {lid}")
        locations.append(Location(lid, floor.id, pose, names, str(category), bool(featured)))
    return locations


def _load_connectors(chk: _Checker, value: object, by_floor: _Floors,
                     location_ids: set[str]) -> list[Connector]:
    connectors: list[Connector] = []
    for i, item in enumerate(chk.seq(value, "connectors")):
        where = f"connectors[{i}]"
        doc = chk.mapping(item, where)
        if not chk.keys(doc, where, ("id", "kind", "names", "meeting"), ("serves",)):
            continue
        cid = doc["id"]
        if not isinstance(cid, str) or not _ID_RE.match(cid):
            chk.problem(f"{where}.id", f"{_show(cid)} must be a string of letters, digits, '_', '.', '-'")
            continue
        if any(c.id == cid for c in connectors) or cid in location_ids:
            chk.problem(f"{where}.id", f"duplicate id {cid!r} (connector ids must differ from every other id)")
            continue
        kind = doc["kind"]
        if kind not in WAYS:
            chk.problem(f"{where}.kind", f"{_show(kind)} is not one of {', '.join(WAYS)}")
        names = chk.names(doc["names"], f"{where}.names")
        meeting: dict[float, Pose2D] = {}
        for j, m in enumerate(chk.seq(doc["meeting"], f"{where}.meeting")):
            mwhere = f"{where}.meeting[{j}]"
            mdoc = chk.mapping(m, mwhere)
            if not chk.keys(mdoc, mwhere, ("floor", "pose")):
                continue
            floor = _floor_ref(chk, mdoc["floor"], f"{mwhere}.floor", by_floor)
            pose = chk.pose(mdoc["pose"], f"{mwhere}.pose")
            if floor is None or pose is None:
                continue
            if floor.id in meeting:
                chk.problem(f"{mwhere}.floor", f"floor {floor.label} listed twice for connector {cid}")
                continue
            _in_free_space(chk, floor, pose, f"{mwhere}.pose", f"the meeting point of {cid}")
            meeting[floor.id] = pose
        serves = _serves(chk, doc.get("serves"), where, cid, meeting, by_floor)
        if kind in WAYS and len(names) == len(LANGUAGES):
            connectors.append(Connector(cid, str(kind), names, meeting, serves))
    if len(by_floor) > 1:
        for fid in by_floor:
            if not any(fid in c.serves for c in connectors):
                chk.problem("connectors", f"no lift or staircase reaches floor {format_floor(fid)}")
    return connectors


def _serves(chk: _Checker, value: object, where: str, cid: str, meeting: dict[float, Pose2D],
            by_floor: _Floors) -> tuple[float, ...]:
    """The floors a connector serves: ``serves`` (default every floor), which must be the floors of its
    meeting poses exactly (a meeting pose elsewhere would offer the connector for trips it cannot make)."""
    if value is None:
        serves = list(by_floor)
    else:
        serves = []
        for j, v in enumerate(chk.seq(value, f"{where}.serves")):
            f = _floor_ref(chk, v, f"{where}.serves[{j}]", by_floor)
            if f is not None and f.id in serves:
                chk.problem(f"{where}.serves[{j}]", f"floor {f.label} is listed twice")
            elif f is not None:
                serves.append(f.id)
        if isinstance(value, list) and len(value) < 2:
            chk.problem(f"{where}.serves", f"{_show(value)}: a lift or staircase serves at least two floors")
    for fid in serves:
        if fid not in meeting:
            chk.problem(f"{where}.meeting", f"connector {cid} serves floor {format_floor(fid)} "
                                            "but has no meeting pose there")
    for fid in meeting:
        if fid not in serves:
            chk.problem(f"{where}.meeting", f"connector {cid} has a meeting pose on floor {format_floor(fid)}, "
                                            f"which it does not serve (serves: "
                                            f"{', '.join(format_floor(f) for f in serves) or 'none'}); "
                                            "remove the pose or add the floor to serves")
    return tuple(sorted(serves))


def _load_robots(chk: _Checker, value: object, by_floor: _Floors) -> list[Robot]:
    robots: list[Robot] = []
    uris: dict[str, str] = {}
    for i, item in enumerate(chk.seq(value, "robots")):
        where = f"robots[{i}]"
        doc = chk.mapping(item, where)
        required = ("name", "floor", "master_uri", "drive", "max_linear", "max_angular",
                    "max_linear_accel", "max_angular_accel", "radius", "home")
        if not chk.keys(doc, where, required, ("relay_port", "sensors")):
            continue
        name = doc["name"]
        if not isinstance(name, str) or not _ROBOT_RE.match(name):
            chk.problem(f"{where}.name", f"{_show(name)} must start with a letter and hold only "
                                         "letters, digits and '_' (it names ROS nodes)")
            continue
        if any(r.name == name for r in robots):
            chk.problem(f"{where}.name", f"duplicate robot name {name!r}")
            continue
        floor = _floor_ref(chk, doc["floor"], f"{where}.floor", by_floor)
        uri = _master_uri(chk, doc["master_uri"], f"{where}.master_uri")
        if uri is not None:
            if uri in uris:
                chk.problem(f"{where}.master_uri", f"{uri!r} is also the master of robot {uris[uri]}; "
                                                   "every robot needs its own master")
            uris[uri] = name
        drive = doc["drive"]
        if drive not in DRIVE_TYPES:
            chk.problem(f"{where}.drive", f"{_show(drive)} is not one of {', '.join(DRIVE_TYPES)}")
        nums = {k: chk.number(doc[k], f"{where}.{k}", positive=True)
                for k in ("max_linear", "max_angular", "max_linear_accel", "max_angular_accel", "radius")}
        home = chk.pose(doc["home"], f"{where}.home")
        relay_port = _relay_port(chk, doc.get("relay_port", DEFAULT_RELAY_PORT), f"{where}.relay_port", i)
        laser = _laser(chk, doc.get("sensors", {}), f"{where}.sensors")
        if floor is not None and home is not None:
            _in_free_space(chk, floor, home, f"{where}.home", f"the home pose of {name}")
            radius = nums["radius"] or 0.0
            for other in (r for r in robots if r.floor == floor.id):
                gap = math.hypot(home.x - other.home.x, home.y - other.home.y) - radius - other.radius
                if gap < 0:
                    chk.problem(f"{where}.home", f"the home of {name} overlaps the home of {other.name} on floor "
                                                 f"{floor.label} ({-gap:.2f} m); robots of one floor park apart")
        if floor is None or uri is None or home is None or drive not in DRIVE_TYPES or None in nums.values() \
                or relay_port is None or laser is None:
            continue
        robots.append(Robot(name=name, floor=floor.id, master_uri=uri, drive=drive, home=home,
                            relay_port=relay_port, laser=laser, **nums))  # type: ignore[arg-type]
    _shared_addresses(chk, robots)
    return robots


def _laser(chk: _Checker, value: object, where: str) -> LaserSensor | None:
    """``sensors: {laser: {fov, range_min, range_max, mount}}``, every key optional (defaults of
    :class:`LaserSensor`)."""
    n = len(chk.problems)
    sensors = chk.mapping(value, where)
    chk.keys(sensors, where, (), ("laser",))
    doc = chk.mapping(sensors.get("laser", {}), f"{where}.laser")
    chk.keys(doc, f"{where}.laser", (), ("fov", "range_min", "range_max", "mount"))
    default = LaserSensor()
    fov = chk.number(doc.get("fov", default.fov), f"{where}.laser.fov", positive=True)
    if fov is not None and fov > FULL_CIRCLE + FOV_TOLERANCE:
        chk.problem(f"{where}.laser.fov", f"{_show(doc['fov'])} must be at most 2 pi (6.2832 rad: all round)")
    low = chk.number(doc.get("range_min", default.range_min), f"{where}.laser.range_min")
    high = chk.number(doc.get("range_max", default.range_max), f"{where}.laser.range_max", positive=True)
    if low is not None and high is not None and not 0 <= low < high:
        chk.problem(f"{where}.laser", f"range_min {low:g}, range_max {high:g}: must satisfy 0 <= range_min < "
                                      "range_max (m)")
    mount = chk.pose(doc.get("mount", [0.0, 0.0, 0.0]), f"{where}.laser.mount")
    if len(chk.problems) > n or fov is None or low is None or high is None or mount is None:
        return None
    return LaserSensor(min(fov, FULL_CIRCLE), low, high, mount)


def _shared_addresses(chk: _Checker, robots: list[Robot]) -> None:
    """Robots on one address (one computer): their relay ports and master ports must not collide (a robot's
    relay ports must not include its own master's port either)."""
    taken: dict[tuple[str, int], str] = {(r.ip, r.port): f"the master of {r.name}" for r in robots}
    for k, r in enumerate(robots):
        for port in range(r.relay_port, r.relay_port + k):
            other = taken.get((r.ip, port))
            if other is not None:
                chk.problem(f"robots[{k}].relay_port", f"relay port {port} of {r.name} on {r.ip} is also used by "
                                                       f"{other}")
            taken[(r.ip, port)] = f"a relay end of {r.name}"


def _relay_port(chk: _Checker, value: object, where: str, index: int) -> int | None:
    """Robot ``index`` listens on ``value`` .. ``value + index - 1``: whole TCP ports."""
    if isinstance(value, bool) or not isinstance(value, int) or not 1024 <= value <= 65535 - max(index, 1):
        chk.problem(where, f"{_show(value)} must be a whole TCP port number in 1024..{65535 - max(index, 1)}")
        return None
    return value


def _master_uri(chk: _Checker, value: object, where: str) -> str | None:
    """``http://<IPv4 address>:<port>/`` in canonical form, else a problem saying what is wrong."""
    text = chk.text(value, where)
    if text is None:
        return None
    expected = "must be http://<IPv4 address>:<port>/ (IP addresses only: no host names, no multicast discovery)"
    parsed = urlparse(text)
    try:
        port = parsed.port
        host = ipaddress.ip_address(parsed.hostname or "")
    except ValueError:
        chk.problem(where, f"{text!r} {expected}")
        return None
    if isinstance(host, ipaddress.IPv6Address):
        chk.problem(where, f"{text!r}: IPv6 master URIs are not supported (the relays and the simulated "
                           "building listen on IPv4, and ROS 1 needs ROS_IPV6=on on every node); use an IPv4 "
                           "address")
        return None
    if parsed.scheme != "http" or port is None or parsed.path not in ("", "/") or parsed.query or \
            parsed.fragment or parsed.username is not None:
        chk.problem(where, f"{text!r} {expected}")
        return None
    if host.is_unspecified or host.is_multicast or host == ipaddress.IPv4Address("255.255.255.255") or port == 0:
        chk.problem(where, f"{text!r}: {host}:{port} is not an address a node can connect to (unspecified, "
                           "multicast, broadcast or port 0)")
        return None
    return f"http://{host}:{port}/"
