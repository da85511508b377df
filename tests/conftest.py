"""Fixtures for system tests: several ROS masters on loopback, every process cleaned up.

Each robot gets its own loopback address (127.N.0.11, .12, ... with N per test session) and a free port,
so concurrent test runs never collide; the building file is relocated to those
master URIs in a temporary directory. ``faculty_machines``: each robot a separate machine instead
(a network namespace of its own, gidabot_sim.runner.machines), with a firewall that admits from the
other machines only its relay ports, and one more machine, ``intruder``, that is not a robot.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from sim_building import SimBuilding

from gidabot_navigation.building.model import load_building, relocate_building
from gidabot_sim.runner.machines import Machines
from gidabot_sim.runner.procs import ProcessGroup, master_pid, robot_address, ros_env, start_master, wait_until

REPO = Path(__file__).resolve().parents[1]
FACULTY = REPO / "maps" / "faculty"


def robot_ip(index: int) -> str:
    """Loopback address of robot ``index`` for this test session (see procs.robot_address)."""
    return robot_address(index)


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


@pytest.fixture
def faculty_machines(tmp_path: Path, procs: ProcessGroup) -> Iterator[SimBuilding]:
    """The faculty, each robot a machine of its own with its master (port 11311) and its firewall; plus a
    machine ``intruder`` on the same network. Everything is removed afterwards."""
    base = load_building(FACULTY)
    names = [r.name for r in base.robots]
    with Machines(names, extra=["intruder"]) as net:
        uris = {}
        for r in names:
            ip = net.address(r)
            uri = uris[r] = f"http://{ip}:11311/"
            procs.start(f"master_{r}", net.wrap(r, ["rosmaster", "--core", "-p", "11311", "-w", "3"]),
                        ros_env(uri, ip, log_dir=tmp_path / "logs" / f"master_{r}"))
            wait_until(lambda r=r, uri=uri: net.call(r, master_pid, uri) is not None, 15.0, f"master of {r}")
        path = relocate_building(FACULTY, tmp_path / "building", uris)
        sim = SimBuilding(path, load_building(path), procs, tmp_path / "logs", net)
        for r in names:
            net.firewall(r, sim.building.relay_ports(r))
        yield sim
        procs.close()
