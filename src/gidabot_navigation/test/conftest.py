"""Shared fixtures for gidabot_navigation unit tests (no ROS master)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
FACULTY = REPO / "maps" / "faculty"
FACULTY6 = REPO / "maps" / "faculty6"       # two robots on floors 1 and 2
FACULTY3 = REPO / "maps" / "faculty3"       # no robot on floor 2
TOURS = REPO / "tours"


@pytest.fixture(scope="session")
def faculty():
    from gidabot_navigation.building.model import load_building

    return load_building(FACULTY)


@pytest.fixture(scope="session")
def faculty6():
    from gidabot_navigation.building.model import load_building

    return load_building(FACULTY6)


@pytest.fixture(scope="session")
def faculty3():
    from gidabot_navigation.building.model import load_building

    return load_building(FACULTY3)


@pytest.fixture
def faculty_copy(tmp_path: Path) -> Path:
    """A writable copy of maps/faculty to break on purpose."""
    dest = tmp_path / "faculty"
    shutil.copytree(FACULTY, dest)
    return dest
