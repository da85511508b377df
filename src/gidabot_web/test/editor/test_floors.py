"""Floors added, reordered, renumbered (negative and fractional ids) and removed: every reference follows, the
building stays one gidabot check accepts, and each change is one undo."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from gidabot_navigation.building.model import building_from_doc
from gidabot_web.editor.checks import LiveChecker
from gidabot_web.editor.document import BuildingDocument
from gidabot_web.editor.floors import removal_edits, renumber_edits
from gidabot_web.errors import EditError

REPO = Path(__file__).resolve().parents[4]


@pytest.fixture
def doc(tmp_path: Path) -> BuildingDocument:
    shutil.copytree(REPO / "maps" / "faculty", tmp_path / "faculty")
    return BuildingDocument.open(tmp_path / "faculty")


def accepted(doc: BuildingDocument) -> bool:
    result = LiveChecker().check(doc.plain(), doc.path, doc.revision)
    return result.accepted


def test_a_basement_and_a_mezzanine_renumber_every_reference(doc: BuildingDocument) -> None:
    before = doc.text()
    doc.apply([{"op": "set", "path": ["floors", 1, "aligned_to"], "value": {"floor": 0, "pose": [0, 0, 0]}}],
              "align")
    doc.apply(renumber_edits(doc.plain(), 0, -1), "floor -1")
    doc.apply(renumber_edits(doc.plain(), 1, 0.5), "floor 0.5")
    data = doc.plain()
    assert [f["id"] for f in data["floors"]] == [-1, 0.5, 2, 3]
    assert data["floors"][1]["aligned_to"]["floor"] == -1
    b = building_from_doc(data, doc.path)
    assert {r.name: r.floor for r in b.robots} == {"Tartalo": -1, "Kbot": 0.5, "Galtxagorri": 2, "MariSorgin": 3}
    assert all(set(c.serves) == {-1, 0.5, 2, 3} and set(c.meeting) == {-1, 0.5, 2, 3} for c in b.connectors)
    assert b.location("014").floor == -1 and b.location("104").floor == 0.5
    assert accepted(doc)
    for _ in range(3):
        doc.undo()
    assert doc.text() == before                                        # each renumbering one undo


def test_renumbering_refuses_a_taken_or_non_numeric_id(doc: BuildingDocument) -> None:
    with pytest.raises(EditError, match=r"floor id 2: floors\[2\] has it already"):
        renumber_edits(doc.plain(), 0, 2.0)
    for bad in ("one", True, float("nan"), None):
        with pytest.raises(EditError, match="must be a number"):
            renumber_edits(doc.plain(), 0, bad)
    with pytest.raises(EditError, match="not the index of a floor"):
        renumber_edits(doc.plain(), 7, 5)


def test_reordered_floors_are_still_the_same_building(doc: BuildingDocument) -> None:
    doc.apply([{"op": "move", "path": ["floors", 3], "to": 0}], "floor 3 first")
    assert [f["id"] for f in doc.plain()["floors"]] == [3, 0, 1, 2]
    assert accepted(doc)


def test_a_floor_removed_takes_what_is_on_it(doc: BuildingDocument) -> None:
    before = doc.text()
    doc.apply([{"op": "set", "path": ["floors", 3, "aligned_to"], "value": {"floor": 2, "pose": [0, 0, 0]}},
               {"op": "set", "path": ["connectors", 0, "serves"], "value": [0, 1, 2, 3]}], "align, serves")
    doc.apply(removal_edits(doc.plain(), 2), "remove floor 2")
    data = doc.plain()
    assert [f["id"] for f in data["floors"]] == [0, 1, 3]
    assert "aligned_to" not in data["floors"][2]
    assert data["connectors"][0]["serves"] == [0, 1, 3]
    assert all(m["floor"] != 2 for c in data["connectors"] for m in c["meeting"])
    assert all(item["floor"] != 2 for key in ("locations", "robots") for item in data[key])
    assert [r["name"] for r in data["robots"]] == ["Tartalo", "Kbot", "MariSorgin"]
    assert accepted(doc)
    doc.undo()
    doc.undo()
    assert doc.text() == before
