"""The building editor end to end, in headless chromium: from the faculty's four maps and blueprints alone to a
building gidabot check accepts and the simulated building runs through the paper's Table 4 tour.

The test is the person at the editor: it aligns each blueprint with two clicked point pairs (it knows where the
faculty's blueprints put two map points: their transforms), places 12 places, the lift and the two staircases on
every floor and the four robots, saves, and checks the file: gidabot check accepts it, its blueprint transforms
are the faculty's within 1 % (scale) and 0.5 degrees, and gidabot demo completes the Table 4 tour on it with the
paper's Table 3 (3, 3, 3, 2 goals processed). Then it drags a place into a wall and sees the editor refuse it,
with the reason. A second test starts the preview and sees the robots on the editor's map.

``GIDABOT_SCREENSHOTS=<dir>``: also save the screenshots of docs/screenshots/editor-*.png there.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml
from editor_browser import GIDABOT, EditorPage, EditorProcess, wait_for

import gidabot_sim.runner.procs as procs_mod
from gidabot_navigation.building.geometry import BlueprintTransform
from gidabot_web.editor.preview import Run

pytestmark = [pytest.mark.system, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
FACULTY = REPO / "maps" / "faculty"
TRUTH = BlueprintTransform(16.0, 24.0, 408.0)          # every floor of maps/faculty
ALIGN_POINTS = ((-0.5, -0.5), (72.5, 24.5))             # the building's outer corners, as far apart as can be
FLOOR_NAMES = {0: ("Beheko solairua", "Ground floor", "Planta baja"), 1: ("Lehen solairua", "First floor", "Primera planta"),
               2: ("Bigarren solairua", "Second floor", "Segunda planta"),
               3: ("Hirugarren solairua", "Third floor", "Tercera planta")}
S, N = -math.pi / 2, math.pi / 2
# the 8 rooms of the Table 4 tour (tours/real_world.tour) and 4 more: id, floor, pose, names (eu, en, es), category,
# featured
PLACES = [
    ("014", 0, (10.0, 12.6, N), ("Teknikarien laborategia 1", "Computer Technicians 1", "Técnicos informáticos 1"), "lab", True),
    ("008", 0, (43.0, 11.4, S), ("Atezainen bulegoa", "Caretakers' Office", "Conserjería"), "service", True),
    ("000", 0, (32.0, 11.4, S), ("Sarrera nagusia", "Main Entrance", "Entrada principal"), "entrance", True),
    ("101", 1, (10.0, 11.4, S), ("Idazkaritza", "Secretary's Office", "Secretaría"), "service", True),
    ("104", 1, (28.0, 11.4, S), ("Ada Lovelace aretoa", "Ada Lovelace Auditorium", "Auditorio Ada Lovelace"), "lecture", True),
    ("117", 1, (51.0, 12.6, N), ("Nazioarteko harremanak", "International Office", "Relaciones Internacionales"), "service", False),
    ("223", 2, (37.0, 11.4, S), ("M. Larrea bulegoa", "M. Larrea's Office", "Despacho de M. Larrea"), "office", True),
    ("274", 2, (47.0, 12.6, N), ("K. Sarasola bulegoa", "K. Sarasola's Office", "Despacho de K. Sarasola"), "office", True),
    ("207", 2, (24.5, 11.4, S), ("2.3 mintegia", "Seminar Room 2.3", "Seminario 2.3"), "meeting", False),
    ("325", 3, (21.0, 12.6, N), ("I. Irigoien bulegoa", "I. Irigoien's Office", "Despacho de I. Irigoien"), "office", True),
    ("305", 3, (27.0, 11.4, S), ("RSAIT laborategia", "RSAIT Lab", "Laboratorio RSAIT"), "lab", True),
    ("301", 3, (10.0, 11.4, S), ("IXA laborategia", "IXA Lab", "Laboratorio IXA"), "lab", False),
]
CONNECTORS = [
    ("stairs", "stairs_west", ("Mendebaldeko eskailerak", "West staircase", "Escalera oeste"), (4.4, 12.0, math.pi)),
    ("lift", "lift", ("Igogailua", "Lift", "Ascensor"), (35.5, 12.6, N)),
    ("stairs", "stairs_east", ("Ekialdeko eskailerak", "East staircase", "Escalera este"), (67.6, 12.0, 0.0)),
]
ROBOTS = [   # name, floor, drive, max_linear, max_angular, lin acc, ang acc, radius (maps/faculty)
    ("Tartalo", 0, "differential", 0.6, 1.0, 0.5, 1.5, 0.33),
    ("Kbot", 1, "differential", 0.7, 1.2, 0.6, 2.0, 0.3),
    ("Galtxagorri", 2, "differential", 0.6, 1.2, 0.6, 2.0, 0.27),
    ("MariSorgin", 3, "synchro", 0.5, 0.9, 0.4, 1.2, 0.27),
]
HOME = (30.0, 12.0, 0.0)
ZONE = ((23.0, 15.0), (32.0, 15.0), (32.0, 22.0), (23.0, 22.0))
TABLE3 = {"Tartalo": (8, 3), "Kbot": (8, 3), "Galtxagorri": (8, 3), "MariSorgin": (8, 2)}


def maps_only(dest: Path) -> Path:
    dest.mkdir(parents=True)
    for f in FACULTY.iterdir():
        if f.name != "building.yaml":
            shutil.copy(f, dest / f.name)
    return dest


def screenshots() -> Path | None:
    value = os.environ.get("GIDABOT_SCREENSHOTS")
    return Path(value) if value else None


def align_blueprint(page: EditorPage, floor: int) -> None:
    page.floor(floor)
    page.mode("align")
    for x, y in ALIGN_POINTS:
        page.click_at("map", x, y)
        page.click_at("other", *TRUTH.to_pixel(x, y))
    wait_for(lambda: len(page.js("return window.gidabotEditor.state().pairs;")) == 2, 5, "two point pairs")
    if floor == 0 and screenshots():
        page.shot(screenshots() / "editor-align.png")
    page.click("Fit and apply", change=True)
    assert "fitted on 2 pairs" in page.message(), page.message()
    page.mode("select")


def align_floor_to_the_one_below(page: EditorPage, floor: int) -> None:
    """Floor ``floor``'s map on floor ``floor - 1``'s: the two staircases' meeting points on both maps."""
    page.floor(floor)
    page.mode("floors")
    wait_for(lambda: page.js("return window.gidabotEditor.state().reference;") == floor - 1, 5, "the floor below")
    for x, y, _ in (CONNECTORS[0][3], CONNECTORS[2][3]):
        page.click_at("map", x, y)
        page.click_at("other", x, y)
    page.click("Fit and apply", change=True)
    assert "floor aligned on 2 pairs" in page.message(), page.message()
    page.mode("select")


def draw_zone(page: EditorPage, floor: int, corners) -> None:
    """A keep-out zone: its corners clicked, then the first again."""
    page.floor(floor)
    page.tab("zones")
    page.mode("zone")
    for x, y in corners:
        page.click_at("map", x, y)
    page.click_at("map", *corners[0], change=True)


def name_fields(page: EditorPage, form: str, names: tuple[str, str, str], prefix: str = "name") -> None:
    for lang, text in zip(("eu", "en", "es"), names, strict=True):
        page.type(form, f"{prefix}-{lang}", text)


def add_place(page: EditorPage, place) -> None:
    pid, floor, (x, y, yaw), names, category, featured = place
    page.floor(floor)
    page.tab("locations")
    page.mode("place")
    page.click_at("map", x, y, change=True)                   # a new place where the robot stops
    page.type("item-form", "id", pid)
    name_fields(page, "item-form", names)
    page.choose("item-form", "category", category)
    page.tick("item-form", "featured", featured)
    page.pose("pose", x, y, yaw)


def add_connector(page: EditorPage, connector) -> None:
    kind, cid, names, (x, y, yaw) = connector
    page.floor(0)
    page.tab("connectors")
    page.click("Add lift" if kind == "lift" else "Add staircase", within="item-add-row", change=True)
    wait_for(lambda: page.state()["mode"] == "meeting", 5, "the meeting point mode")
    page.click_at("map", x, y, change=True)                   # its meeting point on floor 0
    page.type("item-form", "id", cid)
    name_fields(page, "item-form", names)
    for floor in range(4):
        page.floor(floor)
        if floor:
            page.click("Place meeting point (click on the map)", within="item-form")
            wait_for(lambda: page.state()["mode"] == "meeting", 5, "the meeting point mode")
            page.click_at("map", x, y, change=True)
        page.pose("meeting", x, y, yaw)


def add_robot(page: EditorPage, index: int, robot) -> None:
    name, floor, drive, vl, va, al, aa, radius = robot
    page.floor(floor)
    page.tab("robots")
    page.click("Add robot", within="item-add-row", change=True)
    wait_for(lambda: page.state()["mode"] == "home", 5, "the home mode")
    page.click_at("map", HOME[0], HOME[1], change=True)       # its home, on this floor
    page.type("item-form", "name", name)
    page.type("item-form", "master_uri", f"http://127.0.0.{11 + index}:11311/")
    page.choose("item-form", "drive", drive)
    for key, value in (("max_linear", vl), ("max_angular", va), ("max_linear_accel", al), ("max_angular_accel", aa),
                       ("radius", radius)):
        page.type("item-form", key, value)
    page.pose("home", *HOME)


def run_table4(building: Path, out: Path) -> dict:
    argv = [str(GIDABOT), "demo", "--building", str(building), "--tour", str(REPO / "tours" / "real_world.tour"),
            "--out", str(out), "--net", str(procs_mod.test_network()), "--json", "--timeout", "600", "--seed", "1"]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=720)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return json.loads(proc.stdout)


@pytest.mark.timeout(1800)
def test_from_maps_and_blueprints_to_a_building_that_runs_table_4(tmp_path: Path) -> None:
    lab = maps_only(tmp_path / "lab")
    editor = EditorProcess(lab, tmp_path / "editor.log")
    page = None
    try:
        page = EditorPage(editor.url)
        assert "problem(s): gidabot check would refuse it" in page.status()
        for floor in range(4):
            align_blueprint(page, floor)
            page.type("floor-form", "floor-name-eu", FLOOR_NAMES[floor][0])
            page.type("floor-form", "floor-name-en", FLOOR_NAMES[floor][1])
            page.type("floor-form", "floor-name-es", FLOOR_NAMES[floor][2])
        align_floor_to_the_one_below(page, 1)
        draw_zone(page, 0, ZONE)                                  # inside room 018: no way goes there
        if screenshots():
            page.shot(screenshots() / "editor-keepout.png")
        for place in PLACES:
            add_place(page, place)
        for connector in CONNECTORS:
            add_connector(page, connector)
        for index, robot in enumerate(ROBOTS):
            add_robot(page, index, robot)
        page.settle()
        assert page.status().startswith("✓ accepted"), (page.status(), page.state()["check"])
        if screenshots():
            page.floor(1)
            page.tab("locations")
            page.shot(screenshots() / "editor-building.png")
        page.press("save")
        wait_for(lambda: page.message().startswith("Saved "), 20, "the save")
        assert (lab / "building.yaml").exists()

        # the saved building: gidabot check accepts it; the transforms are the faculty's
        check = subprocess.run([str(GIDABOT), "check", str(lab)], capture_output=True, text=True, timeout=120)
        assert check.returncode == 0 and check.stdout.startswith("ok   "), check.stdout
        assert "12 locations, 3 connectors, 4 robots, 6 relays" in check.stdout
        doc = yaml.safe_load((lab / "building.yaml").read_text())
        for floor in doc["floors"]:
            t = floor["blueprint_transform"]
            assert t["scale"] == pytest.approx(16.0, rel=0.01), t
            assert abs(math.degrees(t.get("rotation", 0.0))) < 0.5, t
            fitted = BlueprintTransform(t["scale"], *t["origin_px"], t.get("rotation", 0.0))
            assert math.dist(fitted.to_pixel(36.0, 12.0), TRUTH.to_pixel(36.0, 12.0)) < 5.0, t
        assert [loc["id"] for loc in doc["locations"]] == [p[0] for p in PLACES]
        assert "draft" not in doc
        [zone] = doc["floors"][0]["keep_out"]
        assert zone["id"] == "zone1" and len(zone["polygon"]) == 4
        assert all(math.dist(p, q) < 0.3 for p, q in zip(zone["polygon"], ZONE, strict=True)), zone
        aligned = doc["floors"][1]["aligned_to"]
        assert aligned["floor"] == 0 and math.hypot(*aligned["pose"][:2]) < 0.3, aligned
        assert abs(math.degrees(aligned["pose"][2])) < 0.5, aligned

        # a place dragged into a wall: refused, with the reason
        page.floor(0)
        page.tab("locations")
        page.drag("map", (43.0, 11.4), (44.8, 10.4))             # 008, into the corridor's south wall
        problems = page.state()["check"]["problems"]
        assert page.status().startswith("✗ 1 problem(s)"), page.status()
        [problem] = problems
        assert problem["where"] == "locations[1].pose"
        assert "is inside a wall or unknown space on floor 0; location 008 must be in free space" in problem["message"]
        shown = page.driver.find_element("id", "problems").text
        assert "location 008 must be in free space" in shown
        if screenshots():
            page.shot(screenshots() / "editor-refused.png")
        saved = (lab / "building.yaml").read_bytes()
        page.press("save")
        wait_for(lambda: "not saved: the checks reject this building" in page.message(), 20, "the refusal")
        assert (lab / "building.yaml").read_bytes() == saved
        page.press("undo", change=True)
        assert page.status().startswith("✓ accepted")
    finally:
        if page is not None:
            page.close()
        assert editor.stop() == 0

    # the simulated building on the saved file: the Table 4 tour and Table 3
    report = run_table4(lab, tmp_path / "runs")
    assert report["tour"]["goals"] == 8 and report["tour"]["completed"] == 8, report["tour"]
    rows = {r["name"]: (r["received"], r["processed"]) for r in report["robots"]}
    assert rows == TABLE3, rows


@pytest.mark.timeout(900)
def test_the_preview_shows_the_robots_of_the_simulated_building(tmp_path: Path) -> None:
    lab = tmp_path / "faculty"
    shutil.copytree(FACULTY, lab)
    editor = EditorProcess(lab, tmp_path / "editor.log", "--speed", "10")
    page = None
    try:
        page = EditorPage(editor.url)
        assert page.status().startswith("✓ accepted")
        page.press("preview-start")
        wait_preview(page, lambda robots: len(robots) == 4, 240, "the four robots of the preview on the editor's map")
        robots = page.state()["preview"]["robots"]
        assert {name: p["floor"] for name, p in robots.items()} == {"Tartalo": 0, "Kbot": 1, "Galtxagorri": 2,
                                                                     "MariSorgin": 3}
        start = robots["Tartalo"]
        wait_preview(page, lambda robots: "Tartalo" in robots and math.dist(
            (start["x"], start["y"]), (robots["Tartalo"]["x"], robots["Tartalo"]["y"])) > 1.0,
            240, "Tartalo to move (the tour of the featured places)")
        if screenshots():
            page.floor(0)
            page.shot(screenshots() / "editor-preview.png")
        page.press("preview-stop")
        wait_for(lambda: page.state()["preview"]["state"] == Run.STOPPED, 90, "the preview to stop")
    finally:
        if page is not None:
            page.close()
        assert editor.stop() == 0
    leftovers = [p for p in Path("/proc").iterdir() if p.name.isdigit() and "gidabot-preview-" in
                 _cmdline(p)]
    assert leftovers == [], leftovers


def wait_preview(page: EditorPage, predicate, timeout: float, what: str) -> None:
    """Wait until ``predicate(robots)`` holds for the preview's robots on the page; fail at once when the preview
    ended, and on a timeout say where it was (its state and the demo's last line)."""
    def robots() -> dict:
        preview = page.state()["preview"] or {}
        assert preview.get("state") not in (Run.FAILED, Run.FINISHED, Run.STOPPED), f"the preview ended: {preview}"
        return predicate(preview.get("robots", {}))

    try:
        wait_for(robots, timeout, what)
    except AssertionError as err:
        raise AssertionError(f"{err}; the preview: {page.state()['preview']}") from err


def _cmdline(proc: Path) -> str:
    try:
        return (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


@pytest.mark.timeout(300)
def test_an_unreachable_place_is_shown_where_the_way_closes(tmp_path: Path) -> None:
    """The faculty with a closed door across floor 2's corridor: the places beyond it are listed as not reachable;
    a click on one shows its floor, the place in red and where the way closes."""
    from building_support import paint

    lab = tmp_path / "faculty"
    shutil.copytree(FACULTY, lab)
    paint(lab, 2, 50.0, 50.2, 10.0, 14.0)
    editor = EditorProcess(lab, tmp_path / "editor.log")
    page = None
    try:
        page = EditorPage(editor.url)
        problems = page.state()["check"]["problems"]
        assert page.status().startswith(f"✗ {len(problems)} problem(s)")
        by_place = {p["where"]: p for p in problems}
        assert [m[2] for m in by_place["location 231"]["marks"]] == ["place", "closed", "reached"]
        item = next(li for li in page.driver.find_elements("css selector", "#problems li")
                    if li.text.startswith("location 231:"))
        assert "walled off (no free way at all): the way closes at (50." in item.text
        item.click()
        state = page.state()
        assert state["floor"] == 2 and state["selected"]["list"] == "locations"
        assert state["doc"]["locations"][state["selected"]["index"]]["id"] == "231"
        if screenshots():
            page.shot(screenshots() / "editor-unreachable.png")
    finally:
        if page is not None:
            page.close()
        assert editor.stop() == 0


@pytest.mark.timeout(300)
def test_floors_renumbered_added_reordered_and_removed_in_the_page(tmp_path: Path) -> None:
    """A basement (-1) and a mezzanine (0.5): the floor's id changed in its form moves its places, robots and
    meeting points along and the building is still accepted; the floor below is the ghost; a floor added, moved
    up and removed (after the confirmation)."""
    lab = tmp_path / "faculty"
    shutil.copytree(FACULTY, lab)
    editor = EditorProcess(lab, tmp_path / "editor.log")
    page = None
    ids = lambda: [f["id"] for f in page.state()["doc"]["floors"]]          # noqa: E731
    try:
        page = EditorPage(editor.url)
        page.floor(0)
        page.type("floor-form", "floor-id", -1)
        page.floor(1)
        page.type("floor-form", "floor-id", 0.5)
        page.settle()
        assert ids() == [-1, 0.5, 2, 3] and page.status().startswith("✓ accepted"), page.status()
        robots = {r["name"]: r["floor"] for r in page.state()["doc"]["robots"]}
        assert robots == {"Tartalo": -1, "Kbot": 0.5, "Galtxagorri": 2, "MariSorgin": 3}
        assert page.js("return window.gidabotEditor.ghost();") == 0               # floor -1 under floor 0.5
        if screenshots():
            page.mode("floors")
            page.shot(screenshots() / "editor-floors.png")
            page.mode("select")
        page.press("floor-add", change=True)
        assert ids() == [-1, 0.5, 2, 3, 0] and page.js("return window.gidabotEditor.floorIndex();") == 4
        assert page.status().startswith("✗"), page.status()                      # no connector serves it
        page.press("floor-up", change=True)
        assert ids() == [-1, 0.5, 2, 0, 3]
        before = page.revision()
        page.driver.find_element("id", "floor-remove").click()
        page.driver.switch_to.alert.accept()
        page.changed(before)
        assert ids() == [-1, 0.5, 2, 3] and page.status().startswith("✓ accepted"), page.status()
        page.press("save")
        wait_for(lambda: page.message().startswith("Saved "), 20, "the save")
    finally:
        if page is not None:
            page.close()
        assert editor.stop() == 0
    check = subprocess.run([str(GIDABOT), "check", str(lab)], capture_output=True, text=True, timeout=120)
    assert check.returncode == 0 and check.stdout.startswith("ok   "), check.stdout
