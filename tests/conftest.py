"""Fixtures for system tests: several ROS masters on loopback, every process cleaned up.

Each robot gets its own loopback address (127.N.0.11, .12, ... with N per test session) and a free port,
so concurrent test runs never collide; the building file is relocated to those
master URIs in a temporary directory.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from gidabot_navigation.building.model import Building, load_building, relocate_building
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master

REPO = Path(__file__).resolve().parents[1]
FACULTY = REPO / "maps" / "faculty"


def robot_ip(index: int) -> str:
    """Loopback address of robot ``index`` for this test session (see procs.robot_address)."""
    return robot_address(index)


@dataclass
class SimBuilding:
    """A building whose robots' masters are running: ``procs`` owns them."""

    path: Path               # relocated building.yaml
    building: Building
    procs: ProcessGroup
    log_dir: Path

    def env(self, robot: str, **extra: str) -> dict[str, str]:
        r = self.building.robot(robot)
        return ros_env(r.master_uri, r.ip, log_dir=self.log_dir / "ros" / robot, **extra)

    def restart_master(self, robot: str) -> None:
        self.procs.restart(f"master_{robot}")
        from gidabot_sim.runner.procs import master_pid, wait_until

        uri = self.building.robot(robot).master_uri
        wait_until(lambda: master_pid(uri) is not None, 15.0, f"master of {robot} back")


@pytest.fixture
def procs(tmp_path: Path) -> Iterator[ProcessGroup]:
    with ProcessGroup(tmp_path / "logs") as group:
        yield group


@pytest.fixture
def faculty_masters(tmp_path: Path, procs: ProcessGroup) -> SimBuilding:
    """The faculty with a running master per robot (free ports on 127.N.0.11-14)."""
    base = load_building(FACULTY)
    uris = {r.name: start_master(procs, f"master_{r.name}", robot_ip(i)) for i, r in enumerate(base.robots)}
    path = relocate_building(FACULTY, tmp_path / "building", uris)
    return SimBuilding(path, load_building(path), procs, tmp_path / "logs")
