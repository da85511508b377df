"""The faults of a chaos run, from a seed (ROS-free).

:func:`make_schedule` draws the faults of one run for a building and a :class:`Profile` (how many of each kind,
how long): link cuts between two robots (iptables between their addresses, a relay end stopped, a relay
supervisor killed), master restarts, node restarts, process freezes, people standing in corridors, hostile
messages and overlapping faults (two masters down at once, a link cut during a master restart, a partition
longer than ``partner_timeout``); on separate machines also the faults of a real network (a robot partitioned,
every link flapping, one-way loss, a lossy link, a robot's machine gone) and the robots' clock offsets
(:func:`clock_offsets`). The same seed, building and profile give the same schedule.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterable
from dataclasses import dataclass

from gidabot_navigation.building.model import Building
from gidabot_navigation.interface import GUIDING_NODES, Node
from gidabot_sim.chaos.hostile import HOSTILE_MESSAGES


class Kind:
    """The kinds of fault (:attr:`Fault.kind`; chaos.json's names)."""

    CUT_IPTABLES = "link_cut_iptables"             # every packet between two robots' addresses dropped
    CUT_RELAY_END = "link_cut_relay_end"           # one end of a pair's relay stopped (SIGSTOP), then continued
    CUT_SUPERVISOR = "link_cut_relay_supervisor"   # a robot's relay supervisor killed: its ends die, respawned
    MASTER_RESTART = "master_restart"              # a robot's master stopped and started again (empty)
    NODE_RESTART = "node_restart"                  # goal_manager / multirobot_navigation killed, respawned
    FREEZE = "process_freeze"                      # SIGSTOP, then SIGCONT
    CORRIDOR = "corridor_blocked"                  # a person stands in a robot's way (sim obstacle), then leaves
    HOSTILE = "hostile_message"                    # one hostile message on one master
    # faults that overlap (full profile)
    MASTERS_DOWN = "masters_down"                  # two robots' masters down at once, then started again
    CUT_MASTER_RESTART = "link_cut_master_restart"  # a link cut while the master of one of its robots restarts
    PARTITION = "partition"                        # a robot loses the network (every packet in or out dropped)
    # the faults of a real network between separate machines (gidabot chaos --machines)
    FLAPPING = "links_flapping"                    # every link goes down and up, each at its own random times
    ONE_WAY = "one_way_loss"                       # packets from one robot to another dropped, the way back delivered
    LOSSY = "lossy_link"                           # a share of the packets between two robots dropped at random
    MACHINE_DOWN = "machine_down"                  # a robot's machine gone (its processes stopped, off the network)
    CLOCK_OFFSET = "clock_offset"                  # a robot's clock off by up to 5 minutes, for the whole run


KINDS = (Kind.CUT_IPTABLES, Kind.CUT_RELAY_END, Kind.CUT_SUPERVISOR, Kind.MASTER_RESTART, Kind.NODE_RESTART,
         Kind.FREEZE, Kind.CORRIDOR, Kind.HOSTILE, Kind.MASTERS_DOWN, Kind.CUT_MASTER_RESTART, Kind.PARTITION,
         Kind.FLAPPING, Kind.ONE_WAY, Kind.LOSSY, Kind.MACHINE_DOWN, Kind.CLOCK_OFFSET)
LINK_CUTS = (Kind.CUT_IPTABLES, Kind.CUT_RELAY_END, Kind.CUT_SUPERVISOR)
MACHINES_ONLY = (Kind.FLAPPING, Kind.ONE_WAY, Kind.LOSSY, Kind.MACHINE_DOWN, Kind.CLOCK_OFFSET)

MASTER = "master"                             # freeze target: the robot's ROS master
FREEZE_TARGETS = (*GUIDING_NODES, MASTER, Node.SIM, Node.MOVE_BASE)


@dataclass(frozen=True)
class Profile:
    """How many faults of each kind, and how long each lasts (wall s): a range is drawn from uniformly, a link
    cut's log-uniformly; ``gap_s``: the wait before each fault."""

    # link cuts, master and node restarts, freezes, corridors, hostile messages
    iptables_cuts: int = 3
    relay_end_cuts: int = 2
    cut_s: tuple[float, float] = (1.0, 60.0)
    supervisor_kills: int = 1
    master_restarts: int = -1          # -1: one per robot
    master_down_s: tuple[float, float] = (1.0, 5.0)
    node_restarts: int = 2
    freezes: int = 2
    freeze_s: tuple[float, float] = (1.0, 8.0)
    corridors: int = 2
    corridor_s: tuple[float, float] = (5.0, 20.0)
    hostile: int = 10
    gap_s: tuple[float, float] = (3.0, 7.0)
    # overlapping faults
    masters_down: int = 1                  # two masters down at once
    cut_master_restarts: int = 1           # a link cut during a master restart
    long_partitions: int = 1               # at the trip under way, longer than partner_timeout
    long_partition_s: float = 150.0        # > partner_timeout (120 s): the trip may be given up, then asked again
    # separate machines only
    partitions: int = 2
    partition_s: tuple[float, float] = (5.0, 40.0)
    flaps: int = 1
    flap_s: tuple[float, float] = (20.0, 40.0)       # how long every link flaps
    flap_period_s: tuple[float, float] = (0.5, 4.0)  # each link stays up, or down, this long
    one_way: int = 2
    one_way_s: tuple[float, float] = (5.0, 30.0)
    lossy: int = 1
    lossy_s: tuple[float, float] = (10.0, 30.0)
    loss: float = 0.3                      # share of the packets a lossy link drops (each way)
    machine_downs: int = 1
    machine_down_s: float = 300.0          # > every partner timeout
    clock_offset_s: float = 300.0          # the robots' clocks spread over +-this (s)


PROFILES = {
    "full": Profile(),
    "quick": Profile(iptables_cuts=1, relay_end_cuts=1, supervisor_kills=1, master_restarts=1, node_restarts=2,
                     freezes=1, corridors=1, hostile=6, cut_s=(2.0, 6.0), master_down_s=(1.0, 2.0),
                     freeze_s=(2.0, 3.0), corridor_s=(4.0, 6.0), gap_s=(2.0, 3.0), masters_down=1,
                     cut_master_restarts=1, long_partitions=0, partitions=1, partition_s=(3.0, 6.0), flaps=1,
                     flap_s=(6.0, 8.0), one_way=1, one_way_s=(3.0, 5.0), lossy=1, lossy_s=(4.0, 6.0),
                     machine_downs=1, machine_down_s=15.0),
}


def clock_offsets(seed: int, building: Building, profile: Profile) -> dict[str, float]:
    """The robots' wall-clock offsets of a run on separate machines: spread evenly over +-``clock_offset_s``
    (the first and last of the spread at the extremes), in an order drawn from the seed."""
    names = [r.name for r in building.robots]
    rng = random.Random(seed * 7919 + 1)
    rng.shuffle(names)
    n, span = len(names), profile.clock_offset_s
    return {name: round(-span + 2 * span * k / (n - 1), 1) if n > 1 else 0.0 for k, name in enumerate(names)}


@dataclass(frozen=True)
class Fault:
    """One fault: ``robot`` (master, node, floor...), ``other`` (the pair's other robot for link cuts),
    ``target`` (node / process / hostile message / relay side), ``duration`` (wall s), ``gap`` (wall s
    to wait before it)."""

    kind: str
    robot: str
    other: str = ""
    target: str = ""
    duration: float = 0.0
    gap: float = 0.0
    crash: bool = False               # master restarts: SIGKILL instead of SIGINT
    active: bool = False              # aimed at the trip under way when injected (its two robots / a robot of it)

    def label(self) -> str:
        where = f"{self.robot}-{self.other}" if self.other else self.robot
        where += " (trip under way)" if self.active else ""
        what = f" {self.target}" if self.target else ""
        length = f" {self.duration:.1f} s" if self.duration else ""
        return f"{self.kind} {where}{what}{length}"


def _log_uniform(rng: random.Random, low: float, high: float) -> float:
    return math.exp(rng.uniform(math.log(low), math.log(high)))


def make_schedule(seed: int, building: Building, profile: Profile, machines: bool = False) -> list[Fault]:
    """The faults of one run, in order (deterministic for a seed, a building and ``machines``: the faults
    of a real network between separate machines are added only then)."""
    rng = random.Random(seed)
    robots = [r.name for r in building.robots]
    pairs = [(a.name, b.name) for a, b in building.relay_pairs()]
    p = profile
    cuts = p.iptables_cuts + p.relay_end_cuts
    shortest, longest = p.cut_s
    durations = [_log_uniform(rng, shortest, longest) for _ in range(cuts)]
    if cuts >= 2:      # the whole range: one short cut and one long one
        durations[0] = rng.uniform(shortest, min(longest, shortest * 3))
        durations[1] = rng.uniform(max(shortest, longest * 0.75), longest)
    rng.shuffle(durations)
    faults: list[Fault] = []
    for i in range(p.iptables_cuts):
        a, b = rng.choice(pairs)
        faults.append(Fault(Kind.CUT_IPTABLES, a, b, duration=round(durations[i], 1)))
    for i in range(p.relay_end_cuts):
        a, b = rng.choice(pairs)
        length = round(durations[p.iptables_cuts + i], 1)
        faults.append(Fault(Kind.CUT_RELAY_END, a, b, target=rng.choice("ab"), duration=length))
    for _ in range(p.supervisor_kills):
        faults.append(Fault(Kind.CUT_SUPERVISOR, rng.choice(robots)))
    masters = robots if p.master_restarts < 0 else rng.sample(robots, min(p.master_restarts, len(robots)))
    for r in masters:
        faults.append(Fault(Kind.MASTER_RESTART, r, duration=round(rng.uniform(*p.master_down_s), 1),
                            crash=rng.random() < 0.5))
    for i in range(p.node_restarts):
        faults.append(Fault(Kind.NODE_RESTART, rng.choice(robots), target=GUIDING_NODES[i % len(GUIDING_NODES)]))
    for _ in range(p.freezes):
        faults.append(Fault(Kind.FREEZE, rng.choice(robots), target=rng.choice(FREEZE_TARGETS),
                            duration=round(rng.uniform(*p.freeze_s), 1)))
    for _ in range(p.corridors):
        faults.append(Fault(Kind.CORRIDOR, "", duration=round(rng.uniform(*p.corridor_s), 1)))
    for _ in range(p.masters_down):
        a, b = rng.sample(robots, 2)
        faults.append(Fault(Kind.MASTERS_DOWN, a, b, duration=round(rng.uniform(*p.master_down_s), 1),
                            crash=rng.random() < 0.5))
    for _ in range(p.cut_master_restarts):
        a, b = rng.choice(pairs)
        faults.append(Fault(Kind.CUT_MASTER_RESTART, a, b, target=rng.choice((a, b)),
                            duration=round(rng.uniform(*p.master_down_s), 1)))
    for _ in range(p.long_partitions):
        faults.append(Fault(Kind.PARTITION, rng.choice(robots), duration=p.long_partition_s, active=True))
    if machines:
        for _ in range(p.partitions):
            faults.append(Fault(Kind.PARTITION, rng.choice(robots), duration=round(rng.uniform(*p.partition_s), 1)))
        for _ in range(p.flaps):
            faults.append(Fault(Kind.FLAPPING, "", duration=round(rng.uniform(*p.flap_s), 1)))
        for _ in range(p.one_way):
            a, b = rng.sample(robots, 2)
            faults.append(Fault(Kind.ONE_WAY, a, b, duration=round(rng.uniform(*p.one_way_s), 1)))
        for _ in range(p.lossy):
            a, b = rng.choice(pairs)
            faults.append(Fault(Kind.LOSSY, a, b, target=f"{p.loss:g}", duration=round(rng.uniform(*p.lossy_s), 1)))
        for _ in range(p.machine_downs):   # the robot is chosen when injected: one the trip under way does not use
            faults.append(Fault(Kind.MACHINE_DOWN, "", duration=p.machine_down_s))
    rng.shuffle(faults)
    names = [h.name for h in HOSTILE_MESSAGES]
    rng.shuffle(names)
    hostile = [Fault(Kind.HOSTILE, rng.choice(robots), target=names[i % len(names)]) for i in range(p.hostile)]
    for h in hostile:                  # between the others, at random places
        faults.insert(rng.randrange(len(faults) + 1), h)
    # half the link cuts, every node restart and freeze of a guiding node hit the trip under way
    out, cut = [], 0
    for f in faults:
        active = f.kind == Kind.NODE_RESTART or (f.kind == Kind.FREEZE and f.target in GUIDING_NODES) or f.active
        if f.kind in (Kind.CUT_IPTABLES, Kind.CUT_RELAY_END):
            active, cut = cut % 2 == 0, cut + 1
        out.append(Fault(f.kind, f.robot, f.other, f.target, f.duration,
                         0.0 if f.kind == Kind.HOSTILE else round(rng.uniform(*p.gap_s), 1), f.crash, active))
    return out


def schedule_seconds(faults: Iterable[Fault], recovery_s: float = 2.0, corridor_wait_s: float = 10.0) -> float:
    """A rough wall-time length of a schedule run back to back (to choose the sim speed)."""
    total = 0.0
    for f in faults:
        total += f.gap + f.duration
        if f.kind in (Kind.CUT_SUPERVISOR, Kind.NODE_RESTART, Kind.MACHINE_DOWN):
            total += 6.0
        if f.kind == Kind.CORRIDOR:
            total += corridor_wait_s
        if f.kind != Kind.HOSTILE:
            total += recovery_s
    return total
