"""Run the whole simulated building on this one machine (a thin layer over the per-robot launches).

Starts one master per robot on the robot's own loopback address (free ports, so
runs never collide) -- or, with ``machines``, each robot as a separate machine: its own
network namespace, address, loopback and firewall on a bridge of the run, its own clock
offset if asked (:mod:`gidabot_sim.runner.machines`) -- sets ``/use_sim_time`` on every master, then per robot a
``rosbag record`` of the shared topics and ``launch/robot.launch sim:=true``
against its master, the simulated visitor (one node per floor, started apart from
the robots' launches: it plays a person, whom restarting a robot's nodes must not
reset) and the progress monitor. Every process is in its own process group;
:meth:`SimulatedBuilding.stop` (and leaving the ``with`` block) stops them all by
process group: recorders first (SIGINT: the bag is closed and indexed), then the
robots, the visitor, the monitor and the masters.

A master can be stopped and started again (:meth:`stop_master`,
:meth:`start_master_again`, fault injection): ``rosbag record`` never re-registers
with a restarted master, so that robot's recording then goes on in a new bag part
(:mod:`gidabot_sim.runner.recorders`; ``recorders.bags`` lists every part that recorded).

With ``machines``, a robot's master and launch run in its namespace with its clock; the
tools of the simulated world (the visitor, the recorder, the monitor, the chaos probes) run in
the namespace of the robot whose master they use, on the host's clock (they are the world, not
the robot); this process reaches a master through a thread inside its namespace
(:meth:`SimulatedBuilding.call`). A robot's firewall admits from the other machines only its relay
ports.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import signal
import socket
import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import rospkg

from gidabot_navigation.building.model import Building, load_building, relocate_building
from gidabot_navigation.interface import Node
from gidabot_navigation.resources import resource
from gidabot_sim.errors import DemoError, MachinesError, ProcessError
from gidabot_sim.runner.forward import Forward
from gidabot_sim.runner.machines import Machines
from gidabot_sim.runner.proc_info import ProcInfo, process_tree, read_proc
from gidabot_sim.runner.procs import ProcessGroup, free_port, free_port_run, master_pid, ros_env, wait_until
from gidabot_sim.runner.recorders import RECORDED_TOPICS, Recorders
from gidabot_sim.world.mates import Mates
from gidabot_sim.world.timeline import Clock, Timeline

T = TypeVar("T")


NODE_GRACE = 6.0   # wall s a node gets to obey SIGINT when the building stops
MACHINE_MASTER_PORT = 11311   # every robot's master on a machine of its own: the standard port
DASHBOARD_PORT = 8080         # every robot's dashboard on a machine of its own: the default port
STAFF_MACHINE = "staff"       # with machines and dashboards: the staff's computer, the only one that reaches them
CLOCK_HISTORY = 3000   # looks at the floors' clocks kept for sim_time_at
# Wall-time rates of the state topics, whatever the speed. Guiding publishes them at rates in ROS (sim)
# time (2 Hz status, 5 Hz poses by default): at 20x that would be 40 + 100 messages per wall second per
# robot, every one of them handled by three relay ends and the recorder on each master (they cost more
# CPU than the rest of the building together). The relays forward at most 10 per second anyway; Table 5
# distances come from each robot's own /amcl_pose (a sample every 0.1 m), not from /gidabot/poses.
STATUS_WALL_HZ, POSE_WALL_HZ = 2.0, 5.0
STATUS_RATE, POSE_RATE = 2.0, 5.0       # guiding's defaults (Hz of ROS time), used up to 1x
# /clock follows simulated time: one message per CLOCK_SIM_PERIOD of sim time at the speed ceiling, between
# CLOCK_MIN_HZ and CLOCK_MAX_HZ per wall second. Every node of a master receives every /clock and wakes its sim-time
# timers on it (about 0.6 % of a core per node at 100 Hz); a period of one sim second is what the guiding nodes'
# timers need (the demo's state timers tick every 4 s of sim time and more at 20x), and at 20x, 20 Hz instead of 50
# took the building from 49.8 to 43.0 ms of CPU per sim s with the same Table 5 (`gidabot demo --cpu --clock-rate`).
CLOCK_SIM_PERIOD, CLOCK_MIN_HZ, CLOCK_MAX_HZ = 1.0, 10.0, 50.0


def state_rate_args(speed: float) -> dict[str, str]:
    """The launch arguments of guiding's state topics at ``speed`` (sim s per wall s): their defaults, slowed
    down in sim time so that their wall-time rates stay at most STATUS_WALL_HZ and POSE_WALL_HZ."""
    return {"status_rate": f"{min(STATUS_RATE, STATUS_WALL_HZ / speed):.4g}",
            "pose_rate": f"{min(POSE_RATE, POSE_WALL_HZ / speed):.4g}"}


def clock_rate_for(speed: float) -> float:
    """/clock messages per wall second at ``speed`` (sim s per wall s): one per CLOCK_SIM_PERIOD of sim time,
    within [CLOCK_MIN_HZ, CLOCK_MAX_HZ]."""
    return min(CLOCK_MAX_HZ, max(CLOCK_MIN_HZ, speed / CLOCK_SIM_PERIOD))


def node_executable(package: str, name: str) -> str:
    """Path of the executable ``name`` of ``package``, found as ``rosrun`` finds it (the devel or install
    space's ``lib/<package>``, else the package directory)."""
    import roslib.packages

    try:
        found = roslib.packages.find_node(package, name)
    except rospkg.ResourceNotFound as err:
        raise DemoError(f"package {package} not found: is the workspace built and sourced?") from err
    if not found:
        raise DemoError(f"{package}'s {name} program was not found (is the workspace built?)")
    return str(found[0])


def rosbag_record_binary() -> str:
    """Path of rosbag's ``record`` program (what ``rosbag record`` runs).

    Started directly so that it is the leader of its process group: a SIGINT reaches it
    once and it closes the bag before exiting (the ``rosbag`` Python wrapper exits at
    once on SIGINT, and the group would be killed while the bag is being closed).
    """
    return node_executable("rosbag", "record")


def write_secret(path: Path) -> Path:
    """A fresh random relay secret (HMAC-SHA256 key, 32 bytes hex) in ``path``, mode 0600."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="ascii") as out:
        out.write(secrets.token_hex(32) + "\n")
    return path


def set_param(master_uri: str, key: str, value: object) -> None:
    """Set a parameter on a master (XML-RPC, no rospy in this process)."""
    try:
        code, msg, _ = xmlrpc.client.ServerProxy(master_uri).setParam("/gidabot_demo", key, value)
    except (OSError, xmlrpc.client.Error) as err:
        raise DemoError(f"cannot set {key} on the master {master_uri}: {err}") from err
    if code != 1:
        raise DemoError(f"cannot set {key} on the master {master_uri}: {msg}")


@dataclass
class SimulatedBuilding:
    """The simulated building's processes. ``addresses`` (one per robot, building order) replace
    the building file's own master addresses (tests use a per-session loopback network).

    Time: every floor's simulator shares the run's timeline (``<run>/timeline``, slot = the robot's index):
    ``speed`` is the ceiling of every floor's clock (None: none, ``--speed max``; :meth:`set_ceiling` changes
    it while the run goes), no floor runs more than ``max_drift`` sim seconds ahead of the slowest live one,
    and :meth:`clocks` tells where each floor is. ``seed``: the simulated noise of robot ``i`` is seeded with
    ``seed + i`` (None: random). ``sim_nice``: CPU niceness of every floor's simulator and stand-ins: in lockstep
    their starvation only slows the floors' time down, so the robots' own software goes first."""

    building_dir: Path
    run_dir: Path
    speed: float | None = 10.0
    seed: int | None = None
    max_drift: float | None = 1.0             # sim s
    peer_timeout: float = 5.0                 # wall s a frozen floor holds the others up at most
    sim_nice: int = 10
    gui: bool = False
    record: bool = True
    relay_secret: Path | None = None          # FILE with the relays' secret; None = a fresh one in run_dir
    seed_tours: Path = field(default_factory=lambda: resource("tours"))
    addresses: list[str] | None = None
    robot_args: dict[str, dict[str, str]] = field(default_factory=dict)   # per robot extra launch args
    common_args: dict[str, str] = field(default_factory=dict)
    start_delay: float = 8.0                  # wall s from launching the robots to sim time 0
    visitor: dict[str, object] | None = None  # the simulated visitor's ~params (tour_file, goal_id, way, ...)
    monitor: bool = True                      # the progress monitor (monitor.jsonl)
    machines: bool = False                    # every robot a machine of its own (network namespaces)
    dashboard: bool = False                   # every robot serves its staff dashboard (dashboard_url)
    clock_offsets: dict[str, float] = field(default_factory=dict)   # machines: robot -> wall clock offset (s)
    building: Building | None = None
    building_file: Path | None = None
    monitor_file: Path | None = None
    start_wall: float = 0.0

    def __post_init__(self) -> None:
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.procs = ProcessGroup(self.run_dir / "logs")
        self._stopped = False
        self._seen: dict[int, ProcInfo] = {}    # every process of the run seen by track()
        self._root: dict[int, str] = {}         # pid -> the managed process it descends from
        self.killed_leftovers: list[str] = []   # processes stop() had to kill after their parents were gone
        self.forced: list[str] = []             # nodes that ignored SIGINT for NODE_GRACE s (robot/node (signal))
        self.recorders = Recorders(self.run_dir)  # every robot's bag parts and their recorders
        self.net: Machines | None = None         # the machines (namespaces) of the run, with ``machines``
        self.off: set[str] = set()               # robots whose machine is off (machine_off)
        self.timeline: Timeline | None = None
        self.mates: Mates | None = None          # several robots on a floor: their shared poses (world/mates.py)
        self._history: list[tuple[float, float]] = []    # (wall, slowest floor's sim time), see clocks()
        self.dashboard_ports: dict[str, int] = {}        # robot -> its dashboard's port (with ``dashboard``)
        self._forwards: dict[str, Forward] = {}          # robot -> this host's way to its dashboard (machines)

    def __enter__(self) -> SimulatedBuilding:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- start ---------------------------------------------------------------
    def start(self, cancelled: Callable[[], bool] = lambda: False) -> None:
        """Masters, /use_sim_time, recorders, every robot's launch, the monitor. Raises DemoError.

        ``cancelled`` is asked between two steps (a signal handler sets it): start-up stops
        there with DemoError, and every process started so far is known to :meth:`stop`.
        """
        def check() -> None:
            if cancelled():
                raise DemoError("start-up interrupted")

        base = load_building(self.building_dir)
        if self.addresses is not None and len(self.addresses) != len(base.robots):
            raise DemoError(f"{len(self.addresses)} addresses for {len(base.robots)} robots")
        names = [r.name for r in base.robots]
        if self.clock_offsets and not self.machines:
            raise DemoError("clock offsets need separate machines (machines=True)")
        if self.machines:
            try:
                self.net = Machines(names, extra=(STAFF_MACHINE,) if self.dashboard else (),
                                    clock_offsets=self.clock_offsets).create()
            except MachinesError as err:
                raise DemoError(f"cannot make the robots' machines: {err}") from err
        uris: dict[str, str] = {}
        relay_ports: dict[str, int] = {}
        try:
            for i, r in enumerate(base.robots):
                ip = self.net.address(r.name) if self.net else self.addresses[i] if self.addresses else r.ip
                check()
                uris[r.name] = self._start_master(r.name, ip)
                if not self.net:       # robots on one host: ports free on their loopback addresses
                    relay_ports[r.name] = free_port_run(ip, max(i, 1))
                if self.dashboard:
                    self.dashboard_ports[r.name] = DASHBOARD_PORT if self.net else free_port(ip)
        except ProcessError as err:
            raise DemoError(f"cannot start the masters: {err}") from err
        self.building_file = relocate_building(self.building_dir, self.run_dir / "building", uris, relay_ports)
        self.building = load_building(self.building_file)
        for r in self.building.robots:   # before any node starts: every node (and rosbag) runs on sim time
            self.call(r.name, set_param, r.master_uri, "/use_sim_time", True)
            if self.net:
                try:
                    self.net.firewall(r.name, self.building.relay_ports(r.name),
                                      staff_ports=[self.dashboard_ports[r.name]] if self.dashboard else [],
                                      staff=STAFF_MACHINE if self.dashboard else None)
                except MachinesError as err:
                    raise DemoError(f"cannot put up the firewall of {r.name}: {err}") from err
        if self.relay_secret is None:
            self.relay_secret = write_secret(self.run_dir / "relay.secret")
        self.start_wall = time.time() + self.start_delay
        self.timeline = Timeline.create(self.run_dir / "timeline", len(self.building.robots), self.speed,
                                        self.max_drift, self.peer_timeout, self.start_wall)
        if any(len(self.building.robots_on(r.floor)) > 1 for r in self.building.robots):
            # robots sharing a floor share its world: each simulator puts the others of its floor in its own
            self.mates = Mates.create(self.run_dir / "mates", [r.home for r in self.building.robots])
        for robot in self.building.robots:
            check()
            if self.record:
                self.start_recorder(robot.name)
            self.launch_robot(robot.name)
        check()
        if self.visitor is not None:
            for robot in self.building.robots:
                self.start_visitor(robot.name)
        if not self.monitor:
            return
        self.monitor_file = self.run_dir / "monitor.jsonl"
        self.monitor_file.touch()
        first = self.building.robots[0]
        robots = "[" + ", ".join(r.name for r in self.building.robots) + "]"
        self.procs.start("monitor", self.command(first.name, [sys.executable, node_executable("gidabot_sim", "monitor"),
                                                              f"_out:={self.monitor_file}", f"_robots:={robots}"]),
                         self.env(first.name))

    def clocks(self) -> dict[str, Clock]:
        """Each robot's floor clock (sim time, heartbeat, timing counters), from the timeline; also kept (a
        while) for :meth:`sim_time_at`."""
        if self.timeline is None or self.building is None:
            return {}
        clocks = {r.name: c for r, c in zip(self.building.robots, self.timeline.clocks(), strict=True)}
        self._history.append((time.time(), min(c.sim for c in clocks.values())))
        del self._history[:-CLOCK_HISTORY]
        return clocks

    def sim_time_at(self, wall: float) -> float:
        """The slowest floor's sim time at wall time ``wall`` (at most that: the latest look at the clocks before
        it; the floors' clocks run at their own pace)."""
        self.clocks()
        before = [sim for w, sim in self._history if w <= wall]
        return before[-1] if before else (self._history[0][1] if self._history else 0.0)

    def set_ceiling(self, speed: float | None) -> None:
        """A new speed ceiling for every floor, from now on (None: none)."""
        if self.timeline is not None:
            self.timeline.set_ceiling(speed)

    def dashboard_url(self, robot: str) -> str:
        """The address of ``robot``'s staff dashboard (with ``dashboard``), on the robot's own address."""
        if self.building is None or robot not in self.dashboard_ports:
            raise DemoError(f"{robot} serves no dashboard in this run")
        return f"http://{self.building.robot(robot).ip}:{self.dashboard_ports[robot]}/"

    def staff_url(self, robot: str) -> str:
        """Where this host reaches ``robot``'s dashboard: its own address on loopback; with separate machines, a
        port of this host's loopback forwarded through the staff machine (:mod:`gidabot_sim.runner.forward`)."""
        url = self.dashboard_url(robot)
        if self.net is None:
            return url
        if robot not in self._forwards:
            net, address = self.net, (self.building.robot(robot).ip, self.dashboard_ports[robot])  # type: ignore[union-attr]
            self._forwards[robot] = Forward(lambda: net.call(STAFF_MACHINE, socket.create_connection, address, 5.0))
        return self._forwards[robot].url

    def env(self, robot: str, clock: bool = False) -> dict[str, str]:
        """Environment of a process using ``robot``'s master; ``clock``: a process of the robot itself (with
        separate machines, it gets the robot's clock offset; the world's tools keep the host's clock)."""
        if self.building is None:
            raise DemoError("the building is not started")
        r = self.building.robot(robot)
        env = ros_env(r.master_uri, r.ip, log_dir=self.run_dir / "ros" / robot)
        return self.net.env(robot, env) if self.net and clock else env

    def command(self, robot: str, argv: list[str]) -> list[str]:
        """``argv`` run where ``robot``'s processes run (its machine's namespace, with separate machines)."""
        return self.net.wrap(robot, argv) if self.net else list(argv)

    def call(self, robot: str, fn: Callable[..., T], *args: object) -> T:
        """``fn(*args)`` where ``robot``'s master can be reached (a thread inside its machine's namespace)."""
        return self.net.call(robot, fn, *args) if self.net else fn(*args)

    def _start_master(self, robot: str, ip: str, timeout: float = 15.0) -> str:
        port = MACHINE_MASTER_PORT if self.net else free_port(ip)
        uri = f"http://{ip}:{port}/"
        env = ros_env(uri, ip, log_dir=self.run_dir / "logs" / f"master_{robot}")
        if self.net:
            env = self.net.env(robot, env)
        self.procs.start(f"master_{robot}", self.command(robot, ["rosmaster", "--core", "-p", str(port), "-w", "3"]),
                         env)
        wait_until(lambda: self.call(robot, master_pid, uri) is not None, timeout, f"master {robot} at {uri}")
        return uri

    def launch_args(self, robot: str) -> list[str]:
        assert self.building is not None
        tours_dir = self.run_dir / "tours" / robot
        index = [r.name for r in self.building.robots].index(robot)
        args = {
            "building": str(self.building_file), "robot": robot, "sim": "true",
            "speed": "max" if self.speed is None else f"{self.speed:g}", "start_wall": f"{self.start_wall:.3f}",
            "timeline": str(self.run_dir / "timeline"), "timeline_slot": str(index),
            "seed": str(-1 if self.seed is None else self.seed + index), "sim_nice": str(self.sim_nice),
            "gui": str(self.gui).lower(), "tours_dir": str(tours_dir),
            "seed_tours": str(self.seed_tours), "relay_secret": str(self.relay_secret or ""),
            "relay_state_dir": str(self.run_dir / "relay" / robot), "dashboard": str(self.dashboard).lower(),
        }
        if self.dashboard:
            args["dashboard_port"] = str(self.dashboard_ports[robot])
            args["dashboard_dir"] = str(self.run_dir / "dashboard" / robot)
        if self.mates is not None and len(self.building.robots_on(self.building.robot(robot).floor)) > 1:
            args["sim_mates"] = str(self.mates.path)
        args.update(self.common_args)
        args.update(self.robot_args.get(robot, {}))
        return [f"{k}:={v}" for k, v in args.items()]

    def start_recorder(self, robot: str) -> Path:
        """A ``rosbag record`` of the shared topics on ``robot``'s master, into its next bag part."""
        name, bag = self.recorders.next_part(robot)
        self.procs.start(name, self.command(robot, [rosbag_record_binary(), "--quiet", "--min-space", "100M", "-O",
                                                    str(bag), *RECORDED_TOPICS]), self.env(robot))
        self.recorders.add(robot, bag)
        return bag

    def start_visitor(self, robot: str) -> None:
        """The simulated visitor's node of ``robot``'s floor, as a process of its own (not in the robot's
        launch: restarting the robot's nodes must not make the person forget where they are)."""
        assert self.building_file is not None and self.visitor is not None
        params = {"building": str(self.building_file), "robot": robot, **self.visitor}
        argv = [sys.executable, node_executable("gidabot_sim", "visitor"), f"__name:={Node.VISITOR}",
                *(f"_{k}:={json.dumps(v)}" for k, v in params.items())]   # JSON is YAML: types kept
        self.procs.start(f"visitor_{robot}", self.command(robot, argv), self.env(robot))

    def stop_master(self, robot: str, crash: bool = False) -> None:
        """Stop ``robot``'s master (``crash``: SIGKILL, else SIGINT); its nodes keep running."""
        name = f"master_{robot}"
        if crash:
            self.procs.signal(name, signal.SIGKILL)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.procs.get(name).popen.wait(timeout=5.0)
        else:
            self.procs.stop(name, grace=5.0)

    def start_master_again(self, robot: str, timeout: float = 15.0) -> float:
        """Start ``robot``'s master again (same address and port) and wait until it answers; then its
        recording goes on in a new bag part. Returns the monotonic time the master answered."""
        name = f"master_{robot}"
        old = self.procs.get(name)
        self.procs.start(name, old.argv, old.env, old.cwd)
        uri = self.building.robot(robot).master_uri if self.building else ""
        wait_until(lambda: self.call(robot, master_pid, uri) is not None, timeout, f"master of {robot} back",
                   interval=0.02)
        up = time.monotonic()
        self.call(robot, set_param, uri, "/use_sim_time", True)
        if self.record and self.recorders.bags.get(robot):
            n = len(self.recorders.bags[robot]) - 1
            self.start_recorder(robot)
            self.recorders.retire(robot, n)
        return up

    def machine_off(self, robot: str) -> list[int]:
        """``robot``'s computer goes off: every process of its launch and its master killed (SIGKILL), and, with
        separate machines, it is off the network. The world's tools on its floor (the visitor, the recorder)
        stay. Returns the pids killed."""
        if self.net is not None:
            self.net.partition(robot)
        self.off.add(robot)
        tree = process_tree({self.procs.get(f"robot_{robot}").popen.pid, self.procs.get(f"master_{robot}").popen.pid})
        self._seen.update(tree)
        for info in tree.values():
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(info.pgid, signal.SIGKILL)
        for name in (f"robot_{robot}", f"master_{robot}"):
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.procs.get(name).popen.wait(timeout=10.0)
        return sorted(tree)

    def machine_on(self, robot: str) -> float:
        """``robot``'s computer is back: on the network, its master (recording in a new bag part) and its launch
        started again, from what it kept on disk. Returns the monotonic time its master answered."""
        if self.net is not None:
            self.net.clear_faults(robot)
        up = self.start_master_again(robot)
        self.launch_robot(robot)
        self.off.discard(robot)
        return up

    def housekeeping(self) -> None:
        """Stop the recorders a restarted master made obsolete, once a newer part of that robot has recorded for
        RECORDER_OVERLAP s (until then the old one records on: no gap while the new one waits for the simulated
        clock); look at the floors' clocks (:meth:`sim_time_at`)."""
        self.clocks()
        for name in self.recorders.obsolete(time.monotonic(), self.procs.alive):
            self.procs.signal(name, signal.SIGINT)      # bag closed and indexed; reaped by stop()

    def launch_robot(self, robot: str) -> None:
        """(Re)start robot's whole stack (its roslaunch) against its master."""
        name = f"robot_{robot}"
        if self.procs.alive(name):
            self.procs.stop(name, grace=20.0)
        launch = str(resource("launch", "robot.launch"))
        self.procs.start(name, self.command(robot, ["roslaunch", "--skip-log-check", launch, *self.launch_args(robot)]),
                         self.env(robot, clock=True))

    def track(self) -> dict[int, ProcInfo]:
        """Scan every process of the run (called now and then, and before :meth:`stop`): what is seen
        here is stopped by :meth:`stop` even if its parent (a roslaunch) is killed before it."""
        roots = {self.procs.get(n).popen.pid for n in self.procs.names() if self.procs.alive(n)}
        tree = process_tree(roots)
        self._seen.update(tree)
        for info in tree.values():
            self._root[info.pid] = self._owner(info, tree)
        return tree

    def _owner(self, info: ProcInfo, tree: dict[int, ProcInfo]) -> str:
        leaders = {self.procs.get(n).popen.pid: n for n in self.procs.names()}
        pid = info.pid
        while pid in tree and pid not in leaders:
            pid = tree[pid].ppid
        return leaders.get(pid, "?")

    def cpu_usage(self) -> list[dict[str, object]]:
        """CPU seconds so far of every live process of the run: owner (robot_<R>, master_<R>,
        record_<R>, monitor), node/program, pid; largest first."""
        rows = [{"owner": self._root.get(info.pid, "?"), "process": info.label, "pid": info.pid,
                 "cpu_s": round(info.cpu_s, 2)} for info in self.track().values()]
        return sorted(rows, key=lambda r: -float(r["cpu_s"]))  # type: ignore[arg-type]

    def _hurry_nodes(self, owners: list[str], grace: float = NODE_GRACE) -> None:
        """roslaunch stops its nodes one by one and gives each 15 s to obey SIGINT before SIGTERM:
        a node still running ``grace`` s after the SIGINT gets SIGTERM (then SIGKILL) from here, by
        its process group (roslaunch starts each node in a session of its own)."""
        leaders = {self.procs.get(n).popen.pid for n in owners}

        def stragglers() -> list[ProcInfo]:
            return [info for info in self.leftovers()
                    if self._root.get(info.pid) in owners and info.pid not in leaders and info.pgid == info.pid]

        deadline = time.monotonic() + grace
        while stragglers() and time.monotonic() < deadline:
            time.sleep(0.2)
        for sig, wait in ((signal.SIGTERM, 2.0), (signal.SIGKILL, 1.0)):
            late = stragglers()
            if not late:
                return
            for info in late:
                with contextlib.suppress(ProcessLookupError, PermissionError):
                    os.killpg(info.pgid, sig)
                note = f"{self._root.get(info.pid, '?')[len('robot_'):]}/{info.label} ({sig.name})"
                if note not in self.forced:
                    self.forced.append(note)
            deadline = time.monotonic() + wait
            while stragglers() and time.monotonic() < deadline:
                time.sleep(0.1)

    def leftovers(self) -> list[ProcInfo]:
        """Processes of this run that are still alive (same pid and start time as when seen)."""
        left = []
        for pid, seen in self._seen.items():
            now = read_proc(pid)
            if now is not None and now.start == seen.start:
                left.append(now)
        return left

    def dead(self) -> list[str]:
        """Names of processes that should be running and are not (a failed launch, a dead master; not those of a
        machine that is off)."""
        off = {f"{kind}_{r}" for r in self.off for kind in ("robot", "master")}
        return [n for n in self.procs.names()
                if not self.procs.alive(n) and n not in self.recorders.retired and n not in off]

    def process_groups(self) -> dict[str, int]:
        """name -> process group id of every process started (each is its group's leader)."""
        return {n: self.procs.get(n).popen.pid for n in self.procs.names()}

    # -- stop ----------------------------------------------------------------
    def stop(self) -> None:
        """Stop recorders (bags closed), then robots, monitor and masters. Idempotent."""
        if self._stopped:
            return
        self._stopped = True
        for forward in self._forwards.values():
            forward.close()
        self.track()
        for name in self.procs.names():
            if name.startswith("record_"):
                self.procs.stop(name, grace=15.0)
        robots = [n for n in self.procs.names() if n.startswith("robot_")]
        for name in robots:   # every robot shuts down at the same time, then each is waited for
            if self.procs.alive(name):
                self.procs.signal(name, signal.SIGINT)
        self._hurry_nodes(robots)
        for name in robots:
            self.procs.stop(name, grace=20.0)
        self.procs.close()
        if self.timeline is not None:
            self.timeline.close()
            self.timeline = None
        if self.mates is not None:
            self.mates.close()
            self.mates = None
        for info in self.leftovers():   # a node whose roslaunch did not stop it (own session: own group)
            with contextlib.suppress(ProcessLookupError, PermissionError):
                if info.pgid == info.pid:
                    os.killpg(info.pid, signal.SIGKILL)
                else:
                    os.kill(info.pid, signal.SIGKILL)
            self.killed_leftovers.append(f"{info.label} (pid {info.pid})")
        if self.net is not None:    # whatever is left inside the machines, then the namespaces and their links
            self.killed_leftovers += [f"pid {pid} (in a machine's namespace)" for pid in self.net.destroy()]
        self.recorders.close()
