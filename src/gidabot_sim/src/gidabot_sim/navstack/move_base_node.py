"""ROS adapter of the move_base stand-in: the ``/move_base`` node (core: :mod:`gidabot_sim.navstack.move_base`).

A lockstep participant of the floor's simulator (docs/simulator.md, "Lockstep"): while a goal runs, its
control cycles run on the odometry of each of the simulator's steps, and the world does not step on before
it has answered.
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

import actionlib
import rospy
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped, Twist
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionGoal, MoveBaseFeedback, MoveBaseResult
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from nav_msgs.srv import GetPlan, GetPlanResponse
from std_srvs.srv import Empty, EmptyResponse

from gidabot_msgs.msg import ObstacleArray
from gidabot_navigation.building.geometry import Pose2D, quaternion_to_yaw
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.planning import Path
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.interface import Node, Service, Topic
from gidabot_navigation.ros.exit_guard import ExitGuard, rospy_exit_guard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.master_watch import keep_registered
from gidabot_navigation.ros.params import param_number
from gidabot_sim.errors import SimConfigError
from gidabot_sim.navstack.amcl import PoseTracker
from gidabot_sim.navstack.move_base import ABORTED, SUCCEEDED, MoveBaseCore, NavConfig, SensedRobot, State
from gidabot_sim.ros import convert as ru
from gidabot_sim.ros.participant import StepAnswers, own_time, synchronous_publisher
from gidabot_sim.world.clock import Periodic
from gidabot_sim.world.kinematics import ZERO, Limits, Twist2D
from gidabot_sim.world.world import obstacle_shape

SELF_CONNECT_TIMEOUT = 10.0     # wall s: the action server's subscriber to this node's own goal topic


def path_msg(path: Path, goal_yaw: float, spacing: float, t: float) -> PathMsg:
    """A plan as navfn returns it: a pose every ``spacing`` m, each facing along the path, the last the goal's yaw."""
    msg = PathMsg()
    msg.header.frame_id = "map"
    msg.header.stamp = ru.stamp(t)
    points = path.densified(spacing)
    for k, (x, y) in enumerate(points):
        if k + 1 < len(points):
            nx, ny = points[k + 1]
            yaw = math.atan2(ny - y, nx - x)
        else:
            yaw = goal_yaw
        pose = PoseStamped()
        pose.header = msg.header
        pose.pose = ru.pose_msg(Pose2D(x, y, yaw))
        msg.poses.append(pose)
    return msg


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
      ``~robot_patience`` (s, 60).
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
            raise SimConfigError(f"~robot: {err}") from err
        try:
            floor = building.floor(float(rospy.get_param("~floor", robot.floor)))
        except (KeyError, TypeError, ValueError) as err:
            raise SimConfigError(f"~floor: {err}") from err

        defaults = NavConfig()
        config = NavConfig(**{name: param_number(f"~{name}", value) for name, value in defaults.__dict__.items()})
        self.core = MoveBaseCore.for_floor(floor, robot.radius, Limits.of_robot(robot), config, RosLog(),
                                           inflation_radius=param_number("~inflation_radius", robot.radius + 0.7),
                                           cost_scaling=param_number("~cost_scaling_factor", 3.0),
                                           goal_tolerance=param_number("~default_tolerance", 0.5), name=robot.name)
        self.spacing = param_number("~plan_point_spacing", floor.map.resolution)
        self.feedback_due = Periodic(param_number("~feedback_rate", 5.0))
        self.control_due = Periodic(config.controller_frequency)
        self.plan_while_active = bool(rospy.get_param("~make_plan_while_active", False))
        self.robot = robot.name
        self.tracker = PoseTracker()
        self.core_lock = threading.Lock()       # the core: control loop vs. services
        self.tracker_lock = threading.Lock()
        self.events: queue.SimpleQueue = queue.SimpleQueue()
        self.wake = threading.Event()
        self.plans_published = 0
        self.rejected = ru.CountingLog(rospy.logerr)       # invalid goals, amcl_pose and odom messages
        self.set_time = own_time()
        self.answers = StepAnswers()
        self.odom_topic = rospy.resolve_name(Topic.ODOM)
        self.turn = threading.Lock()       # a step (odometry thread) or a goal while idle (main loop): one at a time
        self.said = threading.Lock()       # self.active and the answers (a leaf lock: taken under actionlib's too)
        self.active = False                # answering every step (a goal runs)
        self.now = 0.0                     # sim s: the latest odometry's stamp
        self.cmd_pub = synchronous_publisher(Topic.CMD_VEL, Twist)       # to the simulator, before the answer
        self.goal_pub = rospy.Publisher(Topic.MOVE_BASE_CURRENT_GOAL, PoseStamped, queue_size=2)
        self.plan_pub = rospy.Publisher(Topic.MOVE_BASE_PLAN, PathMsg, queue_size=2)
        self.action_goal_pub = rospy.Publisher(Topic.MOVE_BASE_GOAL, MoveBaseActionGoal, queue_size=2)
        self.server = actionlib.SimpleActionServer(Topic.MOVE_BASE, MoveBaseAction, auto_start=False)
        self.server.register_goal_callback(self._on_goal)
        self.server.register_preempt_callback(lambda: self._event("preempt"))
        rospy.Subscriber(Topic.ODOM, Odometry, self._on_odom, queue_size=10, tcp_nodelay=True)
        rospy.Subscriber(Topic.AMCL_POSE, PoseWithCovarianceStamped, self._on_amcl, queue_size=10)
        rospy.Subscriber(str(rospy.get_param("~obstacles_topic", Topic.SIM_OBSTACLES)), ObstacleArray,
                         lambda msg: self._event("obstacles", msg), queue_size=10)
        rospy.Subscriber(str(rospy.get_param("~robots_topic", Topic.ROBOTS_SEEN)), ObstacleArray,
                         lambda msg: self._event("robots", msg), queue_size=10)
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

    # -- callbacks: copy or enqueue ---------------------------------------------------
    def _event(self, kind: str, msg: Any = None) -> None:
        self.events.put((kind, msg))
        self.wake.set()

    def _on_goal(self) -> None:
        """A new goal: the world must wait for this node from now on. Said at once, before the goal is planned
        (tens of milliseconds of wall time the world would otherwise run through while the robot has not started);
        the cycle that accepts and plans it runs at the step the simulator then sends."""
        self._event("goal")
        self._answer(self.now, busy=True, only_if_idle=True)

    def _answer(self, t: float, busy: bool, only_if_idle: bool = False) -> None:
        """Tell the simulator: done through ``t``; ``busy``: a goal runs (every step owed, odometry at every step)."""
        with self.said:
            if only_if_idle and self.active:
                return
            self.answers.answer(t, idle=not busy, inputs=[self.odom_topic] if busy else [])
            self.active = busy

    def _on_odom(self, msg: Odometry) -> None:
        p, q, v = msg.pose.pose.position, msg.pose.pose.orientation, msg.twist.twist
        values = (p.x, p.y, q.x, q.y, q.z, q.w, v.linear.x, v.linear.y, v.angular.z)
        if not all(math.isfinite(x) for x in values):
            self.rejected.reject("odom", f"move_base: ignoring odom with non-finite values {values!r}")
            return
        t = msg.header.stamp.to_sec()
        with self.tracker_lock:
            self.tracker.on_odom(t, Pose2D(p.x, p.y, quaternion_to_yaw(q.x, q.y, q.z, q.w)),
                                 Twist2D(v.linear.x, v.linear.y, v.angular.z))
        self._step(t)

    def _on_amcl(self, msg: PoseWithCovarianceStamped) -> None:
        try:
            pose = ru.pose2d_of(msg.pose.pose, Topic.AMCL_POSE)
        except GidaBotError as err:
            self.rejected.reject(Topic.AMCL_POSE, f"move_base: ignoring amcl_pose: {err}")
            return
        with self.tracker_lock:
            self.tracker.on_estimate(msg.header.stamp.to_sec(), pose)

    def _on_simple_goal(self, msg: PoseStamped) -> None:
        goal = MoveBaseActionGoal()
        goal.header.stamp = rospy.Time.now()
        goal.goal.target_pose = msg
        self.action_goal_pub.publish(goal)

    # -- services ---------------------------------------------------------------------
    def _make_plan(self, req: Any) -> GetPlanResponse:
        if self.server.is_active() and not self.plan_while_active:
            raise rospy.ServiceException("move_base must be in an inactive state to make a plan for an "
                                         "external user")
        resp = GetPlanResponse()
        resp.plan.header.frame_id = "map"
        resp.plan.header.stamp = rospy.Time.now()
        try:
            goal = ru.goal_to_pose2d(req.goal.header.frame_id, req.goal.pose)
            start = None
            if req.start.header.frame_id:
                s = ru.goal_to_pose2d(req.start.header.frame_id, req.start.pose)
                start = (s.x, s.y)
            with self.core_lock:
                path = self.core.make_plan(start, (goal.x, goal.y), float(req.tolerance))
        except (GidaBotError, ValueError, TypeError) as err:
            rospy.logwarn(f"move_base: make_plan: no plan: {err}")
            return resp
        resp.plan = path_msg(path, goal.yaw, self.spacing, rospy.get_time())
        return resp

    def _clear_costmaps(self, _req: Any) -> EmptyResponse:
        with self.core_lock:
            self.core.clear_costmaps()
        rospy.loginfo("move_base: costmaps cleared")
        return EmptyResponse()

    # -- the control loop ------------------------------------------------------------------
    def _drain(self, now: float) -> None:
        latest_obstacles = latest_robots = None
        while True:
            try:
                kind, msg = self.events.get_nowait()
            except queue.Empty:
                break
            if kind == "goal":
                self._accept_goal(now)
            elif kind == "preempt":
                # only if it still stands now: the cancel of a goal a newer one already replaced (the goal and
                # cancel topics are two connections, so it may come after the newer goal) must not stop the newer
                # one (accept_new_goal clears the request, as move_base polls is_preempt_requested())
                if not self.server.is_new_goal_available() and self.server.is_active() \
                        and self.server.is_preempt_requested():
                    self.core.cancel()
                    self._command(ZERO)
                    self.server.set_preempted(MoveBaseResult(), "Goal cancelled")
            elif kind == "obstacles":
                latest_obstacles = msg           # each array is the whole set: only the newest matters
            elif kind == "robots":
                latest_robots = msg
        if latest_obstacles is not None:
            self._obstacles(latest_obstacles)
        if latest_robots is not None:
            self.core.set_robots([SensedRobot(ob.id, ob.x, ob.y, ob.radius) for ob in latest_robots.obstacles
                                  if ob.shape == ob.CIRCLE])

    def _accept_goal(self, now: float) -> None:
        if not self.server.is_new_goal_available():
            return
        goal = self.server.accept_new_goal()     # a running goal is reported PREEMPTED
        if goal is None:
            return
        target = goal.target_pose
        try:
            pose = ru.goal_to_pose2d(target.header.frame_id, target.pose)
            self.core.set_goal(pose, now)
        except GidaBotError as err:
            self.rejected.reject("goal", f"move_base: aborting on goal: {err}")
            self.core.cancel()
            self._command(ZERO)
            self.server.set_aborted(MoveBaseResult(), f"Aborting on goal because it was sent with an invalid "
                                    f"pose: {err}")
            return
        current = PoseStamped()
        current.header.frame_id, current.header.stamp = "map", rospy.Time.now()
        current.pose = ru.pose_msg(pose)
        self.goal_pub.publish(current)
        self.feedback_due.reset()

    def _obstacles(self, msg: ObstacleArray) -> None:
        shapes = {}
        for ob in msg.obstacles:
            try:
                shapes[ob.id] = obstacle_shape(ob.shape, ob.x, ob.y, ob.yaw, ob.radius, ob.width, ob.height)
            except GidaBotError as err:
                rospy.logwarn(f"move_base: ignoring obstacle {ob.id[:64]!r}: {err}")
        if self.core.set_obstacles(shapes):
            rospy.loginfo(f"move_base: costmap updated ({len(shapes)} obstacle(s))")

    def _cycle(self) -> None:
        now = rospy.get_time()
        with self.core_lock:
            self._drain(now)
            with self.tracker_lock:
                pose, velocity, stamp = self.tracker.pose(), self.tracker.velocity, self.tracker.stamp
            if pose is not None and stamp is not None:
                self.core.set_pose(pose, velocity, stamp)
            result = self.core.step(now)
            path, goal, plans_after = self.core.path, self.core.goal, self.core.plans
        if result.cmd is not None:
            self._command(result.cmd)
        if result.outcome == SUCCEEDED and self.server.is_active():
            self.server.set_succeeded(MoveBaseResult(), result.text)
        elif result.outcome == ABORTED and self.server.is_active():
            self.server.set_aborted(MoveBaseResult(), result.text)
        elif self.server.is_active() and pose is not None and self.feedback_due.due(now):
            feedback = MoveBaseFeedback()
            feedback.base_position.header.frame_id = "map"
            feedback.base_position.header.stamp = ru.stamp(now)
            feedback.base_position.pose = ru.pose_msg(pose)
            self.server.publish_feedback(feedback)
        if path is not None and goal is not None and self.plans_published != plans_after:
            self.plans_published = plans_after
            if self.plan_pub.get_num_connections():
                self.plan_pub.publish(path_msg(path.plan, goal.yaw, self.spacing, now))

    def _command(self, cmd: Twist2D) -> None:
        self.cmd_pub.publish(ru.twist_msg(cmd))
        self.answers.command_sent()

    def run(self, guard: ExitGuard) -> None:
        """The control loop, at the simulator's steps, until shutdown. Stops at the first signal
        (``guard.requested``; the guard also ends an idle wait) and tells the guard, which only then closes the
        topics (see :mod:`gidabot_navigation.ros.exit_guard`)."""
        guard.set_wake(self.wake.set)
        try:
            self._loop(lambda: rospy.is_shutdown() or guard.requested)
        except rospy.ROSException:
            if not guard.requested:    # a topic closed under a publish blocked past the guard's wait
                raise
        finally:
            guard.loop_stopped()

    def _busy(self) -> bool:
        return self.core.state is not State.IDLE or not self.events.empty()

    def _step(self, t: float) -> None:
        """The odometry of the simulator's step at ``t``: this node's time; while a goal runs, a control cycle (when
        due) and the answer; once the goal is over, one answer saying it is idle."""
        with self.turn:
            if t < self.now - 1e-9:
                return                       # an older message (a late delivery): the world is past it
            self.now = t
            self.set_time(t)
            if not self.active and not self._busy():
                return
            if self.control_due.due(t):
                self._cycle()
            self._answer(t, self._busy())

    def _loop(self, stop: Callable[[], bool]) -> None:
        """Idle, a goal (or an obstacle update) is handled at once, at the latest odometry's time; if a goal then
        runs, the answer tells the simulator to send every step's odometry and to wait for this node."""
        self.answers.answer(0.0, idle=True)          # known to the simulator from the start
        while not stop():
            self.wake.wait(0.5)
            self.wake.clear()
            with self.turn:
                if self.active or not self._busy():
                    continue
                self._cycle()
                if self._busy():
                    self._answer(self.now, busy=True)


def main() -> None:
    # installed before init_node: a signal while init_node waits on a frozen master would run rospy's
    # handler, which never returns (exit within 1 s of SIGINT/SIGTERM, whatever happens)
    guard = rospy_exit_guard(Node.MOVE_BASE, main_loop=True)
    rospy.init_node(Node.MOVE_BASE, disable_signals=True)
    keep_registered()     # re-register with a restarted master
    try:
        node = MoveBaseNode()
    except (GidaBotError, OSError, ValueError, TypeError) as err:     # bad parameters or files
        rospy.logfatal(f"move_base: cannot start: {err}")
        raise SystemExit(1) from err
    node.run(guard)
    guard.spin(rospy.is_shutdown)    # the shutdown runs in the guard's thread, never in this one
