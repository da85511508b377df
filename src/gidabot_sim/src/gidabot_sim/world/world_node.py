"""ROS adapter of the floor simulator: the ``/sim`` node (cores: :mod:`gidabot_sim.world.world`,
:mod:`gidabot_sim.world.lockstep`).

One node per floor (per master), like one of the paper's Gazebo worlds. It owns sim time: the
floor's clock advances only by the steps it computes, in lockstep with the floor's controllers
(the move_base and amcl stand-ins), within the building's drift bound and under its speed ceiling
(docs/simulator.md, "Simulated time").
"""

from __future__ import annotations

import json
import math
import os
import queue
import threading
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry
from nav_msgs.srv import GetMap, GetMapResponse
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, LaserScan
from tf2_msgs.msg import TFMessage

from gidabot_msgs.msg import Obstacle, ObstacleArray, StepDone
from gidabot_navigation.building.geometry import Pose2D, yaw_to_quaternion
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.planning import Circle
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.interface import Node, Service, Topic
from gidabot_navigation.ros.exit_guard import ExitGuard, rospy_exit_guard
from gidabot_navigation.ros.master_watch import keep_registered
from gidabot_navigation.ros.params import param_number
from gidabot_sim.errors import ObstacleRejected, SimConfigError, SimError
from gidabot_sim.ros import convert as ru
from gidabot_sim.ros.participant import own_time, synchronous_publisher
from gidabot_sim.world.clock import MAX_SPEED, Pacer, Periodic
from gidabot_sim.world.kinematics import Limits
from gidabot_sim.world.lockstep import CONTROLLERS, Answer, Lockstep, Stepper
from gidabot_sim.world.mates import Mates, MateState, mate_motion
from gidabot_sim.world.timeline import Clock as TimelineClock
from gidabot_sim.world.timeline import Timeline
from gidabot_sim.world.world import (
    COLLISION,
    DEADLOCK,
    BatteryModel,
    LaserSpec,
    RobotSpec,
    World,
    obstacle_shape,
)

MAX_EVENTS_PER_STEP = 200     # inputs applied per step (answers and commands always); a flood waits
HEARTBEAT = 0.05              # wall s between two timeline writes while the world waits
MATE_STALE = 5.0              # wall s: a mate whose simulator has not written for this long stands still
IDLE_SLEEP = 0.01             # wall s an idle floor sleeps at least when ahead of its ceiling or of the other floors
ODOM_COVARIANCE = tuple(1e-4 if i in (0, 7, 35) else 0.0 for i in range(36))


def _pose_param(name: str, value: Any) -> Pose2D | None:
    if value in (None, "", []):
        return None
    if isinstance(value, str):
        value = [v for v in value.replace(",", " ").split() if v]
    try:
        x, y, yaw = (float(v) for v in value)
    except (TypeError, ValueError) as err:
        raise SimConfigError(f"{name}: {value!r} must be [x, y, yaw] (m, m, rad)") from err
    return Pose2D(x, y, yaw)


@dataclass(frozen=True)
class SimParams:
    building: str
    robots: tuple[str, ...]
    floor: float
    poses: tuple[Pose2D | None, ...]
    speed: float | None
    start_wall: float
    dt: float
    step: float
    participant_timeout: float
    max_drift: float | None
    timeline: str
    timeline_slot: int
    cmd_timeout: float
    clock_rate_max: float
    odom_rate: float
    truth_rate: float
    rest_rate: float
    laser_rate: float
    battery_rate: float
    laser: LaserSpec
    laser_z: float
    battery: BatteryModel
    seed: int | None
    diagnostics_period: float
    deadlock_time: float
    mates: str

    @staticmethod
    def read() -> SimParams:
        building = str(rospy.get_param("~building", ""))
        robot = str(rospy.get_param("~robot", ""))
        robots = rospy.get_param("~robots", [robot] if robot else [])
        if not building or not robots or not all(isinstance(r, str) and r for r in robots):
            raise SimConfigError("~building (building.yaml or its directory) and ~robot (a robot name) or "
                                 "~robots (a list of robot names) are required")
        poses: list[Pose2D | None]
        if rospy.has_param("~initial_poses"):
            raw = rospy.get_param("~initial_poses")
            if not isinstance(raw, list) or len(raw) != len(robots):
                raise SimConfigError(f"~initial_poses: {raw!r} must be a list of {len(robots)} [x, y, yaw]")
            poses = [_pose_param("~initial_poses", p) for p in raw]
        else:
            poses = [_pose_param("~initial_pose", rospy.get_param("~initial_pose", []))] + [None] * (len(robots) - 1)
        laser = LaserSpec(beams=int(param_number("~laser_beams", 360, 1, 10000, strict=False)),
                          fov=param_number("~laser_fov", 1.5 * math.pi, 0.0, 2 * math.pi),
                          range_min=param_number("~laser_range_min", 0.05, strict=False),
                          range_max=param_number("~laser_range_max", 20.0, strict=False),
                          noise=param_number("~laser_noise", 0.01, strict=False),
                          x=param_number("~laser_x", 0.1, -5, 5, strict=False),
                          y=param_number("~laser_y", 0.0, -5, 5, strict=False))
        battery = BatteryModel(start=param_number("~battery_start", 1.0, 0.0, 1.0, strict=False),
                               idle_per_hour=param_number("~battery_idle_per_hour", 0.05, strict=False),
                               per_km=param_number("~battery_per_km", 0.25, strict=False))
        seed = int(rospy.get_param("~seed", -1))
        speed = rospy.get_param("~speed", 1.0)
        drift = param_number("~max_drift", 1.0, strict=False)
        return SimParams(
            building=building, robots=tuple(robots), floor=float(rospy.get_param("~floor", math.nan)),
            poses=tuple(poses),
            speed=None if speed == "max" else param_number("~speed", 1.0, 0.0, MAX_SPEED),
            start_wall=param_number("~start_wall", 0.0, strict=False),
            dt=param_number("~physics_dt", 0.02, 0.0, 0.2),
            step=param_number("~step", 0.1, 0.0, 10.0),
            participant_timeout=param_number("~participant_timeout", 2.0, 0.0),
            max_drift=drift or None, timeline=str(rospy.get_param("~timeline", "")),
            timeline_slot=int(param_number("~timeline_slot", 0.0, 0.0, 63.0, strict=False)),
            cmd_timeout=param_number("~cmd_timeout", 0.2, 0.0),
            clock_rate_max=param_number("~clock_rate_max", 100.0, 0.0, 1000.0),
            odom_rate=param_number("~odom_rate", 10.0, 0.0, 1000.0),
            truth_rate=param_number("~truth_rate", 5.0, 0.0, 1000.0),
            rest_rate=param_number("~rest_rate", 1.0, 0.0, 1000.0),
            laser_rate=param_number("~laser_rate", 10.0, 0.0, 1000.0),
            battery_rate=param_number("~battery_rate", 1.0, 0.0, 100.0),
            laser=laser, laser_z=param_number("~laser_z", 0.3, -5, 5, strict=False), battery=battery,
            seed=None if seed < 0 else seed, diagnostics_period=param_number("~diagnostics_period", 1.0, 0.0),
            deadlock_time=param_number("~deadlock_time", 30.0, 0.0), mates=str(rospy.get_param("~mates", "")))


class _RobotIO:
    """Topics of one simulated robot (prefix ``robot_<i>/`` when the floor has several)."""

    def __init__(self, node: SimNode, index: int, prefix: str, params: SimParams, seen: bool = False) -> None:
        self.index, self.prefix = index, prefix
        # the lockstep participants' inputs, by resolved name (as StepDone names them)
        self.odom_topic = rospy.resolve_name(prefix + Topic.ODOM)
        self.truth_topic = rospy.resolve_name(prefix + Topic.BASE_POSE_GROUND_TRUTH)
        self.frame = {name: f"{prefix}{name}" for name in ("odom", "base_footprint", "base_link", "base_laser_link")}
        self.odom_msg, self.truth_msg = Odometry(), Odometry()      # reused at every publication
        for msg, frame in ((self.odom_msg, self.frame["odom"]), (self.truth_msg, "map")):
            msg.header.frame_id, msg.child_frame_id = frame, self.frame["base_footprint"]
            msg.pose.covariance = msg.twist.covariance = ODOM_COVARIANCE
        self.odom = rospy.Publisher(prefix + Topic.ODOM, Odometry, queue_size=5)
        self.truth = rospy.Publisher(prefix + Topic.BASE_POSE_GROUND_TRUTH, Odometry, queue_size=5)
        self.scan = rospy.Publisher(prefix + Topic.BASE_SCAN, LaserScan, queue_size=2)
        self.battery = rospy.Publisher(prefix + Topic.BATTERY, BatteryState, queue_size=2)
        self.seen = rospy.Publisher(prefix + Topic.ROBOTS_SEEN, ObstacleArray, queue_size=2) if prefix or seen \
            else None
        rospy.Subscriber(prefix + Topic.CMD_VEL, Twist, node.enqueue, callback_args=(Topic.CMD_VEL, index),
                         queue_size=50, tcp_nodelay=True)
        rospy.Subscriber(prefix + Topic.INITIALPOSE, PoseWithCovarianceStamped, node.enqueue,
                         callback_args=(Topic.INITIALPOSE, index), queue_size=5)


class SimNode:
    """Simulates one floor: its map, robots, laser, battery and run-time obstacles; owns its sim time.

    Per robot (no prefix with one robot; ``robot_<i>/`` with several, as stage_ros does):
      Subscribes:
        ``cmd_vel`` (geometry_msgs/Twist): body velocity (linear.x, linear.y for synchro drive, angular.z),
          clamped to the building's limits, reached at its acceleration limits; none for
          ``~cmd_timeout`` -> the robot brakes to a stop.
        ``initialpose`` (geometry_msgs/PoseWithCovarianceStamped, frame ``map``): teleports the robot
          (what the GUI's admin "Set location" sends); NaN/inf, a bad quaternion, another frame,
          off the map, inside a wall/obstacle/robot -> logged error, counted, ignored.
      Publishes:
        ``odom`` (nav_msgs/Odometry, frame ``odom`` -> ``base_footprint``, body twist) at ``~odom_rate``
          (``~rest_rate`` while the robot stands still without a command);
        ``base_pose_ground_truth`` (nav_msgs/Odometry, frame ``map``) at ``~truth_rate`` (``~rest_rate`` at rest),
          and at once after a relocation;
        ``base_scan`` (sensor_msgs/LaserScan, frame ``base_laser_link``, ``inf`` = no return) at
          ``~laser_rate``, only while somebody subscribes;
        ``battery`` (sensor_msgs/BatteryState, ``percentage`` 0..1) at ``~battery_rate``.
        ``robots_seen`` (gidabot_msgs/ObstacleArray, frame ``map``; several robots only): the other robots its
          laser sees now (id = robot name, a CIRCLE of its radius) at ``~laser_rate``, while somebody subscribes:
          its move_base's obstacle layer.
      tf: ``odom -> base_footprint`` (while /tf has subscribers); static ``base_footprint -> base_link``
        and ``base_link -> base_laser_link``.
    Floor-wide:
      ``/clock`` (rosgraph_msgs/Clock): the sim time of the latest step, at most ``~clock_rate_max`` times
        per wall second; nothing before ``~start_wall``.
      ``/sim/step_done`` (gidabot_msgs/StepDone, subscribed): the lockstep participants' answers; while one
        is not idle, its inputs (a robot's ``odom``) are published at every step (docs/simulator.md, "Lockstep").
      ``map`` (nav_msgs/OccupancyGrid, latched) and ``map_metadata`` (latched), service ``static_map``
        (nav_msgs/GetMap): the floor's map, as map_server serves it.
      ``/sim/obstacle`` (gidabot_msgs/Obstacle, subscribed): add / remove / clear run-time obstacles.
      ``/sim/obstacles`` (gidabot_msgs/ObstacleArray, latched): the current obstacles, on every change.
      ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): ``sim: floor <f>`` every ``~diagnostics_period``
        wall seconds: speed ceiling, sim time, achieved factor, wall time behind the ceiling and waiting
        (for controllers, for other floors, for the ceiling), each participant's stops owed / answered /
        missed and timeouts, counters of rejected input, stalls, scans, batteries; with several robots
        ``robot_collisions`` (contacts, each counted once), ``robot_deadlocks`` (reported) and ``deadlocked``
        (the pairs now), ERROR while two robots are deadlocked.
      Log: a collision between robots (warning) and a deadlock (error: two robots near each other, at least
        one with a goal running, neither moving 0.5 m for ``~deadlock_time``), each naming both robots.
    Params:
      ``~building`` (str), ``~robot`` (str) or ``~robots`` (list of str): robots of the building file
        simulated here (their drive, limits, radius); ``~floor`` (default: the first robot's);
      ``~initial_pose`` ([x, y, yaw], m/rad; default the robot's home) or ``~initial_poses`` (one per robot);
      ``~speed`` (sim s per wall s, 1; ``max``: no ceiling): a ceiling, never a promise; ``~start_wall`` (s since
        the epoch, 0 = now): when sim time 0 starts;
      ``~step`` (sim s, 0.1: the controllers' period), ``~physics_dt`` (s, 0.02; ``~step`` is a multiple of it),
        ``~participant_timeout`` (wall s, 2: a participant that has not answered by then is absent until it
        answers again), ``~timeline`` (path of the building's timeline file, '' = none) and ``~timeline_slot``
        (this floor's slot): the other floors' clocks, the drift bound and the ceiling (which then replaces
        ``~speed``); ``~cmd_timeout`` (s, 0.2), ``~clock_rate_max`` (Hz wall, 100);
      ``~odom_rate`` (Hz, 10), ``~truth_rate`` (Hz, 5), ``~rest_rate`` (Hz, 1), ``~laser_rate`` (Hz, 10),
        ``~battery_rate`` (Hz, 1), all in sim time (at most one message per topic per step);
      ``~laser_beams`` (360), ``~laser_fov`` (rad, 3 pi/2), ``~laser_range_min``/``~laser_range_max``
        (m, 0.05/20), ``~laser_noise`` (m, 0.01), ``~laser_x``/``~laser_y``/``~laser_z`` (m, mount);
      ``~battery_start`` (0..1, 1), ``~battery_idle_per_hour`` (fraction/h, 0.05), ``~battery_per_km``
        (fraction/km, 0.25); ``~seed`` (int, -1 = random); ``~diagnostics_period`` (wall s, 1);
      ``~deadlock_time`` (sim s, 30); ``~mates`` (path of the building's mates file, '' = none: the other robots
        of this floor, each simulated by its own simulator on its own master, share the floor through it,
        :mod:`gidabot_sim.world.mates`: this node writes its robot's motion there after each step and reads
        theirs before each, into its world; ``robots_seen`` is then published for its robot too).
    Restart: the floor's time goes on from where it was (the timeline's slot; without one, ``~resume_at``,
      saved every ``~diagnostics_period``), never back; the robot restarts at its initial pose, obstacles
      are lost.
    Shutdown: the process exits within 1 wall second of SIGINT/SIGTERM, whatever state the master
      and the subscribers are in (:mod:`gidabot_navigation.ros.exit_guard`).
    """

    def __init__(self) -> None:
        self.p = params = SimParams.read()
        building = load_building(params.building)
        robots = []
        for name in params.robots:
            try:
                robots.append(building.robot(name))
            except KeyError as err:
                raise SimConfigError(str(err)) from err
        floor_id = robots[0].floor if math.isnan(params.floor) else params.floor
        try:
            self.floor = building.floor(floor_id)
        except KeyError as err:
            raise SimConfigError(f"~floor: {err}") from err
        substeps = params.step / params.dt
        if abs(substeps - round(substeps)) > 1e-6:
            raise SimConfigError(f"~step: {params.step:g} s must be a multiple of ~physics_dt ({params.dt:g} s)")
        self.world = World.of_floor(self.floor, dt=params.dt, cmd_timeout=params.cmd_timeout,
                           rng=np.random.default_rng(params.seed), deadlock_time=params.deadlock_time)
        for robot, pose in zip(robots, params.poses, strict=True):
            spec = RobotSpec(robot.name, robot.radius, Limits.of_robot(robot), params.laser, params.battery)
            try:
                self.world.add_robot(spec, pose or robot.home)
            except SimError as err:
                raise SimConfigError(f"robot {robot.name}: initial pose: {err}") from err
        self.log = ru.CountingLog(rospy.logerr)
        self.events: queue.SimpleQueue = queue.SimpleQueue()        # initialpose, obstacles: a flood waits
        self.lock_events: queue.SimpleQueue = queue.SimpleQueue()   # cmd_vel and answers: always applied
        self.wake = threading.Event()
        multi = len(robots) > 1
        self.mates, self.mate_slots, self.own_slots = self._open_mates(params, building, robots)
        self.io = [_RobotIO(self, i, f"robot_{i}/" if multi else "", params, seen=bool(self.mate_slots))
                   for i in range(len(robots))]
        # /clock is written in this thread, at once (a tiny message)
        self.clock_pub = synchronous_publisher(Topic.CLOCK, Clock)
        self.tf_pub = rospy.Publisher(Topic.TF, TFMessage, queue_size=20)
        self.tf_static_pub = rospy.Publisher(Topic.TF_STATIC, TFMessage, queue_size=1, latch=True)
        self.map_pub = rospy.Publisher(Topic.MAP, OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub = rospy.Publisher(Topic.MAP_METADATA, MapMetaData, queue_size=1, latch=True)
        self.obstacles_pub = rospy.Publisher(Topic.SIM_OBSTACLES, ObstacleArray, queue_size=1, latch=True)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=5)
        rospy.Subscriber(Topic.SIM_OBSTACLE, Obstacle, self.enqueue, callback_args=("obstacle", -1), queue_size=50)
        rospy.Subscriber(Topic.SIM_STEP_DONE, StepDone, self._on_step_done, queue_size=200, tcp_nodelay=True)
        self.map_msg = ru.occupancy_grid(self.floor.map, 0.0)
        rospy.Service(Service.STATIC_MAP, GetMap, lambda _req: GetMapResponse(map=self.map_msg))
        self.odom_due = Periodic(params.odom_rate)
        self.truth_due = Periodic(params.truth_rate)
        self.rest_due = Periodic(params.rest_rate)
        self.laser_due = Periodic(params.laser_rate)
        self.battery_due = Periodic(params.battery_rate)
        self.tf_due = Periodic(params.odom_rate)
        self.timeline = Timeline.open(params.timeline) if params.timeline else None
        wall = time.time()
        resume = self._resume_time()
        start_wall = wall if resume > 0.0 or params.start_wall == 0.0 else params.start_wall
        speed = self.timeline.ceiling if self.timeline is not None else params.speed
        drift = self.timeline.max_drift if self.timeline is not None else params.max_drift
        self.stepper = Stepper(params.step, Pacer(speed, start_wall, resume), Lockstep(params.participant_timeout),
                               max_drift=drift if self.timeline is not None else None, start=resume)
        self.world.start_at(resume)
        self.start_wall = start_wall
        self.lockstep = self.stepper.lockstep
        self.set_time = own_time()
        self._clock_wall = -math.inf       # wall time of the latest /clock
        self._heartbeat = -math.inf
        self._diag = {"wall": wall, "sim": resume, "next": wall + params.diagnostics_period}
        self.scans = 0

    def _open_mates(self, params: SimParams, building: Any, robots: list) -> tuple[Mates | None, dict[int, int],
                                                                                 dict[int, int]]:
        """The mates file, and the slots of the other robots of this floor (world index -> slot) and of this
        node's own robots (world index -> slot): a slot per robot of the building, in its order."""
        if not params.mates:
            return None, {}, {}
        mates = Mates.open(params.mates)
        names = [r.name for r in building.robots]
        if mates.slots != len(names):
            mates.close()
            raise SimConfigError(f"~mates: {params.mates} has {mates.slots} slots, the building {len(names)} robots")
        own = {i: names.index(r.name) for i, r in enumerate(robots)}
        slots = {}
        for robot in building.robots_on(self.floor.id):
            if robot.name in {r.name for r in robots}:
                continue
            slot = names.index(robot.name)
            state = mates.read(slot)
            spec = RobotSpec(robot.name, robot.radius, Limits.of_robot(robot), params.laser, params.battery)
            slots[self.world.add_mate(spec, state.pose if state.finite() else robot.home)] = slot
        return mates, slots, own

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

    def _resume_time(self) -> float:
        """Sim time to start from: 0 for a new floor; where a restarted simulator's floor was (never earlier)."""
        if self.timeline is not None:
            return self.timeline.read(self.p.timeline_slot).sim
        value = rospy.get_param("~resume_at", 0.0)
        return float(value) if isinstance(value, (int, float)) and math.isfinite(value) and value > 0 else 0.0

    # -- callbacks: enqueue only -------------------------------------------------
    def enqueue(self, msg: Any, args: tuple[str, int]) -> None:
        if args[0] == Topic.CMD_VEL:
            self.lock_events.put((Topic.CMD_VEL, args[1], msg, msg._connection_header.get("callerid", "")))
        else:
            self.events.put((args[0], args[1], msg))
        self.wake.set()

    def _on_step_done(self, msg: StepDone) -> None:
        self.lock_events.put(("step_done", -1, msg, ""))
        self.wake.set()

    def _drain(self, wall: float) -> None:
        """Apply the queued commands and answers (all), then other inputs (at most ``MAX_EVENTS_PER_STEP``;
        obstacle changes update the world once)."""
        while True:
            try:
                kind, index, msg, caller = self.lock_events.get_nowait()
            except queue.Empty:
                break
            try:
                if kind == Topic.CMD_VEL:
                    self.lockstep.command(caller)
                    self.world.set_command(index, *ru.twist_of(msg))
                else:
                    self.lockstep.answer(Answer(msg.node, msg.session, msg.done.to_sec(), msg.idle, tuple(msg.inputs),
                                                msg.commands), wall)
            except (GidaBotError, ValueError, TypeError) as err:
                self.log.reject(kind, str(err))
        for _ in range(MAX_EVENTS_PER_STEP):
            try:
                kind, index, msg = self.events.get_nowait()
            except queue.Empty:
                break
            try:
                if kind == Topic.INITIALPOSE:
                    self.world.rebuild()         # check the pose against the obstacles as they are now
                    self._relocate(index, msg)
                elif kind == "obstacle":
                    self._obstacle(msg)
            except (GidaBotError, ValueError, TypeError) as err:
                self.log.reject(kind, str(err))
        if self.world.rebuild():
            self._publish_obstacles()
        for node in self.lockstep.timed_out:
            rospy.logwarn(f"sim: {node} has not answered for {self.lockstep.timeout:g} s: the world goes on without "
                          "it until it answers again")
        for node in self.lockstep.rejoined:
            rospy.loginfo(f"sim: {node} answers again")
        self.lockstep.timed_out.clear()
        self.lockstep.rejoined.clear()


    def _relocate(self, index: int, msg: PoseWithCovarianceStamped) -> None:
        wanted = ru.initialpose_to_pose2d(msg)
        placed = self.world.teleport(index, wanted)
        name = self.world.robots[index].spec.name
        rospy.loginfo(f"sim: {name} set to ({placed.x:.2f}, {placed.y:.2f}, {placed.yaw:.2f})"
                      + ("" if (placed.x, placed.y) == (wanted.x, wanted.y) else
                         f" (asked ({wanted.x:.2f}, {wanted.y:.2f}): moved clear of a wall)"))
        self.odom_due.reset()
        self.truth_due.reset()
        self.rest_due.reset()

    def _obstacle(self, msg: Obstacle) -> None:
        ru.check_map_frame(msg.header.frame_id, f"obstacle {msg.id[:64]!r}", ObstacleRejected)
        if msg.action == Obstacle.ADD:
            shape = obstacle_shape(msg.shape, msg.x, msg.y, msg.yaw, msg.radius, msg.width, msg.height)
            self.world.add_obstacle(msg.id, shape, rebuild=False)
            rospy.loginfo(f"sim: obstacle {msg.id!r} added: {shape}")
        elif msg.action == Obstacle.REMOVE:
            if not self.world.remove_obstacle(msg.id, rebuild=False):
                raise ObstacleRejected(f"obstacle {msg.id[:64]!r}: no such obstacle to remove")
            rospy.loginfo(f"sim: obstacle {msg.id!r} removed")
        elif msg.action == Obstacle.CLEAR:
            rospy.loginfo(f"sim: {self.world.clear_obstacles(rebuild=False)} obstacle(s) cleared")
        else:
            raise ObstacleRejected(f"obstacle action {msg.action!r}: expected 0 (ADD), 1 (REMOVE) or 2 (CLEAR)")

    # -- publishing ----------------------------------------------------------------
    def _publish_obstacles(self) -> None:
        msg = ObstacleArray()
        msg.header.frame_id = "map"
        msg.header.stamp = ru.stamp(self.world.time)
        msg.obstacles = [ru.obstacle_msg(k, s) for k, s in sorted(self.world.obstacles.items())]
        self.obstacles_pub.publish(msg)

    def _publish_static(self) -> None:
        self.map_msg = ru.occupancy_grid(self.floor.map, self.world.time)
        self.map_pub.publish(self.map_msg)
        self.meta_pub.publish(self.map_msg.info)
        self._publish_obstacles()
        transforms = []
        for io, robot in self._own():
            laser = robot.spec.laser
            transforms.append(ru.transform(io.frame["base_footprint"], io.frame["base_link"], Pose2D(0, 0, 0),
                                           self.world.time))
            transforms.append(ru.transform(io.frame["base_link"], io.frame["base_laser_link"],
                                           Pose2D(laser.x, laser.y, laser.yaw), self.world.time, self.p.laser_z))
        self.tf_static_pub.publish(TFMessage(transforms=transforms))

    def _publish_odom(self, io: _RobotIO, robot: Any, t: float) -> None:
        io.odom.publish(self._odometry(io.odom_msg, robot.odom, robot.vel, t))
        self.lockstep.published(io.odom_topic, t)

    def _publish_sensors(self) -> None:
        t = self.world.time
        odom_due, truth_due, rest_due = self.odom_due.due(t), self.truth_due.due(t), self.rest_due.due(t)
        laser_due, battery_due, tf_due = self.laser_due.due(t), self.battery_due.due(t), self.tf_due.due(t)
        inputs = self.lockstep.inputs_due()           # a driving participant's odometry: at every step
        transforms = []
        for io, robot in self._own():
            resting = self.world.at_rest(io.index)
            if ((rest_due if resting else odom_due) or io.odom_topic in inputs) and io.odom.get_num_connections():
                self._publish_odom(io, robot, t)
            if (rest_due if resting else truth_due) and io.truth.get_num_connections():
                io.truth.publish(self._odometry(io.truth_msg, robot.pose, robot.vel, t))
                self.lockstep.published(io.truth_topic, t)
            if tf_due and self.tf_pub.get_num_connections():
                transforms.append(ru.transform(io.frame["odom"], io.frame["base_footprint"], robot.odom, t))
            if laser_due and io.scan.get_num_connections():
                io.scan.publish(self._scan(io, t))
                self.scans += 1
            if laser_due and io.seen is not None and io.seen.get_num_connections():
                io.seen.publish(self._seen(io, t))
            if battery_due:
                io.battery.publish(self._battery(robot, t))
        if transforms:
            self.tf_pub.publish(TFMessage(transforms=transforms))

    @staticmethod
    def _odometry(msg: Odometry, pose: Pose2D, vel: Any, t: float) -> Odometry:
        """``msg`` (the robot's own, reused: publishing serialises it at once) set to ``pose``, ``vel`` at ``t``."""
        msg.header.stamp = ru.stamp(t)
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        p.x, p.y = pose.x, pose.y
        q.x, q.y, q.z, q.w = yaw_to_quaternion(pose.yaw)
        v = msg.twist.twist
        v.linear.x, v.linear.y, v.angular.z = vel.vx, vel.vy, vel.wz
        return msg

    def _scan(self, io: _RobotIO, t: float) -> LaserScan:
        laser = self.p.laser
        msg = LaserScan()
        msg.header.stamp = ru.stamp(t)
        msg.header.frame_id = io.frame["base_laser_link"]
        msg.angle_min, msg.angle_max, msg.angle_increment = laser.angle_min, laser.angle_max, laser.angle_increment
        msg.time_increment = 0.0
        msg.scan_time = 1.0 / self.p.laser_rate
        msg.range_min, msg.range_max = laser.range_min, laser.range_max
        msg.ranges = self.world.scan(io.index).astype(np.float32).tolist()
        return msg

    def _seen(self, io: _RobotIO, t: float) -> ObstacleArray:
        msg = ObstacleArray()
        msg.header.frame_id = "map"
        msg.header.stamp = ru.stamp(t)
        robots = self.world.robots
        msg.obstacles = [ru.obstacle_msg(robots[j].spec.name, Circle(robots[j].pose.x, robots[j].pose.y,
                                                                      robots[j].spec.radius))
                         for j in self.world.seen_robots(io.index)]
        return msg

    def _own(self) -> list[tuple[_RobotIO, Any]]:
        """This node's robots (not its mates) with their topics."""
        return [(io, self.world.robots[io.index]) for io in self.io]

    def _pairs(self) -> None:
        """Several robots: tell the world whose navigation drives (deadlock watch); log what it reports."""
        inputs = self.lockstep.inputs_due()
        for io in self.io:
            self.world.set_active(io.index, io.odom_topic in inputs)
        for event in self.world.take_events():
            if event.kind == DEADLOCK:
                rospy.logerr(f"sim: {event.text}")
            elif event.kind == COLLISION:
                rospy.logwarn(f"sim: collision: {event.text}")
            else:
                rospy.loginfo(f"sim: {event.text}")

    def _battery(self, robot: Any, t: float) -> BatteryState:
        model = robot.spec.battery
        msg = BatteryState()
        msg.header.stamp = ru.stamp(t)
        msg.percentage = float(robot.battery)
        msg.voltage = model.voltage(robot.battery)
        msg.current = -2.0 if robot.vel.speed > 0.01 else -0.8      # A, discharging
        msg.charge = model.capacity_ah * robot.battery
        msg.capacity = msg.design_capacity = model.capacity_ah
        msg.power_supply_status = BatteryState.POWER_SUPPLY_STATUS_DISCHARGING
        msg.power_supply_health = (BatteryState.POWER_SUPPLY_HEALTH_GOOD if robot.battery > 0.0
                                   else BatteryState.POWER_SUPPLY_HEALTH_DEAD)
        msg.power_supply_technology = BatteryState.POWER_SUPPLY_TECHNOLOGY_LION
        msg.present = True
        msg.location = robot.spec.name
        return msg


    def _publish_stop(self, t: float, wall: float) -> None:
        """Everything of the stop the world just reached: sensors (the participants' inputs), then /clock."""
        self._publish_sensors()
        self._write_mates(wall)
        if wall - self._clock_wall >= 1.0 / self.p.clock_rate_max:
            self.clock_pub.publish(Clock(clock=ru.stamp(t)))
            self.set_time(t)                 # this node's own ROS time, as the others see it (log lines)
            self._clock_wall = wall
        self._write_timeline(wall)

    def _idle(self) -> bool:
        """No robot moves or is commanded and no participant drives: a stop changes nothing but the time."""
        return not self.lockstep.inputs_due() and all(self.world.at_rest(io.index) for io in self.io)

    def _publish_missing_inputs(self, t: float) -> None:
        """A participant stopped being idle during this stop: its inputs for it, published now."""
        for topic in self.lockstep.missing_inputs(t):
            for io, robot in self._own():
                if topic == io.odom_topic:
                    self._publish_odom(io, robot, t)

    def _write_timeline(self, wall: float) -> None:
        self._heartbeat = wall
        if self.timeline is None:
            return
        s = self.stepper
        self.timeline.write(self.p.timeline_slot, TimelineClock(
            sim=s.t, wall=wall, behind=s.behind(wall), wait_controllers=s.waited["controllers"],
            wait_floors=s.waited["floors"], wait_ceiling=s.waited["ceiling"], steps=s.steps,
            timeouts=sum(p.timeouts for p in self.lockstep.participants.values()), max_lead=s.max_lead,
            pid=os.getpid()))

    def _follow_ceiling(self, wall: float) -> None:
        if self.timeline is not None:
            self.stepper.pacer.set_speed(self.timeline.ceiling, self.stepper.t, wall)

    def _diagnostics(self, wall: float) -> None:
        d = self._diag
        if wall < d["next"]:
            return
        s = self.stepper
        span = wall - d["wall"]
        achieved = (s.t - d["sim"]) / span if span > 0 else 0.0
        speed = s.pacer.speed
        values = {
            "floor": self.floor.label, "speed": "max" if speed is None else f"{speed:g}", "sim_time": f"{s.t:.2f}",
            "wall_time": f"{wall:.3f}", "achieved_factor": f"{achieved:.2f}", "behind_s": f"{s.behind(wall):.3f}",
            "wait_controllers_s": f"{s.waited['controllers']:.3f}", "wait_floors_s": f"{s.waited['floors']:.3f}",
            "wait_ceiling_s": f"{s.waited['ceiling']:.3f}", "steps": str(s.steps), "max_lead_s": f"{s.max_lead:.2f}",
            "obstacles": str(len(self.world.obstacles)), "stalls": str(sum(r.stalls for _io, r in self._own())),
            "laser_scans": str(self.scans),
        }
        for node, stats in self.lockstep.stats().items():
            values[f"participant {node}"] = json.dumps(stats, separators=(",", ":"))
        for kind in (Topic.CMD_VEL, Topic.INITIALPOSE, "obstacle", "step_done"):
            values[f"rejected_{kind}"] = str(self.log.counts.get(kind, 0))
        for _io, robot in self._own():
            values[f"battery_{robot.spec.name}"] = f"{robot.battery:.4f}"
        deadlocked = self.world.deadlocked
        # counted with one robot too (0: a floor world with one robot has nobody to collide with); with mates,
        # the contacts in which this node's robot was stopped by another robot of the floor
        values["robot_collisions"] = str(self.world.robot_collisions)
        values["robot_deadlocks"] = str(self.world.deadlocks)
        values["deadlocked"] = ", ".join(f"{a}+{b}" for a, b in deadlocked)
        values["floor_robots"] = ",".join(r.spec.name for r in self.world.robots)
        absent = sorted(p.node for p in self.lockstep.participants.values() if p.absent)
        behind = s.behind(wall) - d.get("behind", 0.0) > 0.1 * span
        level = (DiagnosticStatus.ERROR if deadlocked else
                 DiagnosticStatus.WARN if absent or behind else DiagnosticStatus.OK)
        status = DiagnosticStatus(level=level, name=f"sim: floor {self.floor.label}",
                                  message=(f"deadlock: robots {', '.join(f'{a} and {b}' for a, b in deadlocked)}"
                                           if deadlocked else
                                           f"going on without {', '.join(absent)}" if absent else
                                           "behind its speed ceiling" if behind else "running"),
                                  hardware_id=",".join(r.spec.name for _io, r in self._own()),
                                  values=[KeyValue(k, v) for k, v in values.items()])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = ru.stamp(s.t)
        self.diag_pub.publish(msg)
        if self.timeline is None:     # a restarted simulator goes on from here, ahead of any stamp seen so far
            lead = max(achieved, speed or 0.0) * self.p.diagnostics_period * 2.0 + self.p.step
            rospy.set_param("~resume_at", s.t + lead)
        d.update(wall=wall, sim=s.t, next=wall + self.p.diagnostics_period, behind=s.behind(wall))

    # -- main loop -----------------------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """Step the world until shutdown (see the module docstring). Stops at the first signal
        (``guard.requested``, checked at least every 50 ms wall) and tells the guard, which only then closes the
        topics (rospy's own handler closed them from inside this loop, possibly in the middle of a publish:
        see :mod:`gidabot_navigation.ros.exit_guard`)."""
        try:
            self._loop(guard)
        except rospy.ROSException:
            if not guard.requested:    # a topic closed under a publish blocked past the guard's wait
                raise
        finally:
            guard.loop_stopped()
            if self.timeline is not None:
                self.timeline.close()
            if self.mates is not None:
                self.mates.close()

    def _loop(self, guard: ExitGuard) -> None:
        s = self.stepper
        while not rospy.is_shutdown() and not guard.requested and time.time() < self.start_wall:
            rospy.loginfo_once(f"sim: waiting {self.start_wall - time.time():.1f} s for start_wall")
            self.wake.clear()
            self._drain(time.time())
            self.wake.wait(min(self.start_wall - time.time(), 0.05))
        wall = time.time()
        self._publish_static()
        self._publish_stop(s.t, wall)
        speed = s.pacer.speed
        rospy.loginfo(f"sim: floor {self.floor.label} running from {s.t:.1f} s, speed ceiling "
                      f"{'none' if speed is None else f'{speed:g}x'}, a step every {s.step:g} s"
                      + ("" if self.timeline is None else
                         f", timeline {self.timeline.path} slot {self.p.timeline_slot}"))
        while not rospy.is_shutdown() and not guard.requested:
            self.wake.clear()
            wall = time.time()
            self._drain(wall)
            self._follow_ceiling(wall)
            peers = self.timeline.slowest_peer(self.p.timeline_slot, wall) if self.timeline is not None else None
            wait = s.check(wall, peers)
            if wait is None:
                self._read_mates(wall)
                self.world.advance_to(s.advance(wall))
                if len(self.world.robots) > 1:
                    self._pairs()
                self._publish_stop(s.t, wall)
                self._diagnostics(wall)
                continue
            timeout = min(wait.until - wall, HEARTBEAT)
            if wait.reason == CONTROLLERS:
                self._publish_missing_inputs(s.t)
            elif self._idle():              # nothing moves: wake less often, then step through what is due
                timeout = max(timeout, IDLE_SLEEP)
            if wall - self._heartbeat >= HEARTBEAT:
                self._write_timeline(wall)
                self._write_mates(wall)
            self._diagnostics(wall)
            self.wake.wait(max(0.0, timeout))


def main() -> None:
    # installed before init_node: a signal while init_node waits on a frozen master would run rospy's
    # handler, which never returns (exit within 1 s of SIGINT/SIGTERM, whatever happens)
    guard = rospy_exit_guard(Node.SIM, main_loop=True)
    rospy.init_node(Node.SIM, disable_signals=True)
    keep_registered()     # re-register with a restarted master
    try:
        node = SimNode()
    except (GidaBotError, OSError, ValueError, TypeError) as err:     # bad parameters or files
        rospy.logfatal(f"sim: cannot start: {err}")
        raise SystemExit(1) from err
    node.run(guard)
    guard.spin(rospy.is_shutdown)    # the shutdown runs in the guard's thread, never in this one
