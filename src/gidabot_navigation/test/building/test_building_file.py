"""The building file written back as people wrote it (the editor's saving): byte-identical round trips, new keys
in the documented order, comments kept, atomic saves with a backup."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml

from gidabot_navigation.building import building_file as bf
from gidabot_navigation.building.model import building_from_doc, load_building
from gidabot_navigation.errors import BuildingError

REPO = Path(__file__).resolve().parents[4]


@pytest.mark.parametrize("name", ["faculty", "faculty3", "faculty6"])
def test_loaded_and_saved_unchanged_is_byte_identical(tmp_path: Path, name: str) -> None:
    original = (REPO / "maps" / name / "building.yaml").read_bytes()
    doc = bf.read(REPO / "maps" / name / "building.yaml")
    assert bf.dump_text(doc).encode("utf-8") == original
    (tmp_path / "building.yaml").write_bytes(original)
    bf.save(tmp_path, doc)
    assert (tmp_path / "building.yaml").read_bytes() == original


def test_plain_values_are_what_the_nodes_read(faculty) -> None:
    doc = bf.read(REPO / "maps" / "faculty" / "building.yaml")
    data = bf.plain(doc)
    assert data == yaml.safe_load((REPO / "maps" / "faculty" / "building.yaml").read_text())
    assert [loc["id"] for loc in data["locations"]][4] == "008"          # YAML 1.1, as PyYAML: a string
    assert building_from_doc(data, faculty.path).locations == faculty.locations


def test_an_edit_changes_only_its_lines_and_keeps_the_comments() -> None:
    path = REPO / "maps" / "faculty" / "building.yaml"
    doc = bf.read(path)
    doc["locations"][0]["pose"][0] = 9.25
    bf.set_key(doc["floors"][2], "floor", "keep_out", [{"polygon": [[1.0, 2.0], [3.0, 2.0], [3.0, 4.0]], "id": "z"}])
    bf.set_key(doc, "building", "draft", True)
    before, after = path.read_text().splitlines(), bf.dump_text(doc).splitlines()
    assert after[:2] == before[:2] and after[0].startswith("# The Faculty")       # the comments
    assert after[4] == "draft: true"                                            # after id and name
    floor2 = after.index("- id: 2")
    assert after[floor2 + 9:floor2 + 13] == ["    origin_px: [24, 408.0]", "  keep_out:", "  - id: z",
                                              "    polygon: [[1.0, 2.0], [3.0, 2.0], [3.0, 4.0]]"]
    assert "  pose: [9.25, 11.4, -1.5708]" in after
    assert len(after) == len(before) + 4


def test_new_mappings_follow_the_documented_order() -> None:
    robot = bf.to_yaml({"home": [1.0, 2.0, 0.0], "radius": 0.3, "name": "R2", "floor": 0, "drive": "synchro"},
                       "robot")
    assert list(robot) == ["name", "floor", "drive", "radius", "home"]
    text = bf.dump_text(bf.to_yaml({"robots": [robot]}, "building"))
    assert text == "robots:\n- name: R2\n  floor: 0\n  drive: synchro\n  radius: 0.3\n  home: [1.0, 2.0, 0.0]\n"


def test_save_is_atomic_and_keeps_the_previous_file(tmp_path: Path) -> None:
    doc = bf.load_text("id: a\nname: A  # first\n")
    bf.save(tmp_path, doc)
    assert (tmp_path / "building.yaml").read_text() == "id: a\nname: A  # first\n"
    assert not (tmp_path / "building.yaml.bak").exists()
    os.chmod(tmp_path / "building.yaml", 0o640)
    doc["name"] = "B"
    bf.save(tmp_path, doc)
    assert (tmp_path / "building.yaml").read_text() == "id: a\nname: B  # first\n"
    assert (tmp_path / "building.yaml.bak").read_text() == "id: a\nname: A  # first\n"
    assert (tmp_path / "building.yaml").stat().st_mode & 0o777 == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["building.yaml", "building.yaml.bak"]   # no temporary left


def test_not_a_building_file() -> None:
    with pytest.raises(BuildingError, match="not valid YAML"):
        bf.load_text("id: [a\n")
    with pytest.raises(BuildingError, match="expected a mapping"):
        bf.load_text("- a\n")
    assert dict(bf.load_text("")) == {}


def test_the_faculty_through_the_round_trip_still_loads(tmp_path: Path) -> None:
    for f in (REPO / "maps" / "faculty").iterdir():
        (tmp_path / f.name).write_bytes(f.read_bytes())
    bf.save(tmp_path, bf.read(tmp_path / "building.yaml"))
    assert len(load_building(tmp_path).locations) == 56
