"""System test: every long-running node of a robot exits within 2 s of SIGINT or SIGTERM, its master frozen
(SIGSTOP) or not (gidabot_navigation.ros.exit_guard).

Without the guard, rospy unregisters from the master in its signal handler with an XML-RPC call without a
timeout: with the master frozen, goal_manager, multirobot_navigation, tour_store, the relay ends and
supervisor, the visitor, the monitor, the chaos probe and the GUI never exited. Each node is started
directly (not by roslaunch) against one master, so each one's exit is timed; the simulator's stand-ins are
covered by tests/sim/test_sim_exit.py, and here while ``init_node`` waits on a master frozen from the start
(the stand-ins installed their guard after ``init_node``: rospy's handler ran in that window and never
returned).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import xmlrpc.client
from collections.abc import Iterator
from pathlib import Path

import pytest
from exit_timing import signal_and_time

from gidabot_navigation.building.model import load_building, relocate_building
from gidabot_navigation.interface import Node, global_name, relay_end_name
from gidabot_navigation.relay.supervisor import EndOptions, EndSpec, end_argv
from gidabot_sim.runner.procs import ProcessGroup, free_port, robot_address, ros_env, start_master, wait_until

pytestmark = pytest.mark.system
REPO = Path(__file__).resolve().parents[2]
FACULTY = REPO / "maps" / "faculty"
NAV_NODES = REPO / "src" / "gidabot_navigation" / "nodes"
SIM_NODES = REPO / "src" / "gidabot_sim" / "nodes"
GUI_NODE = REPO / "src" / "gidabot_gui" / "nodes" / "gui"
DASHBOARD_NODE = REPO / "src" / "gidabot_web" / "nodes" / "dashboard"
ROBOT = "Kbot"
EXIT_BOUND = 2.0     # s
ROS_NODES = {        # process name -> ROS node name (registered on the master once it runs)
    "goal_manager": global_name(Node.GOAL_MANAGER), "multirobot_navigation": global_name(Node.MULTIROBOT_NAVIGATION),
    "tour_store": global_name(Node.TOUR_STORE), "relay_supervisor": global_name(Node.RELAY_SUPERVISOR),
    "people": global_name(Node.PEOPLE),
    "relay_end": relay_end_name(ROBOT, "Galtxagorri"), "visitor": global_name(Node.VISITOR),
    "monitor": global_name(Node.MONITOR), "gui": global_name(Node.GUI), "chaos_probe": global_name(Node.CHAOS_PROBE),
    "dashboard": global_name(Node.DASHBOARD),
}   # the monitor is anonymous: /monitor_<pid>_<ms>


class Robot:
    """One master and every long-running node of one robot (the chaos probe on a pipe, as chaos runs it)."""

    def __init__(self, procs: ProcessGroup, tmp: Path, stand_ins: bool = False,
                 frozen_from_start: bool = False) -> None:
        self.procs = procs
        ip = robot_address([r.name for r in load_building(FACULTY).robots].index(ROBOT))
        self.uri = start_master(procs, "master", ip)
        if frozen_from_start:
            procs.signal("master", signal.SIGSTOP)     # every node's init_node waits on it
        building = str(relocate_building(FACULTY, tmp / "building", {ROBOT: self.uri}))
        self.env = {**ros_env(self.uri, ip, log_dir=tmp / "ros"), "QT_QPA_PLATFORM": "offscreen"}
        common = [f"_building:={building}", f"_robot:={ROBOT}"]
        py = sys.executable
        secret = tmp / "relay.secret"
        secret.write_text("exit-test-secret-0123456789\n")
        secret.chmod(0o600)
        starts = {
            "goal_manager": [py, str(NAV_NODES / "goal_manager"), *common, f"_state_dir:={tmp / 'gm'}"],
            "multirobot_navigation": [py, str(NAV_NODES / "multirobot_navigation"), *common,
                                      f"_state_dir:={tmp / 'nav'}"],
            "tour_store": [py, str(NAV_NODES / "tour_store"), *common, f"_tours_dir:={tmp / 'tours'}",
                           f"_seed_dir:={REPO / 'tours'}"],
            "relay_supervisor": [py, str(NAV_NODES / "relay_supervisor"), *common, f"_secret_file:={secret}",
                                 f"_state_dir:={tmp / 'relay_sup'}"],
            "people": [py, str(NAV_NODES / "people"), *common],
            "relay_end": end_argv(EndSpec(ROBOT, "Galtxagorri", "a", self.uri, ip, robot_address(2),
                                          free_port(robot_address(2)), ip),
                                  EndOptions(state_dir=str(tmp / "relay_end"), secret_file=str(secret))),
            "visitor": [py, str(SIM_NODES / "visitor"), *common, "__name:=visitor"],
            "monitor": [py, str(SIM_NODES / "monitor"), f"_out:={tmp / 'monitor.jsonl'}"],
            "gui": [py, str(GUI_NODE), *common, "_speech:=false", "_fullscreen:=false"],
            "dashboard": [py, str(DASHBOARD_NODE), *common, f"_state_dir:={tmp / 'dashboard'}",
                          f"_port:={free_port(ip)}"],
        }
        if stand_ins:
            starts |= {"sim": [py, str(SIM_NODES / "world"), f"__name:={Node.SIM}", *common, "_speed:=20",
                               "_use_sim_time:=true"],
                       "move_base": [py, str(SIM_NODES / "move_base"), f"__name:={Node.MOVE_BASE}", *common],
                       "amcl": [py, str(SIM_NODES / "amcl"), f"__name:={Node.AMCL}"]}
        self.names = [*starts, "chaos_probe"]
        for name, argv in starts.items():
            procs.start(name, argv, self.env)
        log = open(tmp / "chaos_probe.log", "ab")  # noqa: SIM115 - closed at once: the child has its copy
        self.probe = subprocess.Popen([py, str(SIM_NODES / "chaos_probe"), "--robot", ROBOT, "--out",
                                       str(tmp / "probe.jsonl")], env=self.env, stdin=subprocess.PIPE,
                                      stdout=subprocess.DEVNULL, stderr=log, start_new_session=True)
        log.close()

    def alive(self, name: str) -> bool:
        return self.probe.poll() is None if name == "chaos_probe" else self.procs.alive(name)

    def signal(self, name: str, sig: int) -> None:
        if name == "chaos_probe":
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.probe.pid, sig)
        else:
            proc = self.procs.get(name).popen
            with contextlib.suppress(ProcessLookupError):
                os.kill(proc.pid, sig)          # the node itself, as roslaunch does

    def pid(self, name: str) -> int:
        return self.probe.pid if name == "chaos_probe" else self.procs.get(name).popen.pid

    def at_master(self, name: str) -> bool:
        """The node has a TCP connection to its master (a frozen master's kernel still accepts it: the node
        then waits for the answer to its first call, in init_node)."""
        host, port = self.uri.split("//", 1)[1].rstrip("/").split(":")
        remote = "".join(f"{int(b):02X}" for b in reversed(host.split("."))) + f":{int(port):04X}"
        inodes = set()
        with contextlib.suppress(OSError):
            for fd in Path(f"/proc/{self.pid(name)}/fd").iterdir():
                with contextlib.suppress(OSError):
                    target = os.readlink(fd)
                    if target.startswith("socket:["):
                        inodes.add(target[len("socket:["):-1])
        with open("/proc/net/tcp") as table:
            return any(f[2] == remote and f[9] in inodes for f in (line.split() for line in list(table)[1:]))

    def signal_and_time(self, names: list[str], sig: int) -> dict[str, float]:
        """Send ``sig`` to every node at once; wall s until each one has exited (inf: not within the bound + 5 s)."""
        return signal_and_time(names, self.signal, self.alive, sig, EXIT_BOUND + 5.0)

    def children(self, name: str) -> list[int]:
        """Pids of the child processes of ``name``."""
        pid = self.procs.get(name).popen.pid
        out: list[int] = []
        for task in Path(f"/proc/{pid}/task").iterdir():
            with contextlib.suppress(OSError):
                out += [int(c) for c in (task / "children").read_text().split()]
        return out

    def running(self) -> set[str]:
        """Nodes registered with a topic of their own (past init_node and the guard's installation)."""
        try:
            _, _, state = xmlrpc.client.ServerProxy(self.uri).getSystemState("/exit_test")
        except (OSError, xmlrpc.client.Error):
            return set()
        nodes = {n for group in state for _topic, names in group for n in names if _topic != "/rosout"}
        return {name for name, node in ROS_NODES.items() if any(n == node or n.startswith(node + "_") for n in nodes)}

    def close(self) -> None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.probe.pid, signal.SIGKILL)
        self.probe.wait(5)
        if self.probe.stdin:
            self.probe.stdin.close()


@pytest.fixture
def robot(tmp_path: Path) -> Iterator[Robot]:
    with ProcessGroup(tmp_path / "logs") as procs:
        r = Robot(procs, tmp_path)
        try:
            yield r
        finally:
            procs.signal("master", signal.SIGCONT)
            r.close()


@pytest.mark.timeout(300)
@pytest.mark.parametrize("frozen", [True, False], ids=["master frozen", "master running"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_every_node_exits_within_2_s(robot: Robot, tmp_path: Path, sig: int, frozen: bool) -> None:
    wait_until(lambda: robot.running() == set(ROS_NODES), 120, "every node running", interval=0.2)
    ends = robot.children("relay_supervisor")          # the relay ends the supervisor started
    assert ends
    if frozen:
        robot.procs.signal("master", signal.SIGSTOP)
    times = robot.signal_and_time(list(ROS_NODES), sig)
    robot.procs.signal("master", signal.SIGCONT)
    print(f"\n[exit] {signal.Signals(sig).name}, master {'frozen' if frozen else 'running'}: "
          + ", ".join(f"{n} {t:.2f} s" for n, t in sorted(times.items(), key=lambda kv: kv[1])))
    assert max(times.values()) < EXIT_BOUND, times
    # and nothing the supervisor started is left: it stops its ends, or the kernel SIGTERMs them (pdeathsig)
    wait_until(lambda: not any(Path(f"/proc/{pid}").exists() and not _zombie(pid) for pid in ends), EXIT_BOUND + 2.0,
               f"the supervisor's relay ends {ends} gone", interval=0.05)


@pytest.mark.timeout(300)
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_node_signalled_while_init_node_waits_on_a_frozen_master_exits_within_2_s(tmp_path: Path, sig: int) -> None:
    """A robot started (or restarted) while its master is frozen, then stopped: every node, the stand-ins
    included, is in init_node waiting for the master's answer when the signal comes."""
    with ProcessGroup(tmp_path / "logs") as procs:
        robot = Robot(procs, tmp_path, stand_ins=True, frozen_from_start=True)
        try:
            wait_until(lambda: all(robot.at_master(n) for n in robot.names), 120,
                       "every node waiting for the frozen master", interval=0.1)
            times = robot.signal_and_time(robot.names, sig)
        finally:
            procs.signal("master", signal.SIGCONT)
            robot.close()
    print(f"\n[exit in init_node] {signal.Signals(sig).name}, master frozen: "
          + ", ".join(f"{n} {t:.2f} s" for n, t in sorted(times.items(), key=lambda kv: kv[1])))
    assert max(times.values()) < EXIT_BOUND, times


def _zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except (OSError, IndexError):
        return True
