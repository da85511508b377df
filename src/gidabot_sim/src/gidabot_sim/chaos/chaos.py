"""``gidabot chaos``: the simulated building runs a tour while faults are injected (issue 9).

Starts the simulated Faculty as ``gidabot demo`` does (four masters, six relays, every
robot's nodes, the simulated visitor, one rosbag per robot) plus a chaos probe on every
master, waits for the tour to start, then injects the faults of a seeded schedule one
after the other (:func:`gidabot_sim.chaos.core.make_schedule`): link cuts between two
robots (iptables between their addresses, a relay end stopped, a relay supervisor
killed), a restart of every robot's master, node restarts, process freezes, people
standing in corridors, hostile messages on any master, and overlapping faults (two
masters down at once, a link cut during a master restart, a partition longer than
``partner_timeout``). With ``--machines`` every robot is a separate machine (a network
namespace of its own, :mod:`gidabot_sim.runner.machines`) whose clock is off by up to 5
minutes, and the faults of a real network are added: a robot partitioned, every link
flapping, one-way loss, a lossy link, a robot's machine gone for 5 minutes. It measures
every recovery, waits for the tour to end, stops everything, and prints a table: faults by
kind, recovery times, what became of every request of the visitor, goals accepted /
completed / lost / duplicated, the paper's Table 3 (expected, from the probes, from the
bags), every hostile message and the node that counted it, crashed nodes, the tour
directories. Definitions and measured runs: docs/chaos.md.

    bin/gidabot chaos                          # Table 2 tour, seed 1, every kind of fault (~29)
    bin/gidabot chaos --machines --seed 7 --json   # separate machines; one JSON object on stdout
    bin/gidabot chaos --profile quick --tour tours/real_world.tour

Needs root (iptables, network namespaces). Exit status: 0 every target met, 1 a target
missed, 2 bad arguments, 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import math
import os
import random
import select
import shutil
import signal
import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any, TextIO

from gidabot_navigation.building.model import Building, load_building
from gidabot_navigation.errors import BuildingError, TourError, TourNameError
from gidabot_navigation.interface import LEG_START, WAY_STAIRS, WAYS, Node, Phase, RobotState, global_name
from gidabot_navigation.resources import resource
from gidabot_navigation.tours.tour_file import Tour, check_tour_file_name, parse_tour
from gidabot_sim.chaos import core as cc
from gidabot_sim.chaos.faults import LinkCuts
from gidabot_sim.demo.demo import POSE_RATE, POSE_WALL_HZ, STATUS_RATE, STATUS_WALL_HZ, Signals, report
from gidabot_sim.errors import ChaosError, DemoError, FaultError, MachinesError, ProcessError, ReportError
from gidabot_sim.runner.building_runner import RUNS, SimulatedBuilding, node_executable, process_tree
from gidabot_sim.runner.machines import Machines
from gidabot_sim.runner.procs import robot_address

DEFAULT_SEED = 1
SIM_S_PER_GOAL = 100.0        # a goal of the long tour takes about 100 s of sim time (docs/demo.md)
RECOVERY_WAIT = 30.0          # wall s a fault gets to recover before it counts as not recovered
CORRIDOR_WAIT = 60.0          # wall s to wait for a robot driving a long enough leg
HOSTILE_WAIT = 8.0            # wall s for the nodes to count a hostile message (they publish counters at 1 Hz)
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


# ---------------------------------------------------------------------------
# The probes
# ---------------------------------------------------------------------------

class ChaosProbeClient:
    """The chaos probe process on one master (``gidabot_sim.chaos.probe_node``), driven by JSON lines;
    ``command`` runs its command line where that master is (a robot's machine)."""

    def __init__(self, robot: str, env: dict[str, str], out: Path, log: Path, timeout: float = 30.0,
                 command: Callable[[list[str]], list[str]] = list) -> None:
        self.robot = robot
        self.out = out
        self.timeout = timeout
        out.parent.mkdir(parents=True, exist_ok=True)
        self._log = open(log, "ab")  # noqa: SIM115 - closed in close()
        argv = command([sys.executable, node_executable("gidabot_sim", "chaos_probe"), "--robot", robot,
                        "--out", str(out)])
        self.proc = subprocess.Popen(argv, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log,
                                     start_new_session=True, text=True, bufsize=1)
        self._read(60.0, "start")

    def _read(self, timeout: float, what: str) -> dict[str, Any]:
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        if not ready:
            raise ChaosError(f"chaos probe of {self.robot} did not answer {what} within {timeout:g} s")
        line = self.proc.stdout.readline()
        if not line:
            raise ChaosError(f"chaos probe of {self.robot} exited (code {self.proc.poll()})")
        return json.loads(line)

    def call(self, op: str, **kw: Any) -> dict[str, Any]:
        if self.proc.poll() is not None:
            raise ChaosError(f"chaos probe of {self.robot} exited with {self.proc.returncode}")
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps({"op": op, **kw}) + "\n")
        self.proc.stdin.flush()
        reply = self._read(self.timeout, op)
        if not reply.get("ok"):
            raise ChaosError(f"chaos probe of {self.robot}: {op} failed: {reply.get('error')}")
        return reply

    def first(self, topic: str, since: float, stamped: float | None = None) -> dict[str, float]:
        """robot -> wall time of its first ``topic`` message received after ``since`` (and stamped at or after
        ROS time ``stamped``: sent after that moment, not a stale one a link delivers when it comes back)."""
        kw = {} if stamped is None else {"stamped": stamped}
        return self.call("deliveries", topic=topic, since=since, **kw)["first"]

    def close(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(OSError, ValueError, ChaosError):
                self.call("quit")
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(timeout=5)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=5)
        for stream in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(OSError):
                stream.close()  # type: ignore[union-attr]
        self._log.close()

    def records(self) -> list[dict[str, Any]]:
        out = []
        with contextlib.suppress(FileNotFoundError), open(self.out, encoding="utf-8") as f:
            for line in f:
                with contextlib.suppress(json.JSONDecodeError):
                    out.append(json.loads(line))
        return out


class Tail:
    """New records of every probe's file since the last call (to follow the tour)."""

    def __init__(self, paths: list[Path]) -> None:
        self.offsets = dict.fromkeys(paths, 0)

    def read(self) -> list[dict[str, Any]]:
        recs = []
        for path, off in self.offsets.items():
            try:
                with open(path, encoding="utf-8") as f:
                    f.seek(off)
                    data = f.read()
            except FileNotFoundError:
                continue
            end = data.rfind("\n") + 1
            self.offsets[path] = off + end
            for line in data[:end].splitlines():
                with contextlib.suppress(json.JSONDecodeError):
                    recs.append(json.loads(line))
        return recs


@dataclass
class TourWatch:
    """The tour's progress from the probes' records: goals accepted, steps done, its end."""

    tour_file: str
    last_step: int
    robots: set[str]
    goals: set[str] = field(default_factory=set)
    floors: dict[str, tuple[float, float]] = field(default_factory=dict)   # goal uid -> (start, goal floor)
    done: set[str] = field(default_factory=set)                            # goal uids reached
    finished: bool = False
    failure: str = ""
    last_step_done: int = -1
    latest: str = ""

    def feed(self, recs: list[dict[str, Any]]) -> None:
        for r in recs:
            if r.get("k") == "goal" and r.get("c") == global_name(Node.GOAL_MANAGER) and r.get("m") == r.get("origin") \
                    and r.get("tour_file") == self.tour_file:
                self.goals.add(str(r.get("uid")))
                with contextlib.suppress(TypeError, ValueError):
                    self.floors[str(r.get("uid"))] = (float(r.get("initial_floor")), float(r.get("goal_floor")))
            if r.get("k") != "event" or r.get("robot") not in self.robots or r.get("m") != r.get("robot") \
                    or r.get("c") not in cc.GUIDING_CALLERS or r.get("tour_file") != self.tour_file:
                continue
            phase = r.get("phase")
            if phase in (Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED, Phase.NO_ROBOT_ON_FLOOR):  # (the last: found alone)
                self.done.add(str(r.get("goal_uid")))
                self.last_step_done = max(self.last_step_done, int(r.get("tour_step", -1)))
                self.latest = f"step {int(r.get('tour_step', -1)) + 1} done at {r.get('robot')}"
            if phase == Phase.TOUR_FINISHED and (r.get("tour_step") == self.last_step or r.get("leg") == LEG_START):
                self.finished = True            # (the start leg's: the tour ends on floors without robot)
            elif phase in (Phase.UNREACHABLE, Phase.TIMEOUT):   # the visit ends (PARTNER_OFFLINE: asked again)
                self.failure = f"{r.get('robot')}: phase {phase} ({r.get('detail', '')})"


    def active(self) -> tuple[float, float] | None:
        """(start floor, goal floor) of the tour's goal under way, None between goals."""
        pending = [u for u in self.floors if u not in self.done]
        return self.floors[pending[-1]] if pending else None


# ---------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------

def _now() -> float:
    return time.time()


class ChaosRun:
    """One chaos run: the building, the probes, the faults (see the module docstring)."""

    def __init__(self, args: argparse.Namespace, building: Building, tour: Tour, out: TextIO,
                 stop: Callable[[], bool]) -> None:
        self.args = args
        self.base = building
        self.tour = tour
        self.out = out
        self.stopped = stop
        self.profile = cc.PROFILES[args.profile]
        self.schedule = cc.make_schedule(args.seed, building, self.profile, machines=args.machines)
        self.clock_offsets = cc.clock_offsets(args.seed, building, self.profile) if args.machines else {}
        self.step_trips = cc.tour_step_trips(tour, args.start_floor, building)
        self.trips = list(self.step_trips.values())
        sched_s = cc.schedule_seconds(self.schedule)
        if args.speed is None:   # the tour must outlast the faults: ~100 s of sim time per goal; the faults take
            # longer than their schedule on a loaded machine (a relay supervisor respawned 11.7 s after its kill
            # instead of ~3 s: the quick run's tour ended with 2 of 16 faults not injected at 1.3x): 2x margin
            args.speed = round(min(20.0, max(1.5, SIM_S_PER_GOAL * len(tour.goals) / (2.0 * sched_s))), 1)
        if args.timeout is None:
            args.timeout = 240.0 + sched_s + 3.0 * SIM_S_PER_GOAL * len(tour.goals) / args.speed
        stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
        self.run_dir = args.out.resolve() / f"{stamp}-chaos-{Path(tour.file_name).stem}-seed{args.seed}"
        self.results: list[cc.FaultResult] = []
        self.probes: dict[str, ChaosProbeClient] = {}
        self.killed: set[int] = set()           # pids this run killed on purpose (expected deaths)
        self.cuts = LinkCuts()                  # robots on one host: link cuts by address in this host's iptables
        self.begin = _now()
        self.log_sizes: dict[Path, int] = {}
        self.tours_before: dict[str, dict[str, str]] = {}
        self.sim: SimulatedBuilding | None = None
        self.watch = TourWatch(tour.file_name, len(tour.goals) - 1, {r.name for r in building.robots})
        self.tail: Tail | None = None
        self.rng = random.Random(args.seed + 1)

    # -- output -----------------------------------------------------------------------------
    def say(self, text: str) -> None:
        print(f"[{_now() - self.begin:6.1f} s] {text}", file=self.out, flush=True)

    # -- start ------------------------------------------------------------------------------
    def start(self) -> None:
        args = self.args
        seed = self.run_dir / "seed_tours"
        shutil.copytree(resource("tours"), seed, dirs_exist_ok=True)
        shutil.copy(args.tour, seed / self.tour.file_name)
        launch_args = {"gui_fullscreen": "false",
                       "status_rate": f"{min(STATUS_RATE, STATUS_WALL_HZ / args.speed):.4g}",
                       "pose_rate": f"{min(POSE_RATE, POSE_WALL_HZ / args.speed):.4g}"}
        robot_args = {r.name: {"guiding_state_dir": str(self.run_dir / "guiding" / r.name)} for r in self.base.robots}
        visitor = {"tour_file": self.tour.file_name, "way": args.way, "start_floor": args.start_floor}
        addresses = ([robot_address(i, args.net) for i in range(len(self.base.robots))] if args.net is not None
                     else None)
        self.sim = SimulatedBuilding(args.building, self.run_dir, speed=args.speed, relay_secret=None,
                                     seed_tours=seed, addresses=addresses, common_args=launch_args,
                                     robot_args=robot_args, visitor=visitor, monitor=False, machines=args.machines,
                                     clock_offsets=self.clock_offsets)
        self.sim.start(cancelled=self.stopped)
        assert self.sim.building is not None
        for r in self.sim.building.robots:
            self.probes[r.name] = ChaosProbeClient(
                r.name, self.sim.env(r.name), self.run_dir / "chaos" / f"{r.name}.jsonl",
                self.run_dir / "logs" / f"probe_{r.name}.log",
                command=lambda argv, robot=r.name: self.sim.command(robot, argv))  # type: ignore[union-attr]
        self.tail = Tail([p.out for p in self.probes.values()])
        for robot, offset in self.clock_offsets.items():      # a setting of the whole run, listed with the faults
            self.results.append(cc.FaultResult(cc.Fault(cc.CLOCK_OFFSET, robot, target=f"{offset:+g} s"),
                                               injected=self.begin,
                                               detail=f"wall clock {offset:+g} s (the world keeps the host's)"))

    @property
    def building(self) -> Building:
        assert self.sim is not None and self.sim.building is not None
        return self.sim.building

    def wait_ready(self, timeout: float = 180.0) -> None:
        """Every robot's status and pending list on every master; the tour in every tour store."""
        names = set(self.probes)
        deadline = time.monotonic() + timeout
        since = _now() - 3600
        while time.monotonic() < deadline and not self.stopped():
            ok = all(set(p.first("status", since)) >= names and set(p.first("pending", since)) >= names
                     for p in self.probes.values())
            tours_ok = all((self.run_dir / "tours" / r / self.tour.file_name).exists() for r in names)
            if ok and tours_ok:
                return
            self.check_alive()
            time.sleep(0.5)
        raise ChaosError(f"the building did not come up within {timeout:g} s")

    # -- the tour ---------------------------------------------------------------------------
    def follow(self) -> None:
        assert self.tail is not None
        self.watch.feed(self.tail.read())
        if self.sim is not None:
            self.sim.housekeeping()

    def check_alive(self) -> None:
        assert self.sim is not None
        for name in self.sim.dead():
            if not name.startswith("master_"):
                raise ChaosError(f"{name} stopped unexpectedly (see {self.run_dir / 'logs'})")
        for p in self.probes.values():
            if p.proc.poll() is not None:
                raise ChaosError(f"the chaos probe of {p.robot} exited with {p.proc.returncode}")

    def pause(self, seconds: float) -> None:
        """Wait ``seconds`` of wall time, following the tour meanwhile."""
        end = time.monotonic() + seconds
        while time.monotonic() < end and not self.stopped():
            self.follow()
            time.sleep(min(0.2, max(0.0, end - time.monotonic())))

    def over(self) -> bool:
        return self.watch.finished or bool(self.watch.failure) or self.stopped() or \
            _now() - self.begin > self.args.timeout

    # -- processes --------------------------------------------------------------------------
    def processes(self, robot: str, label: str) -> list[Any]:
        assert self.sim is not None
        self.sim.track()
        owner = f"robot_{robot}"
        tree = process_tree({self.sim.procs.get(owner).popen.pid})
        return [info for info in tree.values() if info.label == label]

    def node_pid(self, robot: str, node: str) -> int:
        found = self.processes(robot, node)
        if len(found) != 1:
            raise ChaosError(f"{len(found)} processes of {node} found under {robot}'s launch")
        return found[0].pid

    def relay_end_pid(self, a: str, b: str, side: str) -> int | None:
        """The end of the relay (a, b) on ``side``'s robot (a's end connects, b's listens); an end runs as
        ``python -m gidabot_navigation.relay.end_node``."""
        for info in self.processes(a if side == "a" else b, "end_node"):
            argv = " ".join(info.argv)
            if f"--robot_a {a} " in argv and f"--robot_b {b} " in argv and f"--side {side} " in argv:
                return info.pid
        return None

    def master_uri(self, robot: str) -> str:
        return self.building.robot(robot).master_uri

    def lookup_node(self, robot: str, node: str) -> str:
        assert self.sim is not None
        return self.sim.call(robot, _lookup_node, self.master_uri(robot), node)

    # -- recovery ---------------------------------------------------------------------------
    def first_everywhere(self, topic: str, source: str, masters: list[str], since: float,
                         timeout: float = RECOVERY_WAIT) -> float | None:
        """Wall time by which ``source``'s ``topic`` (status / pending) reached every master in ``masters``
        after ``since`` (the latest of the first deliveries), None if not within ``timeout``."""
        deadline = time.monotonic() + timeout
        stamped = self.sim_time(since) - 0.1       # (a stamp is the floor's latest step)
        while time.monotonic() < deadline and not self.stopped():
            firsts = [self.probes[m].first(topic, since, stamped).get(source) for m in masters]
            if all(t is not None for t in firsts):
                return max(firsts)  # type: ignore[type-var]
            self.follow()
            time.sleep(0.1)
        return None

    def sim_time(self, wall: float) -> float:
        """The slowest floor's sim time at wall time ``wall`` (docs/simulator.md: each floor has its own clock)."""
        assert self.sim is not None
        return self.sim.sim_time_at(wall)

    def link_recovered(self, a: str, b: str, since: float) -> float | None:
        ta = self.first_everywhere("status", a, [b], since)
        tb = self.first_everywhere("status", b, [a], since)
        return None if ta is None or tb is None else max(ta, tb)

    def master_recovered(self, robot: str, since: float, timeout: float = RECOVERY_WAIT) -> float | None:
        """A fresh subscription on ``robot``'s master: by when it received every robot's status."""
        probe = self.probes[robot]
        probe.call("fresh")
        names = set(self.probes)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not self.stopped():
            first = probe.call("fresh_deliveries")["first"]
            if set(first) >= names:
                return max(first[n] for n in names)
            self.follow()
            time.sleep(0.1)
        return None

    # -- faults -----------------------------------------------------------------------------
    def active_robots(self) -> list[str]:
        """The robots of the tour's trip under way: its start floor's, then its goal floor's."""
        trip = self.watch.active()
        if trip is None:
            return []
        return list(dict.fromkeys(r.name for f in trip for r in self.building.robots_on(f)))

    def busy_robot(self, robots: list[str], wait: float = 15.0) -> str | None:
        """One of ``robots`` whose status says it is running a leg (driving, or waiting at a meeting point),
        waiting up to ``wait`` s for one; None if none is."""
        deadline = time.monotonic() + wait
        while not self.over():
            busy = [r for r in robots if self.probes[r].call("plan").get("state") in (
                RobotState.GUIDING, RobotState.TO_MEETING, RobotState.WAITING)]
            if busy:
                return self.rng.choice(busy)
            if time.monotonic() >= deadline:
                return None
            self.pause(0.3)
        return None

    def aim(self, fault: cc.Fault) -> cc.Fault:
        """Faults marked ``active`` hit the trip under way (a link cut between its two robots, a node of a
        robot it needs) when there is one; otherwise they keep the robots the schedule chose."""
        if not fault.active:
            return fault
        robots = self.active_robots()
        if fault.kind in (cc.CUT_IPTABLES, cc.CUT_RELAY_END) and len(robots) == 2:
            order = [r.name for r in self.building.robots]
            a, b = sorted(robots, key=order.index)
            return cc.Fault(fault.kind, a, b, fault.target, fault.duration, fault.gap, fault.crash, fault.active)
        if fault.kind == cc.PARTITION and robots:           # a robot of the trip: the other may give the trip up
            return cc.Fault(fault.kind, self.rng.choice(robots), duration=fault.duration, gap=fault.gap,
                            active=fault.active)
        if fault.kind in (cc.NODE_RESTART, cc.FREEZE) and robots:
            busy = self.busy_robot(robots)       # a robot driving or waiting for this trip, if one is soon
            robot = busy or self.rng.choice(robots)
            return cc.Fault(fault.kind, robot, fault.other, fault.target, fault.duration, fault.gap, fault.crash,
                            fault.active)
        return cc.Fault(fault.kind, fault.robot, fault.other, fault.target, fault.duration, fault.gap, fault.crash)

    def inject(self, fault: cc.Fault) -> cc.FaultResult:
        fault = self.aim(fault)
        res = cc.FaultResult(fault)
        handler = {cc.CUT_IPTABLES: self._cut_iptables, cc.CUT_RELAY_END: self._cut_relay_end,
                   cc.CUT_SUPERVISOR: self._kill_supervisor, cc.MASTER_RESTART: self._restart_master,
                   cc.NODE_RESTART: self._restart_node, cc.FREEZE: self._freeze, cc.CORRIDOR: self._corridor,
                   cc.HOSTILE: self._hostile, cc.MASTERS_DOWN: self._masters_down,
                   cc.CUT_MASTER_RESTART: self._cut_master_restart, cc.PARTITION: self._partition,
                   cc.FLAPPING: self._flapping, cc.ONE_WAY: self._one_way, cc.LOSSY: self._lossy,
                   cc.MACHINE_DOWN: self._machine_down}[fault.kind]
        try:
            handler(fault, res)
        except (ChaosError, FaultError, MachinesError, ProcessError, OSError) as err:
            res.skipped = res.skipped or f"{type(err).__name__}: {err}"
            if res.injected is not None and res.cleared is None:
                res.recovered = False
        return res

    def _recovery(self, res: cc.FaultResult, recovered_at: float | None) -> None:
        assert res.cleared is not None
        if recovered_at is None:
            res.recovered = False
            res.detail += " not recovered within the wait"
        else:
            res.recovery_s = round(max(0.0, recovered_at - res.cleared), 3)

    # -- the network between two robots: their machines' iptables, or this host's by address
    def cut(self, a: str, b: str) -> None:
        assert self.sim is not None
        if self.sim.net is not None:
            self.sim.net.cut(a, b)
        else:
            self.cuts.cut(self.building.robot(a).ip, self.building.robot(b).ip)

    def restore(self, a: str, b: str) -> None:
        assert self.sim is not None
        if self.sim.net is not None:
            self.sim.net.uncut(a, b)
        else:
            self.cuts.restore(self.building.robot(a).ip, self.building.robot(b).ip)

    def clear_network_faults(self) -> None:
        self.cuts.clear_all()
        if self.sim is not None and self.sim.net is not None:
            for robot in self.sim.net.machines:
                if robot not in self.sim.off:
                    self.sim.net.clear_faults(robot)

    def all_links_recovered(self, robots: list[str], since: float) -> float | None:
        """When every link between two of ``robots`` delivered both ways after ``since`` (None: one did not)."""
        times = [self.link_recovered(a, b, since) for i, a in enumerate(robots) for b in robots[i + 1:]]
        return None if any(t is None for t in times) else max(times)  # type: ignore[type-var]

    def _cut_iptables(self, f: cc.Fault, res: cc.FaultResult) -> None:
        res.injected = _now()
        self.cut(f.robot, f.other)
        try:
            self.pause(f.duration)
        finally:
            self.restore(f.robot, f.other)
        res.cleared = _now()
        self._recovery(res, self.link_recovered(f.robot, f.other, res.cleared))

    def _stop_for(self, pgid: int, duration: float, res: cc.FaultResult) -> None:
        """SIGSTOP the process group ``pgid`` for ``duration`` s, then SIGCONT (also when interrupted);
        ``res`` gets the injection and clearing times."""
        res.injected = _now()
        os.killpg(pgid, signal.SIGSTOP)
        try:
            self.pause(duration)
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pgid, signal.SIGCONT)
        res.cleared = _now()

    def _cut_relay_end(self, f: cc.Fault, res: cc.FaultResult) -> None:
        pid = self.relay_end_pid(f.robot, f.other, f.target)
        if pid is None:
            raise ChaosError(f"relay end {f.robot}_{f.other}.{f.target} not found")
        self._stop_for(pid, f.duration, res)
        res.detail = f"pid {pid}"
        self._recovery(res, self.link_recovered(f.robot, f.other, res.cleared))

    def _kill_supervisor(self, f: cc.Fault, res: cc.FaultResult) -> None:
        ends = [(a.name, b.name, "a" if a.name == f.robot else "b") for a, b in self.building.relay_pairs()
                if f.robot in (a.name, b.name)]                      # this robot's end of each of its relays
        pairs = [b if a == f.robot else a for a, b, _ in ends]
        old_ends = {e: self.relay_end_pid(*e) for e in ends}
        pid = self.node_pid(f.robot, Node.RELAY_SUPERVISOR)
        res.injected = _now()
        self.killed.add(pid)
        self.killed.update(p for p in old_ends.values() if p)
        os.killpg(pid, signal.SIGKILL)
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not self.stopped():   # roslaunch respawns it; it starts new ends
            now = {k: self.relay_end_pid(*k) for k in old_ends}
            if all(p is not None and p != old_ends[k] for k, p in now.items()):
                break
            self.pause(0.2)
        else:
            raise ChaosError(f"the relay supervisor of {f.robot} did not start its ends again within 60 s")
        res.cleared = _now()
        res.detail = (f"its relay ends (relays with {', '.join(pairs)}) restarted "
                      f"{res.cleared - res.injected:.1f} s after the kill")
        times = [self.link_recovered(f.robot, o, res.cleared) for o in pairs]
        self._recovery(res, None if any(t is None for t in times) else max(times))  # type: ignore[type-var]

    def _restart_master(self, f: cc.Fault, res: cc.FaultResult) -> None:
        assert self.sim is not None
        res.injected = _now()
        self.sim.stop_master(f.robot, crash=f.crash)
        self.pause(f.duration)
        self.sim.start_master_again(f.robot)
        res.cleared = _now()
        res.detail = "SIGKILL" if f.crash else "SIGINT"
        self._recovery(res, self.master_recovered(f.robot, res.cleared))

    def _restart_node(self, f: cc.Fault, res: cc.FaultResult) -> None:
        node = global_name(f.target)
        old_uri = self.lookup_node(f.robot, node)
        pid = self.node_pid(f.robot, f.target)
        res.injected = _now()
        self.killed.add(pid)
        os.killpg(pid, signal.SIGKILL)
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not self.stopped():
            uri = self.lookup_node(f.robot, node)
            if uri and uri != old_uri:
                break
            self.pause(0.1)
        else:
            raise ChaosError(f"{node} of {f.robot} did not register again within 60 s")
        res.cleared = _now()
        res.detail = f"pid {pid}; back {res.cleared - res.injected:.1f} s after the kill"
        topic = "pending" if f.target == Node.GOAL_MANAGER else "status"
        others = [r for r in self.probes if r != f.robot]
        self._recovery(res, self.first_everywhere(topic, f.robot, others, res.cleared))

    def _freeze(self, f: cc.Fault, res: cc.FaultResult) -> None:
        assert self.sim is not None
        if f.target == cc.MASTER:
            pgid = self.sim.procs.get(f"master_{f.robot}").popen.pid
        else:
            pgid = self.node_pid(f.robot, f.target)
        self._stop_for(pgid, f.duration, res)
        others = [r for r in self.probes if r != f.robot]
        if f.target == Node.GOAL_MANAGER:
            self._recovery(res, self.first_everywhere("pending", f.robot, others, res.cleared))
        elif f.target == Node.MULTIROBOT_NAVIGATION:
            self._recovery(res, self.first_everywhere("status", f.robot, others, res.cleared))
        elif f.target == cc.MASTER:
            self._recovery(res, self.master_recovered(f.robot, res.cleared))
        else:
            res.detail = "no shared output: recovery not measured"

    def _corridor(self, f: cc.Fault, res: cc.FaultResult) -> None:
        deadline = time.monotonic() + CORRIDOR_WAIT
        robots = list(self.probes)
        while time.monotonic() < deadline and not self.over():
            self.rng.shuffle(robots)
            for robot in robots:
                found = self._place_person(robot, f, res)
                if found:
                    return
            self.pause(0.3)
        res.skipped = "no robot drove a leg long enough to block"
        res.fault = cc.Fault(f.kind, "-", duration=f.duration, gap=f.gap)

    def _place_person(self, robot: str, f: cc.Fault, res: cc.FaultResult) -> bool:
        info = self.probes[robot].call("plan")
        if info.get("state") not in (RobotState.GUIDING, RobotState.TO_MEETING) or not info.get("pose") \
                or not info.get("plan"):
            return False
        r = self.building.robot(robot)
        spot = cc.choose_obstacle(self.building, r.floor, tuple(info["pose"][:2]),
                                  [tuple(p) for p in info["plan"]], r.radius)
        if spot is None:
            return False
        x, y, radius = spot
        oid = f"chaos_person_{len(self.results)}"
        res.injected = _now()
        self.probes[robot].call("obstacle", action="add", id=oid, x=x, y=y, radius=radius)
        res.detail = f"{robot} ({info['state']}, {info['goal_uid']}): person at ({x:.1f}, {y:.1f}) r {radius} m"
        try:
            self.pause(f.duration)
        finally:
            self.probes[robot].call("obstacle", action="remove", id=oid)
        res.cleared = _now()
        res.fault = cc.Fault(f.kind, robot, target=str(info["goal_uid"]), duration=f.duration, gap=f.gap)
        return True

    def _hostile(self, f: cc.Fault, res: cc.FaultResult) -> None:
        """One hostile message on one master, accounted for: which node of that master rejected and counted
        it (a ``rejected*`` counter of its /diagnostics that grew; one hostile message at a time)."""
        h = cc.hostile_by_name(f.target)
        other = next(r.name for r in self.building.robots if r.name != f.robot)
        msg = cc.fill_placeholders(h.msg, f.robot, other)
        probe = self.probes[f.robot]
        before = probe.call("counters")["status"]
        res.injected = _now()
        probe.call("pub", topic=h.topic, type=h.type, msg=msg, wait=3.0)
        res.cleared = res.injected
        res.detail = f"{h.topic} ({h.type})"
        deadline = time.monotonic() + HOSTILE_WAIT
        grew: dict[str, int] = {}
        while time.monotonic() < deadline and not self.stopped():
            after = probe.call("counters")
            grew = {f"{name}.{key}": value - before.get(name, {}).get(key, 0)
                    for name, values in after["status"].items() for key, value in values.items()
                    if key.startswith(cc.HOSTILE_COUNTERS) and value > before.get(name, {}).get(key, 0)}
            # every node that reports counters spoke after the message: what grew is all there is to see
            if grew and all(t > res.injected + 1.0 for t in after["heard"].values()):
                break
            self.pause(0.3)
        res.accounted = grew

    # -- overlapping faults -------------------------------------------------------------------
    def _masters_down(self, f: cc.Fault, res: cc.FaultResult) -> None:
        assert self.sim is not None
        robots = [f.robot, f.other]
        res.injected = _now()
        for r in robots:
            self.sim.stop_master(r, crash=f.crash)
        self.pause(f.duration)
        for r in robots:
            self.sim.start_master_again(r)
        res.cleared = _now()
        res.detail = f"both at once ({'SIGKILL' if f.crash else 'SIGINT'})"
        times = [self.master_recovered(r, res.cleared) for r in robots]
        self._recovery(res, None if any(t is None for t in times) else max(times))  # type: ignore[type-var]

    def _cut_master_restart(self, f: cc.Fault, res: cc.FaultResult) -> None:
        """The link (robot, other) is cut; meanwhile the master of ``target`` stops and starts again; then the
        link comes back. Recovered when the master serves again and the link delivers both ways."""
        assert self.sim is not None
        res.injected = _now()
        self.cut(f.robot, f.other)
        try:
            self.pause(1.0)
            self.sim.stop_master(f.target, crash=True)
            self.pause(f.duration)
            self.sim.start_master_again(f.target)
            self.pause(2.0)
        finally:
            self.restore(f.robot, f.other)
        res.cleared = _now()
        res.detail = f"master of {f.target} restarted during the cut"
        times = [self.master_recovered(f.target, res.cleared), self.link_recovered(f.robot, f.other, res.cleared)]
        self._recovery(res, None if any(t is None for t in times) else max(times))  # type: ignore[type-var]

    def _partition(self, f: cc.Fault, res: cc.FaultResult) -> None:
        """``robot`` (for a fault aimed at the trip under way: the robot that guides the visitor now) loses the
        network; longer than ``partner_timeout``, the goal floor's robot may give the trip up (the visitor
        then asks again)."""
        assert self.sim is not None
        robot = f.robot
        others = [r.name for r in self.building.robots if r.name != robot]
        res.injected = _now()
        if self.sim.net is not None:
            self.sim.net.partition(robot)
        else:
            for o in others:
                self.cut(robot, o)
        try:
            self.pause(f.duration)
        finally:
            if self.sim.net is not None:
                self.sim.net.clear_faults(robot)
            else:
                for o in others:
                    self.restore(robot, o)
        res.cleared = _now()
        times = [self.link_recovered(robot, o, res.cleared) for o in others]
        self._recovery(res, None if any(t is None for t in times) else max(times))  # type: ignore[type-var]

    # -- faults of a real network between separate machines ---------------------------------
    def _network(self) -> Machines:
        assert self.sim is not None
        if self.sim.net is None:
            raise ChaosError("this fault needs separate machines (--machines)")
        return self.sim.net

    def _flapping(self, f: cc.Fault, res: cc.FaultResult) -> None:
        """Every link goes down and up for ``duration`` s, each at its own random times."""
        net = self._network()
        pairs = [(a.name, b.name) for a, b in self.building.relay_pairs()]
        down: set[tuple[str, str]] = set()
        toggles = 0
        due = {p: time.monotonic() + self.rng.uniform(0.0, self.profile.flap_period_s[1]) for p in pairs}
        res.injected = _now()
        end = time.monotonic() + f.duration
        try:
            while time.monotonic() < end and not self.stopped():
                for p, at in due.items():
                    if time.monotonic() >= at:
                        (net.uncut if p in down else net.cut)(*p)
                        down ^= {p}
                        toggles += 1
                        due[p] = time.monotonic() + self.rng.uniform(*self.profile.flap_period_s)
                self.pause(0.1)
        finally:
            for p in list(down):
                net.uncut(*p)
        res.cleared = _now()
        res.detail = f"{toggles} link changes on {len(pairs)} links"
        self._recovery(res, self.all_links_recovered([r.name for r in self.building.robots], res.cleared))

    def _one_way(self, f: cc.Fault, res: cc.FaultResult) -> None:
        """Packets from ``robot`` to ``other`` dropped, the other way delivered."""
        net = self._network()
        res.injected = _now()
        net.drop(f.robot, f.other)
        try:
            self.pause(f.duration)
        finally:
            net.undrop(f.robot, f.other)
        res.cleared = _now()
        res.detail = f"{f.robot} -> {f.other} dropped, {f.other} -> {f.robot} delivered"
        self._recovery(res, self.link_recovered(f.robot, f.other, res.cleared))

    def _lossy(self, f: cc.Fault, res: cc.FaultResult) -> None:
        """A share ``target`` of the packets between ``robot`` and ``other`` dropped, each way, at random."""
        net = self._network()
        p = float(f.target)
        res.injected = _now()
        net.drop(f.robot, f.other, p)
        net.drop(f.other, f.robot, p)
        try:
            self.pause(f.duration)
        finally:
            net.undrop(f.robot, f.other, p)
            net.undrop(f.other, f.robot, p)
        res.cleared = _now()
        res.detail = f"{100 * p:.0f} % of the packets dropped each way"
        self._recovery(res, self.link_recovered(f.robot, f.other, res.cleared))

    def _machine_down(self, f: cc.Fault, res: cc.FaultResult) -> None:
        """A robot's machine is gone for ``duration`` s (its processes killed, off the network), then starts
        again from its disk: a robot the trip under way does not use. Recovered when, once its status is
        published again, every link of it delivers both ways (the time its stack takes to start is
        reported apart)."""
        assert self.sim is not None
        self._network()
        busy = set(self.active_robots())
        robot = self.rng.choice([r.name for r in self.building.robots if r.name not in busy])
        res.fault = cc.Fault(f.kind, robot, duration=f.duration, gap=f.gap)
        res.injected = _now()
        self.killed.update(self.sim.machine_off(robot))
        try:
            self.pause(f.duration)
        finally:
            self.sim.machine_on(robot)
        booted = _now()
        others = [r.name for r in self.building.robots if r.name != robot]
        up = self.first_everywhere("status", robot, [robot], booted, timeout=120.0)
        res.cleared = up if up is not None else _now()
        res.detail = f"back on the network; its stack published its status {res.cleared - booted:.1f} s later"
        times = [self.link_recovered(robot, o, res.cleared) for o in others]
        self._recovery(res, None if any(t is None for t in times) else max(times))  # type: ignore[type-var]

    # -- the whole run ----------------------------------------------------------------------
    def run_faults(self) -> None:
        n = len(self.schedule)
        for i, fault in enumerate(self.schedule, 1):
            self.pause(fault.gap)
            self.check_alive()
            if self.over():
                self.results.extend(cc.FaultResult(f, skipped="the tour was over") for f in self.schedule[i - 1:])
                self.say(f"the tour is over ({self.outcome()}); {n - i + 1} fault(s) not injected")
                return
            res = self.inject(fault)
            self.results.append(res)
            self.say(f"fault {i}/{n}: {res.fault.label()}"
                     + (f": SKIPPED ({res.skipped})" if res.skipped else "")
                     + (f"; recovered in {res.recovery_s:.2f} s" if res.recovery_s is not None else "")
                     + ("; NOT RECOVERED" if not res.recovered else "")
                     + (f" [{res.detail.strip()}]" if res.detail else "")
                     + (f" | tour: {self.watch.latest}" if self.watch.latest else ""))

    def outcome(self) -> str:
        if self.watch.finished:
            return "completed"
        if self.watch.failure:
            return f"failed: {self.watch.failure}"
        if self.stopped():
            return "interrupted"
        if _now() - self.begin > self.args.timeout:
            return f"timed out after {self.args.timeout:.0f} s (last: {self.watch.latest or 'no step done'})"
        return "not finished"

    def wait_for_tour(self) -> None:
        last = ""
        while not self.over():
            self.pause(1.0)
            self.check_alive()
            if self.watch.latest != last:
                last = self.watch.latest
                self.say(f"tour: {last}")

    # -- checks after the run ---------------------------------------------------------------
    def tour_dirs(self) -> dict[str, dict[str, str]]:
        """robot -> {file name: sha256} of every regular file of its tour directory (not the lock)."""
        out = {}
        for r in self.base.robots:
            d = self.run_dir / "tours" / r.name
            out[r.name] = {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.iterdir())
                           if p.is_file() and not p.is_symlink() and not p.name.endswith(".lock")} \
                if d.is_dir() else {}
        return out

    def tours_problems(self) -> list[str]:
        after = self.tour_dirs()
        problems = []
        for robot, before in self.tours_before.items():
            now = after.get(robot, {})
            for name in sorted(set(before) | set(now)):
                if before.get(name) != now.get(name):
                    what = "appeared" if name not in before else "vanished" if name not in now else "changed"
                    problems.append(f"{robot}: {name[:60]!r} {what}")
        tours = {robot: {n: h for n, h in files.items() if n.endswith(".tour")} for robot, files in after.items()}
        first = next(iter(tours.values()), {})
        problems += [f"{robot}'s tours differ from {self.base.robots[0].name}'s" for robot, t in tours.items()
                     if t != first]
        return problems

    def mark_logs(self) -> None:
        """Remember how long every log is now: what is written while everything stops is not counted."""
        for path in list((self.run_dir / "logs").glob("*.log")) + list((self.run_dir / "ros").rglob("*.log")):
            with contextlib.suppress(OSError):
                self.log_sizes[path] = path.stat().st_size

    def crashes(self) -> tuple[list[str], dict[str, int]]:
        """Unexpected process deaths (roslaunch, relay supervisor, our own processes) and tracebacks."""
        crashes: list[str] = []
        tbs: dict[str, int] = {}
        for path, size in self.log_sizes.items():
            try:
                with open(path, "rb") as fh:
                    text = fh.read(size).decode(errors="replace")
            except OSError:
                continue
            rel = str(path.relative_to(self.run_dir))
            n = cc.tracebacks(text)
            if n:
                tbs[rel] = n
            if path.parent.name == "logs" and path.name.startswith("robot_"):
                robot = path.stem[len("robot_"):]
                for node, pid, code in cc.roslaunch_deaths(text):
                    if pid not in self.killed:
                        crashes.append(f"{robot}/{node} died (pid {pid}, exit code {code})")
                for key, code in cc.relay_end_exits(text):
                    crashes.append(f"{robot}: relay end {key} exited with {code}")
        return crashes, tbs

    def hostile_counters(self) -> dict[str, int]:
        """Sum of every ``rejected_*`` counter on every master's /diagnostics, by kind of node."""
        total: dict[str, int] = {}
        for p in self.probes.values():
            with contextlib.suppress(ChaosError):
                for name, values in p.call("counters")["status"].items():
                    who = name.split(":")[0]
                    for k, v in values.items():
                        if k.startswith("rejected_") and v:
                            total[f"{who}.{k}"] = total.get(f"{who}.{k}", 0) + v
        return total

    def relay_counters(self) -> dict[str, int]:
        """What the relay ends of every robot did, summed: link losses, events resent, acknowledged on
        reconnection, duplicates suppressed (the journal and acknowledgements at work)."""
        total: dict[str, int] = {}
        for p in self.probes.values():
            with contextlib.suppress(ChaosError):
                for name, values in p.call("counters")["status"].items():
                    if name.startswith("relay "):
                        for k, v in values.items():
                            if k in cc.RELAY_COUNTERS:
                                total[k] = total.get(k, 0) + v
        return total


def _lookup_node(master_uri: str, node: str) -> str:
    try:
        code, _, uri = xmlrpc.client.ServerProxy(master_uri).lookupNode("/chaos", node)
    except (OSError, xmlrpc.client.Error):
        return ""
    return str(uri) if code == 1 else ""


def _load_tour(path: Path, building: Building) -> Tour:
    try:
        check_tour_file_name(path.name)
        return parse_tour(path.read_bytes(), path.name, building, source=str(path))
    except (OSError, TourError, TourNameError) as err:
        raise ChaosError(f"{path}: {err}") from err


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="gidabot chaos", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"fault schedule seed (default {DEFAULT_SEED})")
    p.add_argument("--tour", type=Path, default=resource("tours", "long_tour.tour"),
                   help="tour to run (default: tours/long_tour.tour, the paper's Table 2)")
    p.add_argument("--profile", choices=sorted(cc.PROFILES), default="full",
                   help="how many faults: full = the issue's (about 26), quick = one or two of each kind")
    p.add_argument("--speed", type=float, default=None,
                   help="sim seconds per wall second (default: slow enough for the tour to outlast the faults)")
    p.add_argument("--way", choices=WAYS, default=WAY_STAIRS)
    p.add_argument("--start-floor", type=float, default=None, help="default: the tour's first floor")
    p.add_argument("--building", type=Path, default=resource("maps", "faculty"))
    p.add_argument("--out", type=Path, default=RUNS,
                   help="output folder; the run goes to OUT/<date>-<time>-chaos-<tour>-seed<N>/")
    p.add_argument("--timeout", type=float, default=None, help="wall seconds before giving up")
    p.add_argument("--net", type=int, default=None, metavar="N", help="masters on 127.N.0.11... (tests)")
    p.add_argument("--machines", action="store_true",
                   help="every robot a separate machine (network namespace, firewall, clock off by up to 5 "
                        "minutes) and the faults of a real network between them")
    p.add_argument("--json", action="store_true", help="print the result as one JSON object (progress on stderr)")
    return p.parse_args(argv)


def run_chaos(args: argparse.Namespace, out: TextIO, stop: Signals) -> int:
    building = load_building(args.building)
    tour = _load_tour(args.tour, building)
    if args.start_floor is None:
        args.start_floor = tour.goals[0].floor
    if not building.has_robot(args.start_floor):
        raise ChaosError(f"start floor {args.start_floor:g} has no robot")
    if args.speed is not None and not (math.isfinite(args.speed) and 0 < args.speed <= 50):
        raise ChaosError(f"--speed {args.speed:g}: expected a factor in (0, 50]")
    if args.net is not None and not 1 <= args.net <= 254:
        raise ChaosError(f"--net {args.net}: expected 1..254")
    if args.net is not None and args.machines:
        raise ChaosError("--net and --machines exclude each other (separate machines have addresses of their own)")
    if shutil.which("iptables") is None:
        raise ChaosError("iptables is not installed (make setup installs it): link cuts need it")
    run = ChaosRun(args, building, tour, out, lambda: bool(stop))
    counts = {k: sum(1 for f in run.schedule if f.kind == k) for k in cc.KINDS}
    print(f"GidaBot chaos: seed {args.seed}, tour {tour.file_name} ({len(tour.goals)} goals), speed {args.speed:g}x, "
          f"{len(run.schedule)} faults ({', '.join(f'{k} {v}' for k, v in counts.items() if v)})"
          + (f"; separate machines, clocks {', '.join(f'{r} {o:+g} s' for r, o in run.clock_offsets.items())}"
             if args.machines else "") + f"\nrun folder: {run.run_dir}", file=out, flush=True)
    error = ""
    try:
        run.start()
        run.say("building started; waiting for every robot on every master")
        run.wait_ready()
        run.tours_before = run.tour_dirs()
        run.say("ready; waiting for the tour's first goal")
        while not run.watch.goals and not run.over():
            run.pause(0.5)
            run.check_alive()
        run.say(f"tour started; injecting {len(run.schedule)} faults")
        run.run_faults()
        run.wait_for_tour()
        run.say(f"tour: {run.outcome()}")
        run.pause(2.0)    # the last events reach every probe and recorder
    except (ChaosError, DemoError, ProcessError, OSError) as err:
        error = str(err)
        print(f"gidabot chaos: {err}", file=sys.stderr)
    finally:
        run.clear_network_faults()
        hostile = run.hostile_counters() if run.probes and not error else {}
        relays = run.relay_counters() if run.probes and not error else {}
        run.mark_logs()
        began = time.monotonic()
        for p in run.probes.values():
            p.close()
        if run.sim is not None:
            run.sim.stop()
            run.say(f"stopped every process in {time.monotonic() - began:.1f} s"
                    + (f"; ignored SIGINT: {', '.join(run.sim.forced)}" if run.sim.forced else ""))
    if run.sim is None or run.sim.building is None:
        return EXIT_FAILED
    return finish(run, hostile, relays, error, out)


def finish(run: ChaosRun, hostile: dict[str, int], relays: dict[str, int], error: str, out: TextIO) -> int:
    args = run.args
    assert run.sim is not None and run.sim.building is not None
    records = [rec for p in run.probes.values() for rec in p.records()]
    book = cc.Bookkeeping(run.building, records)
    fates = book.fates()
    crashes, tbs = run.crashes()
    if run.sim.forced:
        crashes += [f"ignored SIGINT at shutdown: {n}" for n in run.sim.forced]
    lost, answered, _ = book.partner_notices()
    outcome = error or run.outcome()
    # the tour's length on one clock (the host's, as the probes saw it): the robots' clocks may disagree
    events = [r for r in records if r.get("k") == "event" and r.get("tour_file") == run.tour.file_name
              and r.get("m") == r.get("robot")]
    walls = [float(e.get("w", 0.0)) for e in events]
    wall_s = max(walls) - min(walls) if walls else 0.0
    sim_s = wall_s * float(args.speed)
    run_json = {"building": "building/building.yaml", "tour": run.tour.file_name, "goals": len(run.tour.goals),
                "completed": run.watch.last_step_done + 1, "outcome": outcome, "speed": args.speed, "seed": args.seed,
                "sim_s": round(sim_s, 1), "wall_s": round(wall_s, 1),
                "robots": [{"name": r.name, "floor": r.floor, "bag": f"{r.name}.bag",
                            "bags": [p.name for p in run.sim.bags.get(r.name, [])]} for r in run.base.robots],
                "bag_parts_never_recorded": run.sim.never_recorded}
    (run.run_dir / "run.json").write_text(json.dumps(run_json, indent=2), encoding="utf-8")
    bags: dict[str, tuple[int, int]] = {}
    bags_error = ""
    try:
        rep_run, rep_records = report.load_run(run.run_dir)
        rep = report.analyse(rep_records, rep_run)
        bags = {r["name"]: (r["received"], r["processed"]) for r in rep["robots"]}
        bad = {f"{r.name} {topic}": n for r in rep_records for topic, n in r.bad.items() if n}
        if bad:
            bags_error = "unreadable messages: " + ", ".join(f"{k} {v}" for k, v in bad.items())
        (run.run_dir / "report.json").write_text(json.dumps(rep, indent=2), encoding="utf-8")
    except ReportError as err:
        bags_error = str(err)
    steps = book.visit(fates, run.tour.file_name, len(run.tour.goals))
    # the tour's Table 3; a step the system ended counts as the trip of the retry that completed it
    expected = cc.expected_table3(run.building, cc.trips_with_retries(run.step_trips, book.retried_routes(steps)))
    result = cc.ChaosResult(
        seed=args.seed, tour=run.tour.file_name, speed=args.speed, faults=run.results, fates=fates,
        duplicated_cancels=book.duplicated_cancels(), republished_cancels=book.duplicated_cancels(republished=True),
        table3_expected=expected,
        table3_measured=cc.fold_table3(run.building, book.table3(fates)),
        table3_bags=cc.fold_table3(run.building, bags) if bags else {}, tours_intact=False, tours_problems=[],
        crashes=crashes, tracebacks=tbs, hostile_rejected=hostile, partner_lost=lost, partner_answered=answered,
        tour_completed=book.tour_finished(run.tour.file_name, len(run.tour.goals) - 1), outcome=outcome,
        run_folder=str(run.run_dir), wall_s=wall_s, sim_s=sim_s, steps=steps,
        table3_bags_expected=book.table3_with(expected, fates, book.retried_goals(steps)), bags_error=bags_error,
        machines=bool(args.machines), relay_counters=relays,
        table3_tour=cc.expected_table3(run.building, run.trips))
    problems = run.tours_problems() if run.tours_before else ["the tour directories were never read"]
    result.tours_intact, result.tours_problems = not problems, problems
    doc = result.to_json()
    (run.run_dir / "chaos.json").write_text(json.dumps(doc, indent=2), encoding="utf-8")
    print("\n" + result.format(), file=out, flush=True)
    print(f"\nrun folder: {run.run_dir}  (chaos.json, chaos/<robot>.jsonl, bags, logs/)", file=out, flush=True)
    if args.json:
        print(json.dumps(doc))
    return EXIT_OK if not result.failures() else EXIT_FAILED


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    out = sys.stderr if args.json else sys.stdout
    with Signals(lambda text: print(text, file=out, flush=True)) as stop:
        try:
            code = run_chaos(args, out, stop)
        except (ChaosError, BuildingError) as err:
            print(f"gidabot chaos: {err}", file=sys.stderr)
            return EXIT_USAGE
        return EXIT_INTERRUPTED if stop else code
