"""The move_base stand-in as its node runs it (ROS-free): goals and cancels, odometry and estimates, the
control cycles at the simulator's steps and the lockstep answers (docs/simulator.md, "Lockstep").

:class:`MoveBaseLoop` wraps the planner and follower (:class:`~gidabot_sim.navstack.move_base.MoveBaseCore`)
and a :class:`~gidabot_sim.navstack.amcl.PoseTracker`. The node calls its ``on_*`` methods from its callbacks
(any thread) and drives the action server, the topics and the answers through a :class:`MoveBasePort`:

* a new goal makes the node owe every step at once (answered before the goal is planned: the world does
  not run on while the robot has not started); it is accepted and planned by the cycle of the step the
  simulator then sends;
* while a goal runs, each odometry message (one per step) runs a control cycle when
  ``controller_frequency`` has one due, then answers the step; once the goal is over, one answer says the
  node is idle, and it answers nothing more;
* idle, a goal (or an obstacle update) is handled at once by :meth:`MoveBaseLoop.idle_turn`, at the latest
  odometry's time;
* a cancel stops the robot only if it still stands when the cycle runs (the cancel of a goal a newer one
  replaced may arrive after the newer goal);
* each array of obstacles or of robots seen is the whole set: only the newest of those queued counts.

Time is the latest odometry's stamp (sim s), passed in: tests need no clock.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Sequence
from typing import Protocol

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.planning import Path, Shape
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.interface import Topic
from gidabot_navigation.logs import Logger
from gidabot_sim.errors import PlanRefused
from gidabot_sim.navstack.amcl import PoseTracker
from gidabot_sim.navstack.move_base import ABORTED, SUCCEEDED, MoveBaseCore, SensedRobot, State
from gidabot_sim.world.clock import Periodic
from gidabot_sim.world.kinematics import ZERO, Twist2D
from gidabot_sim.world.rejections import CountingLog

GOAL, PREEMPT, OBSTACLES, ROBOTS = "goal", "preempt", "obstacles", "robots"      # queued inputs
CANCELLED = "Goal cancelled"


class MoveBasePort(Protocol):
    """What the loop drives in its node: the action server (SimpleActionServer semantics), the topics and the
    answers to the simulator."""

    def new_goal_available(self) -> bool: ...
    def accept_new_goal(self) -> Pose2D | None:
        """Accept the new goal (a running one is reported PREEMPTED); its pose, None when there is none;
        :class:`~gidabot_sim.errors.NavGoalRejected` (the goal accepted) when its pose is invalid."""
    def goal_active(self) -> bool: ...
    def preempt_requested(self) -> bool: ...
    def preempted(self, text: str) -> None: ...
    def succeeded(self, text: str) -> None: ...
    def aborted(self, text: str) -> None: ...
    def feedback(self, pose: Pose2D, t: float) -> None: ...
    def command(self, cmd: Twist2D) -> None:
        """Publish ``cmd`` on cmd_vel (before the answer it is counted in)."""
    def current_goal(self, pose: Pose2D, t: float) -> None: ...
    def wants_plan(self) -> bool: ...
    def plan(self, path: Path, goal_yaw: float, t: float) -> None: ...
    def answer(self, t: float, idle: bool, inputs: Sequence[str]) -> None:
        """Tell the simulator: done through ``t`` (gidabot_msgs/StepDone)."""
    def set_time(self, t: float) -> None:
        """This process's ROS time."""


class MoveBaseLoop:
    """See the module docstring. ``odom_topic``: the resolved name of the odometry topic (this node's input in
    its answers); ``feedback_rate`` (Hz, sim time); ``plan_while_active``: make_plan also while a goal runs."""

    def __init__(self, nav: MoveBaseCore, port: MoveBasePort, log: Logger, odom_topic: str = Topic.ODOM,
                 feedback_rate: float = 5.0, plan_while_active: bool = False) -> None:
        self.nav, self.port, self.log = nav, port, log
        self.odom_topic = odom_topic
        self.plan_while_active = plan_while_active
        self.feedback_due = Periodic(feedback_rate)
        self.control_due = Periodic(nav.config.controller_frequency)
        self.tracker = PoseTracker()
        self.rejected = CountingLog(log.error)      # invalid goals, amcl_pose and odom messages
        self.plans_published = 0
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        self.core_lock = threading.Lock()      # the core: control cycles vs. services
        self.tracker_lock = threading.Lock()
        self.turn = threading.Lock()           # a step (odometry thread) or an idle turn (main loop): one at a time
        self.said = threading.Lock()           # self.active and the answers (a leaf lock: taken under actionlib's too)
        self.active = False                    # answering every step (a goal runs)
        self.now = 0.0                         # sim s: the latest odometry's stamp

    # -- inputs (any thread) -----------------------------------------------------------------------------
    def start(self) -> None:
        """Known to the simulator from the start: idle (unless a goal came first and said otherwise)."""
        with self.said:
            if not self.active:
                self.port.answer(0.0, idle=True, inputs=())

    def on_goal(self) -> None:
        """A new goal: the world must wait for this node from now on. Said at once, before the goal is planned
        (tens of milliseconds of wall time the world would otherwise run through while the robot has not
        started); the cycle that accepts and plans it runs at the step the simulator then sends."""
        self._events.put((GOAL, None))
        self._answer(self.now, busy=True, only_if_idle=True)

    def on_preempt(self) -> None:
        self._events.put((PREEMPT, None))

    def on_obstacles(self, read: Callable[[], tuple[dict[str, Shape], list[str]]]) -> None:
        """The run-time obstacles (``read()``: all of them by id, and what was wrong with those left out)."""
        self._events.put((OBSTACLES, read))

    def on_robots(self, read: Callable[[], list[SensedRobot]]) -> None:
        """The other robots the laser sees now (all of them)."""
        self._events.put((ROBOTS, read))

    def on_estimate(self, read: Callable[[], tuple[float, Pose2D]]) -> None:
        """A localisation estimate (``read()``: stamp and map pose)."""
        estimate = self.rejected.read(Topic.AMCL_POSE, "move_base: ignoring", read)
        if estimate is not None:
            with self.tracker_lock:
                self.tracker.on_estimate(*estimate)

    def on_odom(self, read: Callable[[], tuple[float, Pose2D, Twist2D]]) -> None:
        """The odometry of the simulator's step (``read()``: stamp, odom pose, body velocity): this node's time;
        while a goal runs, a control cycle (when due) and the answer; once the goal is over, one answer saying it
        is idle."""
        odom = self.rejected.read(Topic.ODOM, "move_base: ignoring", read)
        if odom is None:
            return
        t, pose, velocity = odom
        with self.tracker_lock:
            self.tracker.on_odom(t, pose, velocity)
        with self.turn:
            if t < self.now - 1e-9:
                return                       # an older message (a late delivery): the world is past it
            self.now = t
            self.port.set_time(t)
            if not self.active and not self._busy():
                return
            if self.control_due.due(t):
                self._cycle()
            self._answer(t, self._busy())

    def idle_turn(self) -> None:
        """Idle, a goal (or an obstacle update) is handled at once, at the latest odometry's time; if a goal then
        runs, the answer tells the simulator to send every step's odometry and to wait for this node."""
        with self.turn:
            if self.active or not self._busy():
                return
            self._cycle()
            if self._busy():
                self._answer(self.now, busy=True)

    # -- services (any thread) ---------------------------------------------------------------------------
    def make_plan(self, read: Callable[[], tuple[Pose2D | None, Pose2D, float]]) -> tuple[Path, float] | None:
        """A plan for the make_plan service (``read()``: start, None for the robot's pose; goal; tolerance): the
        path and the goal's yaw, None when there is none (logged). :class:`~gidabot_sim.errors.PlanRefused`
        while a goal runs, as move_base, unless ``plan_while_active``."""
        if self.port.goal_active() and not self.plan_while_active:
            raise PlanRefused("move_base must be in an inactive state to make a plan for an external user")
        try:
            start, goal, tolerance = read()
            with self.core_lock:
                path = self.nav.make_plan(None if start is None else (start.x, start.y), (goal.x, goal.y), tolerance)
        except (GidaBotError, ValueError, TypeError) as err:
            self.log.warning(f"move_base: make_plan: no plan: {err}")
            return None
        return path, goal.yaw

    def clear_costmaps(self) -> None:
        with self.core_lock:
            self.nav.clear_costmaps()
        self.log.info("move_base: costmaps cleared")

    # -- the control cycle ---------------------------------------------------------------------------------
    def _busy(self) -> bool:
        return self.nav.state is not State.IDLE or not self._events.empty()

    def _answer(self, t: float, busy: bool, only_if_idle: bool = False) -> None:
        """Tell the simulator: done through ``t``; ``busy``: a goal runs (every step owed, odometry at every step)."""
        with self.said:
            if only_if_idle and self.active:
                return
            self.port.answer(t, idle=not busy, inputs=(self.odom_topic,) if busy else ())
            self.active = busy

    def _drain(self, now: float) -> None:
        latest_obstacles = latest_robots = None
        port = self.port
        while True:
            try:
                kind, read = self._events.get_nowait()
            except queue.Empty:
                break
            if kind == GOAL:
                self._accept_goal(now)
            elif kind == PREEMPT:
                # only if it still stands now: the cancel of a goal a newer one already replaced (the goal and
                # cancel topics are two connections, so it may come after the newer goal) must not stop the newer
                # one (accepting a new goal clears the request, as move_base polls is_preempt_requested())
                if not port.new_goal_available() and port.goal_active() and port.preempt_requested():
                    self.nav.cancel()
                    port.command(ZERO)
                    port.preempted(CANCELLED)
            elif kind == OBSTACLES:
                latest_obstacles = read
            elif kind == ROBOTS:
                latest_robots = read
        if latest_obstacles is not None:
            shapes, problems = latest_obstacles()
            for problem in problems:
                self.log.warning(f"move_base: ignoring {problem}")
            if self.nav.set_obstacles(shapes):
                self.log.info(f"move_base: costmap updated ({len(shapes)} obstacle(s))")
        if latest_robots is not None:
            self.nav.set_robots(latest_robots())

    def _accept_goal(self, now: float) -> None:
        port = self.port
        if not port.new_goal_available():
            return
        try:
            pose = port.accept_new_goal()
            if pose is None:
                return
            self.nav.set_goal(pose, now)
        except GidaBotError as err:
            self.rejected.reject("goal", f"move_base: aborting on goal: {err}")
            self.nav.cancel()
            port.command(ZERO)
            port.aborted(f"Aborting on goal because it was sent with an invalid pose: {err}")
            return
        port.current_goal(pose, now)
        self.feedback_due.reset()

    def _cycle(self) -> None:
        now, port = self.now, self.port
        with self.core_lock:
            self._drain(now)
            with self.tracker_lock:
                pose, velocity, stamp = self.tracker.pose(), self.tracker.velocity, self.tracker.stamp
            if pose is not None and stamp is not None:
                self.nav.set_pose(pose, velocity, stamp)
            result = self.nav.step(now)
            path, goal, plans_after = self.nav.path, self.nav.goal, self.nav.plans
        if result.cmd is not None:
            port.command(result.cmd)
        if result.outcome == SUCCEEDED and port.goal_active():
            port.succeeded(result.text)
        elif result.outcome == ABORTED and port.goal_active():
            port.aborted(result.text)
        elif pose is not None and port.goal_active() and self.feedback_due.due(now):
            port.feedback(pose, now)
        if path is not None and goal is not None and self.plans_published != plans_after:
            self.plans_published = plans_after
            if port.wants_plan():
                port.plan(path.plan, goal.yaw, now)
