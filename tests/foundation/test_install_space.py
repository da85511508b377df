"""The install space: ``catkin_make install`` into a temporary prefix, then one robot's launch from it alone.

The build uses its own build, devel and install directories (the checkout's devel space is not touched)
and a clean environment, so the install space chains to nothing of the checkout. The robot then runs
with only that install space sourced: ``ROS_PACKAGE_PATH``, ``PYTHONPATH`` and ``CMAKE_PREFIX_PATH``
name no directory of the checkout. The venv stays first on ``PATH``: it is the Python environment
(Debian's python3 and the pinned PyPI extras of requirements.txt) that installed nodes run in
(``#!/usr/bin/env python3``), and holds nothing of the workspace.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import urllib.request
import xmlrpc.client
from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building, relocate_building
from gidabot_sim.runner.proc_info import ProcInfo, process_tree, read_proc
from gidabot_sim.runner.procs import (
    ProcessError,
    ProcessGroup,
    free_port,
    master_pid,
    robot_address,
    ros_env,
    wait_until,
)

pytestmark = pytest.mark.system

REPO = Path(__file__).resolve().parents[2]
VENV_BIN = Path(sys.prefix) / "bin"
NODES = ("/goal_manager", "/multirobot_navigation", "/tour_store", "/relay_supervisor", "/sim", "/move_base", "/amcl",
         "/dashboard")
BUILD_TIMEOUT = 300.0     # s; about 10 s on the 2-core test machine
START_TIMEOUT = 90.0      # s from roslaunch to every node registered


def http_status(url: str) -> int | None:
    try:
        with urllib.request.urlopen(url, timeout=2.0) as r:
            return int(r.status)
    except (OSError, ValueError):
        return None


def clean_env(home: Path) -> dict[str, str]:
    """Nothing of the checkout's environment: the venv and the system on PATH, a private HOME."""
    return {"PATH": f"{VENV_BIN}:/usr/bin:/bin", "HOME": str(home), "LANG": "C.UTF-8"}


def sourced(setup: Path, base: dict[str, str]) -> dict[str, str]:
    """``base`` after ``source setup``."""
    out = subprocess.run(["bash", "-c", f'source "{setup}" && env -0'], env=base, capture_output=True,
                         timeout=60, check=True)
    return dict(line.split("=", 1) for line in out.stdout.decode().split("\0") if "=" in line)


def build_install_space(tmp: Path) -> Path:
    env = clean_env(tmp / "home")
    cmd = ["catkin_make", "-C", str(tmp), "--source", str(REPO / "src"), "--build", str(tmp / "build"),
           f"-DCATKIN_DEVEL_PREFIX={tmp / 'devel'}", f"-DCMAKE_INSTALL_PREFIX={tmp / 'install'}",
           f"-DPYTHON_EXECUTABLE={sys.executable}", "-DCATKIN_ENABLE_TESTING=OFF", "install"]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=BUILD_TIMEOUT)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-4000:]
    return tmp / "install"


def registered(master_uri: str) -> set[str]:
    """Every node known to the master (publishers, subscribers, services)."""
    _, _, state = xmlrpc.client.ServerProxy(master_uri).getSystemState("/test")
    return {node for group in state for _, nodes in group for node in nodes}


def node_argv(master_uri: str, node: str) -> tuple[str, ...]:
    _, _, uri = xmlrpc.client.ServerProxy(master_uri).lookupNode("/test", node)
    _, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/test")
    info = read_proc(int(pid))
    assert info is not None, f"{node} (pid {pid}) is gone"
    return info.argv


def running(tree: dict[int, ProcInfo]) -> list[ProcInfo]:
    """The processes of ``tree`` still alive (the same process: same start time)."""
    return [info for info in tree.values() if (now := read_proc(info.pid)) is not None and now.start == info.start]


def test_one_robot_runs_from_the_install_space(tmp_path: Path) -> None:
    install = build_install_space(tmp_path)
    share = install / "share" / "gidabot_navigation"
    for resource in ("launch/robot.launch", "config/shared_topics.yaml", "maps/faculty/building.yaml",
                     "tours/real_world.tour"):
        assert (share / resource).is_file() and not (share / resource).is_symlink(), resource
    for program in ("gidabot_navigation/goal_manager", "gidabot_sim/world", "gidabot_gui/gui"):
        assert os.access(install / "lib" / program, os.X_OK), program
    editor_page = install / "lib/python3/dist-packages/gidabot_web/editor/static"     # gidabot edit's package data
    assert {"index.html", "editor.js", "editor.css"} <= {p.name for p in editor_page.iterdir()}

    env = sourced(install / "setup.bash", clean_env(tmp_path / "home"))
    for var in ("ROS_PACKAGE_PATH", "PYTHONPATH", "CMAKE_PREFIX_PATH"):
        assert env[var].split(":")[0].startswith(str(install)), (var, env[var])
        assert str(REPO / "src") not in env[var] and str(REPO / "devel") not in env[var], (var, env[var])
    where = subprocess.run([sys.executable, "-c", "import gidabot_navigation.resources as r; "
                            "print(r.__file__); print(r.resource('launch', 'robot.launch'))"],
                           env=env, capture_output=True, text=True, timeout=60, check=True).stdout.split()
    assert where == [str(install / "lib/python3/dist-packages/gidabot_navigation/resources.py"),
                     str(share / "launch/robot.launch")]

    base = load_building(share / "maps" / "faculty")
    robot = base.robots[0]            # the first robot: it owns relays to every other robot
    ip = robot_address(0)
    port = free_port(ip)
    uri = f"http://{ip}:{port}/"
    others = {r.name: f"http://{robot_address(i)}:{free_port(robot_address(i))}/"   # never started
              for i, r in enumerate(base.robots) if i > 0}
    building = relocate_building(share / "maps" / "faculty", tmp_path / "building", {robot.name: uri, **others})
    tours = tmp_path / "tours"
    dashboard = f"http://{ip}:{free_port(ip)}"
    with ProcessGroup(tmp_path / "logs") as procs:
        procs.start("master", ["rosmaster", "--core", "-p", str(port), "-w", "3"],
                    ros_env(uri, ip, base=env, log_dir=tmp_path / "ros" / "master"))
        wait_until(lambda: master_pid(uri) is not None, 15.0, f"master at {uri}")
        launch = procs.start("robot", ["roslaunch", "--skip-log-check", "gidabot_navigation", "robot.launch",
                                       f"building:={building}", f"robot:={robot.name}", "sim:=true", "gui:=false",
                                       f"tours_dir:={tours}", f"relay_state_dir:={tmp_path / 'relay'}",
                                       f"dashboard_port:={dashboard.rsplit(':', 1)[1]}",
                                       f"dashboard_dir:={tmp_path / 'dashboard'}"],
                             ros_env(uri, ip, base=env, log_dir=tmp_path / "ros" / "robot"), cwd=tmp_path)
        relay = f"/gidabot_relay_{robot.name}_{base.robots[1].name}"   # its side a runs on this master
        try:
            wait_until(lambda: set(NODES) | {relay} <= registered(uri), START_TIMEOUT,
                       f"{', '.join(NODES)} and {relay} registered")
            seeds = sorted(p.name for p in (share / "tours").glob("*.tour"))
            wait_until(lambda: sorted(p.name for p in tours.glob("*.tour")) == seeds, 30.0, "tours seeded")
            for name in seeds:
                assert (tours / name).read_bytes() == (share / "tours" / name).read_bytes()
            params = xmlrpc.client.ServerProxy(uri)
            assert params.getParam("/test", "/tour_store/seed_dir")[2] == str(share / "tours")
            assert params.getParam("/test", "/relay_supervisor/topics_file")[2] == str(
                share / "config" / "shared_topics.yaml")
            for node in NODES:
                argv = " ".join(node_argv(uri, node))
                assert f"{install}/lib/" in argv and str(REPO / "src") not in argv, (node, argv)
            assert "-m gidabot_navigation.relay.end_node" in " ".join(node_argv(uri, relay))
            for page in ("/", "/static/dashboard.js", "/web/web.js", "/blueprints/floor-0.png"):   # its files too
                wait_until(lambda page=page: http_status(dashboard + page) == 200, 30.0, f"the dashboard's {page}")
        finally:
            tree = process_tree({launch.popen.pid})      # the nodes run in sessions of their own
            procs.close()
            with contextlib.suppress(ProcessError):
                wait_until(lambda: not running(tree), 20.0, "every process of the launch gone")
            left = running(tree)
            for info in left:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(info.pgid, signal.SIGKILL)
        assert not left, f"left running after the launch stopped: {[i.label for i in left]}"
