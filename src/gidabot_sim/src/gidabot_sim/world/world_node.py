"""ROS adapter of the floor simulator: the ``/sim`` node (core: :mod:`gidabot_sim.world.world`).

One node per floor (per master), like one of the paper's Gazebo worlds. It owns sim
time: it publishes ``/clock`` from the wall clock with the shared formula
(:mod:`gidabot_sim.world.clock`) and steps the world's physics to it.
"""

from __future__ import annotations

import math
import queue
import time
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import rospy
import rospy.impl.simtime
import rospy.rostime
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry
from nav_msgs.srv import GetMap, GetMapResponse
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, LaserScan
from tf2_msgs.msg import TFMessage

from gidabot_msgs.msg import Obstacle, ObstacleArray
from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.interface import Node, Service, Topic
from gidabot_navigation.ros.exit_guard import ExitGuard, rospy_exit_guard
from gidabot_navigation.ros.master_watch import keep_registered
from gidabot_navigation.ros.params import param_number
from gidabot_sim.errors import ObstacleRejected, SimConfigError, SimError
from gidabot_sim.ros import convert as ru
from gidabot_sim.world.clock import Periodic, SimClock, tick_period
from gidabot_sim.world.kinematics import Limits
from gidabot_sim.world.world import BatteryModel, LaserSpec, RobotSpec, World, obstacle_shape

MAX_EVENTS_PER_TICK = 200     # inputs applied per /clock tick; a flood waits for the next ticks


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
    speed: float
    start_wall: float
    dt: float
    cmd_timeout: float
    max_catchup: float
    clock_step: float
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
        return SimParams(
            building=building, robots=tuple(robots), floor=float(rospy.get_param("~floor", math.nan)),
            poses=tuple(poses), speed=param_number("~speed", 1.0, 0.0, 1000.0),
            start_wall=param_number("~start_wall", 0.0, strict=False),
            dt=param_number("~physics_dt", 0.02, 0.0, 0.2),
            cmd_timeout=param_number("~cmd_timeout", 0.2),
            max_catchup=param_number("~max_catchup", 10.0),
            clock_step=param_number("~clock_step", 0.05, 0.0, 10.0),
            clock_rate_max=param_number("~clock_rate_max", 100.0, 0.0, 1000.0),
            odom_rate=param_number("~odom_rate", 20.0, 0.0, 1000.0),
            truth_rate=param_number("~truth_rate", 5.0, 0.0, 1000.0),
            rest_rate=param_number("~rest_rate", 1.0, 0.0, 1000.0),
            laser_rate=param_number("~laser_rate", 10.0, 0.0, 1000.0),
            battery_rate=param_number("~battery_rate", 1.0, 0.0, 100.0),
            laser=laser, laser_z=param_number("~laser_z", 0.3, -5, 5, strict=False), battery=battery,
            seed=None if seed < 0 else seed, diagnostics_period=param_number("~diagnostics_period", 1.0))


class _RobotIO:
    """Topics of one simulated robot (prefix ``robot_<i>/`` when the floor has several)."""

    def __init__(self, node: SimNode, index: int, prefix: str, params: SimParams) -> None:
        self.index, self.prefix = index, prefix
        self.frame = {name: f"{prefix}{name}" for name in ("odom", "base_footprint", "base_link", "base_laser_link")}
        self.odom = rospy.Publisher(prefix + Topic.ODOM, Odometry, queue_size=5)
        self.truth = rospy.Publisher(prefix + Topic.BASE_POSE_GROUND_TRUTH, Odometry, queue_size=5)
        self.scan = rospy.Publisher(prefix + Topic.BASE_SCAN, LaserScan, queue_size=2)
        self.battery = rospy.Publisher(prefix + Topic.BATTERY, BatteryState, queue_size=2)
        rospy.Subscriber(prefix + Topic.CMD_VEL, Twist, node.enqueue, callback_args=(Topic.CMD_VEL, index),
                         queue_size=5)
        rospy.Subscriber(prefix + Topic.INITIALPOSE, PoseWithCovarianceStamped, node.enqueue,
                         callback_args=(Topic.INITIALPOSE, index), queue_size=5)


class SimNode:
    """Simulates one floor: its map, robots, laser, battery and run-time obstacles; owns ``/clock``.

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
      tf: ``odom -> base_footprint`` (while /tf has subscribers); static ``base_footprint -> base_link``
        and ``base_link -> base_laser_link``.
    Floor-wide:
      ``/clock`` (rosgraph_msgs/Clock): sim time = (wall - ``~start_wall``) * ``~speed``, about every
        ``~clock_step`` sim seconds but at most ``~clock_rate_max`` per wall second; nothing before
        ``~start_wall``.
      ``map`` (nav_msgs/OccupancyGrid, latched) and ``map_metadata`` (latched), service ``static_map``
        (nav_msgs/GetMap): the floor's map, as map_server serves it.
      ``/sim/obstacle`` (gidabot_msgs/Obstacle, subscribed): add / remove / clear run-time obstacles.
      ``/sim/obstacles`` (gidabot_msgs/ObstacleArray, latched): the current obstacles, on every change.
      ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): ``sim: floor <f>`` every ``~diagnostics_period``
        wall seconds (speed, sim time, achieved factor, lag, counters of rejected input, stalls, scans).
    Params:
      ``~building`` (str), ``~robot`` (str) or ``~robots`` (list of str): robots of the building file
        simulated here (their drive, limits, radius); ``~floor`` (default: the first robot's);
      ``~initial_pose`` ([x, y, yaw], m/rad; default the robot's home) or ``~initial_poses`` (one per robot);
      ``~speed`` (sim s per wall s, 1), ``~start_wall`` (s since the epoch, 0 = now);
      ``~physics_dt`` (s, 0.02), ``~cmd_timeout`` (s, 0.2), ``~max_catchup`` (s, 10: a longer stall of
        the process is skipped, not simulated); ``~clock_step`` (s, 0.05), ``~clock_rate_max`` (Hz, 100);
      ``~odom_rate`` (Hz, 20), ``~truth_rate`` (Hz, 5), ``~rest_rate`` (Hz, 1), ``~laser_rate`` (Hz, 10),
        ``~battery_rate`` (Hz, 1), all in sim time (at most one message per topic per /clock tick);
      ``~laser_beams`` (360), ``~laser_fov`` (rad, 3 pi/2), ``~laser_range_min``/``~laser_range_max``
        (m, 0.05/20), ``~laser_noise`` (m, 0.01), ``~laser_x``/``~laser_y``/``~laser_z`` (m, mount);
      ``~battery_start`` (0..1, 1), ``~battery_idle_per_hour`` (fraction/h, 0.05), ``~battery_per_km``
        (fraction/km, 0.25); ``~seed`` (int, -1 = random); ``~diagnostics_period`` (wall s, 1).
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
        self.world = World(self.floor.map, dt=params.dt, cmd_timeout=params.cmd_timeout,
                           max_catchup=params.max_catchup, rng=np.random.default_rng(params.seed))
        for robot, pose in zip(robots, params.poses, strict=True):
            spec = RobotSpec(robot.name, robot.radius, Limits.of_robot(robot), params.laser, params.battery)
            try:
                self.world.add_robot(spec, pose or robot.home)
            except SimError as err:
                raise SimConfigError(f"robot {robot.name}: initial pose: {err}") from err
        self.log = ru.CountingLog(rospy.logerr)
        self.events: queue.SimpleQueue = queue.SimpleQueue()
        multi = len(robots) > 1
        self.io = [_RobotIO(self, i, f"robot_{i}/" if multi else "", params) for i in range(len(robots))]
        # /clock is published synchronously (no queue thread per subscriber): tiny messages, 100 per wall
        # second, and a tick must not wait behind a queue (rospy warns about queue_size=None: intended)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)
            self.clock_pub = rospy.Publisher(Topic.CLOCK, Clock, queue_size=None)
        self.tf_pub = rospy.Publisher(Topic.TF, TFMessage, queue_size=20)
        self.tf_static_pub = rospy.Publisher(Topic.TF_STATIC, TFMessage, queue_size=1, latch=True)
        self.map_pub = rospy.Publisher(Topic.MAP, OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub = rospy.Publisher(Topic.MAP_METADATA, MapMetaData, queue_size=1, latch=True)
        self.obstacles_pub = rospy.Publisher(Topic.SIM_OBSTACLES, ObstacleArray, queue_size=1, latch=True)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=5)
        rospy.Subscriber(Topic.SIM_OBSTACLE, Obstacle, self.enqueue, callback_args=("obstacle", -1), queue_size=50)
        self.map_msg = ru.occupancy_grid(self.floor.map, 0.0)
        rospy.Service(Service.STATIC_MAP, GetMap, lambda _req: GetMapResponse(map=self.map_msg))
        self.odom_due = Periodic(params.odom_rate)
        self.truth_due = Periodic(params.truth_rate)
        self.rest_due = Periodic(params.rest_rate)
        self.laser_due = Periodic(params.laser_rate)
        self.battery_due = Periodic(params.battery_rate)
        self.tf_due = Periodic(params.odom_rate)
        self.clock = SimClock.create(params.speed, params.start_wall, time.time())
        if params.start_wall == 0.0:     # "now": keep it, so a respawned simulator continues the same timeline
            rospy.set_param("~start_wall", self.clock.start_wall)
        self.period = tick_period(params.speed, params.clock_step, params.clock_rate_max)
        self._diag = {"wall": time.time(), "sim": 0.0}
        self.late_ticks = 0
        self.scans = 0

    # -- callbacks: enqueue only -------------------------------------------------
    def enqueue(self, msg: Any, args: tuple[str, int]) -> None:
        self.events.put((args[0], args[1], msg))

    def _drain(self) -> None:
        """Apply the queued inputs (at most ``MAX_EVENTS_PER_TICK``; obstacle changes update the world once)."""
        for _ in range(MAX_EVENTS_PER_TICK):
            try:
                kind, index, msg = self.events.get_nowait()
            except queue.Empty:
                break
            try:
                if kind == Topic.CMD_VEL:
                    self.world.set_command(index, *ru.twist_of(msg))
                elif kind == Topic.INITIALPOSE:
                    self.world.rebuild()         # check the pose against the obstacles as they are now
                    self._relocate(index, msg)
                elif kind == "obstacle":
                    self._obstacle(msg)
            except (GidaBotError, ValueError, TypeError) as err:
                self.log.reject(kind, str(err))
        if self.world.rebuild():
            self._publish_obstacles()

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
        for io, robot in zip(self.io, self.world.robots, strict=True):
            laser = robot.spec.laser
            transforms.append(ru.transform(io.frame["base_footprint"], io.frame["base_link"], Pose2D(0, 0, 0),
                                           self.world.time))
            transforms.append(ru.transform(io.frame["base_link"], io.frame["base_laser_link"],
                                           Pose2D(laser.x, laser.y, laser.yaw), self.world.time, self.p.laser_z))
        self.tf_static_pub.publish(TFMessage(transforms=transforms))

    def _publish_sensors(self) -> None:
        t = self.world.time
        odom_due, truth_due, rest_due = self.odom_due.due(t), self.truth_due.due(t), self.rest_due.due(t)
        laser_due, battery_due, tf_due = self.laser_due.due(t), self.battery_due.due(t), self.tf_due.due(t)
        transforms = []
        for io, robot in zip(self.io, self.world.robots, strict=True):
            resting = self.world.at_rest(io.index)
            if (rest_due if resting else odom_due) and io.odom.get_num_connections():
                io.odom.publish(self._odometry(io.frame["odom"], io.frame["base_footprint"], robot.odom,
                                               robot.vel, t))
            if (rest_due if resting else truth_due) and io.truth.get_num_connections():
                io.truth.publish(self._odometry("map", io.frame["base_footprint"], robot.pose, robot.vel, t))
            if tf_due and self.tf_pub.get_num_connections():
                transforms.append(ru.transform(io.frame["odom"], io.frame["base_footprint"], robot.odom, t))
            if laser_due and io.scan.get_num_connections():
                io.scan.publish(self._scan(io, t))
                self.scans += 1
            if battery_due:
                io.battery.publish(self._battery(robot, t))
        if transforms:
            self.tf_pub.publish(TFMessage(transforms=transforms))

    @staticmethod
    def _odometry(frame: str, child: str, pose: Pose2D, vel: Any, t: float) -> Odometry:
        msg = Odometry()
        msg.header.stamp = ru.stamp(t)
        msg.header.frame_id = frame
        msg.child_frame_id = child
        msg.pose.pose = ru.pose_msg(pose)
        msg.pose.covariance = [1e-4 if i in (0, 7, 35) else 0.0 for i in range(36)]
        msg.twist.twist = ru.twist_msg(vel)
        msg.twist.covariance = [1e-4 if i in (0, 7, 35) else 0.0 for i in range(36)]
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

    def _diagnostics(self, wall: float) -> None:
        d = self._diag
        span = wall - d["wall"]
        if span < self.p.diagnostics_period:
            return
        achieved = (self.world.time - d["sim"]) / span if span > 0 else 0.0
        lag = self.clock.sim_time(wall) - self.world.time
        values = {
            "floor": self.floor.label, "speed": f"{self.p.speed:g}", "sim_time": f"{self.world.time:.2f}",
            "achieved_factor": f"{achieved:.2f}", "lag_s": f"{lag:.3f}", "late_ticks": str(self.late_ticks),
            "skipped_s": f"{self.world.skipped:.2f}", "obstacles": str(len(self.world.obstacles)),
            "stalls": str(sum(r.stalls for r in self.world.robots)), "laser_scans": str(self.scans),
        }
        for kind in (Topic.CMD_VEL, Topic.INITIALPOSE, "obstacle"):
            values[f"rejected_{kind}"] = str(self.log.counts.get(kind, 0))
        for robot in self.world.robots:
            values[f"battery_{robot.spec.name}"] = f"{robot.battery:.4f}"
        status = DiagnosticStatus(level=DiagnosticStatus.OK if lag < 1.0 + self.p.speed * self.period
                                  else DiagnosticStatus.WARN,
                                  name=f"sim: floor {self.floor.label}",
                                  message="running" if lag < 1.0 else "lagging behind the clock",
                                  hardware_id=",".join(r.spec.name for r in self.world.robots),
                                  values=[KeyValue(k, v) for k, v in values.items()])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = ru.stamp(self.world.time)
        self.diag_pub.publish(msg)
        d.update(wall=wall, sim=self.world.time)

    def _stop_listening_to_own_clock(self) -> None:
        """With /use_sim_time, rospy subscribed this node to /clock to drive rospy.Time; the simulator is
        the clock, so it sets rospy's time itself at every tick (:meth:`_set_own_time`) instead of
        receiving its own 100 messages per wall second. Uses rospy internals, so only when present."""
        sub = getattr(rospy.impl.simtime, "_clock_sub", None)
        self._own_time = getattr(rospy.rostime, "_set_rostime", None) if sub is not None else None
        if sub is not None and self._own_time is not None:
            sub.unregister()

    def _set_own_time(self, now: Any) -> None:
        if self._own_time is not None:
            self._own_time(now)

    # -- main loop -----------------------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """Tick on the wall clock until shutdown: events, physics to the clock, /clock, sensors.

        Stops at the first signal (``guard.requested``, checked every tick, i.e. every <= 0.2 s wall) and
        tells the guard, which only then closes the topics (rospy's own handler closed them from inside
        this loop, possibly in the middle of a publish: see :mod:`gidabot_navigation.ros.exit_guard`)."""
        try:
            self._loop(guard)
        except rospy.ROSException:
            if not guard.requested:    # a topic closed under a publish blocked past the guard's wait
                raise
        finally:
            guard.loop_stopped()

    def _loop(self, guard: ExitGuard) -> None:
        self._stop_listening_to_own_clock()
        started = False
        next_tick = time.time()
        while not rospy.is_shutdown() and not guard.requested:
            wall = time.time()
            target = self.clock.sim_time(wall)
            if target < 0.0:
                rospy.loginfo_once(f"sim: waiting {-target / self.p.speed:.1f} s for start_wall")
                self._drain()
                time.sleep(min(-target / self.p.speed, 0.2))
                next_tick = time.time()
                continue
            if not started:
                self.world.start_at(target)
                self._diag.update(wall=wall, sim=target)
                self._publish_static()
                started = True
                rospy.loginfo(f"sim: floor {self.floor.label} running at {self.p.speed:g}x, "
                              f"/clock every {self.period * 1000:.0f} ms wall")
            self._drain()
            self.world.advance_to(target)
            now = ru.stamp(target)
            self.clock_pub.publish(Clock(clock=now))
            self._set_own_time(now)
            self._publish_sensors()
            self._diagnostics(wall)
            next_tick += self.period
            now = time.time()
            if next_tick < now:             # starved: resynchronise, the next tick catches up more
                self.late_ticks += 1
                next_tick = now
            else:
                time.sleep(next_tick - now)


def main() -> None:
    rospy.init_node(Node.SIM)
    guard = rospy_exit_guard(Node.SIM, main_loop=True)    # exit within 1 s of SIGINT/SIGTERM, whatever happens
    keep_registered()     # re-register with a restarted master
    try:
        node = SimNode()
    except (GidaBotError, OSError, ValueError, TypeError) as err:     # bad parameters or files
        rospy.logfatal(f"sim: cannot start: {err}")
        raise SystemExit(1) from err
    node.run(guard)
    guard.spin(rospy.is_shutdown)    # the shutdown runs in the guard's thread, never in this one
