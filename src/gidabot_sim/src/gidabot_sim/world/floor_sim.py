"""One floor's simulator as the ``/sim`` node runs it (ROS-free): inputs, stepping, what to publish when.

:class:`FloorSim` owns a floor's :class:`~gidabot_sim.world.world.World` (its robots, and the mates of
:mod:`gidabot_sim.world.mates`) and its clock (:class:`~gidabot_sim.world.lockstep.Stepper`). The node
posts every input it receives (:meth:`FloorSim.post`: a velocity command, a lockstep answer, a
relocation, an obstacle change) and calls :meth:`FloorSim.tick` in its loop with the wall time. A tick
applies the inputs (commands and answers all of them, the others at most ``MAX_EVENTS_PER_STEP``: a flood
waits), steps the world when the lockstep, the other floors (the building's timeline) and the speed
ceiling allow, and hands the node what to publish as :data:`Output` values, in order:

* at each stop, each robot's sensors at their sim-time rates (odometry at every stop while a lockstep
  participant drives on it, at ``rest_rate`` while the robot stands still), only to topics somebody
  listens to (``wanted``), then ``/clock`` (at most ``clock_rate_max`` per wall second);
* while the stop waits for a participant that stopped being idle during it, that participant's inputs;
* the obstacles after every change, the diagnostics every ``diagnostics_period`` wall seconds (and,
  without a timeline, the sim time a restarted simulator resumes from).

The tick returns how long the node may sleep (wall s) before the next one, unless an input wakes it.
Time is passed in: tests need no clock.
"""

from __future__ import annotations

import json
import math
import os
import queue
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building, Robot
from gidabot_navigation.building.planning import Circle, GridPlanner, Shape
from gidabot_navigation.errors import GidaBotError, PlanningError
from gidabot_navigation.interface import Topic
from gidabot_navigation.logs import Logger
from gidabot_sim.errors import ObstacleRejected, SimConfigError, SimError
from gidabot_sim.visitor.behaviour import draw_bystanders
from gidabot_sim.world.clock import Pacer, Periodic
from gidabot_sim.world.kinematics import Limits, Twist2D
from gidabot_sim.world.lockstep import CONTROLLERS, Lockstep, Stepper
from gidabot_sim.world.mates import Mates, MateState, mate_motion
from gidabot_sim.world.people import PERSON_RADIUS, Crowd, Directive, RobotDisc
from gidabot_sim.world.rejections import CountingLog
from gidabot_sim.world.timeline import Clock as TimelineClock
from gidabot_sim.world.timeline import Timeline
from gidabot_sim.world.world import COLLISION, DEADLOCK, BatteryModel, LaserSpec, RobotSpec, SimRobot, World

MAX_EVENTS_PER_STEP = 200     # inputs applied per tick (answers and commands always); a flood waits
HEARTBEAT = 0.05              # wall s between two timeline writes while the world waits
MATE_STALE = 5.0              # wall s: a mate whose simulator has not written for this long stands still
IDLE_SLEEP = 0.01             # wall s an idle floor sleeps at least when ahead of its ceiling or of the other floors
START_POLL = 0.05             # wall s between two looks at the inputs before ``start_wall``
# the kinds of input (:meth:`FloorSim.post`), also the keys of the rejection counts
CMD_VEL, INITIALPOSE, OBSTACLE, STEP_DONE = Topic.CMD_VEL, Topic.INITIALPOSE, "obstacle", "step_done"
VISITOR_BODY = "visitor_body"
ADD, REMOVE, CLEAR = "add", "remove", "clear"       # obstacle changes
OK, WARN, ERROR = 0, 1, 2                           # diagnostics levels (diagnostic_msgs/DiagnosticStatus)
REQUIRED = "~building (building.yaml or its directory) and ~robot (a robot name) or ~robots (a list of robot names) " \
    "are required"
FRAMES = ("odom", "base_footprint", "base_link", "base_laser_link")    # each robot's frames, under its prefix


def pose_of(name: str, value: Any) -> Pose2D | None:
    """An initial pose parameter: [x, y, yaw] (m, m, rad) or "x, y, yaw"; None for none (default: the home)."""
    if value is None or (isinstance(value, (str, list, tuple)) and len(value) == 0):
        return None
    if isinstance(value, str):
        value = [v for v in value.replace(",", " ").split() if v]
    try:
        x, y, yaw = (float(v) for v in value)
    except (TypeError, ValueError) as err:
        raise SimConfigError(f"{name}: {value!r} must be [x, y, yaw] (m, m, rad)") from err
    return Pose2D(x, y, yaw)


def robot_names(robot: Any, robots: Any) -> tuple[str, ...]:
    """The robots simulated here: ``robots`` (``~robots``), else the one ``robot`` (``~robot``)."""
    if robots is None:
        robots = [robot] if robot else []
    if not isinstance(robots, (list, tuple)) or not robots or not all(isinstance(r, str) and r for r in robots):
        raise SimConfigError(REQUIRED)
    return tuple(robots)


def initial_poses(robots: Sequence[str], many: Any, one: Any) -> tuple[Pose2D | None, ...]:
    """The robots' initial poses: ``many`` (``~initial_poses``, one per robot; None when not given), else ``one``
    (``~initial_pose``) for the first robot; None: the robot's home."""
    if many is not None:
        if not isinstance(many, (list, tuple)) or len(many) != len(robots):
            raise SimConfigError(f"~initial_poses: {many!r} must be a list of {len(robots)} [x, y, yaw]")
        return tuple(pose_of("~initial_poses", p) for p in many)
    return (pose_of("~initial_pose", one),) + (None,) * (len(robots) - 1)


@dataclass(frozen=True)
class SimConfig:
    """The simulator's parameters (the node's ``~`` parameters of the same names; docs/simulator.md)."""

    building: str
    robots: tuple[str, ...]
    floor: float | None = None            # None: the first robot's
    poses: tuple[Pose2D | None, ...] = ()     # one per robot (None: its home); () for all homes
    speed: float | None = 1.0             # the ceiling, sim s per wall s (None: none)
    start_wall: float = 0.0               # wall time of sim time 0 (0: now)
    dt: float = 0.02                      # physics step, sim s
    step: float = 0.1                     # the lockstep's stops, sim s (a multiple of dt)
    participant_timeout: float = 2.0      # wall s
    timeline: str = ""                    # the building's timeline: the drift bound and the ceiling (replaces speed)
    timeline_slot: int = 0
    cmd_timeout: float = 0.2
    clock_rate_max: float = 100.0         # /clock messages per wall s, at most
    odom_rate: float = 10.0               # Hz of sim time, all of them
    truth_rate: float = 5.0
    rest_rate: float = 1.0
    laser_rate: float = 5.0               # base_scan and robots_seen: the people tracker reads 5 scans a sim s
    #                                       (its track_rate), a costmap's obstacle layer is updated at 5 Hz
    battery_rate: float = 1.0
    laser: LaserSpec = field(default_factory=LaserSpec)
    laser_fov_declared: bool = True       # each robot's laser covers the fov its building file declares
    #                                       (sensors.laser.fov, all round unless said), not laser.fov
    laser_z: float = 0.3
    battery: BatteryModel = field(default_factory=BatteryModel)
    seed: int | None = None
    diagnostics_period: float = 1.0       # wall s
    deadlock_time: float = 30.0           # sim s
    mates: str = ""
    people: int = 0                       # bystanders walking this floor (simulated by its first robot's simulator)
    people_seed: int = 1                  # their choices

    def __post_init__(self) -> None:
        if not isinstance(self.building, str) or not self.building:
            raise SimConfigError(REQUIRED)
        robot_names("", self.robots)
        if not self.poses:
            object.__setattr__(self, "poses", (None,) * len(self.robots))
        if len(self.poses) != len(self.robots):
            raise SimConfigError(f"~initial_poses: {len(self.poses)} poses for {len(self.robots)} robots")
        if self.floor is not None and (isinstance(self.floor, bool) or not isinstance(self.floor, (int, float))):
            raise SimConfigError(f"~floor: {self.floor!r} must be a floor number")
        substeps = self.step / self.dt
        if abs(substeps - round(substeps)) > 1e-6:
            raise SimConfigError(f"~step: {self.step:g} s must be a multiple of ~physics_dt ({self.dt:g} s)")


# -- what the node publishes (those of every stop not frozen: a frozen dataclass costs 3x as much to make) -----
@dataclass(slots=True)
class Motion:
    """A robot's pose and body velocity at ``t``."""

    index: int
    pose: Pose2D
    vel: Twist2D
    t: float


@dataclass(slots=True)
class Odom(Motion):
    """Robot ``index``'s odometry: its pose in its odom frame."""


@dataclass(slots=True)
class Truth(Motion):
    """Robot ``index``'s true pose in the map frame."""


@dataclass(slots=True)
class Frame:
    """A transform ``parent`` -> ``child`` at ``t`` (``z``: its height)."""

    parent: str
    child: str
    pose: Pose2D
    t: float
    z: float = 0.0


@dataclass(slots=True)
class Transforms:
    frames: tuple[Frame, ...]
    static: bool = False               # /tf_static (latched) instead of /tf


@dataclass(slots=True)
class Scan:
    """One laser scan of robot ``index``: ranges (m, ``inf`` = no return) of its laser ``laser`` at ``t``."""

    index: int
    laser: LaserSpec
    ranges: np.ndarray
    t: float
    scan_time: float                   # s between two scans


@dataclass(slots=True)
class Seen:
    """The other robots robot ``index``'s laser sees at ``t``: (name, disc) each."""

    index: int
    robots: tuple[tuple[str, Circle], ...]
    t: float


@dataclass(slots=True)
class Battery:
    """Robot ``name``'s (``index``) battery at ``t``: ``fraction`` of a full charge of ``model``, ``current`` A
    (negative: discharging)."""

    index: int
    name: str
    model: BatteryModel
    fraction: float
    current: float
    t: float


@dataclass(frozen=True, slots=True)
class ClockTick:
    """The floor's clock reached ``t``: ``/clock``, and the node's own ROS time."""

    t: float


@dataclass(frozen=True, slots=True)
class MapOut:
    """The floor's map (and its metadata), stamped ``t``."""

    t: float


@dataclass(frozen=True, slots=True)
class Obstacles:
    """Every run-time obstacle, sorted by id, at ``t``."""

    items: tuple[tuple[str, Shape], ...]
    t: float


@dataclass(frozen=True, slots=True)
class Diagnostics:
    """The floor's diagnostics status at sim time ``t``."""

    level: int                          # OK, WARN or ERROR
    name: str
    message: str
    hardware_id: str
    values: tuple[tuple[str, str], ...]
    t: float


@dataclass(frozen=True, slots=True)
class ResumeAt:
    """Where a restarted simulator of this floor starts (no timeline): a little ahead of any stamp seen so far."""

    t: float


Output = Odom | Truth | Transforms | Scan | Seen | Battery | ClockTick | MapOut | Obstacles | Diagnostics | ResumeAt


@dataclass(frozen=True)
class ObstacleChange:
    """A ``/sim/obstacle`` input: ADD (or replace) ``id`` as ``shape``, REMOVE ``id``, or CLEAR them all."""

    action: str
    id: str = ""
    shape: Shape | None = None


def _resume_value(value: Any) -> float:
    return float(value) if isinstance(value, (int, float)) and math.isfinite(value) and value > 0 else 0.0


class FloorSim:
    """Simulates one floor and owns its sim time (see the module docstring).

    ``emit`` receives the outputs in order; ``wanted(topic, index)`` says whether somebody listens to a
    robot's topic (``Topic.ODOM``, ``BASE_POSE_GROUND_TRUTH``, ``BASE_SCAN``, ``ROBOTS_SEEN``; ``Topic.TF``
    with index -1): a sensor nobody listens to is not computed. ``resolve`` gives a topic's resolved name
    (lockstep answers name their inputs so); ``resume_at``: the sim time a restarted simulator without a
    timeline starts from (what :class:`ResumeAt` said last).
    """

    def __init__(self, config: SimConfig, building: Building, wall: float, emit: Callable[[Output], None],
                 wanted: Callable[[str, int], bool], resolve: Callable[[str], str], log: Logger,
                 resume_at: Any = 0.0) -> None:
        self.config = c = config
        self.emit, self.wanted, self.log = emit, wanted, log
        robots = []
        for name in c.robots:
            try:
                robots.append(building.robot(name))
            except KeyError as err:
                raise SimConfigError(f"~robots: {err.args[0]}") from err
        try:
            self.floor = building.floor(robots[0].floor if c.floor is None else c.floor)
        except KeyError as err:
            raise SimConfigError(f"~floor: {err.args[0]}") from err
        self.world = World.of_floor(self.floor, dt=c.dt, cmd_timeout=c.cmd_timeout,
                                    rng=np.random.default_rng(c.seed), deadlock_time=c.deadlock_time)
        for robot, pose in zip(robots, c.poses, strict=True):
            try:
                self.world.add_robot(self._spec(robot), pose or robot.home)
            except SimError as err:
                raise SimConfigError(f"robot {robot.name}: initial pose: {err}") from err
        self.own = list(range(len(robots)))
        multi = len(robots) > 1
        self.prefixes = [f"robot_{i}/" if multi else "" for i in self.own]
        self.frames = [{name: f"{prefix}{name}" for name in FRAMES} for prefix in self.prefixes]
        # the lockstep participants' inputs, by resolved name (as StepDone names them)
        self.odom_topics = [resolve(prefix + Topic.ODOM) for prefix in self.prefixes]
        self.truth_topics = [resolve(prefix + Topic.BASE_POSE_GROUND_TRUTH) for prefix in self.prefixes]
        self.rejected = CountingLog(self.log.error)
        self._inputs: queue.SimpleQueue = queue.SimpleQueue()        # relocations, obstacles: a flood waits
        self._lock_inputs: queue.SimpleQueue = queue.SimpleQueue()   # commands and answers: always applied
        self.mates: Mates | None = None
        self.mate_slots: dict[int, int] = {}      # world index of another robot of the floor -> its mates slot
        self.own_slots: dict[int, int] = {}       # world index of this node's robot -> its mates slot
        if c.mates:
            self._open_mates(building, robots)
        self.odom_due, self.truth_due, self.rest_due = (Periodic(c.odom_rate), Periodic(c.truth_rate),
                                                        Periodic(c.rest_rate))
        self.laser_due, self.battery_due, self.tf_due = (Periodic(c.laser_rate), Periodic(c.battery_rate),
                                                         Periodic(c.odom_rate))
        self.timeline = Timeline.open(c.timeline) if c.timeline else None
        resume = self.timeline.read(c.timeline_slot).sim if self.timeline is not None else _resume_value(resume_at)
        self.start_wall = wall if resume > 0.0 or c.start_wall == 0.0 else c.start_wall
        speed = self.timeline.ceiling if self.timeline is not None else c.speed
        drift = self.timeline.max_drift if self.timeline is not None else None
        self.stepper = Stepper(c.step, Pacer(speed, self.start_wall, resume), Lockstep(c.participant_timeout),
                               max_drift=drift, start=resume)
        self.lockstep = self.stepper.lockstep
        self.world.start_at(resume)
        self.sees_robots = len(self.world.robots) > 1    # other robots for a laser to see: robots_seen published
        self.crowd = self._crowd(building)
        self._people_seen = False          # a robots_seen listed people: one more is published once they are gone
        self.started = False
        self.scans = 0
        self._said_waiting = False
        self._clock_wall = -math.inf       # wall time of the latest /clock
        self._heartbeat = -math.inf        # ... and of the latest timeline write
        self._diag = {"wall": wall, "sim": resume, "next": wall + c.diagnostics_period, "behind": 0.0}

    def _crowd(self, building: Building) -> Crowd:
        """The floor's people: visitors' bodies as their nodes direct, and ``people`` bystanders when this simulator
        has the floor's first robot (by name: one simulator of the floor walks them)."""
        c = self.config
        first = min((r.name for r in building.robots_on(self.floor.id)), default="")
        if c.people <= 0 or first not in c.robots:
            return Crowd(self.world.clearance)
        planner = GridPlanner(self.floor.map, PERSON_RADIUS, inflation_radius=PERSON_RADIUS + 0.3)

        def plan(a: tuple[float, float], b: tuple[float, float]) -> list[tuple[float, float]] | None:
            try:
                return planner.plan(a, b).densified(0.5)
            except PlanningError:
                return None
        places = [(loc.pose.x, loc.pose.y) for loc in building.locations_on(self.floor.id)]
        places += [(m.x, m.y) for conn in building.connectors for f, m in conn.meeting.items() if f == self.floor.id]
        return Crowd(self.world.clearance, plan, places, draw_bystanders(c.people, c.people_seed, self.floor.label))

    def _spec(self, robot: Robot) -> RobotSpec:
        laser = replace(self.config.laser, fov=robot.laser.fov) if self.config.laser_fov_declared else \
            self.config.laser
        return RobotSpec(robot.name, robot.radius, Limits.of_robot(robot), laser, self.config.battery)

    def _open_mates(self, building: Building, robots: list[Robot]) -> None:
        """The mates file, and the slots of the other robots of this floor and of this node's own robots: a slot
        per robot of the building, in its order."""
        mates = Mates.open(self.config.mates)
        names = [r.name for r in building.robots]
        if mates.slots != len(names):
            mates.close()
            raise SimConfigError(f"~mates: {self.config.mates} has {mates.slots} slots, the building "
                                 f"{len(names)} robots")
        self.mates = mates
        self.own_slots = {i: names.index(r.name) for i, r in enumerate(robots)}
        here = {r.name for r in robots}
        for robot in building.robots_on(self.floor.id):
            if robot.name not in here:
                slot = names.index(robot.name)
                state = mates.read(slot)
                index = self.world.add_mate(self._spec(robot), state.pose if state.finite() else robot.home)
                self.mate_slots[index] = slot

    def close(self) -> None:
        if self.timeline is not None:
            self.timeline.close()
        if self.mates is not None:
            self.mates.close()

    # -- inputs --------------------------------------------------------------------------------------
    def post(self, kind: str, index: int, value: Callable[[], Any], caller: str = "") -> None:
        """An input from the node (any thread): ``kind`` CMD_VEL (``value()``: vx, vy, wz; ``caller``: the node
        that sent it), STEP_DONE (an :class:`~gidabot_sim.world.lockstep.Answer`), INITIALPOSE (a Pose2D in the
        map frame) or OBSTACLE (an :class:`ObstacleChange`), for robot ``index``. ``value()`` runs when the input
        is applied, in :meth:`tick`; a :class:`GidaBotError`, ValueError or TypeError it (or applying it) raises
        is counted and logged as a rejected ``kind``."""
        if kind in (CMD_VEL, STEP_DONE, VISITOR_BODY):
            self._lock_inputs.put((kind, index, value, caller))
        else:
            self._inputs.put((kind, index, value))

    def _drain(self, wall: float) -> None:
        while True:
            try:
                kind, index, value, caller = self._lock_inputs.get_nowait()
            except queue.Empty:
                break
            try:
                if kind == CMD_VEL:
                    self.lockstep.command(caller)
                    self.world.set_command(index, *value())
                elif kind == VISITOR_BODY:
                    self._visitor_body(value())
                else:
                    self.lockstep.answer(value(), wall)
            except (GidaBotError, ValueError, TypeError) as err:
                self.rejected.reject(kind, str(err))
        changed = False
        for _ in range(MAX_EVENTS_PER_STEP):
            try:
                kind, index, value = self._inputs.get_nowait()
            except queue.Empty:
                break
            try:
                if kind == INITIALPOSE:
                    changed |= self.world.rebuild()        # the pose is checked against the obstacles as they are now
                    self._relocate(index, value())
                elif kind == OBSTACLE:
                    self._obstacle(value())
            except (GidaBotError, ValueError, TypeError) as err:
                self.rejected.reject(kind, str(err))
        if self.world.rebuild() or changed:
            self._emit_obstacles()
        for node in self.lockstep.timed_out:
            self.log.warning(f"sim: {node} has not answered for {self.lockstep.timeout:g} s: the world goes on "
                             "without it until it answers again")
        for node in self.lockstep.rejoined:
            self.log.info(f"sim: {node} answers again")
        self.lockstep.timed_out.clear()
        self.lockstep.rejoined.clear()

    def _visitor_body(self, directive: Directive) -> None:
        self.crowd.direct(directive, self._robot_discs())
        self.log.info(f"sim: visitor {directive.visitor_id}: {directive.mode} {directive.robot}")

    def _robot_discs(self) -> list[RobotDisc]:
        return [RobotDisc(r.spec.name, r.pose.x, r.pose.y, r.spec.radius, r.pose.yaw) for r in self.world.robots]

    def _relocate(self, index: int, wanted: Pose2D) -> None:
        placed = self.world.teleport(index, wanted)
        name = self.world.robots[index].spec.name
        self.log.info(f"sim: {name} set to ({placed.x:.2f}, {placed.y:.2f}, {placed.yaw:.2f})"
                      + ("" if (placed.x, placed.y) == (wanted.x, wanted.y) else
                         f" (asked ({wanted.x:.2f}, {wanted.y:.2f}): moved clear of a wall)"))
        for due in (self.odom_due, self.truth_due, self.rest_due):     # the new pose at the next stop
            due.reset()

    def _obstacle(self, change: ObstacleChange) -> None:
        if change.action == ADD:
            assert change.shape is not None
            self.world.add_obstacle(change.id, change.shape, rebuild=False)
            self.log.info(f"sim: obstacle {change.id!r} added: {change.shape}")
        elif change.action == REMOVE:
            if not self.world.remove_obstacle(change.id, rebuild=False):
                raise ObstacleRejected(f"obstacle {change.id[:64]!r}: no such obstacle to remove")
            self.log.info(f"sim: obstacle {change.id!r} removed")
        elif change.action == CLEAR:
            self.log.info(f"sim: {self.world.clear_obstacles(rebuild=False)} obstacle(s) cleared")
        else:
            raise ObstacleRejected(f"obstacle action {change.action!r}: expected {ADD}, {REMOVE} or {CLEAR}")

    # -- the loop ------------------------------------------------------------------------------------
    def tick(self, wall: float) -> float:
        """Apply the inputs, step when the stop may be left, emit what is due; returns the wall seconds the node
        may sleep before the next tick (0: tick again at once)."""
        self._drain(wall)
        if not self.started:
            if wall < self.start_wall:
                if not self._said_waiting:
                    self._said_waiting = True
                    self.log.info(f"sim: waiting {self.start_wall - wall:.1f} s for start_wall")
                return min(self.start_wall - wall, START_POLL)
            return self._start(wall)
        s = self.stepper
        if self.timeline is not None:        # the runner may change the ceiling while the run goes
            s.pacer.set_speed(self.timeline.ceiling, s.t, wall)
        peers = self.timeline.slowest_peer(self.config.timeline_slot, wall) if self.timeline is not None else None
        wait = s.check(wall, peers)
        if wait is None:
            self._read_mates(wall)
            self.world.advance_to(s.advance(wall))
            if self.crowd:
                self.crowd.step(self.world.time, self._robot_discs())
                self.world.set_people([(b.person_id, b.x, b.y, b.radius) for b in self.crowd.bodies])
            if self.sees_robots or self.world.events:
                self._pairs()
            self._stop(wall)
            self._diagnostics(wall)
            return 0.0
        sleep = min(wait.until - wall, HEARTBEAT)
        if wait.reason == CONTROLLERS:
            self._missing_inputs(s.t)
        elif self._idle():              # nothing moves: wake less often, then step through what is due
            sleep = max(sleep, IDLE_SLEEP)
        if wall - self._heartbeat >= HEARTBEAT:
            self._write_timeline(wall)
            self._write_mates(wall)
        self._diagnostics(wall)
        return max(0.0, sleep)

    def _start(self, wall: float) -> float:
        """``start_wall`` has come: the static scene and the first stop."""
        self.started = True
        t, c = self.world.time, self.config
        self.emit(MapOut(t))
        self._emit_obstacles()
        frames: list[Frame] = []
        for i in self.own:
            laser = self.world.robots[i].spec.laser
            f = self.frames[i]
            frames.append(Frame(f["base_footprint"], f["base_link"], Pose2D(0.0, 0.0, 0.0), t))
            frames.append(Frame(f["base_link"], f["base_laser_link"], Pose2D(laser.x, laser.y, laser.yaw), t,
                                c.laser_z))
        self.emit(Transforms(tuple(frames), static=True))
        self._stop(wall)
        speed = self.stepper.pacer.speed
        self.log.info(f"sim: floor {self.floor.label} running from {t:.1f} s, speed ceiling "
                      f"{'none' if speed is None else f'{speed:g}x'}, a step every {self.stepper.step:g} s"
                      + ("" if self.timeline is None else
                         f", timeline {self.timeline.path} slot {c.timeline_slot}"))
        return 0.0

    def _idle(self) -> bool:
        """No robot moves or is commanded and no participant drives: a stop changes nothing but the time."""
        return not self.lockstep.inputs_due() and all(self.world.at_rest(i) for i in self.own)

    def _pairs(self) -> None:
        """Several robots: tell the world whose navigation drives (deadlock watch); log what it reports."""
        inputs = self.lockstep.inputs_due()
        for i in self.own:
            self.world.set_active(i, self.odom_topics[i] in inputs)
        for event in self.world.take_events():
            if event.kind == DEADLOCK:
                self.log.error(f"sim: {event.text}")
            elif event.kind == COLLISION:
                self.log.warning(f"sim: collision: {event.text}")
            else:
                self.log.info(f"sim: {event.text}")

    # -- a stop's outputs ----------------------------------------------------------------------------
    def _stop(self, wall: float) -> None:
        """Everything of the stop the world just reached: sensors (the participants' inputs), then /clock."""
        self._sensors()
        self._write_mates(wall)
        if wall - self._clock_wall >= 1.0 / self.config.clock_rate_max:
            self.emit(ClockTick(self.world.time))
            self._clock_wall = wall
        self._write_timeline(wall)

    def _sensors(self) -> None:
        t, world, wanted, emit = self.world.time, self.world, self.wanted, self.emit
        odom_due, truth_due, rest_due = self.odom_due.due(t), self.truth_due.due(t), self.rest_due.due(t)
        laser_due, battery_due, tf_due = self.laser_due.due(t), self.battery_due.due(t), self.tf_due.due(t)
        inputs = self.lockstep.inputs_due()           # a driving participant's odometry: at every stop
        frames = []
        tf = tf_due and wanted(Topic.TF, -1)
        for i in self.own:
            robot = world.robots[i]
            resting = world.at_rest(i)
            if ((rest_due if resting else odom_due) or self.odom_topics[i] in inputs) and wanted(Topic.ODOM, i):
                self._odom(i, robot, t)
            if (rest_due if resting else truth_due) and wanted(Topic.BASE_POSE_GROUND_TRUTH, i):
                emit(Truth(i, robot.pose, robot.vel, t))
                self.lockstep.published(self.truth_topics[i], t)
            if tf:
                frames.append(Frame(self.frames[i]["odom"], self.frames[i]["base_footprint"], robot.odom, t))
            exact: list[np.ndarray] | None = [] if world.people else None
            if laser_due and wanted(Topic.BASE_SCAN, i):
                emit(Scan(i, robot.spec.laser, world.scan(i, exact=exact), t, 1.0 / self.config.laser_rate))
                self.scans += 1
            people = bool(world.people) or self._people_seen
            if laser_due and (self.sees_robots or people) and wanted(Topic.ROBOTS_SEEN, i):
                seen = world.robots
                bodies = tuple((world.people[k][0], Circle(*world.people[k][1:]))
                               for k in world.seen_people(i, exact[0] if exact else None))
                self._people_seen = bool(world.people)
                emit(Seen(i, tuple((seen[j].spec.name, Circle(seen[j].pose.x, seen[j].pose.y, seen[j].spec.radius))
                                   for j in world.seen_robots(i)) + bodies, t))
            if battery_due:
                emit(self._battery(i, robot, t))
        if frames:
            emit(Transforms(tuple(frames)))

    def _odom(self, i: int, robot: SimRobot, t: float) -> None:
        self.emit(Odom(i, robot.odom, robot.vel, t))
        self.lockstep.published(self.odom_topics[i], t)

    @staticmethod
    def _battery(i: int, robot: SimRobot, t: float) -> Battery:
        return Battery(i, robot.spec.name, robot.spec.battery, float(robot.battery),
                       -2.0 if robot.vel.speed > 0.01 else -0.8, t)

    def _missing_inputs(self, t: float) -> None:
        """A participant stopped being idle during this stop: its inputs for it, now."""
        for topic in self.lockstep.missing_inputs(t):
            for i in self.own:
                if topic == self.odom_topics[i]:
                    self._odom(i, self.world.robots[i], t)

    def _emit_obstacles(self) -> None:
        self.emit(Obstacles(tuple(sorted(self.world.obstacles.items())), self.world.time))

    # -- the building's files ------------------------------------------------------------------------
    def _read_mates(self, wall: float) -> None:
        """The other robots of this floor, as their simulators last wrote them, into the world."""
        if self.mates is None:
            return
        for index, slot in self.mate_slots.items():
            state = self.mates.read(slot)
            if state.finite():
                pose, vx, vy, t, active = mate_motion(state, wall, MATE_STALE)
                self.world.set_mate(index, pose, vx, vy, t if t >= 0 else self.world.time, active)

    def _write_mates(self, wall: float) -> None:
        """This node's robots' motion (map frame), for the simulators of the other robots of the floor."""
        if self.mates is None:
            return
        for index, slot in self.own_slots.items():
            r = self.world.robots[index]
            c, s = math.cos(r.pose.yaw), math.sin(r.pose.yaw)
            self.mates.write(slot, MateState(self.world.time, wall, r.pose.x, r.pose.y, r.pose.yaw,
                                             r.vel.vx * c - r.vel.vy * s, r.vel.vx * s + r.vel.vy * c,
                                             1.0 if r.active else 0.0))

    def _write_timeline(self, wall: float) -> None:
        self._heartbeat = wall
        if self.timeline is None:
            return
        s = self.stepper
        self.timeline.write(self.config.timeline_slot, TimelineClock(
            sim=s.t, wall=wall, behind=s.behind(wall), wait_controllers=s.waited["controllers"],
            wait_floors=s.waited["floors"], wait_ceiling=s.waited["ceiling"], steps=s.steps,
            timeouts=sum(p.timeouts for p in self.lockstep.participants.values()), max_lead=s.max_lead,
            pid=os.getpid()))

    # -- diagnostics ---------------------------------------------------------------------------------
    def _diagnostics(self, wall: float) -> None:
        d = self._diag
        if wall < d["next"]:
            return
        s, world, c = self.stepper, self.world, self.config
        span = wall - d["wall"]
        achieved = (s.t - d["sim"]) / span if span > 0 else 0.0
        speed = s.pacer.speed
        own = [world.robots[i] for i in self.own]
        values = {
            "floor": self.floor.label, "speed": "max" if speed is None else f"{speed:g}", "sim_time": f"{s.t:.2f}",
            "wall_time": f"{wall:.3f}", "achieved_factor": f"{achieved:.2f}", "behind_s": f"{s.behind(wall):.3f}",
            "wait_controllers_s": f"{s.waited['controllers']:.3f}", "wait_floors_s": f"{s.waited['floors']:.3f}",
            "wait_ceiling_s": f"{s.waited['ceiling']:.3f}", "steps": str(s.steps), "max_lead_s": f"{s.max_lead:.2f}",
            "obstacles": str(len(world.obstacles)), "stalls": str(sum(r.stalls for r in own)),
            "laser_scans": str(self.scans),
            # rays cast, and how many of those casts found the walls' ranges kept (a robot that had not moved)
            "laser_casts": str(world.caster.casts), "laser_casts_kept": str(world.caster.cached),
        }
        for node, stats in self.lockstep.stats().items():
            values[f"participant {node}"] = json.dumps(stats, separators=(",", ":"))
        for kind in (CMD_VEL, INITIALPOSE, OBSTACLE, STEP_DONE, VISITOR_BODY):
            values[f"rejected_{kind}"] = str(self.rejected.counts.get(kind, 0))
        for robot in own:
            values[f"battery_{robot.spec.name}"] = f"{robot.battery:.4f}"
        deadlocked = world.deadlocked
        # counted with one robot too (0: a floor world with one robot has nobody to collide with); with mates,
        # the contacts in which this node's robot was stopped by another robot of the floor
        values["robot_collisions"] = str(world.robot_collisions)
        values["robot_deadlocks"] = str(world.deadlocks)
        values["people_collisions"] = str(world.people_collisions)     # a robot of this node stopped by a person
        values["people"] = str(len(world.people))
        # where each body truly is (m, map frame): what a report or a person reading the bag checks the robots'
        # view of their visitors against
        values["people_at"] = "; ".join(f"{pid} {x:.2f} {y:.2f}" for pid, x, y, _r in world.people)
        values["deadlocked"] = ", ".join(f"{a}+{b}" for a, b in deadlocked)
        values["floor_robots"] = ",".join(r.spec.name for r in world.robots)
        absent = sorted(p.node for p in self.lockstep.participants.values() if p.absent)
        behind = s.behind(wall) - d["behind"] > 0.1 * span
        level = ERROR if deadlocked else WARN if absent or behind else OK
        message = (f"deadlock: robots {', '.join(f'{a} and {b}' for a, b in deadlocked)}" if deadlocked else
                   f"going on without {', '.join(absent)}" if absent else
                   "behind its speed ceiling" if behind else "running")
        self.emit(Diagnostics(level, f"sim: floor {self.floor.label}", message, ",".join(r.spec.name for r in own),
                              tuple(values.items()), s.t))
        if self.timeline is None:     # a restarted simulator goes on from here, ahead of any stamp seen so far
            self.emit(ResumeAt(s.t + max(achieved, speed or 0.0) * c.diagnostics_period * 2.0 + c.step))
        d.update(wall=wall, sim=s.t, next=wall + c.diagnostics_period, behind=s.behind(wall))
