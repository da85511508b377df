"""The preview's ROS-free parts: the building copy it runs, its tour, the poses it reads (the process handling
itself runs in the editor's system test)."""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import pytest
import yaml

from gidabot_navigation.building.model import load_building
from gidabot_web.editor.document import BuildingDocument
from gidabot_web.editor.preview import FEATURED, PoseBook, Preview, Run, fitting_tours, preview_copy, tour_text
from gidabot_web.errors import PreviewError

REPO = Path(__file__).resolve().parents[4]
FACULTY = REPO / "maps" / "faculty"


def test_the_copy_names_files_by_absolute_path_and_is_no_draft(tmp_path: Path) -> None:
    data = BuildingDocument.open(FACULTY).plain()
    data["draft"] = True
    out = preview_copy(data, FACULTY, tmp_path / "copy")
    doc = yaml.safe_load(out.read_text())
    assert "draft" not in doc and doc["floors"][2]["map"] == str((FACULTY / "floor2.yaml").resolve())
    assert load_building(out).locations == load_building(FACULTY).locations


def test_tours_fit_the_building(faculty) -> None:
    name, text = tour_text(FEATURED, faculty, REPO / "tours")
    assert name == "preview.tour" and text.startswith("Tour: Preview\n0, 001, Copy Shop\n")
    assert len(text.splitlines()) == 1 + 8
    assert tour_text("real_world.tour", faculty, REPO / "tours")[1] == (REPO / "tours" / "real_world.tour").read_text()
    assert set(fitting_tours(faculty, REPO / "tours")) == {"long_tour.tour", "paper_example.tour", "real_world.tour"}
    for bad, reason in (("../etc/passwd", "tour '../etc/passwd'"), ("nothing.tour", "no such file")):
        with pytest.raises(PreviewError, match=reason):
            tour_text(bad, faculty, REPO / "tours")


def test_a_tour_of_rooms_the_building_does_not_have_is_refused(tmp_path: Path, faculty) -> None:
    (tmp_path / "other.tour").write_text("Tour\n0, 999, Nowhere\n")
    with pytest.raises(PreviewError, match="does not fit this building"):
        tour_text("other.tour", faculty, tmp_path)
    assert fitting_tours(faculty, tmp_path) == []


def test_poses_are_checked_before_they_are_kept(tmp_path: Path) -> None:
    book = PoseBook()
    assert book.heard("Kbot", 1.0, 30.0, 12.0, 0.5, 10.0)
    for bad in (("Kbot\n", 1.0, 1.0, 1.0, 0.0, 0.0), ("K" * 40, 1.0, 1.0, 1.0, 0.0, 0.0),
                ("Kbot", 1.0, float("nan"), 1.0, 0.0, 0.0), (3, 1.0, 1.0, 1.0, 0.0, 0.0),
                ("Kbot", 1.0, float("inf"), 1.0, 0.0, 0.0)):
        assert not book.heard(*bad), bad
    for i in range(PoseBook.MAX_ROBOTS + 5):
        book.heard(f"R{i}", 0.0, 1.0, 1.0, 0.0, 0.0)
    assert len(book.robots) == PoseBook.MAX_ROBOTS
    book.write(tmp_path / "poses.json")
    data = json.loads((tmp_path / "poses.json").read_text())
    assert data["robots"]["Kbot"] == {"floor": 1.0, "x": 30.0, "y": 12.0, "yaw": 0.5, "stamp": 10.0}
    assert not book.changed and [p.name for p in tmp_path.iterdir()] == ["poses.json"]


def test_a_preview_needs_a_building_without_problems(tmp_path: Path) -> None:
    data = BuildingDocument.open(FACULTY).plain()
    data["locations"][0]["pose"] = [19.0, 10.4, 0.0]
    with pytest.raises(PreviewError, match="fix them before a preview"):
        Preview(tours_dir=REPO / "tours").start(data, FACULTY)
    assert Preview().poll().state == Run.IDLE


def test_a_failed_preview_says_why_and_keeps_its_logs(tmp_path: Path) -> None:
    """A demo that exits with an error: the preview fails with its last line and the directory of its logs, which
    is kept (a finished or stopped preview removes it)."""
    fake = tmp_path / "python"
    fake.write_text("#!/bin/sh\necho 'demo: starting'\necho 'demo: the simulator of floor 0 crashed'\nexit 3\n")
    fake.chmod(0o755)
    preview = Preview(tours_dir=REPO / "tours", python=str(fake))
    preview.start(BuildingDocument.open(FACULTY).plain(), FACULTY)
    deadline = time.monotonic() + 30
    while (state := preview.poll()).state in (Run.STARTING, Run.RUNNING) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert state.state == Run.FAILED, state
    kept = Path(state.message.rsplit("its logs are kept in ", 1)[1].rstrip(")"))
    try:
        assert state.message.startswith("demo: the simulator of floor 0 crashed (gidabot demo exited with 3;")
        assert (kept / "logs" / "demo.log").read_text().endswith("crashed\n")
        assert preview.poll() == state and not preview.running
    finally:
        shutil.rmtree(kept)
