"""The editor's live checks are gidabot check's: the same verdict, every problem placed on its floor and item."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from building_support import paint

from gidabot_navigation import cli
from gidabot_web.editor.checks import LiveChecker, item_of
from gidabot_web.editor.document import BuildingDocument

REPO = Path(__file__).resolve().parents[4]


@pytest.fixture
def faculty_dir(tmp_path: Path) -> Path:
    dest = tmp_path / "faculty"
    shutil.copytree(REPO / "maps" / "faculty", dest)
    return dest


def test_the_faculty_is_accepted_and_a_second_check_reads_nothing_again(faculty_dir: Path) -> None:
    doc, checker = BuildingDocument.open(faculty_dir), LiveChecker()
    first = checker.check(doc.plain(), doc.path, doc.revision)
    assert first.accepted and first.problems == [] and first.warnings == []
    assert first.summary == "4 floors, 56 locations, 3 connectors, 4 robots, 6 relays"
    again = checker.check(doc.plain(), doc.path, doc.revision)
    assert again.accepted and again.seconds < max(0.2, first.seconds)


def test_a_place_moved_into_a_wall_is_a_problem_on_its_floor(faculty_dir: Path) -> None:
    doc, checker = BuildingDocument.open(faculty_dir), LiveChecker()
    doc.apply([{"op": "set", "path": ["locations", 2, "pose"], "value": [19.0, 10.4, 0.0]}], "into the wall")
    result = checker.check(doc.plain(), doc.path, doc.revision)
    assert not result.accepted
    [problem] = result.problems
    assert problem["where"] == "locations[2].pose" and problem["item"] == {"list": "locations", "index": 2}
    assert "(19, 10.4) is inside a wall or unknown space on floor 0" in problem["message"]
    assert problem["floor"] == 0 and problem["marks"] == [[19.0, 10.4, "place"]]
    doc.undo()
    assert checker.check(doc.plain(), doc.path, doc.revision).accepted


def test_an_unreachable_place_names_where_the_way_closes_as_gidabot_check_does(faculty_dir: Path, capsys) -> None:
    paint(faculty_dir, 2, 50.0, 50.2, 10.0, 14.0)                 # a closed door across floor 2's corridor
    doc, checker = BuildingDocument.open(faculty_dir), LiveChecker()
    result = checker.check(doc.plain(), doc.path, doc.revision)
    assert not result.accepted
    found = {p["where"]: p for p in result.problems}
    assert "location 231" in found and found["location 231"]["item"] == {"list": "locations", "id": "231"}
    assert [m[2] for m in found["location 231"]["marks"]] == ["place", "closed", "reached"]
    assert cli.main([str(faculty_dir)]) == 1
    out = capsys.readouterr().out
    for p in result.problems:
        assert f"{p['where']}: {p['message']}" in out


def test_where_a_problem_is() -> None:
    assert item_of("floors[1].keep_out[2].polygon") == {"list": "floors", "index": 1, "zone": 2}
    assert item_of("robots[0].home") == {"list": "robots", "index": 0}
    assert item_of("connector lift (meeting point on floor 2)") == {"list": "connectors", "id": "lift"}
    assert item_of("robot Kbot") == {"list": "robots", "id": "Kbot"}
    assert item_of("id") is None and item_of("line 3") is None


def test_a_way_too_narrow_marks_its_narrowest_point(faculty_dir: Path) -> None:
    """A gap of 0.4 m across floor 2's corridor: free, but too narrow for Galtxagorri (radius 0.27 m); the places
    beyond are problems whose marks are the place (drawn red) and the narrowest point of the way."""
    paint(faculty_dir, 2, 50.0, 50.2, 10.0, 11.8)
    paint(faculty_dir, 2, 50.0, 50.2, 12.2, 14.0)
    doc, checker = BuildingDocument.open(faculty_dir), LiveChecker()
    result = checker.check(doc.plain(), doc.path, doc.revision)
    assert not result.accepted
    found = {p["where"]: p for p in result.problems}
    problem = found["location 229"]
    assert problem["floor"] == 2 and "the way is too narrow" in problem["message"]
    kinds = {m[2]: m[:2] for m in problem["marks"]}
    assert set(kinds) == {"place", "narrow"}
    x, y = kinds["narrow"]
    assert 49.9 <= x <= 50.3 and 11.8 <= y <= 12.2
