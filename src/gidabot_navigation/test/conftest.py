"""Shared fixtures for gidabot_navigation unit tests (no ROS master)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
FACULTY = REPO / "maps" / "faculty"
TOURS = REPO / "tours"


@pytest.fixture(scope="session")
def faculty():
    from gidabot_navigation.building.model import load_building

    return load_building(FACULTY)


@pytest.fixture
def faculty_copy(tmp_path: Path) -> Path:
    """A writable copy of maps/faculty to break on purpose."""
    dest = tmp_path / "faculty"
    shutil.copytree(FACULTY, dest)
    return dest
