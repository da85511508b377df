"""ROS adapter of the floor simulator: the ``/sim`` node (core: :mod:`gidabot_sim.world.floor_sim`, on
:mod:`gidabot_sim.world.world` and :mod:`gidabot_sim.world.lockstep`).

One node per floor (per master), like one of the paper's Gazebo worlds. It owns sim time: the
floor's clock advances only by the steps it computes, in lockstep with the floor's controllers
(the move_base and amcl stand-ins), within the building's drift bound and under its speed ceiling
(docs/simulator.md, "Simulated time"). The node reads its parameters, posts what it receives to the
core, runs the core's ticks and publishes what the core emits (conversions: :mod:`gidabot_sim.ros.convert`).
"""

from __future__ import annotations

import math
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import MapMetaData, OccupancyGrid, Odometry
from nav_msgs.srv import GetMap, GetMapResponse
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, LaserScan
from tf2_msgs.msg import TFMessage

from gidabot_msgs.msg import Obstacle, ObstacleArray, StepDone, VisitorBody
from gidabot_navigation.building.model import load_building
from gidabot_navigation.interface import Node, Service, Topic
from gidabot_navigation.ros.adapter import sender
from gidabot_navigation.ros.exit_guard import ExitGuard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.node_main import run_node
from gidabot_navigation.ros.params import param_number
from gidabot_sim.ros import convert
from gidabot_sim.ros.participant import own_time, synchronous_publisher
from gidabot_sim.world import floor_sim as fs
from gidabot_sim.world.clock import MAX_SPEED
from gidabot_sim.world.world import BatteryModel, LaserSpec

SIM = fs.SimConfig      # its fields' defaults are the parameters' defaults


def read_config() -> fs.SimConfig:
    """The node's parameters (ranges checked here, the rest by the core)."""
    poses = rospy.get_param("~initial_poses") if rospy.has_param("~initial_poses") else None
    robots = fs.robot_names(str(rospy.get_param("~robot", "")), rospy.get_param("~robots", None))
    fov = param_number("~laser_fov", 0.0, 0.0, 2 * math.pi, strict=False)     # 0: the building file's
    laser = LaserSpec(beams=int(param_number("~laser_beams", LaserSpec.beams, 1, 10000, strict=False)),
                      fov=fov or LaserSpec.fov,
                      range_min=param_number("~laser_range_min", LaserSpec.range_min, strict=False),
                      range_max=param_number("~laser_range_max", LaserSpec.range_max, strict=False),
                      noise=param_number("~laser_noise", LaserSpec.noise, strict=False),
                      x=param_number("~laser_x", LaserSpec.x, -5, 5, strict=False),
                      y=param_number("~laser_y", LaserSpec.y, -5, 5, strict=False))
    battery = BatteryModel(start=param_number("~battery_start", BatteryModel.start, 0.0, 1.0, strict=False),
                           idle_per_hour=param_number("~battery_idle_per_hour", BatteryModel.idle_per_hour,
                                                      strict=False),
                           per_km=param_number("~battery_per_km", BatteryModel.per_km, strict=False))
    seed = int(param_number("~seed", -1, -math.inf, strict=False))
    speed = rospy.get_param("~speed", SIM.speed)
    return fs.SimConfig(
        building=str(rospy.get_param("~building", "")), robots=robots, floor=rospy.get_param("~floor", None),
        poses=fs.initial_poses(robots, poses, rospy.get_param("~initial_pose", [])),
        speed=None if speed == "max" else param_number("~speed", SIM.speed, 0.0, MAX_SPEED),
        start_wall=param_number("~start_wall", SIM.start_wall, strict=False),
        dt=param_number("~physics_dt", SIM.dt, 0.0, 0.2), step=param_number("~step", SIM.step, 0.0, 10.0),
        participant_timeout=param_number("~participant_timeout", SIM.participant_timeout, 0.0),
        timeline=str(rospy.get_param("~timeline", SIM.timeline)),
        timeline_slot=int(param_number("~timeline_slot", SIM.timeline_slot, 0.0, 63.0, strict=False)),
        cmd_timeout=param_number("~cmd_timeout", SIM.cmd_timeout, 0.0),
        clock_rate_max=param_number("~clock_rate_max", SIM.clock_rate_max, 0.0, 1000.0),
        odom_rate=param_number("~odom_rate", SIM.odom_rate, 0.0, 1000.0),
        truth_rate=param_number("~truth_rate", SIM.truth_rate, 0.0, 1000.0),
        rest_rate=param_number("~rest_rate", SIM.rest_rate, 0.0, 1000.0),
        laser_rate=param_number("~laser_rate", SIM.laser_rate, 0.0, 1000.0),
        battery_rate=param_number("~battery_rate", SIM.battery_rate, 0.0, 100.0),
        laser=laser, laser_fov_declared=not fov,
        laser_z=param_number("~laser_z", SIM.laser_z, -5, 5, strict=False), battery=battery,
        seed=None if seed < 0 else seed,
        diagnostics_period=param_number("~diagnostics_period", SIM.diagnostics_period, 0.0),
        deadlock_time=param_number("~deadlock_time", SIM.deadlock_time, 0.0),
        mates=str(rospy.get_param("~mates", SIM.mates)),
        people=int(param_number("~people", SIM.people, 0.0, 100.0, strict=False)),
        people_seed=int(param_number("~people_seed", SIM.people_seed, -math.inf, strict=False)))


class _RobotIO:
    """The topics of one simulated robot (prefix ``robot_<i>/`` when the floor has several) and its reused
    odometry messages."""

    def __init__(self, node: SimNode, index: int) -> None:
        sim, prefix = node.sim, node.sim.prefixes[index]
        self.frames = frames = sim.frames[index]
        self.odom_msg = convert.odometry_msg(frames["odom"], frames["base_footprint"])
        self.truth_msg = convert.odometry_msg("map", frames["base_footprint"])
        self.pubs = {Topic.ODOM: rospy.Publisher(prefix + Topic.ODOM, Odometry, queue_size=5),
                     Topic.BASE_POSE_GROUND_TRUTH: rospy.Publisher(prefix + Topic.BASE_POSE_GROUND_TRUTH, Odometry,
                                                                   queue_size=5),
                     Topic.BASE_SCAN: rospy.Publisher(prefix + Topic.BASE_SCAN, LaserScan, queue_size=2),
                     Topic.BATTERY: rospy.Publisher(prefix + Topic.BATTERY, BatteryState, queue_size=2)}
        self.pubs[Topic.ROBOTS_SEEN] = rospy.Publisher(prefix + Topic.ROBOTS_SEEN, ObstacleArray, queue_size=2)
        rospy.Subscriber(prefix + Topic.CMD_VEL, Twist, node.on_cmd_vel, callback_args=index, queue_size=50,
                         tcp_nodelay=True)
        rospy.Subscriber(prefix + Topic.INITIALPOSE, PoseWithCovarianceStamped, node.on_initialpose,
                         callback_args=index, queue_size=5)


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
        ``robots_seen`` (gidabot_msgs/ObstacleArray, frame ``map``; several robots, or people on the floor): the
          other robots its laser sees now (id = robot name, a CIRCLE of its radius) and the people (id
          ``person/<visitor or bystander>``, a CIRCLE of a person) at ``~laser_rate``, while somebody subscribes:
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
      ``/sim/visitor_body`` (gidabot_msgs/VisitorBody, subscribed): what a simulated visitor's body does on this
        floor (follow a robot, leave, gone; its behaviour), from the visitor node (:mod:`gidabot_sim.world.people`).
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
      ``~odom_rate`` (Hz, 10), ``~truth_rate`` (Hz, 5), ``~rest_rate`` (Hz, 1), ``~laser_rate`` (Hz, 5: the
        people tracker's rate), ``~battery_rate`` (Hz, 1), all in sim time (at most one message per topic per
        step);
      ``~laser_beams`` (360), ``~laser_fov`` (rad, 0: what the building file declares for the robot,
        ``sensors.laser.fov``, all round unless said), ``~laser_range_min``/``~laser_range_max``
        (m, 0.05/20), ``~laser_noise`` (m, 0.01), ``~laser_x``/``~laser_y``/``~laser_z`` (m, mount);
      ``~battery_start`` (0..1, 1), ``~battery_idle_per_hour`` (fraction/h, 0.05), ``~battery_per_km``
        (fraction/km, 0.25); ``~seed`` (int, -1 = random); ``~diagnostics_period`` (wall s, 1);
      ``~deadlock_time`` (sim s, 30); ``~people`` (0..100, 0) bystanders walking the floor between its places (the
        simulator of the floor's first robot by name walks them), drawn from ``~people_seed`` (1);
      ``~mates`` (path of the building's mates file, '' = none: the other robots
        of this floor, each simulated by its own simulator on its own master, share the floor through it,
        :mod:`gidabot_sim.world.mates`: this node writes its robot's motion there after each step and reads
        theirs before each, into its world; ``robots_seen`` is then published for its robot too).
    Restart: the floor's time goes on from where it was (the timeline's slot; without one, ``~resume_at``,
      saved every ``~diagnostics_period``), never back; the robot restarts at its initial pose, obstacles
      are lost.
    Shutdown: the process exits within 1 wall second of SIGINT/SIGTERM, whatever state the master
      and the subscribers are in (:mod:`gidabot_navigation.ros.exit_guard`).
    """

    def __init__(self, config: fs.SimConfig) -> None:
        self.wake = threading.Event()
        self.sim = fs.FloorSim(config, load_building(config.building), time.time(), self._emit, self._wanted,
                               rospy.resolve_name, RosLog(), rospy.get_param("~resume_at", 0.0))
        self.io = [_RobotIO(self, i) for i in self.sim.own]
        self.clock_pub = synchronous_publisher(Topic.CLOCK, Clock)      # written in this thread, at once
        self.tf_pub = rospy.Publisher(Topic.TF, TFMessage, queue_size=20)
        self.tf_static_pub = rospy.Publisher(Topic.TF_STATIC, TFMessage, queue_size=1, latch=True)
        self.map_pub = rospy.Publisher(Topic.MAP, OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub = rospy.Publisher(Topic.MAP_METADATA, MapMetaData, queue_size=1, latch=True)
        self.obstacles_pub = rospy.Publisher(Topic.SIM_OBSTACLES, ObstacleArray, queue_size=1, latch=True)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=5)
        rospy.Subscriber(Topic.SIM_OBSTACLE, Obstacle, self.on_obstacle, queue_size=50)
        rospy.Subscriber(Topic.SIM_VISITOR_BODY, VisitorBody, self.on_visitor_body, queue_size=50)
        rospy.Subscriber(Topic.SIM_STEP_DONE, StepDone, self.on_step_done, queue_size=200, tcp_nodelay=True)
        self.map_msg = convert.occupancy_grid(self.sim.floor.map, 0.0)
        rospy.Service(Service.STATIC_MAP, GetMap, lambda _req: GetMapResponse(map=self.map_msg))
        self.set_time = own_time()
        self._publish = {fs.Odom: self._odom, fs.Truth: self._truth, fs.Transforms: self._transforms,
                         fs.Scan: self._scan, fs.Seen: self._seen, fs.Battery: self._battery,
                         fs.ClockTick: self._clock, fs.MapOut: self._map, fs.Obstacles: self._obstacles,
                         fs.Diagnostics: self._diagnostics, fs.ResumeAt: self._resume_at}

    # -- callbacks: convert and post ---------------------------------------------------------------------
    def on_cmd_vel(self, msg: Twist, index: int) -> None:
        self.sim.post(fs.CMD_VEL, index, lambda: convert.twist_of(msg), sender(msg))
        self.wake.set()

    def on_initialpose(self, msg: PoseWithCovarianceStamped, index: int) -> None:
        self.sim.post(fs.INITIALPOSE, index, lambda: convert.initialpose_to_pose2d(msg))
        self.wake.set()

    def on_obstacle(self, msg: Obstacle) -> None:
        self.sim.post(fs.OBSTACLE, -1, lambda: convert.obstacle_change_of(msg))
        self.wake.set()

    def on_visitor_body(self, msg: VisitorBody) -> None:
        self.sim.post(fs.VISITOR_BODY, -1, lambda: convert.visitor_body_of(msg))
        self.wake.set()

    def on_step_done(self, msg: StepDone) -> None:
        self.sim.post(fs.STEP_DONE, -1, lambda: convert.answer_of(msg))
        self.wake.set()

    # -- what the core emits -------------------------------------------------------------------------------
    def _wanted(self, topic: str, index: int) -> bool:
        pub = self.tf_pub if topic == Topic.TF else self.io[index].pubs.get(topic)
        return pub is not None and pub.get_num_connections() > 0

    def _emit(self, out: fs.Output) -> None:
        self._publish[type(out)](out)

    def _odom(self, out: fs.Odom) -> None:
        io = self.io[out.index]
        io.pubs[Topic.ODOM].publish(convert.fill_odometry(io.odom_msg, out.pose, out.vel, out.t))

    def _truth(self, out: fs.Truth) -> None:
        io = self.io[out.index]
        io.pubs[Topic.BASE_POSE_GROUND_TRUTH].publish(convert.fill_odometry(io.truth_msg, out.pose, out.vel, out.t))

    def _transforms(self, out: fs.Transforms) -> None:
        (self.tf_static_pub if out.static else self.tf_pub).publish(convert.transforms_msg(out))

    def _scan(self, out: fs.Scan) -> None:
        io = self.io[out.index]
        io.pubs[Topic.BASE_SCAN].publish(convert.scan_msg(out, io.frames["base_laser_link"]))

    def _seen(self, out: fs.Seen) -> None:
        self.io[out.index].pubs[Topic.ROBOTS_SEEN].publish(convert.seen_msg(out))

    def _battery(self, out: fs.Battery) -> None:
        self.io[out.index].pubs[Topic.BATTERY].publish(convert.battery_msg(out))

    def _clock(self, out: fs.ClockTick) -> None:
        self.clock_pub.publish(convert.clock_msg(out.t))
        self.set_time(out.t)                 # this node's own ROS time, as the others see it (log lines)

    def _map(self, out: fs.MapOut) -> None:
        self.map_msg = convert.occupancy_grid(self.sim.floor.map, out.t)
        self.map_pub.publish(self.map_msg)
        self.meta_pub.publish(self.map_msg.info)

    def _obstacles(self, out: fs.Obstacles) -> None:
        self.obstacles_pub.publish(convert.obstacles_msg(out))

    def _diagnostics(self, out: fs.Diagnostics) -> None:
        self.diag_pub.publish(convert.diagnostics_msg(out))

    @staticmethod
    def _resume_at(out: fs.ResumeAt) -> None:
        rospy.set_param("~resume_at", out.t)

    # -- main loop -----------------------------------------------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """Tick the core until shutdown. Stops at the first signal (``guard.requested``, checked at least every
        50 ms wall) and tells the guard, which only then closes the topics (rospy's own handler closed them from
        inside this loop, possibly in the middle of a publish: see :mod:`gidabot_navigation.ros.exit_guard`)."""
        try:
            while not rospy.is_shutdown() and not guard.requested:
                self.wake.clear()
                sleep = self.sim.tick(time.time())
                if sleep > 0.0:
                    self.wake.wait(sleep)
        except rospy.ROSException:
            if not guard.requested:    # a topic closed under a publish blocked past the guard's wait
                raise
        finally:
            guard.loop_stopped()
            self.sim.close()


def main(argv: list[str] | None = None) -> int:
    return run_node(Node.SIM, lambda: SimNode(read_config()),
                    lambda n: f"sim: floor {n.sim.floor.label}: {', '.join(n.sim.config.robots)}", argv)
