"""A building whose robots' masters run, on loopback or on separate machines (the fixtures of
conftest.py and tests/tour_mesh.py build it; tests/relay_system.RelayMesh and the other system helpers
take it)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gidabot_navigation.building.model import Building
from gidabot_sim.runner.machines import Machines
from gidabot_sim.runner.procs import ProcessGroup, master_pid, ros_env, wait_until


@dataclass
class SimBuilding:
    """A building whose robots' masters are running: ``procs`` owns them."""

    path: Path               # relocated building.yaml
    building: Building
    procs: ProcessGroup
    log_dir: Path
    net: Machines | None = None   # separate machines (network namespaces), or every robot on loopback

    def env(self, robot: str, **extra: str) -> dict[str, str]:
        r = self.building.robot(robot)
        return ros_env(r.master_uri, r.ip, log_dir=self.log_dir / "ros" / robot, **extra)

    def command(self, robot: str, argv: list[str]) -> list[str]:
        """``argv`` run on ``robot``'s machine."""
        return self.net.wrap(robot, argv) if self.net else list(argv)

    def call(self, robot: str, fn: Callable[..., Any], *args: Any) -> Any:
        """``fn(*args)`` from ``robot``'s machine (where its master can be reached)."""
        return self.net.call(robot, fn, *args) if self.net else fn(*args)

    def restart_master(self, robot: str) -> None:
        self.procs.restart(f"master_{robot}")
        uri = self.building.robot(robot).master_uri
        wait_until(lambda: self.call(robot, master_pid, uri) is not None, 15.0, f"master of {robot} back")
