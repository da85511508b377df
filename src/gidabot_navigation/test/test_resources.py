"""gidabot_navigation.resources: the shipped files, found through the package (here: the devel space)."""

from __future__ import annotations

from pathlib import Path

import pytest

from gidabot_navigation.errors import ResourceError
from gidabot_navigation.resources import package_dir, resource

REPO = Path(__file__).resolve().parents[3]


def test_the_top_level_directories_through_the_package() -> None:
    assert package_dir() == REPO / "src" / "gidabot_navigation"
    assert resource("launch", "robot.launch") == REPO / "launch" / "robot.launch"     # links resolved
    assert resource("maps", "faculty") == REPO / "maps" / "faculty"
    assert resource("tours") == REPO / "tours"
    assert resource("config", "shared_topics.yaml") == package_dir() / "config" / "shared_topics.yaml"


def test_a_missing_file_is_named() -> None:
    with pytest.raises(ResourceError, match=r"launch/nowhere.launch not found in package gidabot_navigation"):
        resource("launch", "nowhere.launch")


def test_a_package_not_on_the_path(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    with pytest.raises(ResourceError, match="package gidabot_navigation not found on ROS_PACKAGE_PATH"):
        resource("tours")


def test_no_runtime_module_walks_up_from_its_file() -> None:
    """Resources come through the package (an install space has no checkout around it): no module of
    the packages' python sources reaches a file by climbing from ``__file__``."""
    offenders = [f"{path.relative_to(REPO)}:{n}: {line.strip()}"
                 for path in sorted((REPO / "src").glob("*/src/**/*.py"))
                 for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                 if "__file__" in line and ("parents[" in line or ".parent" in line or "'..'" in line
                                            or '".."' in line)]
    assert not offenders, "modules that find files from __file__:\n" + "\n".join(offenders)
