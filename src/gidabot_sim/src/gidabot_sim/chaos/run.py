"""One chaos run (ROS-free): the simulated building with a chaos probe on every master, followed and measured.

:class:`ChaosRun` starts the simulated Faculty as ``gidabot demo`` does (one master per robot, the relays, every
robot's nodes, the simulated visitor, one rosbag per robot) plus a chaos probe on every master
(:class:`~gidabot_sim.chaos.probe_client.ChaosProbeClient`), waits until every robot is seen on every master,
follows the tour (:class:`~gidabot_sim.chaos.tour_watch.TourWatch`), finds the processes the faults hit
(:mod:`gidabot_sim.chaos.injectors` injects them), measures recoveries through the probes, and after the run
reads what the checks need: the tour directories, the logs (:mod:`gidabot_sim.chaos.crashes`) and the nodes'
counters.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

from gidabot_navigation.building.model import Building
from gidabot_navigation.tours.tour_file import Tour
from gidabot_sim.chaos.crashes import log_sizes, scan_logs
from gidabot_sim.chaos.probe_client import ChaosProbeClient
from gidabot_sim.chaos.result import RELAY_COUNTERS, FaultResult
from gidabot_sim.chaos.schedule import PROFILES, Fault, Kind, clock_offsets, make_schedule, schedule_seconds
from gidabot_sim.chaos.table3 import tour_step_trips
from gidabot_sim.chaos.tour_watch import Tail, TourWatch
from gidabot_sim.errors import ChaosError
from gidabot_sim.runner.building_runner import SimulatedBuilding, state_rate_args
from gidabot_sim.runner.command_line import run_folder, seed_tours
from gidabot_sim.runner.proc_info import process_tree
from gidabot_sim.runner.procs import node_uri, robot_address

SIM_S_PER_GOAL = 100.0        # a goal of the long tour takes about 100 s of sim time (docs/demo.md)
RECOVERY_WAIT = 30.0          # wall s a fault gets to recover before it counts as not recovered


def wall_time() -> float:
    """Wall time (s since the epoch): when faults are injected and cleared, what the probes record."""
    return time.time()


def latest(times: list[float | None]) -> float | None:
    """The latest of ``times`` (when every one of several things had recovered), None if one of them is None."""
    return None if any(t is None for t in times) else max(times)  # type: ignore[type-var]


class ChaosRun:
    """One chaos run: the building, its probes, the tour, the processes and recoveries the faults need."""

    def __init__(self, args: argparse.Namespace, building: Building, tour: Tour, out: TextIO,
                 stop: Callable[[], bool]) -> None:
        self.args = args
        self.base = building
        self.tour = tour
        self.out = out
        self.stopped = stop
        self.profile = PROFILES[args.profile]
        self.schedule = make_schedule(args.seed, building, self.profile, machines=args.machines)
        self.clock_offsets = clock_offsets(args.seed, building, self.profile) if args.machines else {}
        self.step_trips = tour_step_trips(tour, args.start_floor, building)
        self.trips = list(self.step_trips.values())
        sched_s = schedule_seconds(self.schedule)
        if args.speed is None:   # the tour must outlast the faults: ~100 s of sim time per goal; the faults take
            # longer than their schedule on a loaded machine (a relay supervisor respawns in seconds): 2x margin
            args.speed = round(min(20.0, max(1.5, SIM_S_PER_GOAL * len(tour.goals) / (2.0 * sched_s))), 1)
        if args.timeout is None:
            args.timeout = 240.0 + sched_s + 3.0 * SIM_S_PER_GOAL * len(tour.goals) / args.speed
        self.run_dir = run_folder(args.out, f"chaos-{Path(tour.file_name).stem}-seed{args.seed}")
        self.results: list[FaultResult] = []
        self.probes: dict[str, ChaosProbeClient] = {}
        self.killed: set[int] = set()           # pids this run killed on purpose (expected deaths)
        self.begin = wall_time()
        self.log_sizes: dict[Path, int] = {}
        self.tours_before: dict[str, dict[str, str]] = {}
        self.sim: SimulatedBuilding | None = None
        self.watch = TourWatch(tour.file_name, len(tour.goals) - 1, {r.name for r in building.robots})
        self.tail: Tail | None = None

    # -- output -----------------------------------------------------------------------------
    def say(self, text: str) -> None:
        print(f"[{wall_time() - self.begin:6.1f} s] {text}", file=self.out, flush=True)

    # -- start ------------------------------------------------------------------------------
    def start(self) -> None:
        args = self.args
        seed = seed_tours(self.run_dir, args.tour, self.tour.file_name)
        launch_args = {"gui_fullscreen": "false", **state_rate_args(args.speed)}
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
            self.results.append(FaultResult(Fault(Kind.CLOCK_OFFSET, robot, target=f"{offset:+g} s"),
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
        since = wall_time() - 3600
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
            wall_time() - self.begin > self.args.timeout

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

    def node_uri(self, robot: str, node: str) -> str:
        assert self.sim is not None
        return self.sim.call(robot, node_uri, self.master_uri(robot), node, "/chaos")

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
        """When the link between ``a`` and ``b`` delivered both ways after ``since`` (None: it did not)."""
        return latest([self.first_everywhere("status", a, [b], since), self.first_everywhere("status", b, [a], since)])

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

    def all_links_recovered(self, robots: list[str], since: float) -> float | None:
        """When every link between two of ``robots`` delivered both ways after ``since`` (None: one did not)."""
        return latest([self.link_recovered(a, b, since) for i, a in enumerate(robots) for b in robots[i + 1:]])

    def outcome(self) -> str:
        if self.watch.finished:
            return "completed"
        if self.watch.failure:
            return f"failed: {self.watch.failure}"
        if self.stopped():
            return "interrupted"
        if wall_time() - self.begin > self.args.timeout:
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
        self.log_sizes = log_sizes(self.run_dir)

    def crashes(self) -> tuple[list[str], dict[str, int]]:
        """Unexpected process deaths (roslaunch, relay supervisor, our own processes) and tracebacks."""
        return scan_logs(self.run_dir, self.log_sizes, self.killed)

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
                            if k in RELAY_COUNTERS:
                                total[k] = total.get(k, 0) + v
        return total
