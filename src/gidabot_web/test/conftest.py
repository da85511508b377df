"""Shared fixtures of gidabot_web's unit tests (no ROS master)."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def faculty():
    from gidabot_navigation.building.model import load_building

    return load_building(REPO / "maps" / "faculty")
