"""System tests: the simulated floor's nodes (sim, move_base, amcl) exit within ~1 s of SIGINT whatever
state their master and subscribers are in (gidabot_navigation.ros.exit_guard).

Found in chaos runs: rospy's SIGINT handler shuts the node down inside the main thread, which could
be in the middle of a publish holding a non-reentrant lock of rospy's (a self-deadlock, 1 run in ~60
here), and unregisters from the master without a timeout (a frozen master: a hang every time).
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from exit_timing import signal_and_time
from probe import Probe

from gidabot_navigation.building.model import load_building, relocate_building
from gidabot_navigation.interface import Node, Topic
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master, wait_until

pytestmark = pytest.mark.system
REPO = Path(__file__).resolve().parents[2]
FACULTY = REPO / "maps" / "faculty"
NODES = REPO / "src" / "gidabot_sim" / "nodes"
ROBOT = "Kbot"
EXIT_BOUND = 2.0     # s: the guard's 1 s grace plus slack for a loaded machine (rospy alone: forever)
SUBSCRIPTIONS = ((Topic.CLOCK, "rosgraph_msgs/Clock"), (Topic.ODOM, "nav_msgs/Odometry"),
                 (Topic.BASE_POSE_GROUND_TRUTH, "nav_msgs/Odometry"), (Topic.BASE_SCAN, "sensor_msgs/LaserScan"),
                 (Topic.TF, "tf2_msgs/TFMessage"), (Topic.BATTERY, "sensor_msgs/BatteryState"))


@pytest.fixture
def procs(tmp_path: Path) -> Iterator[ProcessGroup]:
    with ProcessGroup(tmp_path / "logs") as group:
        yield group
        for name in group.names():          # a test may leave its master or a probe stopped
            group.signal(name, signal.SIGCONT)


def start_floor(procs: ProcessGroup, tmp_path: Path, speed: str = "20") -> dict[str, str]:
    """A master, then sim + move_base + amcl started directly (so each one's exit is timed)."""
    ip = robot_address([r.name for r in load_building(FACULTY).robots].index(ROBOT))
    uri = start_master(procs, "master", ip)
    building = relocate_building(FACULTY, tmp_path / "building", {ROBOT: uri})
    env = ros_env(uri, ip, log_dir=tmp_path / "ros")
    common = [f"_building:={building}", f"_robot:={ROBOT}"]
    procs.start("sim", [sys.executable, str(NODES / "world"), f"__name:={Node.SIM}", *common, f"_speed:={speed}",
                        "_use_sim_time:=true"], env)
    procs.start("move_base", [sys.executable, str(NODES / "move_base"), f"__name:={Node.MOVE_BASE}", *common], env)
    procs.start("amcl", [sys.executable, str(NODES / "amcl"), f"__name:={Node.AMCL}"], env)
    return env


def subscribed_probe(env: dict[str, str], log: Path) -> Probe:
    probe = Probe(env, log)
    for topic, type_ in SUBSCRIPTIONS:
        probe.sub(topic, type_)
    return probe


def sigint_and_time(procs: ProcessGroup, names: tuple[str, ...]) -> dict[str, float]:
    """SIGINT every node at once (as roslaunch does at shutdown); wall s until each has exited."""
    return signal_and_time(names, procs.signal, procs.alive, signal.SIGINT, EXIT_BOUND + 3.0)


def forced_exits(procs: ProcessGroup, name: str) -> list[str]:
    log = procs.get(name).log_path
    text = log.read_text(errors="replace") if log else ""
    return [line for line in text.splitlines() if "exiting now" in line]


def test_nodes_exit_promptly_while_their_master_is_frozen(procs: ProcessGroup, tmp_path: Path) -> None:
    env = start_floor(procs, tmp_path)
    with subscribed_probe(env, tmp_path / "probe.log") as probe:
        probe.wait(Topic.ODOM, lambda m: True, 60, "the simulator running")
        procs.signal("master", signal.SIGSTOP)     # rospy's unregistration would wait for it forever
        exits = sigint_and_time(procs, ("sim", "move_base", "amcl"))
        procs.signal("master", signal.SIGCONT)
    assert all(t < EXIT_BOUND for t in exits.values()), exits
    assert "shutdown did not finish" in " ".join(forced_exits(procs, "sim"))    # the guard ended it


def test_sim_exits_promptly_with_a_frozen_subscriber_and_again_after_a_master_restart(
        procs: ProcessGroup, tmp_path: Path) -> None:
    env = start_floor(procs, tmp_path)
    live = subscribed_probe(env, tmp_path / "live.log")
    frozen = subscribed_probe(env, tmp_path / "frozen.log")
    try:
        live.wait(Topic.ODOM, lambda m: True, 60, "the simulator running")
        frozen.wait(Topic.BASE_SCAN, lambda m: True, 30, "scans reaching the second subscriber")
        # the master restarts (the nodes re-register), then a subscriber freezes for good
        master_uri = env["ROS_MASTER_URI"]
        procs.stop("master", grace=3.0)
        start_master(procs, "master", env["ROS_IP"], port=int(master_uri.rstrip("/").rsplit(":", 1)[1]))
        wait_until(lambda: live.call(op="status")["generation"] >= 1, 20, "the probe re-registered")
        os.killpg(frozen.proc.pid, signal.SIGSTOP)
        n = len(live.msgs(Topic.ODOM))
        live.wait(Topic.ODOM, lambda m: True, 10, "the simulator still running", since=n)
        exits = sigint_and_time(procs, ("sim", "move_base", "amcl"))
    finally:
        os.killpg(frozen.proc.pid, signal.SIGCONT)
        frozen.close()
        live.close()
    assert all(t < EXIT_BOUND for t in exits.values()), exits
    assert not forced_exits(procs, "sim")          # an orderly shutdown: nothing left to force
