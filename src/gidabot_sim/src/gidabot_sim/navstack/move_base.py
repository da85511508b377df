"""The move_base stand-in's brain (ROS-free): global planning, re-planning and path following.

Semantics follow move_base (what guiding relies on):

* one goal at a time; a new goal replaces the current one (the node reports the old
  one PREEMPTED), :meth:`MoveBaseCore.cancel` stops the robot (PREEMPTED);
* the global plan comes from :class:`~gidabot_navigation.building.planning.GridPlanner` (A* on
  the inflated costmap: walls, unknown space, run-time obstacles); it is re-planned
  whenever the obstacles change, when the robot strays from it and when it makes no
  progress;
* no plan -> the planner retries for ``planner_patience`` seconds (an obstacle may go
  away), then ABORTED. A goal that no obstacle explains (outside the map, inside a
  wall, unreachable on the bare map) aborts at once;
* the robot stuck for ``controller_patience`` (no safe velocity) or making no progress
  for ``oscillation_timeout`` -> ABORTED;
* SUCCEEDED once the estimated position is within ``xy_goal_tolerance`` of the goal
  (latched, as base_local_planner's ``latch_xy_goal_tolerance``) and the heading within
  ``yaw_goal_tolerance``.

The follower is a pure-pursuit controller: it steers towards the point ``lookahead``
metres ahead on the path, turns on the spot when that point is far off the heading
(differential drive) or slides towards it while turning (synchro drive), brakes so
it can stop at the goal, and before every command simulates the next
``safety_time`` seconds of motion against the costmap: a command that would bring
the robot closer than its radius to a lethal cell is slowed down or replaced by a
turn on the spot. It never commands more than the robot's velocity limits and ramps
within its acceleration limits.

Time is passed in (sim seconds): :meth:`MoveBaseCore.step` is called at the controller
frequency and returns the velocity command and, when the goal ends, its outcome.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import numpy as np

from gidabot_navigation.building.geometry import Pose2D, wrap_angle
from gidabot_navigation.building.occupancy import FREE, OccupancyMap
from gidabot_navigation.building.planning import GridPlanner, Path, Shape
from gidabot_navigation.errors import PlanningError
from gidabot_navigation.logs import Logger
from gidabot_sim.errors import NavGoalRejected, SimConfigError
from gidabot_sim.world.kinematics import ZERO, Limits, Twist2D, clamp_velocity, integrate

SAFETY_STEP = 0.2     # s between the points of a trajectory checked against the costmap (0.14 m at 0.7 m/s)
SUCCEEDED = "succeeded"
ABORTED = "aborted"


class State(Enum):
    IDLE = "idle"
    PLANNING = "planning"
    FOLLOWING = "following"
    ROTATING = "rotating"     # at the goal position, turning to the goal heading


@dataclass(frozen=True)
class NavConfig:
    """Parameters of the stand-in (names as in move_base / base_local_planner where one exists)."""

    xy_goal_tolerance: float = 0.25      # m
    yaw_goal_tolerance: float = 0.2      # rad
    controller_frequency: float = 10.0   # Hz (sim time)
    planner_patience: float = 5.0        # s a failing plan is retried while obstacles could clear
    controller_patience: float = 15.0    # s without a safe velocity before aborting
    oscillation_timeout: float = 30.0    # s without oscillation_distance of progress -> re-plan, then abort
    oscillation_distance: float = 0.5    # m
    lookahead: float = 0.8               # m, pure-pursuit lookahead at full speed
    min_lookahead: float = 0.35          # m
    rotate_in_place_angle: float = 0.9   # rad: heading error beyond which a differential robot turns on the spot
    replan_distance: float = 0.8         # m off the path -> re-plan
    safety_time: float = 1.2             # s of motion checked against the costmap before each command
    pose_timeout: float = 5.0            # s without a pose estimate -> abort
    heading_gain: float = 2.0            # 1/s, turning-on-the-spot and final-heading gain
    footprint_padding: float = 0.05      # m added to the robot's radius for planning (costmap_2d's padding)

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SimConfigError(f"move_base {name}: {value!r} must be a finite number > 0")


@dataclass(frozen=True)
class StepResult:
    cmd: Twist2D | None          # velocity to publish (None: nothing, the stand-in is idle)
    outcome: str | None = None   # SUCCEEDED or ABORTED when the goal ended in this step
    text: str = ""               # the result's status text (move_base's wording where it has one)


class _Null:
    """No log (the core without a logger)."""

    def info(self, msg: str) -> None: ...
    def warning(self, msg: str) -> None: ...
    def error(self, msg: str) -> None: ...


class FollowedPath:
    """A plan densified for following: points, cumulative arc length, progress index."""

    def __init__(self, path: Path, step: float) -> None:
        pts = np.asarray(path.densified(step), dtype=np.float64)
        self.plan = path
        self.xy = pts
        seg = np.hypot(np.diff(pts[:, 0]), np.diff(pts[:, 1]))
        self.s = np.concatenate([[0.0], np.cumsum(seg)])
        self.index = 0

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def project(self, x: float, y: float, window: float) -> tuple[int, float]:
        """Closest point to (x, y) from the current index up to ``window`` m ahead: (index, distance)."""
        end = int(np.searchsorted(self.s, self.s[self.index] + window, side="right"))
        seg = self.xy[self.index:max(end, self.index + 1)]
        d2 = (seg[:, 0] - x) ** 2 + (seg[:, 1] - y) ** 2
        k = int(np.argmin(d2))
        self.index += k
        return self.index, float(math.sqrt(d2[k]))

    def point_at(self, s: float) -> tuple[float, float]:
        k = int(np.searchsorted(self.s, min(s, self.s[-1]), side="left"))
        k = min(k, len(self.s) - 1)
        return float(self.xy[k, 0]), float(self.xy[k, 1])

    def remaining(self) -> list[tuple[float, float]]:
        return [(float(x), float(y)) for x, y in self.xy[self.index::4]] + [tuple(self.xy[-1])]


class MoveBaseCore:
    """Plans and follows paths to one goal at a time (see the module docstring)."""

    @classmethod
    def for_robot(cls, grid: OccupancyMap, radius: float, limits: Limits, config: NavConfig | None = None,
                  log: Logger | None = None, inflation_radius: float | None = None, cost_scaling: float = 3.0,
                  goal_tolerance: float = 0.5) -> MoveBaseCore:
        """A core with its planner: inscribed radius = ``radius`` + ``footprint_padding``."""
        config = config or NavConfig()
        padded = radius + config.footprint_padding
        planner = GridPlanner(grid, padded, inflation_radius=max(inflation_radius or radius + 0.7, padded),
                              cost_scaling=cost_scaling, goal_tolerance=goal_tolerance)
        return cls(planner, limits, radius, config, log)

    def __init__(self, planner: GridPlanner, limits: Limits, radius: float, config: NavConfig | None = None,
                 log: Logger | None = None, static_planner: Callable[[], GridPlanner] | None = None) -> None:
        self.planner = planner
        self.limits = limits
        self.radius = float(radius)
        self.config = config or NavConfig()
        self.log = log or _Null()
        self._static_factory = static_planner or (lambda: GridPlanner(
            planner.grid, planner.robot_radius, planner.inflation_radius, planner.cost_scaling,
            planner.inflation_cost, planner.goal_tolerance))
        self._static: GridPlanner | None = None
        self.state = State.IDLE
        self.goal: Pose2D | None = None
        self.path: FollowedPath | None = None
        self.pose: Pose2D | None = None
        self.velocity: Twist2D = ZERO
        self.pose_time: float | None = None
        self.last_cmd: Twist2D = ZERO
        self.plans = 0                       # plans made (for tests and diagnostics)
        self.replans = 0
        self._obstacles: dict[str, Shape] = {}
        self._reset_goal_state(0.0)

    # -- inputs ----------------------------------------------------------------
    def _reset_goal_state(self, now: float) -> None:
        self._goal_time = now
        self._need_plan = False
        self._plan_fail_since: float | None = None
        self._plan_error = ""
        self._blocked_since: float | None = None
        self._progress_best = math.inf
        self._progress_time = now
        self._oscillation_replanned = False
        self._turning = False

    def set_goal(self, goal: Pose2D, now: float) -> None:
        """Start driving to ``goal`` (map frame), replacing any current goal.

        :class:`NavGoalRejected` when the goal is not finite (the node reports it ABORTED, as move_base does
        for an invalid quaternion).
        """
        if not goal.is_finite():
            raise NavGoalRejected(f"goal ({goal.x!r}, {goal.y!r}, {goal.yaw!r}) is not finite (m, m, rad)")
        self.goal = Pose2D(goal.x, goal.y, wrap_angle(goal.yaw))
        self.path = None
        self.state = State.PLANNING
        self._reset_goal_state(now)
        self._need_plan = True
        self.log.info(f"move_base: new goal ({goal.x:.2f}, {goal.y:.2f}, {goal.yaw:.2f})")

    def cancel(self) -> None:
        """Drop the current goal (PREEMPTED by the node); the next step commands zero velocity once."""
        if self.state is not State.IDLE:
            self.log.info("move_base: goal cancelled")
        self._finish()

    def set_pose(self, pose: Pose2D, velocity: Twist2D, now: float) -> None:
        """The robot's estimated map pose and body velocity at ``now``."""
        self.pose, self.velocity, self.pose_time = pose, velocity, now

    def set_obstacles(self, obstacles: dict[str, Shape]) -> bool:
        """The run-time obstacles now known (all of them); re-plans the current goal when they changed."""
        changed = self.planner.set_obstacles(obstacles)
        self._obstacles = dict(obstacles)
        if changed and self.state in (State.FOLLOWING, State.PLANNING, State.ROTATING):
            self._need_plan = True
        return changed

    def clear_costmaps(self) -> None:
        """move_base's ~clear_costmaps: reset the costmap to the static map; the obstacle layer (here the
        simulator's obstacle list, a perfect sensor) marks the known obstacles again at once."""
        self.planner.clear_obstacles()
        self.planner.set_obstacles(self._obstacles)
        if self.state is not State.IDLE:
            self._need_plan = True

    # -- planning ----------------------------------------------------------------
    def make_plan(self, start: tuple[float, float] | None, goal: tuple[float, float],
                  tolerance: float = 0.0) -> Path:
        """A plan from ``start`` (None: the robot's pose) to ``goal``; :class:`PlanningError` if none.

        ``tolerance`` (m): how far the goal may move when it is too close to an obstacle (0: the default).
        """
        if start is None:
            if self.pose is None:
                raise PlanningError("no start given and the robot's pose is not known yet")
            start = (self.pose.x, self.pose.y)
        old = self.planner.goal_tolerance
        if math.isfinite(tolerance) and tolerance > 0:
            self.planner.goal_tolerance = float(tolerance)
        try:
            return self.planner.plan(start, goal)
        finally:
            self.planner.goal_tolerance = old

    def _permanent(self, goal: Pose2D) -> bool:
        """True when no change of the run-time obstacles could make ``goal`` reachable from the robot."""
        grid = self.planner.grid
        if not grid.contains(goal.x, goal.y) or grid.value_at(goal.x, goal.y) != FREE:
            return True
        if not self._obstacles:
            return True
        if self._static is None:
            self._static = self._static_factory()
        try:
            self._static.plan((self.pose.x, self.pose.y), (goal.x, goal.y))  # type: ignore[union-attr]
        except PlanningError:
            return True
        return False

    def _plan(self, now: float) -> StepResult | None:
        assert self.goal is not None and self.pose is not None
        try:
            path = self.planner.plan((self.pose.x, self.pose.y), (self.goal.x, self.goal.y))
        except PlanningError as err:
            self._plan_error = str(err)
            if self._permanent(self.goal):
                return self._abort(f"Failed to find a valid plan: {err}")
            if self._plan_fail_since is None:
                self._plan_fail_since = now
                self.log.warning(f"move_base: no plan ({err}); retrying for "
                                 f"{self.config.planner_patience:g} s")
            if now - self._plan_fail_since >= self.config.planner_patience:
                return self._abort(f"Failed to find a valid plan. Even after executing recovery behaviors. "
                                   f"({err})")
            self.state = State.PLANNING
            return StepResult(ZERO)
        self.plans += 1
        if self.path is not None:
            self.replans += 1
        self.path = FollowedPath(path, self.planner.grid.resolution)
        self._need_plan = False
        self._plan_fail_since = None
        self._progress_best, self._progress_time = math.inf, now
        if self.state is not State.ROTATING:
            self.state = State.FOLLOWING
        return None

    # -- control -----------------------------------------------------------------
    def step(self, now: float) -> StepResult:
        """One control cycle at sim time ``now``."""
        if self.state is State.IDLE:
            return StepResult(None)
        if self.pose is None or self.pose_time is None or now - self.pose_time > self.config.pose_timeout:
            if now - max(self._goal_time, self.pose_time or -math.inf) > self.config.pose_timeout:
                return self._abort("No robot pose (odom / amcl_pose) for "
                                   f"{self.config.pose_timeout:g} s")
            return StepResult(ZERO)
        if self._need_plan:
            failed = self._plan(now)
            if failed is not None:
                return failed
        assert self.goal is not None and self.path is not None
        pose = self.pose
        dist_goal = math.hypot(self.goal.x - pose.x, self.goal.y - pose.y)
        if self.state is State.FOLLOWING and dist_goal <= self.config.xy_goal_tolerance:
            self.state = State.ROTATING
            self._progress_time = now
        if self.state is State.ROTATING:
            return self._rotate_to_goal(now)
        return self._follow(now, pose, dist_goal)

    def _rotate_to_goal(self, now: float) -> StepResult:
        assert self.goal is not None and self.pose is not None
        err = wrap_angle(self.goal.yaw - self.pose.yaw)
        if abs(err) <= self.config.yaw_goal_tolerance:
            if abs(self.velocity.wz) < 0.3 * self.limits.max_angular and self.velocity.speed < 0.1:
                return self._succeed()
            return self._command(ZERO)
        if now - self._progress_time > self.config.oscillation_timeout:
            return self._abort("Robot is oscillating: cannot reach the goal heading")
        return self._command(Twist2D(0.0, 0.0, self._turn_rate(err)))

    def _turn_rate(self, err: float) -> float:
        """Turning speed towards heading error ``err``: proportional, and slow enough to stop on it."""
        w = min(self.limits.max_angular, self.config.heading_gain * abs(err),
                math.sqrt(2.0 * self.limits.max_angular_accel * abs(err)))
        w = max(w, min(0.15, self.limits.max_angular))
        return math.copysign(w, err)

    def _follow(self, now: float, pose: Pose2D, dist_goal: float) -> StepResult:
        assert self.path is not None
        cfg = self.config
        path = self.path
        speed = self.velocity.speed
        index, deviation = path.project(pose.x, pose.y, window=2.0 + cfg.lookahead)
        if deviation > cfg.replan_distance:
            self.log.info(f"move_base: {deviation:.2f} m off the path, re-planning")
            self._need_plan = True
            failed = self._plan(now)
            if failed is not None:
                return failed
            path = self.path
            index, deviation = path.project(pose.x, pose.y, window=2.0 + cfg.lookahead)
        remaining = path.length - float(path.s[index]) + deviation
        # progress watchdog (move_base's oscillation timeout): re-plan once, then give up
        if remaining < self._progress_best - cfg.oscillation_distance:
            self._progress_best, self._progress_time = remaining, now
            self._oscillation_replanned = False
        elif now - self._progress_time > cfg.oscillation_timeout:
            if self._oscillation_replanned:
                return self._abort(f"Robot is oscillating: no progress of {cfg.oscillation_distance:g} m "
                                   f"in {cfg.oscillation_timeout:g} s")
            self._oscillation_replanned, self._progress_time = True, now
            self._need_plan = True
            return self._command(ZERO)

        lookahead = max(cfg.min_lookahead, cfg.lookahead * max(speed / self.limits.max_linear, 0.5))
        tx, ty = path.point_at(float(path.s[index]) + lookahead)
        if math.hypot(tx - pose.x, ty - pose.y) < 1e-6:
            tx, ty = self.goal.x, self.goal.y  # type: ignore[union-attr]
        bearing = math.atan2(ty - pose.y, tx - pose.x)
        alpha = wrap_angle(bearing - pose.yaw)
        # brake so the robot can stop at the goal (remaining distance along the path)
        v_stop = math.sqrt(2.0 * 0.8 * self.limits.max_linear_accel
                           * max(remaining - 0.5 * cfg.xy_goal_tolerance, 0.0))
        v_max = min(self.limits.max_linear, max(v_stop, 0.05))
        if self.limits.holonomic:
            cmd = self._holonomic(pose, bearing, alpha, v_max, path, index)
        else:
            cmd = self._differential(pose, tx, ty, alpha, v_max)
        safe = self._safe(pose, cmd)
        if safe is None:
            # no forward motion keeps the robot clear: turn on the spot (towards the path) meanwhile
            if self._blocked_since is None:
                self._blocked_since = now
                self.log.warning("move_base: no safe velocity, re-planning")
                self._need_plan = True
            elif now - self._blocked_since > cfg.controller_patience:
                return self._abort(f"Failed to find a valid control for {cfg.controller_patience:g} s "
                                   "(robot stuck)")
            return self._command(Twist2D(0.0, 0.0, self._turn_rate(alpha)) if abs(alpha) > 0.1 else ZERO)
        self._blocked_since = None
        return self._command(safe)

    def _differential(self, pose: Pose2D, tx: float, ty: float, alpha: float, v_max: float) -> Twist2D:
        cfg = self.config
        threshold = cfg.rotate_in_place_angle * (0.5 if self._turning else 1.0)   # hysteresis
        if abs(alpha) > threshold:
            self._turning = True
            return Twist2D(0.0, 0.0, self._turn_rate(alpha))
        self._turning = False
        dist = max(math.hypot(tx - pose.x, ty - pose.y), 1e-3)
        curvature = 2.0 * math.sin(alpha) / dist
        v = v_max * max(math.cos(alpha), 0.3)
        if abs(curvature) * v > self.limits.max_angular:
            v = self.limits.max_angular / abs(curvature)
        return Twist2D(v, 0.0, curvature * v)

    def _holonomic(self, pose: Pose2D, bearing: float, alpha: float, v_max: float, path: FollowedPath,
                   index: int) -> Twist2D:
        # slide towards the lookahead point; turn the body to the direction of travel meanwhile
        v = v_max
        ahead = path.point_at(float(path.s[index]) + 0.5)
        heading = math.atan2(ahead[1] - pose.y, ahead[0] - pose.x) if math.hypot(
            ahead[0] - pose.x, ahead[1] - pose.y) > 0.1 else pose.yaw
        return Twist2D(v * math.cos(alpha), v * math.sin(alpha), self._turn_rate(wrap_angle(heading - pose.yaw))
                       if abs(wrap_angle(heading - pose.yaw)) > 0.05 else 0.0)

    def _safe(self, pose: Pose2D, cmd: Twist2D) -> Twist2D | None:
        """``cmd``, or a slower variant, whose next ``safety_time`` s keep the robot clear of lethal cells;
        None when only turning on the spot is safe (a disc turning in place touches nothing new)."""
        if cmd.speed < 1e-6:
            return cmd
        for scale in (1.0, 0.5, 0.25):
            trial = Twist2D(cmd.vx * scale, cmd.vy * scale, cmd.wz)
            if self._trajectory_clear(pose, trial):
                return trial
        return None

    def _trajectory_clear(self, pose: Pose2D, cmd: Twist2D) -> bool:
        """True when moving at ``cmd`` for ``safety_time`` keeps the robot's disc off lethal cells (or at
        least does not bring it closer). The costmap's clearance is measured between cell centres: the
        edge of a lethal cell lies half a cell nearer."""
        dt = SAFETY_STEP
        margin = self.radius + 0.5 * self.planner.grid.resolution
        start = self.planner.clearance(pose.x, pose.y)
        p = pose
        steps = max(1, int(math.ceil(self.config.safety_time / dt)))
        for _ in range(steps):
            p = integrate(p, cmd, dt)
            c = self.planner.clearance(p.x, p.y)
            if c < margin and c < start - 1e-6:
                return False
        return True

    # -- outcomes ----------------------------------------------------------------
    def _command(self, cmd: Twist2D) -> StepResult:
        cmd = clamp_velocity(cmd, self.limits)
        self.last_cmd = cmd
        return StepResult(cmd)

    def _succeed(self) -> StepResult:
        self._finish()
        return StepResult(ZERO, SUCCEEDED, "Goal reached.")

    def _abort(self, text: str) -> StepResult:
        self.log.warning(f"move_base: aborting: {text}")
        self._finish()
        return StepResult(ZERO, ABORTED, text)

    def _finish(self) -> None:
        self.state = State.IDLE
        self.goal = None
        self.path = None
        self.last_cmd = ZERO
