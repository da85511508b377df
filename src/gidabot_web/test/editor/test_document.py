"""The building editor's document: edits on the round-trip YAML tree, undone and redone exactly; a new building
from a folder of maps and blueprints; file names outside the folder refused."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from gidabot_navigation.building.model import building_from_doc
from gidabot_web.editor.document import BuildingDocument, folder_file, skeleton
from gidabot_web.errors import EditError

REPO = Path(__file__).resolve().parents[4]
FACULTY = REPO / "maps" / "faculty"


@pytest.fixture
def faculty_dir(tmp_path: Path) -> Path:
    dest = tmp_path / "faculty"
    shutil.copytree(FACULTY, dest)
    return dest


@pytest.fixture
def maps_only(tmp_path: Path) -> Path:
    """The faculty's four maps and blueprints, no building.yaml (what a lab starts from)."""
    dest = tmp_path / "lab"
    dest.mkdir()
    for f in FACULTY.iterdir():
        if f.name != "building.yaml":
            shutil.copy(f, dest / f.name)
    return dest


def test_opened_and_unchanged_is_the_file_itself(faculty_dir: Path) -> None:
    doc = BuildingDocument.open(faculty_dir)
    assert doc.text() == (faculty_dir / "building.yaml").read_text()
    assert not doc.dirty and doc.can_undo() is None and doc.can_redo() is None


def test_edits_undo_and_redo_give_back_the_same_text(faculty_dir: Path) -> None:
    doc = BuildingDocument.open(faculty_dir)
    texts = [doc.text()]
    doc.apply([{"op": "set", "path": ["locations", 0, "pose"], "value": [9.123456, 11.4, -1.5708]}], "move 001")
    texts.append(doc.text())
    assert "  pose: [9.1235, 11.4, -1.5708]\n" in texts[-1]                 # 4 decimals
    doc.apply([{"op": "insert", "path": ["floors", 1, "keep_out", 0],
                "value": {"polygon": [[40, 13], [44, 13], [44, 13.4]], "id": "glass"}},
               {"op": "set", "path": ["locations", 3, "names", "en"], "value": "Main door"}], "zone and a name")
    texts.append(doc.text())
    assert "  keep_out:\n  - id: glass\n    polygon: [[40, 13], [44, 13], [44, 13.4]]\n" in texts[-1]
    doc.apply([{"op": "move", "path": ["robots", 3], "to": 0}], "MariSorgin first")
    texts.append(doc.text())
    assert texts[-1].index("name: MariSorgin") < texts[-1].index("name: Tartalo")
    doc.apply([{"op": "delete", "path": ["connectors", 1]}, {"op": "delete", "path": ["floors", 0, "names", "eu"]}],
              "no lift")
    texts.append(doc.text())
    assert "kind: lift" not in texts[-1]
    assert doc.can_undo() == "no lift" and doc.dirty
    for expected in reversed(texts[:-1]):
        doc.undo()
        assert doc.text() == expected
    assert doc.undo() is None and doc.can_redo() == "move 001"
    for expected in texts[1:]:
        doc.redo()
        assert doc.text() == expected
    assert doc.redo() is None
    doc.undo()
    doc.apply([{"op": "set", "path": ["name"], "value": "X"}], "rename")       # a new change drops the redo
    assert doc.can_redo() is None


def test_a_change_is_all_or_nothing(faculty_dir: Path) -> None:
    doc = BuildingDocument.open(faculty_dir)
    before = doc.text()
    with pytest.raises(EditError, match=r"edit 2 of 2 \(set locations\[999\]\.pose\): .*not a mapping or list"):
        doc.apply([{"op": "set", "path": ["locations", 0, "pose"], "value": [1.0, 2.0, 0.0]},
                   {"op": "set", "path": ["locations", 999, "pose"], "value": [1.0, 2.0, 0.0]}], "two moves")
    assert doc.text() == before and doc.can_undo() is None and doc.revision == 0


@pytest.mark.parametrize("edit, reason", [
    ({"op": "set", "path": ["name"], "value": float("nan")}, "not a finite number"),
    ({"op": "set", "path": ["name"], "value": object()}, "not plain data"),
    ({"op": "set", "path": ["name"]}, "no value given"),
    ({"op": "set", "path": [], "value": 1}, "expected a list of 1 to 8 keys"),
    ({"op": "set", "path": ["locations", "x"], "value": 1}, "index 'x' out of range"),
    ({"op": "frobnicate", "path": ["name"]}, "unknown op"),
    ({"op": "delete", "path": ["nothing"]}, "is not in the document"),
    ({"op": "move", "path": ["robots", 0], "to": 9}, "index 9 out of range"),
    ({"op": "set", "path": ["floors", 0, "map"], "value": "../faculty/floor0.yaml"}, "not a file of the building"),
    ({"op": "set", "path": ["floors", 0, "blueprint"], "value": "/etc/passwd"}, "not a file of the building"),
    ({"op": "set", "path": ["floors", 0, "blueprint"], "value": "missing.png"}, "not a file of the building"),
    ({"op": "set", "path": ["floors", 0, "blueprint"], "value": "link.png"}, "not a file of the building"),
    ({"op": "insert", "path": ["floors", 4], "value": {"id": 4, "map": "..", "blueprint": "floor0.png"}},
     "map '..': not a file"),
    ({"op": "set", "path": ["name"], "value": "x" * 3000}, "at most 2000"),
])
def test_bad_edits_are_refused_with_the_reason(faculty_dir: Path, edit: dict, reason: str) -> None:
    (faculty_dir / "link.png").symlink_to(faculty_dir / "floor0.png")
    doc = BuildingDocument.open(faculty_dir)
    with pytest.raises(EditError, match=reason):
        doc.apply([edit], "bad")
    assert doc.text() == (faculty_dir / "building.yaml").read_text()


def test_files_of_the_folder_only(faculty_dir: Path) -> None:
    assert folder_file(faculty_dir, "floor1.png") == faculty_dir / "floor1.png"
    for name in ("../faculty/floor1.png", ".hidden", "-x", "sub/floor1.png", "", None, 3, "floor9.png"):
        assert folder_file(faculty_dir, name) is None, name


def test_a_folder_of_maps_and_blueprints_gives_a_new_building(maps_only: Path) -> None:
    data = skeleton(maps_only)
    assert [f["id"] for f in data["floors"]] == [0, 1, 2, 3]
    assert [(f["map"], f["blueprint"]) for f in data["floors"]] == [(f"floor{i}.yaml", f"floor{i}.png")
                                                                    for i in range(4)]
    assert data["floors"][2]["names"] == {"eu": "2. solairua", "en": "Floor 2", "es": "Planta 2"}
    t = data["floors"][0]["blueprint_transform"]
    assert t["scale"] == pytest.approx(16.2, abs=0.1) and t["origin_px"] == [pytest.approx(16.2, abs=0.1),
                                                                             pytest.approx(415.8, abs=0.2)]
    doc = BuildingDocument.open(maps_only)
    assert not doc.existed and doc.dirty and doc.plain() == data
    assert doc.text().startswith("id: lab\nname: lab\nfloors:\n- id: 0\n  names:\n    eu: 0. solairua\n")
    with pytest.raises(Exception, match="at least one location"):
        building_from_doc(doc.plain(), doc.path, allow_draft=True)
