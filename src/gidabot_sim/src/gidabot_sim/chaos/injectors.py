"""The faults of a chaos run, injected one after the other and their recoveries measured (ROS-free).

:class:`Injector` runs the schedule (:mod:`gidabot_sim.chaos.schedule`) on a :class:`~gidabot_sim.chaos.run.ChaosRun`:
one handler per kind of fault puts it in place (iptables between two robots' addresses or their machines'
firewalls, SIGSTOP, SIGKILL, a master stopped, a person on ``/sim/obstacle``, a hostile message through a probe),
clears it, and measures when what it broke works again (:mod:`gidabot_sim.chaos.result`, recovery time). Faults
aimed at the trip under way hit its robots (:meth:`Injector.aim`).
"""

from __future__ import annotations

import contextlib
import os
import random
import signal
import time
from collections.abc import Callable, Iterator

from gidabot_navigation.interface import Node, RobotState, global_name
from gidabot_sim.chaos.faults import LinkCuts
from gidabot_sim.chaos.hostile import HOSTILE_COUNTERS, fill_placeholders, hostile_by_name
from gidabot_sim.chaos.obstacle import choose_obstacle
from gidabot_sim.chaos.result import FaultResult
from gidabot_sim.chaos.run import ChaosRun, latest, wall_time
from gidabot_sim.chaos.schedule import MASTER, Fault, Kind
from gidabot_sim.errors import ChaosError, FaultError, MachinesError, ProcessError
from gidabot_sim.runner.machines import Machines

CORRIDOR_WAIT = 60.0          # wall s to wait for a robot driving a long enough leg
HOSTILE_WAIT = 8.0            # wall s for the nodes to count a hostile message (they publish counters at 1 Hz)


class Injector:
    """Injects the faults of ``run``'s schedule, each in turn (:meth:`run_faults`), and clears every network fault
    at the end (:meth:`clear_network_faults`)."""

    def __init__(self, run: ChaosRun) -> None:
        self.run = run
        self.rng = random.Random(run.args.seed + 1)
        self.cuts = LinkCuts()                  # robots on one host: link cuts by address in this host's iptables

    def active_robots(self) -> list[str]:
        """The robots of the tour's trip under way: its start floor's, then its goal floor's."""
        trip = self.run.watch.active()
        if trip is None:
            return []
        return list(dict.fromkeys(r.name for f in trip for r in self.run.building.robots_on(f)))

    def busy_robot(self, robots: list[str], wait: float = 15.0) -> str | None:
        """One of ``robots`` whose status says it is running a leg (driving, or waiting at a meeting point),
        waiting up to ``wait`` s for one; None if none is."""
        deadline = time.monotonic() + wait
        while not self.run.over():
            busy = [r for r in robots if self.run.probes[r].call("plan").get("state") in (
                RobotState.GUIDING, RobotState.TO_MEETING, RobotState.WAITING)]
            if busy:
                return self.rng.choice(busy)
            if time.monotonic() >= deadline:
                return None
            self.run.pause(0.3)
        return None

    def aim(self, fault: Fault) -> Fault:
        """Faults marked ``active`` hit the trip under way (a link cut between its two robots, a node of a
        robot it needs) when there is one; otherwise they keep the robots the schedule chose."""
        if not fault.active:
            return fault
        robots = self.active_robots()
        if fault.kind in (Kind.CUT_IPTABLES, Kind.CUT_RELAY_END) and len(robots) == 2:
            order = [r.name for r in self.run.building.robots]
            a, b = sorted(robots, key=order.index)
            return Fault(fault.kind, a, b, fault.target, fault.duration, fault.gap, fault.crash, fault.active)
        if fault.kind == Kind.PARTITION and robots:           # a robot of the trip: the other may give the trip up
            return Fault(fault.kind, self.rng.choice(robots), duration=fault.duration, gap=fault.gap,
                         active=fault.active)
        if fault.kind in (Kind.NODE_RESTART, Kind.FREEZE) and robots:
            busy = self.busy_robot(robots)       # a robot driving or waiting for this trip, if one is soon
            robot = busy or self.rng.choice(robots)
            return Fault(fault.kind, robot, fault.other, fault.target, fault.duration, fault.gap, fault.crash,
                         fault.active)
        return Fault(fault.kind, fault.robot, fault.other, fault.target, fault.duration, fault.gap, fault.crash)

    def inject(self, fault: Fault) -> FaultResult:
        fault = self.aim(fault)
        res = FaultResult(fault)
        handler = {Kind.CUT_IPTABLES: self._cut_iptables, Kind.CUT_RELAY_END: self._cut_relay_end,
                   Kind.CUT_SUPERVISOR: self._kill_supervisor, Kind.MASTER_RESTART: self._restart_master,
                   Kind.NODE_RESTART: self._restart_node, Kind.FREEZE: self._freeze, Kind.CORRIDOR: self._corridor,
                   Kind.HOSTILE: self._hostile, Kind.MASTERS_DOWN: self._masters_down,
                   Kind.CUT_MASTER_RESTART: self._cut_master_restart, Kind.PARTITION: self._partition,
                   Kind.FLAPPING: self._flapping, Kind.ONE_WAY: self._one_way, Kind.LOSSY: self._lossy,
                   Kind.MACHINE_DOWN: self._machine_down}[fault.kind]
        try:
            handler(fault, res)
        except (ChaosError, FaultError, MachinesError, ProcessError, OSError) as err:
            res.skipped = res.skipped or f"{type(err).__name__}: {err}"
            if res.injected is not None and res.cleared is None:
                res.recovered = False
        return res

    def _recovery(self, res: FaultResult, recovered_at: float | None) -> None:
        """``res``'s recovery time: from its clearing to ``recovered_at`` (None: not recovered within the wait)."""
        assert res.cleared is not None
        if recovered_at is None:
            res.recovered = False
            res.detail += " not recovered within the wait"
        else:
            res.recovery_s = round(max(0.0, recovered_at - res.cleared), 3)

    @contextlib.contextmanager
    def _in_place(self, res: FaultResult, inject: Callable[[], object], clear: Callable[[], object]) -> Iterator[None]:
        """The fault in place for the block: ``inject`` it (``res.injected``: now), then ``clear`` it, also when the
        block is interrupted (``res.cleared``: then, when it was not)."""
        res.injected = wall_time()
        inject()
        try:
            yield
        finally:
            clear()
        res.cleared = wall_time()

    # -- the network between two robots: their machines' iptables, or this host's by address
    def cut(self, a: str, b: str) -> None:
        self._link(a, b, up=False)

    def restore(self, a: str, b: str) -> None:
        self._link(a, b, up=True)

    def _link(self, a: str, b: str, up: bool) -> None:
        sim = self.run.sim
        assert sim is not None
        if sim.net is not None:
            (sim.net.uncut if up else sim.net.cut)(a, b)
        else:
            ips = (self.run.building.robot(a).ip, self.run.building.robot(b).ip)
            (self.cuts.restore if up else self.cuts.cut)(*ips)

    def clear_network_faults(self) -> None:
        self.cuts.clear_all()
        if self.run.sim is not None and self.run.sim.net is not None:
            for robot in self.run.sim.net.machines:
                if robot not in self.run.sim.off:
                    self.run.sim.net.clear_faults(robot)

    def _cut_iptables(self, f: Fault, res: FaultResult) -> None:
        with self._in_place(res, lambda: self.cut(f.robot, f.other), lambda: self.restore(f.robot, f.other)):
            self.run.pause(f.duration)
        self._recovery(res, self.run.link_recovered(f.robot, f.other, res.cleared))

    def _stop_for(self, pgid: int, duration: float, res: FaultResult) -> None:
        """SIGSTOP the process group ``pgid`` for ``duration`` s, then SIGCONT (also when interrupted);
        ``res`` gets the injection and clearing times."""
        def resume() -> None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pgid, signal.SIGCONT)

        with self._in_place(res, lambda: os.killpg(pgid, signal.SIGSTOP), resume):
            self.run.pause(duration)

    def _cut_relay_end(self, f: Fault, res: FaultResult) -> None:
        pid = self.run.relay_end_pid(f.robot, f.other, f.target)
        if pid is None:
            raise ChaosError(f"relay end {f.robot}_{f.other}.{f.target} not found")
        self._stop_for(pid, f.duration, res)
        res.detail = f"pid {pid}"
        self._recovery(res, self.run.link_recovered(f.robot, f.other, res.cleared))

    def _kill_supervisor(self, f: Fault, res: FaultResult) -> None:
        ends = [(a.name, b.name, "a" if a.name == f.robot else "b") for a, b in self.run.building.relay_pairs()
                if f.robot in (a.name, b.name)]                      # this robot's end of each of its relays
        pairs = [b if a == f.robot else a for a, b, _ in ends]
        old_ends = {e: self.run.relay_end_pid(*e) for e in ends}
        pid = self.run.node_pid(f.robot, Node.RELAY_SUPERVISOR)
        res.injected = wall_time()
        self.run.killed.add(pid)
        self.run.killed.update(p for p in old_ends.values() if p)
        os.killpg(pid, signal.SIGKILL)
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not self.run.stopped():   # roslaunch respawns it; it starts new ends
            now = {k: self.run.relay_end_pid(*k) for k in old_ends}
            if all(p is not None and p != old_ends[k] for k, p in now.items()):
                break
            self.run.pause(0.2)
        else:
            raise ChaosError(f"the relay supervisor of {f.robot} did not start its ends again within 60 s")
        res.cleared = wall_time()
        res.detail = (f"its relay ends (relays with {', '.join(pairs)}) restarted "
                      f"{res.cleared - res.injected:.1f} s after the kill")
        self._recovery(res, latest([self.run.link_recovered(f.robot, o, res.cleared) for o in pairs]))

    def _restart_master(self, f: Fault, res: FaultResult) -> None:
        assert self.run.sim is not None
        res.injected = wall_time()
        self.run.sim.stop_master(f.robot, crash=f.crash)
        self.run.pause(f.duration)
        self.run.sim.start_master_again(f.robot)
        res.cleared = wall_time()
        res.detail = "SIGKILL" if f.crash else "SIGINT"
        self._recovery(res, self.run.master_recovered(f.robot, res.cleared))

    def _restart_node(self, f: Fault, res: FaultResult) -> None:
        node = global_name(f.target)
        old_uri = self.run.node_uri(f.robot, node)
        pid = self.run.node_pid(f.robot, f.target)
        res.injected = wall_time()
        self.run.killed.add(pid)
        os.killpg(pid, signal.SIGKILL)
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not self.run.stopped():
            uri = self.run.node_uri(f.robot, node)
            if uri and uri != old_uri:
                break
            self.run.pause(0.1)
        else:
            raise ChaosError(f"{node} of {f.robot} did not register again within 60 s")
        res.cleared = wall_time()
        res.detail = f"pid {pid}; back {res.cleared - res.injected:.1f} s after the kill"
        topic = "pending" if f.target == Node.GOAL_MANAGER else "status"
        others = [r for r in self.run.probes if r != f.robot]
        self._recovery(res, self.run.first_everywhere(topic, f.robot, others, res.cleared))

    def _freeze(self, f: Fault, res: FaultResult) -> None:
        assert self.run.sim is not None
        if f.target == MASTER:
            pgid = self.run.sim.procs.get(f"master_{f.robot}").popen.pid
        else:
            pgid = self.run.node_pid(f.robot, f.target)
        self._stop_for(pgid, f.duration, res)
        others = [r for r in self.run.probes if r != f.robot]
        if f.target == Node.GOAL_MANAGER:
            self._recovery(res, self.run.first_everywhere("pending", f.robot, others, res.cleared))
        elif f.target == Node.MULTIROBOT_NAVIGATION:
            self._recovery(res, self.run.first_everywhere("status", f.robot, others, res.cleared))
        elif f.target == MASTER:
            self._recovery(res, self.run.master_recovered(f.robot, res.cleared))
        else:
            res.detail = "no shared output: recovery not measured"

    def _corridor(self, f: Fault, res: FaultResult) -> None:
        deadline = time.monotonic() + CORRIDOR_WAIT
        robots = list(self.run.probes)
        while time.monotonic() < deadline and not self.run.over():
            self.rng.shuffle(robots)
            for robot in robots:
                found = self._place_person(robot, f, res)
                if found:
                    return
            self.run.pause(0.3)
        res.skipped = "no robot drove a leg long enough to block"
        res.fault = Fault(f.kind, "-", duration=f.duration, gap=f.gap)

    def _place_person(self, robot: str, f: Fault, res: FaultResult) -> bool:
        info = self.run.probes[robot].call("plan")
        if info.get("state") not in (RobotState.GUIDING, RobotState.TO_MEETING) or not info.get("pose") \
                or not info.get("plan"):
            return False
        r = self.run.building.robot(robot)
        spot = choose_obstacle(self.run.building, r.floor, tuple(info["pose"][:2]),
                               [tuple(p) for p in info["plan"]], r.radius)
        if spot is None:
            return False
        x, y, radius = spot
        oid = f"chaos_person_{len(self.run.results)}"
        probe = self.run.probes[robot]
        with self._in_place(res, lambda: probe.call("obstacle", action="add", id=oid, x=x, y=y, radius=radius),
                            lambda: probe.call("obstacle", action="remove", id=oid)):
            res.detail = f"{robot} ({info['state']}, {info['goal_uid']}): person at ({x:.1f}, {y:.1f}) r {radius} m"
            self.run.pause(f.duration)
        res.fault = Fault(f.kind, robot, target=str(info["goal_uid"]), duration=f.duration, gap=f.gap)
        return True

    def _hostile(self, f: Fault, res: FaultResult) -> None:
        """One hostile message on one master, accounted for: which node of that master rejected and counted
        it (a ``rejected*`` counter of its /diagnostics that grew; one hostile message at a time)."""
        h = hostile_by_name(f.target)
        other = next(r.name for r in self.run.building.robots if r.name != f.robot)
        msg = fill_placeholders(h.msg, f.robot, other)
        probe = self.run.probes[f.robot]
        before = probe.call("counters")["status"]
        res.injected = wall_time()
        probe.call("pub", topic=h.topic, type=h.type, msg=msg, wait=3.0)
        res.cleared = res.injected
        res.detail = f"{h.topic} ({h.type})"
        deadline = time.monotonic() + HOSTILE_WAIT
        grew: dict[str, int] = {}
        while time.monotonic() < deadline and not self.run.stopped():
            after = probe.call("counters")
            grew = {f"{name}.{key}": value - before.get(name, {}).get(key, 0)
                    for name, values in after["status"].items() for key, value in values.items()
                    if key.startswith(HOSTILE_COUNTERS) and value > before.get(name, {}).get(key, 0)}
            # every node that reports counters spoke after the message: what grew is all there is to see
            if grew and all(t > res.injected + 1.0 for t in after["heard"].values()):
                break
            self.run.pause(0.3)
        res.accounted = grew

    # -- overlapping faults -------------------------------------------------------------------
    def _masters_down(self, f: Fault, res: FaultResult) -> None:
        assert self.run.sim is not None
        robots = [f.robot, f.other]
        res.injected = wall_time()
        for r in robots:
            self.run.sim.stop_master(r, crash=f.crash)
        self.run.pause(f.duration)
        for r in robots:
            self.run.sim.start_master_again(r)
        res.cleared = wall_time()
        res.detail = f"both at once ({'SIGKILL' if f.crash else 'SIGINT'})"
        self._recovery(res, latest([self.run.master_recovered(r, res.cleared) for r in robots]))

    def _cut_master_restart(self, f: Fault, res: FaultResult) -> None:
        """The link (robot, other) is cut; meanwhile the master of ``target`` stops and starts again; then the
        link comes back. Recovered when the master serves again and the link delivers both ways."""
        sim = self.run.sim
        assert sim is not None
        with self._in_place(res, lambda: self.cut(f.robot, f.other), lambda: self.restore(f.robot, f.other)):
            self.run.pause(1.0)
            sim.stop_master(f.target, crash=True)
            self.run.pause(f.duration)
            sim.start_master_again(f.target)
            self.run.pause(2.0)
        res.detail = f"master of {f.target} restarted during the cut"
        self._recovery(res, latest([self.run.master_recovered(f.target, res.cleared),
                                    self.run.link_recovered(f.robot, f.other, res.cleared)]))

    def _partition(self, f: Fault, res: FaultResult) -> None:
        """``robot`` (for a fault aimed at the trip under way: the robot that guides the visitor now) loses the
        network; longer than ``partner_timeout``, the goal floor's robot may give the trip up (the visitor
        then asks again)."""
        assert self.run.sim is not None
        net = self.run.sim.net
        robot = f.robot
        others = [r.name for r in self.run.building.robots if r.name != robot]

        def links(up: bool) -> None:
            if net is not None:
                (net.clear_faults if up else net.partition)(robot)
            else:
                for o in others:
                    self._link(robot, o, up)

        with self._in_place(res, lambda: links(False), lambda: links(True)):
            self.run.pause(f.duration)
        self._recovery(res, latest([self.run.link_recovered(robot, o, res.cleared) for o in others]))

    # -- faults of a real network between separate machines ---------------------------------
    def _network(self) -> Machines:
        assert self.run.sim is not None
        if self.run.sim.net is None:
            raise ChaosError("this fault needs separate machines (--machines)")
        return self.run.sim.net

    def _flapping(self, f: Fault, res: FaultResult) -> None:
        """Every link goes down and up for ``duration`` s, each at its own random times."""
        net = self._network()
        pairs = [(a.name, b.name) for a, b in self.run.building.relay_pairs()]
        down: set[tuple[str, str]] = set()
        toggles = 0
        due = {p: time.monotonic() + self.rng.uniform(0.0, self.run.profile.flap_period_s[1]) for p in pairs}

        def all_up() -> None:
            for p in list(down):
                net.uncut(*p)

        with self._in_place(res, lambda: None, all_up):
            end = time.monotonic() + f.duration
            while time.monotonic() < end and not self.run.stopped():
                for p, at in due.items():
                    if time.monotonic() >= at:
                        (net.uncut if p in down else net.cut)(*p)
                        down ^= {p}
                        toggles += 1
                        due[p] = time.monotonic() + self.rng.uniform(*self.run.profile.flap_period_s)
                self.run.pause(0.1)
        res.detail = f"{toggles} link changes on {len(pairs)} links"
        self._recovery(res, self.run.all_links_recovered([r.name for r in self.run.building.robots], res.cleared))

    def _one_way(self, f: Fault, res: FaultResult) -> None:
        """Packets from ``robot`` to ``other`` dropped, the other way delivered."""
        net = self._network()
        with self._in_place(res, lambda: net.drop(f.robot, f.other), lambda: net.undrop(f.robot, f.other)):
            self.run.pause(f.duration)
        res.detail = f"{f.robot} -> {f.other} dropped, {f.other} -> {f.robot} delivered"
        self._recovery(res, self.run.link_recovered(f.robot, f.other, res.cleared))

    def _lossy(self, f: Fault, res: FaultResult) -> None:
        """A share ``target`` of the packets between ``robot`` and ``other`` dropped, each way, at random."""
        net = self._network()
        p = float(f.target)

        def lose() -> None:
            net.drop(f.robot, f.other, p)
            net.drop(f.other, f.robot, p)

        def deliver() -> None:
            net.undrop(f.robot, f.other, p)
            net.undrop(f.other, f.robot, p)

        with self._in_place(res, lose, deliver):
            self.run.pause(f.duration)
        res.detail = f"{100 * p:.0f} % of the packets dropped each way"
        self._recovery(res, self.run.link_recovered(f.robot, f.other, res.cleared))

    def _machine_down(self, f: Fault, res: FaultResult) -> None:
        """A robot's machine is gone for ``duration`` s (its processes killed, off the network), then starts
        again from its disk: a robot the trip under way does not use. Recovered when, once its status is
        published again, every link of it delivers both ways (the time its stack takes to start is
        reported apart)."""
        sim = self.run.sim
        assert sim is not None
        self._network()
        busy = set(self.active_robots())
        robot = self.rng.choice([r.name for r in self.run.building.robots if r.name not in busy])
        res.fault = Fault(f.kind, robot, duration=f.duration, gap=f.gap)
        with self._in_place(res, lambda: self.run.killed.update(sim.machine_off(robot)),
                            lambda: sim.machine_on(robot)):
            self.run.pause(f.duration)
        booted = res.cleared
        assert booted is not None
        others = [r.name for r in self.run.building.robots if r.name != robot]
        up = self.run.first_everywhere("status", robot, [robot], booted, timeout=120.0)
        res.cleared = up if up is not None else wall_time()
        res.detail = f"back on the network; its stack published its status {res.cleared - booted:.1f} s later"
        self._recovery(res, latest([self.run.link_recovered(robot, o, res.cleared) for o in others]))

    # -- the whole run ----------------------------------------------------------------------
    def run_faults(self) -> None:
        """Every fault of the schedule in turn, after its gap, until the tour is over (the rest: skipped)."""
        run = self.run
        n = len(run.schedule)
        for i, fault in enumerate(run.schedule, 1):
            run.pause(fault.gap)
            run.check_alive()
            if run.over():
                run.results.extend(FaultResult(f, skipped="the tour was over") for f in run.schedule[i - 1:])
                run.say(f"the tour is over ({run.outcome()}); {n - i + 1} fault(s) not injected")
                return
            res = self.inject(fault)
            run.results.append(res)
            run.say(f"fault {i}/{n}: {res.fault.label()}"
                    + (f": SKIPPED ({res.skipped})" if res.skipped else "")
                    + (f"; recovered in {res.recovery_s:.2f} s" if res.recovery_s is not None else "")
                    + ("; NOT RECOVERED" if not res.recovered else "")
                    + (f" [{res.detail.strip()}]" if res.detail else "")
                    + (f" | tour: {run.watch.latest}" if run.watch.latest else ""))
