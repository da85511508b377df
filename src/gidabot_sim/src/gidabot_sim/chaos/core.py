"""Fault injection for the simulated building (ROS-free core of ``gidabot chaos``).

* :func:`make_schedule` — the faults of a run, from a seed: link cuts (iptables between
  two robots' addresses, a relay end stopped, a relay supervisor killed), master
  restarts, node restarts, process freezes, blocked corridors and hostile messages.
* :class:`Bookkeeping` — what the per-master chaos probes recorded, turned into goals
  accepted / completed / lost / duplicated and the paper's Table 3.
* :func:`expected_table3` — Table 3 of a tour without faults.
* log scanning for crashed nodes (:func:`roslaunch_deaths`, :func:`tracebacks`).
* :func:`choose_obstacle` — a person standing in a robot's way that delays it but does
  not make its goal impossible.
* :class:`ChaosResult` — the printed table and the JSON object.

Definitions (docs/chaos.md):

* **accepted**: a goal published on ``/gidabot/goals`` by the ``/goal_manager`` of its
  origin robot (seen there by the probe), or one some robot ACCEPTED;
* **completed**: the goal floor's robot reported GOAL_REACHED / TOUR_STEP_DONE /
  TOUR_FINISHED for it (NO_ROBOT_ON_FLOOR from the start robot when the goal floor
  has none);
* **lost**: accepted, not cancelled, and never completed or never ACCEPTED by a robot
  it involves (the robots of its start and goal floors);
* **duplicated**: a goal or cancel uid delivered more than once on one master, or a
  robot that processed a goal twice (two ACCEPTED events, or two final events, with
  different event uids);
* **recovery time**: from the moment a fault is cleared to the first delivery across
  the affected link (both ways), on the restarted master (to a subscriber that
  registered after the restart), or of the restarted/frozen node's output on every
  other master.
"""

from __future__ import annotations

import math
import random
import re
import statistics
from collections import Counter, defaultdict
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from typing import Any

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import PlanningError
from gidabot_navigation.interface import (
    FINAL_PHASES,
    GUIDING_NODES,
    LEG_COMMITTED,
    PHASE_NAMES,
    REASON_VISITOR,
    Node,
    Phase,
    Topic,
    global_name,
    is_relay_end,
    phase_name,
)
from gidabot_navigation.tours.tour_file import Tour

# -- fault kinds ------------------------------------------------------------------------
CUT_IPTABLES = "link_cut_iptables"            # every packet between two robots' addresses dropped
CUT_RELAY_END = "link_cut_relay_end"          # one end of a pair's relay stopped (SIGSTOP), then continued
CUT_SUPERVISOR = "link_cut_relay_supervisor"  # a robot's relay supervisor killed: its ends die, roslaunch respawns it
MASTER_RESTART = "master_restart"             # a robot's master stopped and started again (empty)
NODE_RESTART = "node_restart"                 # goal_manager / multirobot_navigation killed, respawned by roslaunch
FREEZE = "process_freeze"                     # SIGSTOP, then SIGCONT
CORRIDOR = "corridor_blocked"                 # a person stands in a robot's way (sim obstacle), then leaves
HOSTILE = "hostile_message"                   # one hostile message on one master
# faults that overlap (full profile)
MASTERS_DOWN = "masters_down"                 # two robots' masters down at once, then started again
CUT_MASTER_RESTART = "link_cut_master_restart"  # a link cut while the master of one of its robots restarts
PARTITION = "partition"                       # a robot loses the network (every packet in or out dropped)
# the faults of a real network between separate machines (gidabot chaos --machines)
FLAPPING = "links_flapping"                   # every link goes down and up, each at its own random times
ONE_WAY = "one_way_loss"                      # packets from one robot to another dropped, the way back delivered
LOSSY = "lossy_link"                          # a share of the packets between two robots dropped at random
MACHINE_DOWN = "machine_down"                 # a robot's machine gone (its processes stopped, off the network)
CLOCK_OFFSET = "clock_offset"                 # a robot's clock off by up to 5 minutes, for the whole run
KINDS = (CUT_IPTABLES, CUT_RELAY_END, CUT_SUPERVISOR, MASTER_RESTART, NODE_RESTART, FREEZE, CORRIDOR, HOSTILE,
         MASTERS_DOWN, CUT_MASTER_RESTART, PARTITION, FLAPPING, ONE_WAY, LOSSY, MACHINE_DOWN, CLOCK_OFFSET)
LINK_CUTS = (CUT_IPTABLES, CUT_RELAY_END, CUT_SUPERVISOR)
MACHINES_ONLY = (FLAPPING, ONE_WAY, LOSSY, MACHINE_DOWN, CLOCK_OFFSET)
# phases and cancel reasons by which the system itself ends a trip (the visitor did not choose it)
SYSTEM_ENDS = frozenset({Phase.UNREACHABLE, Phase.TIMEOUT, Phase.PARTNER_OFFLINE})

MASTER = "master"                             # freeze target: the robot's ROS master
FREEZE_TARGETS = (*GUIDING_NODES, MASTER, Node.SIM, Node.MOVE_BASE)

# -- NavEvent phases (gidabot_msgs/NavEvent.msg) ----------------------------------------
COMPLETIONS = frozenset({Phase.GOAL_REACHED, Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED})
VISIBLE_FAILURES = frozenset({Phase.UNREACHABLE, Phase.TIMEOUT, Phase.PARTNER_OFFLINE, Phase.CANCELLED_HERE,
                              Phase.CANCELLED_ELSEWHERE})
GUIDING_CALLERS = tuple(global_name(n) for n in GUIDING_NODES)

RECOVERY_TARGET_S = 5.0
# counters by which a node says it refused (or, for a cancel of a goal never seen, kept aside) a message
HOSTILE_COUNTERS = ("rejected_", "cancel_unknown")
# what the relay ends did (their /diagnostics): links lost, events sent again on a new connection, events the
# peer said at reconnection it had stored (their acknowledgement was lost), duplicates the receiver dropped
RELAY_COUNTERS = ("link_losses", "connections", "resent", "acked_on_reconnect", "duplicates_suppressed", "dropped")


# ---------------------------------------------------------------------------
# Hostile messages
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Hostile:
    """One hostile message: ``msg`` fields ("nan", "inf", "-inf" for floats; ``["__repeat__", c, n]`` for
    a string of n characters c); ``{robot}`` in a string is this master's robot, ``{other}`` another's."""

    name: str
    topic: str
    type: str
    msg: dict[str, Any]


def _goal(**kw: Any) -> dict[str, Any]:
    base = {"uid": "{robot}/chaos/h.1", "origin_robot": "{robot}", "visitor_id": "chaos", "initial_floor": 0.0,
            "initial_pose": {"x": 30.0, "y": 12.0}, "goal_floor": 0.0,
            "goal_pose": {"position": {"x": 30.0, "y": 12.0}, "orientation": {"w": 1.0}}, "way": "stairs",
            "connector": "", "start_id": "robot", "goal_id": "001", "language": "en", "tour_step": -1}
    base.update(kw)
    return base


HOSTILE_MESSAGES: tuple[Hostile, ...] = (
    Hostile("goal_nan_pose", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/nan.1", initial_pose={"x": "nan", "y": 12.0})),
    Hostile("goal_inf_pose", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/inf.1", goal_pose={"position": {"x": "inf", "y": "-inf"},
                                                        "orientation": {"w": "nan"}})),
    Hostile("goal_unknown_floor", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/floor.1", goal_floor=7.5)),
    Hostile("goal_unknown_room", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/room.1", goal_id="999")),
    Hostile("goal_huge_strings", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/huge.1", goal_id=["__repeat__", "9", 300_000],
                  visitor_id=["__repeat__", "v", 200_000])),
    Hostile("goal_ghost_robot", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="Ghost/chaos/ghost.1", origin_robot="Ghost")),
    Hostile("cancel_unknown_goal", Topic.CANCELS, "gidabot_msgs/Cancel",
            {"uid": "{robot}/cancel/chaos.1", "goal_uid": "{robot}/nobody/chaos.404", "origin_robot": "{robot}",
             "reason": "visitor"}),
    Hostile("cancel_ghost_robot", Topic.CANCELS, "gidabot_msgs/Cancel",
            {"uid": "Ghost/cancel/chaos.2", "goal_uid": "{other}/v/gm.x.1", "origin_robot": "Ghost",
             "reason": "because"}),
    Hostile("tour_path_name", Topic.TOURS, "gidabot_msgs/Tour",
            {"uid": "{robot}/tour/chaos.1", "origin_robot": "{robot}", "editor_robot": "{robot}",
             "version": 4_000_000_000_000_000_000, "language": "en", "floor": 0.0, "tour_name": "Escape",
             "file_name": "../../../etc/chaos.tour", "tour_goals_info": ["0, 001, Copy Shop"]}),
    Hostile("tour_device_name", Topic.TOURS, "gidabot_msgs/Tour",
            {"uid": "{robot}/tour/chaos.2", "origin_robot": "{robot}", "editor_robot": "{robot}",
             "version": 1_700_000_000_000_000_000, "language": "en", "floor": 0.0, "tour_name": "Dev",
             "file_name": "con.tour", "tour_goals_info": ["0, 001, Copy Shop"]}),
    Hostile("tour_edit_hidden_name", Topic.TOUR_EDIT, "gidabot_msgs/Tour",
            {"file_name": ".gidabot-tours.json", "tour_name": "Hidden", "language": "en", "floor": 0.0,
             "tour_goals_info": ["0, 001, Copy Shop\n9, 999, injected line"]}),
    Hostile("event_unknown_phase", Topic.NAV_EVENTS, "gidabot_msgs/NavEvent",
            {"uid": "Ghost/event/chaos.1", "robot": "Ghost", "floor": "nan", "goal_uid": "{robot}/v/x",
             "phase": 200, "tour_step": 9999}),
    Hostile("status_nan_pose", Topic.STATUS, "gidabot_msgs/RobotStatus",
            {"robot": "Ghost", "floor": "inf", "nav_pose": {"position": {"x": "nan", "y": "nan"},
                                                            "orientation": {"w": "nan"}},
             "battery": "nan", "state": ["__repeat__", "s", 100_000]}),
    Hostile("pose_inf", Topic.POSES, "gidabot_msgs/NavPose",
            {"robot": "Ghost", "floor": 42.0, "nav_pose": {"position": {"x": "inf", "y": "-inf"}}}),
    Hostile("pending_spoofed", Topic.PENDING, "gidabot_msgs/PendingRequests",
            {"robot": "{robot}", "floor": "nan", "num": 3, "eta": ["nan", "inf"], "wait_new": "-inf"}),
    Hostile("command_unknown_room", Topic.VISITOR_COMMAND, "gidabot_msgs/VisitorCommand",
            {"uid": "{robot}/chaos/cmd/1", "visitor_id": "chaos", "command": 0, "goal_id": "no-such-room",
             "way": "stairs", "language": "en", "tour_step": -1}),
    Hostile("command_hostile_tour", Topic.VISITOR_COMMAND, "gidabot_msgs/VisitorCommand",
            {"uid": "{robot}/chaos/cmd/2", "visitor_id": "chaos", "command": 3, "tour_file": "../../x\\y.tour",
             "language": "xx", "tour_step": -5}),
    Hostile("command_unknown_kind", Topic.VISITOR_COMMAND, "gidabot_msgs/VisitorCommand",
            {"uid": ["__repeat__", "u", 5000], "visitor_id": "chaos", "command": 77, "goal_uid": "nope"}),
    Hostile("initialpose_nan", Topic.INITIALPOSE, "geometry_msgs/PoseWithCovarianceStamped",
            {"header": {"frame_id": "map"}, "pose": {"pose": {"position": {"x": "nan", "y": 3.0},
                                                              "orientation": {"w": 1.0}}}}),
    Hostile("obstacle_nan", Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle",
            {"id": "chaos_nan", "action": 0, "shape": 0, "x": "nan", "y": "inf", "radius": -1.0}),
)


def hostile_by_name(name: str) -> Hostile:
    for h in HOSTILE_MESSAGES:
        if h.name == name:
            return h
    raise KeyError(f"unknown hostile message {name!r} (known: {', '.join(h.name for h in HOSTILE_MESSAGES)})")


def fill_placeholders(value: Any, robot: str, other: str) -> Any:
    """``{robot}`` / ``{other}`` in every string of a message template."""
    if isinstance(value, str):
        return value.replace("{robot}", robot).replace("{other}", other)
    if isinstance(value, dict):
        return {k: fill_placeholders(v, robot, other) for k, v in value.items()}
    if isinstance(value, list) and not (value and value[0] == "__repeat__"):
        return [fill_placeholders(v, robot, other) for v in value]
    return value


# ---------------------------------------------------------------------------
# The schedule
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Profile:
    """How many faults of each kind; link cut durations are log-uniform in [cut_min_s, cut_max_s] (wall s)."""

    iptables_cuts: int = 3
    relay_end_cuts: int = 2
    supervisor_kills: int = 1
    master_restarts: int = -1          # -1: one per robot
    node_restarts: int = 2
    freezes: int = 2
    corridors: int = 2
    hostile: int = 10
    cut_min_s: float = 1.0
    cut_max_s: float = 60.0
    master_down_s: tuple[float, float] = (1.0, 5.0)
    freeze_s: tuple[float, float] = (1.0, 8.0)
    corridor_s: tuple[float, float] = (5.0, 20.0)
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
                     freezes=1, corridors=1, hostile=6, cut_min_s=2.0, cut_max_s=6.0, master_down_s=(1.0, 2.0),
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
    durations = [_log_uniform(rng, p.cut_min_s, p.cut_max_s) for _ in range(cuts)]
    if cuts >= 2:      # the whole range: one short cut and one long one
        durations[0] = rng.uniform(p.cut_min_s, min(p.cut_max_s, p.cut_min_s * 3))
        durations[1] = rng.uniform(max(p.cut_min_s, p.cut_max_s * 0.75), p.cut_max_s)
    rng.shuffle(durations)
    faults: list[Fault] = []
    for i in range(p.iptables_cuts):
        a, b = rng.choice(pairs)
        faults.append(Fault(CUT_IPTABLES, a, b, duration=round(durations[i], 1)))
    for i in range(p.relay_end_cuts):
        a, b = rng.choice(pairs)
        length = round(durations[p.iptables_cuts + i], 1)
        faults.append(Fault(CUT_RELAY_END, a, b, target=rng.choice("ab"), duration=length))
    for _ in range(p.supervisor_kills):
        faults.append(Fault(CUT_SUPERVISOR, rng.choice(robots)))
    masters = robots if p.master_restarts < 0 else rng.sample(robots, min(p.master_restarts, len(robots)))
    for r in masters:
        faults.append(Fault(MASTER_RESTART, r, duration=round(rng.uniform(*p.master_down_s), 1),
                            crash=rng.random() < 0.5))
    for i in range(p.node_restarts):
        faults.append(Fault(NODE_RESTART, rng.choice(robots), target=GUIDING_NODES[i % len(GUIDING_NODES)]))
    for _ in range(p.freezes):
        faults.append(Fault(FREEZE, rng.choice(robots), target=rng.choice(FREEZE_TARGETS),
                            duration=round(rng.uniform(*p.freeze_s), 1)))
    for _ in range(p.corridors):
        faults.append(Fault(CORRIDOR, "", duration=round(rng.uniform(*p.corridor_s), 1)))
    for _ in range(p.masters_down):
        a, b = rng.sample(robots, 2)
        faults.append(Fault(MASTERS_DOWN, a, b, duration=round(rng.uniform(*p.master_down_s), 1),
                            crash=rng.random() < 0.5))
    for _ in range(p.cut_master_restarts):
        a, b = rng.choice(pairs)
        faults.append(Fault(CUT_MASTER_RESTART, a, b, target=rng.choice((a, b)),
                            duration=round(rng.uniform(*p.master_down_s), 1)))
    for _ in range(p.long_partitions):
        faults.append(Fault(PARTITION, rng.choice(robots), duration=p.long_partition_s, active=True))
    if machines:
        for _ in range(p.partitions):
            faults.append(Fault(PARTITION, rng.choice(robots), duration=round(rng.uniform(*p.partition_s), 1)))
        for _ in range(p.flaps):
            faults.append(Fault(FLAPPING, "", duration=round(rng.uniform(*p.flap_s), 1)))
        for _ in range(p.one_way):
            a, b = rng.sample(robots, 2)
            faults.append(Fault(ONE_WAY, a, b, duration=round(rng.uniform(*p.one_way_s), 1)))
        for _ in range(p.lossy):
            a, b = rng.choice(pairs)
            faults.append(Fault(LOSSY, a, b, target=f"{p.loss:g}", duration=round(rng.uniform(*p.lossy_s), 1)))
        for _ in range(p.machine_downs):   # the robot is chosen when injected: one the trip under way does not use
            faults.append(Fault(MACHINE_DOWN, "", duration=p.machine_down_s))
    rng.shuffle(faults)
    names = [h.name for h in HOSTILE_MESSAGES]
    rng.shuffle(names)
    hostile = [Fault(HOSTILE, rng.choice(robots), target=names[i % len(names)]) for i in range(p.hostile)]
    for h in hostile:                  # between the others, at random places
        faults.insert(rng.randrange(len(faults) + 1), h)
    # half the link cuts, every node restart and freeze of a guiding node hit the trip under way
    out, cut = [], 0
    for f in faults:
        active = f.kind == NODE_RESTART or (f.kind == FREEZE and f.target in GUIDING_NODES) or f.active
        if f.kind in (CUT_IPTABLES, CUT_RELAY_END):
            active, cut = cut % 2 == 0, cut + 1
        out.append(Fault(f.kind, f.robot, f.other, f.target, f.duration,
                         0.0 if f.kind == HOSTILE else round(rng.uniform(*p.gap_s), 1), f.crash, active))
    return out


def schedule_seconds(faults: Iterable[Fault], recovery_s: float = 2.0, corridor_wait_s: float = 10.0) -> float:
    """A rough wall-time length of a schedule run back to back (to choose the sim speed)."""
    total = 0.0
    for f in faults:
        total += f.gap + f.duration
        if f.kind in (CUT_SUPERVISOR, NODE_RESTART, MACHINE_DOWN):
            total += 6.0
        if f.kind == CORRIDOR:
            total += corridor_wait_s
        if f.kind != HOSTILE:
            total += recovery_s
    return total


# ---------------------------------------------------------------------------
# Expected Table 3
# ---------------------------------------------------------------------------

def tour_trips(tour: Tour, start_floor: float, building: Building) -> list[tuple[float, float]]:
    """(start floor, goal floor) of every goal of a tour run from ``start_floor``: a stop on a floor without
    robot that follows another such stop gets no goal (the visitor finds it alone, docs/guiding.md)."""
    return list(tour_step_trips(tour, start_floor, building).values())


def tour_step_trips(tour: Tour, start_floor: float, building: Building) -> dict[int, tuple[float, float]]:
    """:func:`tour_trips` by tour step (the steps that make a goal)."""
    trips, here = {}, start_floor
    for k, g in enumerate(tour.goals):
        if not (building.has_robot(here) or building.has_robot(g.floor)):
            here = g.floor
            continue
        trips[k] = (here, g.floor)
        here = g.floor
    return trips


def trips_with_retries(step_trips: dict[int, tuple[float, float]],
                       retried: dict[int, tuple[float, float]]) -> list[tuple[float, float]]:
    """The tour's trips, a step the system ended and the visitor asked for again counted as the trip that
    completed it: the person asks again where they are (e.g. upstairs, where the start robot had sent them
    before the goal floor's robot gave up), so that trip may start on another floor than the tour's."""
    return [retried.get(k, trip) for k, trip in step_trips.items()]


def table3_rows(building: Building) -> dict[str, list[str]]:
    """The rows of Table 3: a robot, or the robots of a floor together ("Kbot+Basajaun"): which of them serves
    a leg is decided trip by trip (docs/guiding.md, who serves a leg), only their sum is known in advance."""
    rows: dict[str, list[str]] = {}
    for f in building.floors:
        robots = [r.name for r in building.robots_on(f.id)]
        if robots:
            rows["+".join(robots)] = robots
    return rows


def fold_table3(building: Building, table: dict[str, tuple[int, int]]) -> dict[str, tuple[int, int]]:
    """A per-robot Table 3 in :func:`table3_rows`: received by each robot of the row, processed by all."""
    return {row: (min(table.get(r, (0, 0))[0] for r in robots), sum(table.get(r, (0, 0))[1] for r in robots))
            for row, robots in table3_rows(building).items()}


def expected_table3(building: Building, trips: list[tuple[float, float]]) -> dict[str, tuple[int, int]]:
    """Table 3 row -> (received, processed) without faults: every goal reaches every robot; a floor's robots
    process the goals with a leg on their floor: the start leg when the trip starts there, the goal leg
    when it ends there coming from another floor."""
    out = {}
    for row, robots in table3_rows(building).items():
        floor = building.robot(robots[0]).floor
        processed = sum(1 for a, b in trips if math.isclose(a, floor) or math.isclose(b, floor))
        out[row] = (len(trips), processed)
    return out


# ---------------------------------------------------------------------------
# Bookkeeping of goals from the probes' records
# ---------------------------------------------------------------------------

@dataclass
class GoalFate:
    uid: str
    origin: str
    initial_floor: float
    goal_floor: float
    goal_id: str
    tour_step: int
    involved: list[str]
    processed_by: list[str] = field(default_factory=list)
    completed: bool = False
    cancelled: bool = False
    cancel_reasons: list[str] = field(default_factory=list)
    visible_failures: list[str] = field(default_factory=list)
    duplicated: list[str] = field(default_factory=list)
    republished: list[str] = field(default_factory=list)     # published again by its own node: see republication
    system_ended: bool = False        # a robot ended it (UNREACHABLE, TIMEOUT, PARTNER_OFFLINE): see StepFate

    @property
    def lost(self) -> bool:
        """Neither ended by anyone nor completed (by every robot it involves): dropped without a word."""
        return not self.cancelled and not self.system_ended and \
            (not self.completed or not set(self.involved) <= set(self.processed_by))


@dataclass
class StepFate:
    """What became of one thing the visitor asked for: a tour step (or the single target, step -1)."""

    step: int
    goals: list[str] = field(default_factory=list)          # the goals made for it, in order
    completed_by: str = ""                                  # the goal that completed it
    system_ends: list[str] = field(default_factory=list)    # goals the system ended: "uid: why"
    visitor_ends: list[str] = field(default_factory=list)   # goals the visitor cancelled
    refusals: int = 0                                       # requests refused with nothing queued (asked again)

    @property
    def passed(self) -> bool:
        """Completed (perhaps by a retry after the system ended a trip), or ended because the visitor chose so."""
        return bool(self.completed_by) or bool(self.visitor_ends)

    def describe(self) -> str:
        label = f"step {self.step + 1}" if self.step >= 0 else "the target"
        if self.completed_by:
            how = f"completed by {self.completed_by}"
        elif self.visitor_ends:
            how = f"ended by the visitor ({'; '.join(self.visitor_ends)})"
        else:
            how = "NOT completed" + ("" if self.goals else " (no goal was ever made for it)")
        ends = f"; ended by the system: {'; '.join(self.system_ends)}" if self.system_ends else ""
        refused = f"; {self.refusals} request(s) refused with nothing queued" if self.refusals else ""
        return f"{label}: {how}{ends}{refused}"


def republication(recs: list[dict[str, Any]]) -> bool:
    """Whether the deliveries ``recs`` of one goal attempt (or cancel) on one master are one guiding node
    publishing the same message again, each time on a new connection to the probe: a restarted goal_manager
    or multirobot_navigation publishes its outbox again (docs/chaos.md, what the faults showed, 2), and a
    publisher replays its recent events to a subscriber that connects again (``ReplayPublisher``); same uid,
    every receiver ignores it. Not one: two copies on one connection (a node that published it twice), a copy
    a relay end delivered (a relay delivers each event exactly once), copies from different publishers, and
    records without their connection number."""
    callers = {str(r.get("c", "")) for r in recs}
    conns = [r.get("n") for r in recs]
    return len(callers) == 1 and callers <= set(GUIDING_CALLERS) and \
        all(isinstance(n, int) and not isinstance(n, bool) and n > 0 for n in conns) and len(set(conns)) == len(conns)


class Bookkeeping:
    """Goals and cancels from every master's probe records (dicts, see ``chaos_probe``).

    Record kinds: ``goal`` (uid, origin, floors, goal_id, tour_step), ``cancel`` (uid, goal_uid, origin,
    reason), ``event`` (uid, robot, goal_uid, phase); each with ``m`` (the master's robot), ``c`` (the
    publisher's caller id) and ``w`` (wall time received).
    """

    def __init__(self, building: Building, records: Iterable[dict[str, Any]]) -> None:
        self.building = building
        self.robots = {r.name: r for r in building.robots}
        self.goal_records: dict[str, list[dict[str, Any]]] = defaultdict(list)     # uid -> every delivery
        self.cancel_records: dict[str, list[dict[str, Any]]] = defaultdict(list)
        self.events: dict[str, dict[str, Any]] = {}                                   # event uid -> record
        self.foreign = Counter()                                                      # hostile / unknown records
        for rec in records:
            kind = rec.get("k")
            if kind == "goal":
                self.goal_records[str(rec.get("uid"))].append(rec)
            elif kind == "cancel":
                self.cancel_records[str(rec.get("uid"))].append(rec)
            elif kind == "event":
                if self._legit_event(rec):
                    self.events.setdefault(str(rec.get("uid")), rec)
                else:
                    self.foreign["event"] += 1

    def _legit_event(self, rec: dict[str, Any]) -> bool:
        robot, phase, caller = rec.get("robot"), rec.get("phase"), str(rec.get("c", ""))
        if robot not in self.robots or not isinstance(phase, int) or phase not in PHASE_NAMES:
            return False
        if rec.get("m") == robot:
            return caller in GUIDING_CALLERS
        return is_relay_end(caller)

    # -- goals ----------------------------------------------------------------------------
    def accepted(self) -> dict[str, dict[str, Any]]:
        """uid -> the goal's record (its newest assignment attempt, from its origin's master when seen there)."""
        out: dict[str, dict[str, Any]] = {}
        for uid, recs in self.goal_records.items():
            own = [rec for rec in recs if rec.get("c") == global_name(Node.GOAL_MANAGER)
                   and rec.get("m") == rec.get("origin") in self.robots]
            if own:
                out[uid] = max(own, key=lambda rec: int(rec.get("attempt", 0)))
        accepted_events = {e.get("goal_uid") for e in self.events.values() if e.get("phase") == Phase.ACCEPTED}
        for uid in accepted_events:
            if uid and uid not in out and self.goal_records.get(uid):
                out[uid] = self.goal_records[uid][0]
        return out

    def fates(self) -> dict[str, GoalFate]:
        goals = self.accepted()
        by_goal: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for ev in self.events.values():
            by_goal[str(ev.get("goal_uid", ""))].append(ev)
        cancels: dict[str, list[str]] = defaultdict(list)
        for recs in self.cancel_records.values():
            rec = recs[0]
            if rec.get("origin") in self.robots:
                cancels[str(rec.get("goal_uid"))].append(str(rec.get("reason")))
        fates = {}
        for uid, g in goals.items():
            a, b = float(g.get("initial_floor", math.nan)), float(g.get("goal_floor", math.nan))
            # the robots its (newest) assignment committed the legs to
            start_robot = str(g.get("start_robot", "")) if g.get("start_state") == LEG_COMMITTED else ""
            goal_robot = str(g.get("goal_robot", "")) if g.get("goal_state") == LEG_COMMITTED else ""
            involved = [r for r in self.robots if r in (start_robot, goal_robot)]
            fate = GoalFate(uid, str(g.get("origin")), a, b, str(g.get("goal_id", "")), int(g.get("tour_step", -1)),
                            involved)
            completes = goal_robot or (start_robot if math.isclose(a, b) else "")
            accepted_by: dict[str, set[str]] = defaultdict(set)
            # a robot answers each proposal of a leg (attempt) and ends each leg it served once
            answers: dict[tuple[str, str, int], set[str]] = defaultdict(set)
            finals: dict[tuple[str, str], set[str]] = defaultdict(set)
            for ev in by_goal.get(uid, []):
                robot, phase = str(ev.get("robot")), int(ev.get("phase", -1))
                leg = str(ev.get("leg", ""))
                if phase == Phase.ACCEPTED:
                    accepted_by[robot].add(str(ev.get("uid")))
                    answers[(robot, leg, int(ev.get("attempt", 0)))].add(str(ev.get("uid")))
                if phase in FINAL_PHASES:
                    finals[(robot, leg)].add(str(ev.get("uid")))
                if phase in COMPLETIONS and completes and robot == completes:
                    fate.completed = True
                if phase in (Phase.NO_ROBOT_ON_FLOOR, Phase.TOUR_FINISHED) and not goal_robot and start_robot \
                        and robot == start_robot and not math.isclose(a, b):
                    fate.completed = True           # sent to a floor without robot: found alone
                if phase in VISIBLE_FAILURES:
                    fate.visible_failures.append(f"{robot}: phase {phase}")
                if phase in SYSTEM_ENDS:
                    fate.system_ended = True
            fate.processed_by = sorted(set(accepted_by) & set(involved), key=lambda r: list(self.robots).index(r))
            fate.cancel_reasons = cancels.get(uid, [])
            fate.cancelled = bool(fate.cancel_reasons)
            for (robot, leg, attempt), uids in answers.items():
                if len(uids) > 1:
                    fate.duplicated.append(f"{robot} accepted it {len(uids)} times"
                                           + (f" (its {leg} leg, attempt {attempt})" if leg else ""))
            for (robot, leg), uids in finals.items():
                if len(uids) > 1:
                    fate.duplicated.append(f"{robot} ended it {len(uids)} times" + (f" (its {leg} leg)" if leg else ""))
            per_master: dict[tuple[str, Any], list[dict[str, Any]]] = defaultdict(list)
            for r in self.goal_records[uid]:
                per_master[(str(r.get("m")), r.get("attempt", 0))].append(r)
            for (master, attempt), recs in per_master.items():
                if len(recs) < 2:
                    continue
                if republication(recs):
                    fate.republished.append(f"attempt {attempt} published {len(recs)} times on {master}'s master by "
                                            f"{recs[0].get('c')}, each on a new connection")
                else:
                    fate.duplicated.append(f"attempt {attempt} delivered {len(recs)} times on {master}'s master")
            fates[uid] = fate
        return fates

    def visit(self, fates: dict[str, GoalFate], tour_file: str, steps: int) -> list[StepFate]:
        """What became of each of the ``steps`` steps of tour ``tour_file`` (``tour_file`` "": one target) the
        visitor asked for: the goals made for it, which one completed it, the trips the system ended (a
        final phase UNREACHABLE, TIMEOUT or PARTNER_OFFLINE, or a cancel for another reason than the
        visitor's), and the requests refused with nothing queued."""
        out = {k: StepFate(k) for k in (range(steps) if tour_file else [-1])}
        goals = self.accepted()
        by_goal: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for ev in self.events.values():
            by_goal[str(ev.get("goal_uid", ""))].append(ev)
        reasons: dict[str, list[tuple[str, str]]] = defaultdict(list)     # goal uid -> (cancel origin, reason)
        for recs in self.cancel_records.values():
            rec = recs[0]
            if rec.get("origin") in self.robots:
                reasons[str(rec.get("goal_uid"))].append((str(rec.get("origin")), str(rec.get("reason"))))
        order = sorted(goals, key=lambda u: min(float(r.get("w", 0.0)) for r in self.goal_records[u]))
        for uid in order:
            g = goals[uid]
            if str(g.get("tour_file", "")) != tour_file:
                continue
            step = out.get(int(g.get("tour_step", -1)) if tour_file else -1)
            if step is None:
                continue
            step.goals.append(uid)
            if fates.get(uid) is not None and fates[uid].completed and not step.completed_by:
                step.completed_by = uid
            for ev in sorted(by_goal.get(uid, []), key=lambda e: float(e.get("w", 0.0))):
                if int(ev.get("phase", -1)) in SYSTEM_ENDS:
                    step.system_ends.append(f"{uid}: {phase_name(int(ev['phase']))} from {ev.get('robot')}"
                                            f"{' (' + str(ev.get('detail'))[:80] + ')' if ev.get('detail') else ''}")
                    break
            for origin, reason in reasons.get(uid, []):
                if reason == REASON_VISITOR:
                    step.visitor_ends.append(f"{uid}: cancelled at {origin}")
                elif not any(e.startswith(f"{uid}:") for e in step.system_ends):
                    step.system_ends.append(f"{uid}: cancelled by {origin} ({reason})")
        for ev in self.events.values():          # refusals answer a request: no goal was made
            if int(ev.get("phase", -1)) in (Phase.PARTNER_OFFLINE, Phase.REJECTED) and not ev.get("goal_uid") \
                    and str(ev.get("tour_file", "")) == tour_file:
                step = out.get(int(ev.get("tour_step", -1)) if tour_file else -1)
                if step is not None:
                    step.refusals += 1
        return list(out.values())

    def retried_routes(self, steps: list[StepFate]) -> dict[int, tuple[float, float]]:
        """Steps the system ended and a retry completed: step -> (start floor, goal floor) of the goal that
        completed it."""
        goals = self.accepted()
        out = {}
        for st in steps:
            g = goals.get(st.completed_by) if st.completed_by and st.system_ends else None
            if g is not None:
                out[st.step] = (float(g.get("initial_floor", math.nan)), float(g.get("goal_floor", math.nan)))
        return out

    def retried_goals(self, steps: list[StepFate]) -> list[str]:
        """Goals of completed steps that the system ended before a retry completed the step (each is one
        more goal in Table 3 than a run without faults has)."""
        return [uid for st in steps if st.completed_by for uid in st.goals if uid != st.completed_by]

    def table3_with(self, expected: dict[str, tuple[int, int]], fates: dict[str, GoalFate],
                    extra: list[str]) -> dict[str, tuple[int, int]]:
        """``expected`` (the rows of :func:`table3_rows`) plus the goals ``extra`` (trips the system ended and a
        retry replaced): one more received on every master that got each, one more processed by every robot
        that accepted each; a row of several robots counts as :func:`fold_table3` does."""
        more = {name: (sum(any(r.get("m") == name for r in self.goal_records.get(uid, [])) for uid in extra),
                       sum(uid in fates and name in fates[uid].processed_by for uid in extra))
                for name in self.robots}
        added = fold_table3(self.building, more)
        return {row: (rec + added.get(row, (0, 0))[0], proc + added.get(row, (0, 0))[1])
                for row, (rec, proc) in expected.items()}

    def duplicated_cancels(self, republished: bool = False) -> dict[str, list[str]]:
        """Cancel uids (of accepted goals) delivered more than once on one master (``republished``: instead,
        those only published again by their own node, see :func:`republication`)."""
        goals = self.accepted()
        out: dict[str, list[str]] = {}
        for uid, recs in self.cancel_records.items():
            if str(recs[0].get("goal_uid")) not in goals:
                continue
            per_master: dict[str, list[dict[str, Any]]] = defaultdict(list)
            for r in recs:
                per_master[str(r.get("m"))].append(r)
            found = [f"{'published' if republished else 'delivered'} {len(rs)} times on {m}'s master"
                     for m, rs in per_master.items() if len(rs) > 1 and republication(rs) == republished]
            if found:
                out[uid] = found
        return out

    def table3(self, fates: dict[str, GoalFate]) -> dict[str, tuple[int, int]]:
        """robot -> (received, processed), counting the accepted goals that were not cancelled."""
        kept = {uid for uid, f in fates.items() if not f.cancelled}
        out = {}
        for name in self.robots:
            received = sum(1 for uid in kept if any(r.get("m") == name for r in self.goal_records.get(uid, [])))
            processed = sum(1 for uid in kept if name in fates[uid].processed_by)
            out[name] = (received, processed)
        return out

    def partner_notices(self) -> tuple[int, int, list[str]]:
        """(PARTNER_LOST notices, of them followed by PARTNER_BACK or the end of that robot's part, unanswered)."""
        seq: dict[tuple[str, str], list[tuple[float, int]]] = defaultdict(list)
        for ev in self.events.values():
            seq[(str(ev.get("robot")), str(ev.get("goal_uid")))].append((float(ev.get("w", 0.0)), int(ev["phase"])))
        lost = answered = 0
        open_: list[str] = []
        for (robot, goal), items in seq.items():
            items.sort()
            for i, (_, phase) in enumerate(items):
                if phase != Phase.PARTNER_LOST:
                    continue
                lost += 1
                if any(p == Phase.PARTNER_BACK or p in FINAL_PHASES for _, p in items[i + 1:]):
                    answered += 1
                else:
                    open_.append(f"{robot} {goal}")
        return lost, answered, open_

    def tour_finished(self, tour_file: str, last_step: int) -> bool:
        return any(ev.get("phase") == Phase.TOUR_FINISHED and ev.get("tour_file") == tour_file
                   and ev.get("tour_step") == last_step for ev in self.events.values())


# ---------------------------------------------------------------------------
# Crashes in the logs
# ---------------------------------------------------------------------------

_DIED = re.compile(r"\[([A-Za-z0-9_]+)-\d+\] process has died \[pid (\d+), exit code (-?\d+)")
_END_EXIT = re.compile(r"relay end (\S+) exited with (-?\d+)")
TRACEBACK = "Traceback (most recent call last)"


def roslaunch_deaths(text: str) -> list[tuple[str, int, int]]:
    """(node, pid, exit code) of every 'process has died' line of a roslaunch output."""
    return [(m.group(1), int(m.group(2)), int(m.group(3))) for m in _DIED.finditer(text)]


def relay_end_exits(text: str) -> list[tuple[str, int]]:
    """(end key, exit code) of every relay end the supervisor saw exit."""
    return [(m.group(1), int(m.group(2))) for m in _END_EXIT.finditer(text)]


_LOGGER_PREFIX = re.compile(r"^\[(rospy\.[A-Za-z_.]+|rosmaster[A-Za-z_.]*|rosgraph[A-Za-z_.]*)\]")
_CRASH_CONTEXT = ("bad callback", "Exception in thread", "Exception ignored in")


def crash_tracebacks(text: str) -> list[str]:
    """The tracebacks of a log that mean our code failed, each as its last line (the exception).

    Counted: an exception in a subscriber callback (rospy's "bad callback"), one that ended a thread,
    and a bare traceback on a process's own output (a process that crashed). Not counted: rospy's and
    rosmaster's own reports of network events (a connection refused while a master or a node restarts,
    "Unable to report rosout", Python's "--- Logging error ---" while the master is away), which log a
    traceback but change nothing, and the second half of a chained exception."""
    lines = text.splitlines()
    found = []
    for i, line in enumerate(lines):
        at = line.find(TRACEBACK)
        if at < 0:
            continue
        head = line[:at]
        context = head
        if not head.strip():                         # a bare traceback: what introduced it?
            j = i - 1
            while j >= 0 and (not lines[j].strip() or lines[j].startswith((" ", "\t"))):
                j -= 1
            context = lines[j] if j >= 0 else ""
            if "During handling of the above exception" in context or "direct cause of the following" in context:
                continue
            if context.startswith("--- Logging error ---"):
                continue
        if any(c in context for c in _CRASH_CONTEXT):
            pass
        elif head.strip() or _LOGGER_PREFIX.match(context):
            continue                                   # a library's report of an I/O error
        k = i + 1
        while k < len(lines) and (lines[k].startswith((" ", "\t")) or not lines[k].strip()):
            k += 1
        found.append(lines[k][:200] if k < len(lines) else "?")
    return found


def tracebacks(text: str) -> int:
    """How many crash tracebacks a log holds (:func:`crash_tracebacks`)."""
    return len(crash_tracebacks(text))


# ---------------------------------------------------------------------------
# A person in a robot's way
# ---------------------------------------------------------------------------

def choose_obstacle(building: Building, floor: float, pose: tuple[float, float], plan: list[tuple[float, float]],
                    robot_radius: float, ahead: tuple[float, float] = (3.0, 9.0), radius: float = 0.3,
                    margin: float = 0.2) -> tuple[float, float, float] | None:
    """(x, y, radius) of a disc on the robot's planned path, ``ahead`` m in front of it, such that a
    path around it still exists for a robot ``margin`` m wider than this one (it delays the robot; it
    never makes the goal impossible). None when no such place exists on this plan."""
    from gidabot_navigation.building.planning import Circle, GridPlanner

    if len(plan) < 2:
        return None
    dense = [plan[0]]
    for (x0, y0), (x1, y1) in zip(plan, plan[1:], strict=False):   # a point every 0.25 m at most
        n = max(1, math.ceil(math.hypot(x1 - x0, y1 - y0) / 0.25))
        dense += [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n) for k in range(1, n + 1)]
    plan = dense
    grid = building.floor(floor).map
    planner = GridPlanner(grid, robot_radius + 0.05 + margin, inflation_radius=robot_radius + 0.7)
    goal = plan[-1]
    # distance along the plan from its point nearest to the robot
    near = min(range(len(plan)), key=lambda i: math.hypot(plan[i][0] - pose[0], plan[i][1] - pose[1]))
    along, candidates = 0.0, []
    for i in range(near + 1, len(plan)):
        along += math.hypot(plan[i][0] - plan[i - 1][0], plan[i][1] - plan[i - 1][1])
        if ahead[0] <= along <= ahead[1]:
            candidates.append(i)
        if along > ahead[1]:
            break
    if math.hypot(goal[0] - pose[0], goal[1] - pose[1]) < ahead[0] + 2.0:
        return None
    for i in candidates[len(candidates) // 2:] + candidates[:len(candidates) // 2]:
        x, y = plan[i]
        nxt = plan[min(i + 1, len(plan) - 1)]
        dx, dy = nxt[0] - plan[i - 1][0], nxt[1] - plan[i - 1][1]
        norm = math.hypot(dx, dy) or 1.0
        nx, ny = -dy / norm, dx / norm
        for offset in (0.0, 0.25, -0.25):
            cx, cy = x + nx * offset, y + ny * offset
            if math.hypot(cx - goal[0], cy - goal[1]) < radius + robot_radius + 1.5:
                continue
            if math.hypot(cx - pose[0], cy - pose[1]) < radius + robot_radius + 1.0:
                continue
            planner.clear_obstacles()
            try:
                planner.add_obstacle("chaos", Circle(cx, cy, radius))
                path = planner.plan(pose, goal)
            except PlanningError:
                continue
            if math.isfinite(path.length):
                return (round(cx, 2), round(cy, 2), radius)
    return None


# ---------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------

@dataclass
class FaultResult:
    """What happened to one fault: wall times (s since the epoch), recovery in s (None: not measured for
    this kind, or not recovered within the wait: see ``recovered``)."""

    fault: Fault
    injected: float | None = None
    cleared: float | None = None
    recovery_s: float | None = None
    recovered: bool = True
    skipped: str = ""                  # why it was not injected
    detail: str = ""
    accounted: dict[str, int] | None = None   # hostile messages: rejection counters that grew (node.counter: +n)

    def row(self) -> dict[str, Any]:
        d = asdict(self.fault)
        d.update(injected=self.injected, cleared=self.cleared, recovery_s=self.recovery_s, recovered=self.recovered,
                 skipped=self.skipped, detail=self.detail)
        if self.accounted is not None:
            d["accounted"] = self.accounted
        return d


@dataclass
class ChaosResult:
    seed: int
    tour: str
    speed: float
    faults: list[FaultResult]
    fates: dict[str, GoalFate]
    duplicated_cancels: dict[str, list[str]]
    table3_expected: dict[str, tuple[int, int]]
    table3_measured: dict[str, tuple[int, int]]
    table3_bags: dict[str, tuple[int, int]]
    tours_intact: bool
    tours_problems: list[str]
    crashes: list[str]
    tracebacks: dict[str, int]
    hostile_rejected: dict[str, int]
    partner_lost: int
    partner_answered: int
    tour_completed: bool
    outcome: str
    run_folder: str
    wall_s: float = 0.0
    sim_s: float = 0.0
    steps: list[StepFate] = field(default_factory=list)            # what the visitor asked for, and its fate
    table3_bags_expected: dict[str, tuple[int, int]] = field(default_factory=dict)   # expected + retried trips
    bags_error: str = ""                                           # the bags could not be read
    machines: bool = False
    relay_counters: dict[str, int] = field(default_factory=dict)   # RELAY_COUNTERS summed over every relay end
    republished_cancels: dict[str, list[str]] = field(default_factory=dict)   # published again by their node
    table3_tour: dict[str, tuple[int, int]] = field(default_factory=dict)     # the tour's, before retries

    # -- derived --------------------------------------------------------------------------
    def injected(self) -> list[FaultResult]:
        return [f for f in self.faults if f.injected is not None]

    def counts(self) -> dict[str, int]:
        c = Counter(f.fault.kind for f in self.injected())
        return {k: c.get(k, 0) for k in KINDS}

    def recoveries(self) -> dict[str, list[float]]:
        out: dict[str, list[float]] = defaultdict(list)
        for f in self.injected():
            if f.recovery_s is not None:
                out[f.fault.kind].append(f.recovery_s)
        return out

    def unrecovered(self) -> list[FaultResult]:
        return [f for f in self.injected() if not f.recovered]

    def max_recovery(self) -> float | None:
        values = [v for vs in self.recoveries().values() for v in vs]
        if self.unrecovered():
            return math.inf
        return max(values) if values else None

    def lost(self) -> list[str]:
        return sorted(uid for uid, f in self.fates.items() if f.lost)

    def duplicated(self) -> list[str]:
        return sorted(uid for uid, f in self.fates.items() if f.duplicated)

    def republished(self) -> list[str]:
        """Goals their own node published again after its restart (or replayed on a new connection): no
        duplicate, each receiver ignores the copy (:func:`republication`); listed apart."""
        return sorted(uid for uid, f in self.fates.items() if f.republished)

    def node_crashes(self) -> int:
        return len(self.crashes) + sum(self.tracebacks.values())

    def unaccounted_hostile(self) -> list[str]:
        """Hostile messages injected that no node of the master they were sent to rejected and counted."""
        return [f.fault.label() for f in self.injected() if f.fault.kind == HOSTILE and not f.accounted]

    def unfinished_steps(self) -> list[StepFate]:
        return [st for st in self.steps if not st.passed]

    def failures(self) -> list[str]:
        """Every target missed (empty: the run passed)."""
        out = []
        if len(self.injected()) < len([f for f in self.faults if not f.skipped]) or \
                any(f.skipped for f in self.faults if f.fault.kind != CORRIDOR):
            out.append("not every planned fault was injected")
        if self.lost():
            out.append(f"{len(self.lost())} goal(s) lost")
        if self.duplicated() or self.duplicated_cancels:
            out.append(f"{len(self.duplicated())} goal(s) and {len(self.duplicated_cancels)} cancel(s) duplicated")
        mr = self.max_recovery()
        if mr is not None and mr > RECOVERY_TARGET_S:
            out.append(f"a recovery took {'too long (not recovered)' if math.isinf(mr) else f'{mr:.1f} s'}")
        if self.unfinished_steps():
            out.append(f"{len(self.unfinished_steps())} request(s) of the visitor neither completed nor ended by the "
                       "visitor: " + "; ".join(st.describe() for st in self.unfinished_steps()))
        if self.table3_measured != self.table3_expected:
            out.append("Table 3 counts differ from the fault-free tour")
        if self.bags_error:
            out.append(f"the bags could not be read: {self.bags_error}")
        elif self.table3_bags != self.table3_bags_expected:
            out.append("Table 3 from the bags differs from the tour's (with the retried trips)")
        if self.unaccounted_hostile():
            out.append(f"{len(self.unaccounted_hostile())} hostile message(s) not rejected and counted by any node: "
                       + "; ".join(self.unaccounted_hostile()))
        if not self.tours_intact:
            out.append("a tour directory changed")
        if self.partner_answered < self.partner_lost:
            out.append(f"{self.partner_lost - self.partner_answered} 'partner lost' notice(s) never followed by "
                       "'partner back' or the end of that robot's part")
        if self.node_crashes():
            out.append(f"{self.node_crashes()} node crash(es)")
        if not self.tour_completed:
            out.append(f"the tour was not completed ({self.outcome})")
        return out

    def to_json(self) -> dict[str, Any]:
        rec = {k: {"n": len(v), "max_s": round(max(v), 2), "median_s": round(statistics.median(v), 2)}
               for k, v in self.recoveries().items()}
        mr = self.max_recovery()
        table = {k: list(v) for k, v in self.table3_bags.items()}
        return {
            "seed": self.seed, "tour": self.tour, "speed": self.speed, "machines": self.machines,
            "faults": [f.row() for f in self.faults], "fault_counts": self.counts(),
            "faults_injected": len(self.injected()), "faults_planned": len(self.faults),
            "accepted": len(self.fates),
            "completed": sum(1 for f in self.fates.values() if f.completed),
            "cancelled": sum(1 for f in self.fates.values() if f.cancelled),
            "lost": len(self.lost()), "duplicated": len(self.duplicated()),
            "cancels_duplicated": len(self.duplicated_cancels),
            "republished": len(self.republished()), "cancels_republished": len(self.republished_cancels),
            "republished_goals": {u: self.fates[u].republished for u in self.republished()},
            "republished_cancels": self.republished_cancels,
            "max_recovery_s": None if mr is None else (round(mr, 2) if math.isfinite(mr) else "not recovered"),
            "recovery": rec,
            "requests": [{"step": st.step, "passed": st.passed, "goals": st.goals, "completed_by": st.completed_by,
                          "system_ends": st.system_ends, "visitor_ends": st.visitor_ends, "refusals": st.refusals}
                         for st in self.steps],
            "ended_by_system": [e for st in self.steps for e in st.system_ends],
            "node_crashes": self.node_crashes(), "crashes": self.crashes, "tracebacks": self.tracebacks,
            "table3_bags": table,
            "table3": {"expected": {k: list(v) for k, v in self.table3_expected.items()},
                       "measured": {k: list(v) for k, v in self.table3_measured.items()},
                       "bags": table, "bags_expected": {k: list(v) for k, v in self.table3_bags_expected.items()},
                       "bags_error": self.bags_error,
                       "tour": {k: list(v) for k, v in (self.table3_tour or self.table3_expected).items()},
                       "unchanged": self.table3_measured == self.table3_expected},
            "tours_intact": self.tours_intact, "tours_problems": self.tours_problems,
            "hostile_rejected": self.hostile_rejected,
            "hostile_unaccounted": self.unaccounted_hostile(),
            "relay_counters": self.relay_counters,
            "partner_lost": self.partner_lost, "partner_lost_answered": self.partner_answered,
            "tour_completed": self.tour_completed, "outcome": self.outcome,
            "lost_goals": self.lost(), "duplicated_goals": {u: self.fates[u].duplicated for u in self.duplicated()},
            "visible_failures": {u: f.visible_failures for u, f in self.fates.items() if f.visible_failures},
            "wall_s": round(self.wall_s, 1), "sim_s": round(self.sim_s, 1),
            "passed": not self.failures(), "failures": self.failures(),
            "run_folder": self.run_folder,
        }

    def format(self) -> str:
        lines = [f"Chaos run: seed {self.seed}, tour {self.tour}, speed {self.speed:g}x; "
                 f"wall {self.wall_s:.0f} s, sim {self.sim_s:.0f} s", "",
                 f"{'Fault kind':<28} {'Injected':>8} {'Recovery max (s)':>17} {'median (s)':>11}"]
        lines.append("-" * len(lines[-1]))
        recs = self.recoveries()
        counts = self.counts()
        for kind in KINDS:
            v = recs.get(kind, [])
            unrec = sum(1 for f in self.unrecovered() if f.fault.kind == kind)
            mx = "not recovered" if unrec else (f"{max(v):.2f}" if v else "-")
            med = f"{statistics.median(v):.2f}" if v else "-"
            lines.append(f"{kind:<28} {counts[kind]:>8} {mx:>17} {med:>11}")
        lines.append(f"{'total':<28} {len(self.injected()):>8}")
        mr = self.max_recovery()
        fates = self.fates
        crashes = f" ({'; '.join(self.crashes[:5])}{'; ...' if len(self.crashes) > 5 else ''})" if self.crashes else ""
        tbs = f"; tracebacks: {', '.join(f'{k} {v}' for k, v in self.tracebacks.items())}" if self.tracebacks else ""
        tours = "yes" if self.tours_intact else "NO: " + "; ".join(self.tours_problems)
        lines += ["",
                  f"Goals accepted {len(fates)}, completed {sum(1 for f in fates.values() if f.completed)}, "
                  f"cancelled {sum(1 for f in fates.values() if f.cancelled)}, lost {len(self.lost())}, "
                  f"duplicated {len(self.duplicated())} (cancels duplicated {len(self.duplicated_cancels)})",
                  f"Published again by their own node after its restart (same uid, ignored by every receiver; "
                  f"not duplicates): {len(self.republished())} goal(s), {len(self.republished_cancels)} cancel(s)"
                  + "".join(f"\n  {u}: {'; '.join(self.fates[u].republished)}" for u in self.republished())
                  + "".join(f"\n  cancel {u}: {'; '.join(v)}" for u, v in self.republished_cancels.items()),
                  "Max recovery: " + ("-" if mr is None else "not recovered" if math.isinf(mr) else f"{mr:.2f} s")
                  + f" (target {RECOVERY_TARGET_S:g} s)",
                  f"Partner offline notices: {self.partner_lost}, followed by 'back' or the end of the leg: "
                  f"{self.partner_answered}",
                  "Hostile messages rejected (counters): "
                  + (", ".join(f"{k} {v}" for k, v in sorted(self.hostile_rejected.items())) or "-"),
                  "Hostile messages, each rejected and counted on the master it was sent to: "
                  + (", ".join(f"{f.fault.target}@{f.fault.robot} -> "
                               + (",".join(f"{k} +{v}" for k, v in sorted((f.accounted or {}).items())) or "NOTHING")
                               for f in self.injected() if f.fault.kind == HOSTILE) or "-"),
                  "Relay ends (all links, summed): "
                  + (", ".join(f"{k} {self.relay_counters.get(k, 0)}" for k in RELAY_COUNTERS)
                     if self.relay_counters else "-"),
                  "What the visitor asked for: "
                  + (f"{sum(st.passed for st in self.steps)} of {len(self.steps)} completed or ended by the visitor"
                     if self.steps else "-"),
                  *[f"  {st.describe()}" for st in self.steps if st.system_ends or st.refusals or not st.passed],
                  f"Node crashes: {self.node_crashes()}{crashes}{tbs}",
                  f"Tour directories intact: {tours}",
                  "", f"{'Table 3':<14} {'expected':>12} {'probes':>12} {'bags':>12} {'bags expected':>14}"]
        for name, exp in self.table3_expected.items():
            m = self.table3_measured.get(name, (0, 0))
            b = self.table3_bags.get(name)
            be = self.table3_bags_expected.get(name, exp)
            lines.append(f"{name:<14} {exp[0]:>5} / {exp[1]:<4} {m[0]:>5} / {m[1]:<4} "
                         + (f"{b[0]:>5} / {b[1]:<4}" if b else f"{'-':>12}") + f" {be[0]:>6} / {be[1]:<5}")
        if self.table3_tour and self.table3_tour != self.table3_expected:
            lines.append("(expected: a step the system ended counted as the trip of the retry that completed it; "
                         "the tour's: " + ", ".join(f"{k} {a} / {b}" for k, (a, b) in self.table3_tour.items()) + ")")
        if self.bags_error:
            lines.append(f"(bags: {self.bags_error})")
        lines += ["", f"Tour: {self.outcome}"]
        failures = self.failures()
        lines.append("RESULT: " + ("PASSED (every request completed, 0 lost, 0 duplicated, recoveries within 5 s, "
                                   "Table 3 as expected from probes and bags, every hostile message counted, no "
                                   "crash, tours intact)" if not failures else "FAILED: " + "; ".join(failures)))
        return "\n".join(lines)
