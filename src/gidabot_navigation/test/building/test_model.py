"""Building loader: the faculty loads; every kind of mistake is reported with file, key and value."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import yaml
from building_support import paint

from gidabot_navigation import cli
from gidabot_navigation.building.geometry import BlueprintTransform
from gidabot_navigation.building.model import format_floor, load_building
from gidabot_navigation.errors import BuildingError


def test_faculty_loads(faculty) -> None:
    assert [f.id for f in faculty.floors] == [0, 1, 2, 3]
    assert [(r.name, r.floor, r.drive) for r in faculty.robots] == [
        ("Tartalo", 0, "differential"), ("Kbot", 1, "differential"),
        ("Galtxagorri", 2, "differential"), ("MariSorgin", 3, "synchro")]
    assert sorted(c.kind for c in faculty.connectors) == ["lift", "stairs", "stairs"]
    for connector in faculty.connectors:
        assert sorted(connector.meeting) == [0, 1, 2, 3]
    for room in ("014", "008", "101", "104", "223", "274", "325", "305"):
        assert faculty.find_location(room) is not None
    assert len(faculty.relay_pairs()) == 6
    assert [r.name for r in faculty.robots_on(2)] == ["Galtxagorri"]
    assert faculty.robots_on(7) == [] and not faculty.has_robot(7) and faculty.has_robot(3)
    assert faculty.find_floor(float("nan")) is None
    assert len({r.master_uri for r in faculty.robots}) == 4


def test_faculty_variants_share_its_maps(faculty, faculty6, faculty3) -> None:
    assert [(r.name, r.floor) for r in faculty6.robots] == [
        ("Tartalo", 0), ("Kbot", 1), ("Basajaun", 1), ("Galtxagorri", 2), ("Lamia", 2), ("MariSorgin", 3)]
    assert len(faculty6.relay_pairs()) == 15 and len({r.master_uri for r in faculty6.robots}) == 6
    assert [r.name for r in faculty3.robots] == ["Tartalo", "Kbot", "MariSorgin"] and not faculty3.has_robot(2)
    for variant in (faculty6, faculty3):
        assert [f.map_file.resolve() for f in variant.floors] == [f.map_file.resolve() for f in faculty.floors]
        assert variant.locations == faculty.locations and variant.connectors == faculty.connectors


def test_every_location_has_three_languages(faculty) -> None:
    for loc in faculty.locations:
        assert set(loc.names) == {"eu", "en", "es"}
        assert loc.name("es") and loc.name("xx") == loc.names["en"]


def test_lookups_and_copies(faculty) -> None:
    assert faculty.floor(1.0000001).id == 1
    with pytest.raises(KeyError, match="unknown floor 9"):
        faculty.floor(9)
    assert [c.id for c in faculty.connectors_between(0, 3, "stairs")] == ["stairs_west", "stairs_east"]
    moved = faculty.with_master_uris({"Kbot": "http://127.0.0.12:40000/"})
    assert moved.robot("Kbot").port == 40000 and faculty.robot("Kbot").port == 11311
    assert moved.robot("Kbot").ip == "127.0.0.12"


def test_relay_links_listen_on_the_later_robot_one_port_per_earlier_robot(faculty) -> None:
    assert [faculty.relay_ports(r.name) for r in faculty.robots] == [[], [11411], [11411, 11412],
                                                                      [11411, 11412, 11413]]
    assert faculty.relay_link_port("Kbot", "MariSorgin") == 11412
    with pytest.raises(KeyError, match="must be listed before"):
        faculty.relay_link_port("MariSorgin", "Kbot")


def test_relocate_building(tmp_path: Path, faculty) -> None:
    from gidabot_navigation.building.model import relocate_building

    out = relocate_building(Path(__file__).resolve().parents[4] / "maps" / "faculty", tmp_path / "copy",
                            {"Tartalo": "http://127.0.0.11:45678/"}, {"Kbot": 30000})
    moved = load_building(out)
    assert moved.robot("Tartalo").port == 45678 and moved.robot("Kbot").port == 11311
    assert moved.robot("Kbot").relay_port == 30000 and moved.robot("Tartalo").relay_port == 11411
    assert [loc.id for loc in moved.locations] == [loc.id for loc in faculty.locations]


def test_format_floor() -> None:
    assert format_floor(0.0) == "0" and format_floor(0.5) == "0.5" and format_floor(-1) == "-1"


def test_blueprint_transform_round_trip() -> None:
    t = BlueprintTransform(scale=16.0, origin_u=24, origin_v=408, rotation=0.3)
    u, v = t.to_pixel(12.5, -3.0)
    assert t.to_map(u, v) == pytest.approx((12.5, -3.0))
    assert BlueprintTransform(16.0, 24, 408).to_pixel(1.0, 1.0) == (40.0, 392.0)


def _edit(path: Path, change: Callable[[dict], None]) -> Path:
    file = path / "building.yaml"
    doc = yaml.safe_load(file.read_text())
    change(doc)
    file.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    return file


def _loc(doc: dict, room: str) -> dict:
    return next(loc for loc in doc["locations"] if loc["id"] == room)


BROKEN: list[tuple[str, Callable[[dict], None], str]] = [
    ("unknown floor", lambda d: _loc(d, "223").update(floor=7),
     "locations[*].floor: unknown floor 7 (floors: 0, 1, 2, 3)"),
    ("outside the map", lambda d: _loc(d, "014").update(pose=[500.0, 12.0, 0.0]),
     "locations[*].pose: (500, 12) is outside the map of floor 0"),
    ("inside a wall", lambda d: _loc(d, "014").update(pose=[10.0, 10.4, 0.0]),
     "locations[*].pose: (10, 10.4) is inside a wall"),
    ("duplicate location id", lambda d: _loc(d, "101").update(id="223"),
     "duplicate location id '223'"),
    ("unquoted room number", lambda d: _loc(d, "101").update(id=101),
     "locations[*].id: 101 must be a string"),
    ("connector missing on a floor", lambda d: d["connectors"][1]["meeting"].pop(2),
     "connectors[1].meeting: connector lift serves floor 2 but has no meeting pose there"),
    ("two robots one master", lambda d: d["robots"][1].update(master_uri=d["robots"][0]["master_uri"]),
     "robots[1].master_uri: 'http://127.0.0.11:11311/' is also the master of robot Tartalo"),
    ("host name instead of IP", lambda d: d["robots"][2].update(master_uri="http://galtxagorri.local:11311"),
     "robots[2].master_uri: 'http://galtxagorri.local:11311' must be http://<IPv4 address>:<port>/"),
    ("unknown drive", lambda d: d["robots"][3].update(drive="legged"),
     "robots[3].drive: 'legged' is not one of differential, synchro"),
    ("negative speed", lambda d: d["robots"][0].update(max_linear=-0.5),
     "robots[0].max_linear: -0.5 must be > 0"),
    ("NaN in a pose", lambda d: d["robots"][0].update(home=[float("nan"), 1.0, 0.0]),
     "robots[0].home[0]: nan is not a finite number"),
    ("missing language", lambda d: _loc(d, "305")["names"].pop("eu"),
     "locations[*].names.eu: is missing (names are needed in eu, en and es)"),
    ("unknown key (typo)", lambda d: d["floors"][0].update(blueprnt="x.png"),
     "floors[0].blueprnt: unknown key"),
    ("map file missing", lambda d: d["floors"][2].update(map="nowhere.yaml"),
     "floors[2].map: 'nowhere.yaml': file not found"),
    ("duplicate floor", lambda d: d["floors"][3].update(id=2),
     "floors[3].id: duplicate floor id 2"),
    ("two robots parked on one spot", lambda d: d["robots"][1].update(floor=0),
     "robots[1].home: the home of Kbot overlaps the home of Tartalo on floor 0 (0.63 m)"),
    ("bad category", lambda d: _loc(d, "001").update(category="shop"),
     "locations[*].category: 'shop' is not one of"),
    ("bad blueprint scale", lambda d: d["floors"][1]["blueprint_transform"].update(scale=0),
     "floors[1].blueprint_transform.scale: 0 must be > 0"),
    ("duplicate robot", lambda d: d["robots"][2].update(name="Kbot"),
     "robots[2].name: duplicate robot name 'Kbot'"),
    ("unknown connector kind", lambda d: d["connectors"][0].update(kind="escalator"),
     "connectors[0].kind: 'escalator' is not one of lift, stairs"),
    ("relay port out of range", lambda d: d["robots"][1].update(relay_port=70000),
     "robots[1].relay_port: 70000 must be a whole TCP port number in 1024..65534"),
    ("relay ports of two robots on one computer", lambda d: d["robots"][1].update(master_uri="http://127.0.0.13:11412/"),
     "robots[2].relay_port: relay port 11411 of Galtxagorri on 127.0.0.13 is also used by a relay end of Kbot"),
    ("meeting pose on a floor the connector does not serve", lambda d: d["connectors"][0].update(serves=[1, 2, 3]),
     "connectors[0].meeting: connector stairs_west has a meeting pose on floor 0, which it does not serve "
     "(serves: 1, 2, 3)"),
    ("connector serving no floor", lambda d: d["connectors"][2].update(serves=[]),
     "connectors[2].serves: []: a lift or staircase serves at least two floors"),
    ("connector serving one floor", lambda d: (d["connectors"][2].update(serves=[3]),
                                               d["connectors"][2].update(meeting=d["connectors"][2]["meeting"][3:])),
     "connectors[2].serves: [3]: a lift or staircase serves at least two floors"),
    ("floor listed twice in serves", lambda d: d["connectors"][1].update(serves=[0, 1, 1, 2, 3]),
     "connectors[1].serves[2]: floor 1 is listed twice"),
    ("IPv6 master URI", lambda d: d["robots"][1].update(master_uri="http://[::1]:11311/"),
     "robots[1].master_uri: 'http://[::1]:11311/': IPv6 master URIs are not supported"),
    ("master URI 0.0.0.0 (listen address)", lambda d: d["robots"][1].update(master_uri="http://0.0.0.0:11311/"),
     "robots[1].master_uri: 'http://0.0.0.0:11311/': 0.0.0.0:11311 is not an address a node can connect to"),
    ("master URI on port 0", lambda d: d["robots"][1].update(master_uri="http://127.0.0.12:0/"),
     "robots[1].master_uri: 'http://127.0.0.12:0/': 127.0.0.12:0 is not an address a node can connect to"),
    ("master URI without port", lambda d: d["robots"][1].update(master_uri="http://127.0.0.12/"),
     "robots[1].master_uri: 'http://127.0.0.12/' must be http://<IPv4 address>:<port>/"),
    ("master URI with https", lambda d: d["robots"][1].update(master_uri="https://127.0.0.12:11311/"),
     "robots[1].master_uri: 'https://127.0.0.12:11311/' must be http://<IPv4 address>:<port>/"),
    ("robot name too long (it names ROS nodes)", lambda d: d["robots"][1].update(name="K" * 33),
     "robots[1].name: 'KKKKKKKKKKKKKKKKKKKKKKKKKKKKKKKKK' must start with a letter"),
    ("robot name with a dash", lambda d: d["robots"][1].update(name="K-bot"),
     "robots[1].name: 'K-bot' must start with a letter"),
    ("location id with a space", lambda d: _loc(d, "101").update(id="10 1"),
     "locations[*].id: '10 1' must be a string of letters, digits"),
    ("connector id equal to a location id", lambda d: d["connectors"][1].update(id="101"),
     "connectors[1].id: duplicate id '101' (connector ids must differ from every other id)"),
    ("blueprint_transform puts places off the image", lambda d: d["floors"][2]["blueprint_transform"].update(
        origin_px=[400, 408.0]),
     "locations[*].pose: (63, 11.4) is at pixel (1408, 226) of the blueprint floor2.png, outside its "
     "1200x432 pixels: check blueprint_transform of floor 2"),
    ("blueprint_transform upside down (v up)", lambda d: d["floors"][0]["blueprint_transform"].update(
        origin_px=[24, 24]),
     "robots[0].home: (30, 12) is at pixel (504, -168) of the blueprint floor0.png, outside its 1200x432 pixels"),
    ("no robot at all", lambda d: d.update(robots=[]),
     "robots: []: a building needs at least one robot"),
    ("no location at all", lambda d: d.update(locations=[]),
     "locations: []: a building needs at least one location"),
    ("building id with a '/'", lambda d: d.update(id="faculty/old"),
     "id: 'faculty/old' must be 1-32 letters, digits, '_', '.', '-' starting with a letter or digit"),
    ("location id with a trailing newline", lambda d: _loc(d, "101").update(id="101\n"),
     "locations[*].id: '101\\n' must be a string of letters, digits"),
    ("robot name with a trailing newline", lambda d: d["robots"][1].update(name="Kbot\n"),
     "robots[1].name: 'Kbot\\n' must start with a letter"),
    ("keep-out zone with two points", lambda d: d["floors"][0].update(
        keep_out=[{"id": "glass", "polygon": [[40.0, 13.0], [44.0, 13.0]]}]),
     "floors[0].keep_out[0].polygon: [[40.0, 13.0], [44.0, 13.0]]: must be a list of 3 to 500 points"),
    ("keep-out zone whose outline crosses itself", lambda d: d["floors"][0].update(
        keep_out=[{"id": "bowtie", "polygon": [[40.0, 11.0], [44.0, 13.0], [44.0, 11.0], [40.0, 13.0]]}]),
     "floors[0].keep_out[0].polygon: [[40.0, 11.0], [44.0, 13.0], [44.0, 11.0], [40.0, 13.0]]: edges 0-1 and 2-3 "
     "cross"),
    ("keep-out zone off the map", lambda d: d["floors"][1].update(
        keep_out=[{"id": "far", "polygon": [[400.0, 11.0], [404.0, 11.0], [404.0, 13.0]]}]),
     "floors[1].keep_out[0].polygon: keep-out zone far (400..404, 11..13 m) lies outside the map"),
    ("two keep-out zones with one id", lambda d: d["floors"][1].update(
        keep_out=[{"id": "z", "polygon": [[40.0, 13.0], [41.0, 13.0], [41.0, 13.4]]},
                  {"id": "z", "polygon": [[50.0, 13.0], [51.0, 13.0], [51.0, 13.4]]}]),
     "floors[1].keep_out[1].id: duplicate keep-out zone id 'z' on this floor"),
    ("a location inside a keep-out zone", lambda d: d["floors"][2].update(
        keep_out=[{"id": "office_223", "polygon": [[36.0, 11.0], [38.0, 11.0], [38.0, 12.0], [36.0, 12.0]]}]),
     "locations[30].pose: (37, 11.4) is inside keep-out zone office_223 of floor 2, where robots never go; "
     "location 223 must be outside it"),
    ("floor aligned to itself", lambda d: d["floors"][1].update(aligned_to={"floor": 1, "pose": [0.0, 0.0, 0.0]}),
     "floors[1].aligned_to.floor: floor 1 is aligned to itself"),
    ("floors aligned in a loop", lambda d: (d["floors"][1].update(aligned_to={"floor": 2, "pose": [0.0, 0.0, 0.0]}),
                                            d["floors"][2].update(aligned_to={"floor": 1, "pose": [0.0, 0.0, 0.0]})),
     "floors[1].aligned_to: floor 1: the floors' aligned_to come back to it in a loop"),
    ("a draft saved by the editor", lambda d: d.update(draft=True),
     "draft: true: the building editor saved this building as a draft (its checks failed); open it with "
     "`gidabot edit "),
    ("blueprint_transform with the wrong scale", lambda d: d["floors"][3]["blueprint_transform"].update(scale=32.0),
     "connectors[2].meeting[3].pose: (67.6, 12) is at pixel (2187, 24) of the blueprint floor3.png, outside its "
     "1200x432 pixels"),
]


def _replace_file(name: str, data: bytes) -> Callable[[Path], None]:
    return lambda d: (d / name).write_bytes(data)


def _text_edit(name: str, old: str, new: str) -> Callable[[Path], None]:
    def edit(d: Path) -> None:
        text = (d / name).read_text()
        assert old in text, (name, old)
        (d / name).write_text(text.replace(old, new, 1))
    return edit


def _truncate(name: str) -> Callable[[Path], None]:
    return lambda d: (d / name).write_bytes((d / name).read_bytes()[:2000])


# mistakes in other files than building.yaml: the blueprints, the maps (gidabot check's reachability)
FILE_BROKEN: list[tuple[str, Callable[[Path], None], str]] = [
    ("blueprint is not an image", _replace_file("floor1.png", b"<html>not found</html>"),
     "floors[1].blueprint: 'floor1.png' is not a readable image"),
    ("blueprint cut short (truncated PNG)", _truncate("floor2.png"),
     "floors[2].blueprint: 'floor2.png' is not a readable image"),
    ("a key given twice (YAML keeps the last)", _text_edit("building.yaml", "  pose: [9.0, 11.4, -1.5708]\n",
                                                          "  pose: [9.0, 11.4, -1.5708]\n  pose: [9.0, 1.4, 0.0]\n"),
     "line 50: key 'pose' is given twice in one mapping: [9.0, 11.4, -1.5708] on line 49, [9.0, 1.4, 0.0] on "
     "line 50 (YAML would silently keep the last)"),
    ("a key given twice in a floor's map file", _text_edit("floor1.yaml", "resolution: 0.05\n",
                                                           "resolution: 0.05\nresolution: 0.5\n"),
     "floors[1].map: [*]floor1.yaml: line 3: key 'resolution' is given twice in one mapping: 0.05 on line 2, "
     "0.5 on line 3"),
    ("a closed door across a corridor", lambda d: paint(d, 2, 50.0, 50.2, 10.0, 14.0),
     "location 229: (56.5, 11.4) on floor 2 is not reachable by Galtxagorri (radius 0.27 m) from its home "
     "(30, 12): walled off (no free way at all): the way closes at (50.03, 12.03)"),
    ("a corridor too narrow for the robot", lambda d: (paint(d, 3, 50.0, 50.2, 10.0, 11.8),
                                                        paint(d, 3, 50.0, 50.2, 12.2, 14.0)),
     "location 311: (59, 11.4) on floor 3 is not reachable by MariSorgin (radius 0.27 m) from its home "
     "(30, 12): the way is too narrow: at ("),
]


@pytest.fixture(scope="module")
def mistakes_table() -> Iterator[dict[str, str]]:
    """Collects mistake -> message; printed at the end (pytest -s): the table of docs/building-format.md."""
    rows: dict[str, str] = {}
    yield rows
    if rows:
        print("\n\n| mistake | what `gidabot check` says |\n|---|---|")
        for label, message in rows.items():
            print(f"| {label} | {message.replace('|', '/')} |")


def _check(building_dir: Path, capsys) -> str:
    assert cli.main([str(building_dir)]) == 1
    out = capsys.readouterr().out
    assert out.startswith(f"FAIL {building_dir}"), out
    return out


@pytest.mark.parametrize("label, change, expected", BROKEN + FILE_BROKEN,
                         ids=[b[0] for b in BROKEN + FILE_BROKEN])
def test_broken_building_names_file_key_value(faculty_copy: Path, capsys, mistakes_table, label: str, change,
                                              expected: str) -> None:
    """Each mistake fails `gidabot check` with a line naming the file, the key (or place) and the value."""
    if (label, change, expected) in BROKEN:
        _edit(faculty_copy, change)
    else:
        change(faculty_copy)
    text = _check(faculty_copy, capsys)
    head, _, rest = expected.partition("[*]")
    line = next((ln for ln in text.splitlines() if head in ln and rest in ln), None)
    assert line is not None, text
    assert f"{faculty_copy / 'building.yaml'}: " in line
    mistakes_table[label] = line.split(f"{faculty_copy / 'building.yaml'}: ", 1)[1]


@pytest.mark.parametrize("change", [_replace_file("floor1.png", b"<html>not found</html>"), _truncate("floor1.png"),
                                    lambda d: (d / "floor1.png").unlink(), lambda d: (d / "floor1.pgm").unlink()],
                         ids=["not an image", "truncated", "blueprint missing", "map image missing"])
def test_a_floor_that_does_not_load_is_one_problem(faculty_copy: Path, change) -> None:
    """A floor whose blueprint or map is broken is reported once, not again at every place, connector and robot
    on it as 'unknown floor 1' (it is declared: only its files are wrong)."""
    change(faculty_copy)
    with pytest.raises(BuildingError) as info:
        load_building(faculty_copy)
    [problem] = info.value.problems
    assert problem.where in ("floors[1].blueprint", "floors[1].map"), problem
    _edit(faculty_copy, lambda d: _loc(d, "101").update(floor=7))
    with pytest.raises(BuildingError) as info:
        load_building(faculty_copy)
    assert [p.message for p in info.value.problems[1:]] == ["unknown floor 7 (floors: 0, 1, 2, 3)"]


@pytest.mark.parametrize("bad_id", ["faculty/old", "../faculty", "..", ".", "", " ", "fac ulty", " faculty",
                                    "faculty\n", "faculty\t", "-faculty", "F" * 33, 42, None, ["faculty"]],
                         ids=lambda v: repr(v) if len(repr(v)) < 20 else f"{len(v)} characters")
def test_building_id_must_be_a_short_identifier(faculty_copy: Path, bad_id: object) -> None:
    """The building id has the rule of location and connector ids: no '/', no whitespace, not '.' or '..', not
    empty; one problem naming the file, the key and the value."""
    _edit(faculty_copy, lambda d: d.update(id=bad_id))
    with pytest.raises(BuildingError) as info:
        load_building(faculty_copy)
    [problem] = info.value.problems
    assert (problem.file, problem.where) == (str(faculty_copy / "building.yaml"), "id")
    assert problem.message == (f"{bad_id!r} must be 1-32 letters, digits, '_', '.', '-' starting with a letter or "
                               "digit (a short identifier: no '/', no spaces)")


@pytest.mark.parametrize("good_id", ["faculty", "faculty6", "0", "eu.ehu_informatika-2", "F" * 32])
def test_building_ids_that_are_short_identifiers_load(faculty_copy: Path, good_id: str) -> None:
    _edit(faculty_copy, lambda d: d.update(id=good_id))
    assert load_building(faculty_copy).id == good_id


@pytest.mark.parametrize("key, message", [
    ("locations", "[]: a building needs at least one location (no visitor or tour has anywhere to go without one)"),
    ("robots", "[]: a building needs at least one robot (every node runs as one of them)"),
], ids=["locations", "robots"])
def test_a_building_without_locations_or_robots(faculty_copy: Path, key: str, message: str) -> None:
    """An empty list of locations or robots is one problem naming the file and the key (nothing else breaks)."""
    _edit(faculty_copy, lambda d: d.update({key: []}))
    with pytest.raises(BuildingError) as info:
        load_building(faculty_copy)
    assert [str(p) for p in info.value.problems] == [f"{faculty_copy / 'building.yaml'}: {key}: {message}"]


def test_yaml_keys_given_twice() -> None:
    from gidabot_navigation.building.yaml_text import DuplicateKeyError, load_yaml

    assert load_yaml("base: &b {x: 1, y: 2}\nd:\n  <<: *b\n  x: 3\n")["d"] == {"x": 3, "y": 2}   # merge, override
    with pytest.raises(DuplicateKeyError) as info:
        load_yaml("l:\n- {id: a, floor: 0, floor: 1}\n")
    assert (info.value.key, info.value.line, info.value.first_line) == ("floor", 2, 2)


def test_several_robots_on_a_floor_and_floors_without_robot(faculty_copy: Path) -> None:
    def change(d: dict) -> None:
        d["robots"][1].update(floor=0, home=[20.0, 12.0, 0.0])       # Kbot joins Tartalo on floor 0
        d["robots"][2].update(floor=0, home=[40.0, 12.0, 0.0])       # and Galtxagorri: floors 1 and 2 have none

    _edit(faculty_copy, change)
    b = load_building(faculty_copy)
    assert [r.name for r in b.robots_on(0)] == ["Tartalo", "Kbot", "Galtxagorri"]
    assert b.robots_on(1) == [] and b.robots_on(2) == [] and [r.name for r in b.robots_on(3)] == ["MariSorgin"]
    assert len(b.relay_pairs()) == 6


def test_all_problems_reported_at_once(faculty_copy: Path) -> None:
    def change(d: dict) -> None:
        d["robots"][0]["drive"] = "legged"
        _loc(d, "223")["floor"] = 7
        d["connectors"][0]["meeting"].pop(0)

    _edit(faculty_copy, change)
    with pytest.raises(BuildingError) as info:
        load_building(faculty_copy)
    assert len(info.value.problems) == 3


@pytest.mark.parametrize("text, expected", [
    ("", "expected a mapping"),
    ("floors: [", "not valid YAML"),
    ("- 1\n- 2\n", "expected a mapping, got [1, 2]"),
])
def test_not_a_building(tmp_path: Path, text: str, expected: str) -> None:
    (tmp_path / "building.yaml").write_text(text)
    with pytest.raises(BuildingError, match=expected.replace("[", r"\[").replace("]", r"\]")):
        load_building(tmp_path)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(BuildingError, match="cannot read"):
        load_building(tmp_path / "nope")


def test_meeting_points_and_homes_are_reachable_free_space(faculty) -> None:
    for connector in faculty.connectors:
        for fid, pose in connector.meeting.items():
            assert faculty.floor(fid).map.is_free(pose.x, pose.y)
            assert math.isfinite(pose.yaw)
