"""ROS adapter of the move_base stand-in: the ``/move_base`` node (cores: :mod:`gidabot_sim.navstack.move_base_loop`
on :mod:`gidabot_sim.navstack.move_base`).

A lockstep participant of the floor's simulator (docs/simulator.md, "Lockstep"): while a goal runs, its
control cycles run on the odometry of each of the simulator's steps, and the world does not step on before
it has answered. The node reads its parameters, hands what it receives to the core and serves the core's
:class:`~gidabot_sim.navstack.move_base_loop.MoveBasePort` (conversions: :mod:`gidabot_sim.ros.convert`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from typing import Any

import actionlib
import rospy
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionGoal, MoveBaseFeedback, MoveBaseResult
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from nav_msgs.srv import GetPlan, GetPlanResponse
from std_msgs.msg import Float32
from std_srvs.srv import Empty, EmptyResponse

from gidabot_msgs.msg import ObstacleArray
from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.planning import Path
from gidabot_navigation.interface import Node, Service, Topic
from gidabot_navigation.ros.exit_guard import ExitGuard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.node_main import run_node
from gidabot_navigation.ros.params import param_number
from gidabot_sim.errors import PlanRefused, SimConfigError
from gidabot_sim.navstack.move_base import MoveBaseCore, NavConfig
from gidabot_sim.navstack.move_base_loop import MoveBaseLoop
from gidabot_sim.ros import convert
from gidabot_sim.ros.participant import StepAnswers, own_time, synchronous_publisher
from gidabot_sim.world.kinematics import Limits, Twist2D

SELF_CONNECT_TIMEOUT = 10.0     # wall s: the action server's subscriber to this node's own goal topic


class MoveBaseNode:
    """Drives the robot to goals like move_base (global planner on the inflated map + path follower).

    Action server ``move_base`` (move_base_msgs/MoveBaseAction, SimpleActionServer semantics):
      a new goal preempts the current one (PREEMPTED); cancel -> PREEMPTED and the robot stops;
      SUCCEEDED within ``~xy_goal_tolerance`` / ``~yaw_goal_tolerance``; ABORTED when no plan exists
      (after ``~planner_patience`` if run-time obstacles could clear), when stuck
      (``~controller_patience``, ``~oscillation_timeout``), or for an invalid goal (NaN, bad
      quaternion, frame other than ``map``). Feedback ``base_position`` (map frame) at ``~feedback_rate``.
    Subscribes:
      ``move_base_simple/goal`` (geometry_msgs/PoseStamped): re-published as an action goal (as move_base).
      ``odom`` (nav_msgs/Odometry) + ``amcl_pose`` (geometry_msgs/PoseWithCovarianceStamped): the robot's
        map pose, as tf's map -> odom -> base_footprint would give it.
      ``~obstacles_topic`` (gidabot_msgs/ObstacleArray, default ``/sim/obstacles``): run-time obstacles,
        lethal in the costmap (a perfect obstacle layer); any change re-plans the running goal.
      ``~robots_topic`` (gidabot_msgs/ObstacleArray, default ``robots_seen``): the other robots the laser sees
        (id = name, CIRCLE), marked in the costmap; a robot in the way is driven around, or yielded to / waited
        for by name priority (:mod:`gidabot_sim.navstack.move_base`); ABORTED naming it after
        ``~robot_patience`` without progress (a deadlock).
      ``move_base/speed_limit`` (std_msgs/Float32): m/s, the most the robot may drive from now on (0: its own
        limits; a guiding robot keeping its visitor's pace), as Nav2's ``speed_limit`` or a local planner's
        ``max_vel_x`` set by dynamic_reconfigure on a robot.
    Publishes:
      ``cmd_vel`` (geometry_msgs/Twist) at ``~controller_frequency`` while a goal runs (zero when it ends);
      ``move_base/current_goal`` (geometry_msgs/PoseStamped); ``move_base/NavfnROS/plan`` (nav_msgs/Path)
      on every (re)plan while subscribed.
    Services:
      ``move_base/make_plan`` (nav_msgs/GetPlan): a plan from ``start`` (empty frame_id: the robot's pose)
        to ``goal``; empty plan when there is none. Like move_base it refuses (service error) while a
        goal is running, unless ``~make_plan_while_active`` is true.
      ``move_base/clear_costmaps`` (std_srvs/Empty).
    Params:
      ``~building`` (str), ``~robot`` (str): radius, drive, velocity/acceleration limits; ``~floor`` (the map,
      default the robot's floor: another floor's robot simulated there, several robots on a floor);
      ``~xy_goal_tolerance`` (m, 0.25), ``~yaw_goal_tolerance`` (rad, 0.2), ``~controller_frequency`` (Hz, 10),
      ``~planner_patience`` (s, 5), ``~controller_patience`` (s, 15), ``~oscillation_timeout`` (s, 30),
      ``~oscillation_distance`` (m, 0.5), ``~lookahead`` (m, 0.8), ``~safety_time`` (s, 1.2),
      ``~footprint_padding`` (m, 0.05: added to the radius for planning),
      ``~inflation_radius`` (m, radius + 0.7), ``~cost_scaling_factor`` (1/m, 3), ``~default_tolerance``
      (m, 0.5: how far a goal too close to an obstacle may move), ``~feedback_rate`` (Hz, 5),
      ``~plan_point_spacing`` (m, the map resolution), ``~make_plan_while_active`` (bool, false),
      ``~robot_mark_step`` (m, 0.1), ``~laser_fov`` (rad, 3 pi/2), ``~yield_timeout`` (s, 10),
      ``~robot_patience`` (s, 60), ``~blocker_distance`` (m, 0.6: a robot or person this close explains no safe
      velocity: waited for, not stuck), ``~wait_budget`` (s, 180: blocked in all during one goal, by blockers
      that keep moving without opening the way, before aborting), ``~stall_timeout`` (s, 60: with a goal, waiting for
      nobody, not moved ``~stall_distance`` (m, 0.1) nor turned ``~stall_turn`` (rad, 0.2): the costmap cleared and
      the goal re-planned; as long again: aborted).
      All times are sim time.
    Lockstep (docs/simulator.md): ROS time is the stamp of the latest odometry (no ``/clock``). While a goal
      runs, the simulator sends the odometry of every step, a control cycle runs on it (at most
      ``~controller_frequency``) with the latest localisation, and is answered on ``/sim/step_done``
      (gidabot_msgs/StepDone) after its cmd_vel; idle, it answers nothing and the world does not wait for it.
    Shutdown: the process exits within 1 wall second of SIGINT/SIGTERM (:mod:`gidabot_navigation.ros.exit_guard`).
    """

    def __init__(self) -> None:
        building = load_building(str(rospy.get_param("~building", "")))
        try:
            robot = building.robot(str(rospy.get_param("~robot", "")))
        except KeyError as err:
            raise SimConfigError(f"~robot: {err.args[0]}") from err
        try:
            floor = building.floor(param_number("~floor", robot.floor, -1e6, strict=False))
        except KeyError as err:
            raise SimConfigError(f"~floor: {err.args[0]}") from err
        defaults = NavConfig()
        config = NavConfig(**{name: param_number(f"~{name}", value) for name, value in defaults.__dict__.items()})
        nav = MoveBaseCore.for_floor(floor, robot.radius, Limits.of_robot(robot), config, RosLog(),
                                     inflation_radius=param_number("~inflation_radius", robot.radius + 0.7),
                                     cost_scaling=param_number("~cost_scaling_factor", 3.0),
                                     goal_tolerance=param_number("~default_tolerance", 0.5), name=robot.name)
        self.spacing = param_number("~plan_point_spacing", floor.map.resolution)
        self.loop = MoveBaseLoop(nav, self, RosLog(), rospy.resolve_name(Topic.ODOM),
                                 param_number("~feedback_rate", 5.0),
                                 bool(rospy.get_param("~make_plan_while_active", False)))
        self.set_time = own_time()
        self.answers = StepAnswers()
        self.wake = threading.Event()
        self.cmd_pub = synchronous_publisher(Topic.CMD_VEL, Twist)       # to the simulator, before the answer
        self.goal_pub = rospy.Publisher(Topic.MOVE_BASE_CURRENT_GOAL, PoseStamped, queue_size=2)
        self.plan_pub = rospy.Publisher(Topic.MOVE_BASE_PLAN, PathMsg, queue_size=2)
        self.action_goal_pub = rospy.Publisher(Topic.MOVE_BASE_GOAL, MoveBaseActionGoal, queue_size=2)
        self.server = actionlib.SimpleActionServer(Topic.MOVE_BASE, MoveBaseAction, auto_start=False)
        self.server.register_goal_callback(self._on_goal)
        self.server.register_preempt_callback(self._on_preempt)
        rospy.Subscriber(Topic.ODOM, Odometry, self._on_odom, queue_size=10, tcp_nodelay=True)
        rospy.Subscriber(Topic.AMCL_POSE, PoseWithCovarianceStamped, self._on_amcl, queue_size=10)
        rospy.Subscriber(str(rospy.get_param("~obstacles_topic", Topic.SIM_OBSTACLES)), ObstacleArray,
                         self._on_obstacles, queue_size=10)
        rospy.Subscriber(str(rospy.get_param("~robots_topic", Topic.ROBOTS_SEEN)), ObstacleArray,
                         self._on_robots, queue_size=10)
        rospy.Subscriber(Topic.MOVE_BASE_SPEED_LIMIT, Float32, self._on_speed_limit, queue_size=2)
        rospy.Service(Service.MAKE_PLAN, GetPlan, self._make_plan)
        rospy.Service(Service.CLEAR_COSTMAPS, Empty, self._clear_costmaps)
        self.server.start()
        self._await_own_goal_topic()
        rospy.Subscriber(Topic.MOVE_BASE_SIMPLE_GOAL, PoseStamped, self._on_simple_goal, queue_size=2)

    def _await_own_goal_topic(self) -> None:
        """A simple goal is re-published on this node's own action goal topic; rospy connects the action server's
        subscriber to it asynchronously, tens of milliseconds after start: a simple goal re-published before is
        lost. So ``move_base_simple/goal`` is subscribed only once that connection is up (at most
        ``SELF_CONNECT_TIMEOUT`` wall seconds, then with a warning)."""
        deadline = time.monotonic() + SELF_CONNECT_TIMEOUT
        while self.action_goal_pub.get_num_connections() < 1:
            if rospy.is_shutdown() or time.monotonic() > deadline:
                rospy.logwarn(f"move_base: the action server did not hear its own goal topic within "
                              f"{SELF_CONNECT_TIMEOUT:g} s: a simple goal sent now may be lost")
                return
            time.sleep(0.01)

    # -- callbacks: convert and hand over -----------------------------------------------------------------
    def _on_goal(self) -> None:
        self.loop.on_goal()
        self.wake.set()

    def _on_preempt(self) -> None:
        self.loop.on_preempt()
        self.wake.set()

    def _on_obstacles(self, msg: ObstacleArray) -> None:
        self.loop.on_obstacles(lambda: convert.obstacle_shapes_of(msg))
        self.wake.set()

    def _on_robots(self, msg: ObstacleArray) -> None:
        self.loop.on_robots(lambda: convert.sensed_robots_of(msg))
        self.wake.set()

    def _on_speed_limit(self, msg: Float32) -> None:
        self.loop.on_speed_limit(float(msg.data))
        self.wake.set()

    def _on_odom(self, msg: Odometry) -> None:
        self.loop.on_odom(lambda: convert.odometry_of(msg, Topic.ODOM))

    def _on_amcl(self, msg: PoseWithCovarianceStamped) -> None:
        self.loop.on_estimate(lambda: convert.amcl_pose_of(msg))

    def _on_simple_goal(self, msg: PoseStamped) -> None:
        goal = MoveBaseActionGoal()
        goal.header.stamp = convert.stamp(rospy.get_time())
        goal.goal.target_pose = msg
        self.action_goal_pub.publish(goal)

    def _make_plan(self, req: Any) -> GetPlanResponse:
        try:
            found = self.loop.make_plan(lambda: convert.plan_request_of(req))
        except PlanRefused as err:
            raise rospy.ServiceException(str(err)) from err
        return GetPlanResponse(plan=convert.plan_msg(found, self.spacing, rospy.get_time()))

    def _clear_costmaps(self, _req: Any) -> EmptyResponse:
        self.loop.clear_costmaps()
        return EmptyResponse()

    # -- the core's port ------------------------------------------------------------------------------------
    def new_goal_available(self) -> bool:
        return self.server.is_new_goal_available()

    def accept_new_goal(self) -> Pose2D | None:
        goal = self.server.accept_new_goal()     # a running goal is reported PREEMPTED
        return None if goal is None else convert.goal_to_pose2d(goal.target_pose.header.frame_id, goal.target_pose.pose)

    def goal_active(self) -> bool:
        return self.server.is_active()

    def preempt_requested(self) -> bool:
        return self.server.is_preempt_requested()

    def preempted(self, text: str) -> None:
        self.server.set_preempted(MoveBaseResult(), text)

    def succeeded(self, text: str) -> None:
        self.server.set_succeeded(MoveBaseResult(), text)

    def aborted(self, text: str) -> None:
        self.server.set_aborted(MoveBaseResult(), text)

    def feedback(self, pose: Pose2D, t: float) -> None:
        self.server.publish_feedback(MoveBaseFeedback(base_position=convert.pose_stamped(pose, t)))

    def command(self, cmd: Twist2D) -> None:
        self.cmd_pub.publish(convert.twist_msg(cmd))
        self.answers.command_sent()

    def current_goal(self, pose: Pose2D, t: float) -> None:
        self.goal_pub.publish(convert.pose_stamped(pose, t))

    def wants_plan(self) -> bool:
        return self.plan_pub.get_num_connections() > 0

    def plan(self, path: Path, goal_yaw: float, t: float) -> None:
        self.plan_pub.publish(convert.path_msg(path, goal_yaw, self.spacing, t))

    def answer(self, t: float, idle: bool, inputs: Sequence[str]) -> None:
        self.answers.answer(t, idle=idle, inputs=inputs)

    # -- the loop -----------------------------------------------------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """Until shutdown: the idle turns (the steps' cycles run in the odometry's thread). Stops at the first
        signal (``guard.requested``; the guard also ends an idle wait) and tells the guard, which only then
        closes the topics (see :mod:`gidabot_navigation.ros.exit_guard`)."""
        guard.set_wake(self.wake.set)
        try:
            self.loop.start()
            while not rospy.is_shutdown() and not guard.requested:
                self.wake.wait(0.5)
                self.wake.clear()
                self.loop.idle_turn()
        except rospy.ROSException:
            if not guard.requested:    # a topic closed under a publish blocked past the guard's wait
                raise
        finally:
            guard.loop_stopped()


def main(argv: list[str] | None = None) -> int:
    return run_node(Node.MOVE_BASE, MoveBaseNode, lambda n: f"move_base of {n.loop.nav.name}", argv)
