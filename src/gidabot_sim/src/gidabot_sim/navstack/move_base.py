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
* the robot not moving at all (``stall_distance`` or ``stall_turn``) for ``stall_timeout`` while it holds a
  goal and waits for nobody -> the costmap cleared and the goal re-planned (move_base's recovery), logged with
  the state it was in; as long again -> ABORTED. This bound holds whatever else the cycle does: re-plans
  (a person walking anywhere on the floor changes the costmap) restart the progress watchdog above, and a
  move the costmap allows may still be refused by the world (a body it does not know exactly);
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

Other robots (several robots on a floor): the robots its laser sees (:meth:`MoveBaseCore.set_robots`)
are marked in the costmap as discs of their radius + ``robot_mark_step`` (re-marked when one has
moved that far, cleared when it is no longer seen where the laser looks, ``laser_fov`` centred
ahead: one in the blind sector behind stays marked, as a costmap clears only by ray tracing); a
path they block is re-planned, so the robot drives around them. When no plan exists because robots
stand in the way (there is one without them; the blocker is the first robot along it), the robot
does not abort after ``planner_patience``: it drives on along that way until its safety check
stops it near the blocker, and a deterministic priority, name order, resolves the meeting: the
robot whose name sorts later *yields* (drives to the nearest reachable spot where the other has
room to pass, then waits there facing it); the other waits for the way to open, and yields itself
when the blocker has not moved for ``yield_timeout`` (it may have no room to yield). Every cycle
re-tries the real goal, so either robot also re-routes when another way opens. Blocked by a robot
without progress for ``robot_patience`` -> ABORTED, naming the robot (a deadlock); blocked by robots or
people for ``wait_budget`` in all during one goal (blockers that keep moving, each wait starting anew, but
never open the way: a livelock) -> ABORTED too. A goal where
another robot stands (parked at a meeting point, or at its screen where the visitor asked): the
plan ends at the nearest free spot next to it, within that robot's disc + this robot's footprint
(navfn's ``default_tolerance``, sized for it), and the goal is reached there (as base_local_planner
checks the goal against the end of the global plan); re-planned as usual, so the robot goes on to
the goal itself if the other leaves first.

Time is passed in (sim seconds): :meth:`MoveBaseCore.step` is called at the controller
frequency and returns the velocity command and, when the goal ends, its outcome.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum

import numpy as np

from gidabot_navigation.building.geometry import Polygon, Pose2D, wrap_angle
from gidabot_navigation.building.model import Floor
from gidabot_navigation.building.occupancy import FREE, OccupancyMap
from gidabot_navigation.building.planning import (
    Circle,
    GridPlanner,
    Path,
    Shape,
    cells_of,
    rasterize,
    sample_polyline,
)
from gidabot_navigation.errors import PlanningError
from gidabot_navigation.logs import Logger
from gidabot_sim.errors import NavGoalRejected, SimConfigError
from gidabot_sim.world.kinematics import ZERO, Limits, Twist2D, clamp_velocity, integrate

YIELD_CANDIDATES = 20000    # nearest cells considered for a yield spot
YIELD_ATTEMPTS = 5          # spots tried (each one's path may rule out the next nearest)
SAFETY_STEP = 0.2     # s between the points of a trajectory checked against the costmap (0.14 m at 0.7 m/s)
SUCCEEDED = "succeeded"
ABORTED = "aborted"


class State(Enum):
    IDLE = "idle"
    PLANNING = "planning"
    FOLLOWING = "following"
    ROTATING = "rotating"     # at the goal position, turning to the goal heading
    YIELDING = "yielding"     # moving aside for (or waiting beside) a robot that blocks the way


@dataclass(frozen=True)
class SensedRobot:
    """Another robot the laser sees: its name (priority) and disc in the map frame (m)."""

    name: str
    x: float
    y: float
    radius: float


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
    robot_mark_step: float = 0.1         # m a seen robot moves before it is marked again (fewer re-plans); its
    #                                      disc is marked this much larger (it may be that far from its mark)
    laser_fov: float = 1.5 * math.pi     # rad: a robot no longer seen is cleared when its place is in view
    yield_timeout: float = 10.0          # s the first name waits for a blocker that does not move before yielding
    robot_patience: float = 60.0         # s blocked by a robot (waiting or yielding) before aborting: deadlock
    blocker_distance: float = 0.6        # m between discs: a robot or person this close explains no safe velocity
    wait_budget: float = 180.0           # s blocked by robots or people in all during one goal (each wait starts
    #                                      anew when the blocker moves) before aborting: a livelock
    stall_timeout: float = 60.0          # s with a goal, waiting for nobody, without moving -> recover, then abort
    stall_distance: float = 0.1          # m: moved (the stall watchdog)
    stall_turn: float = 0.2              # rad: turned (the stall watchdog)

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SimConfigError(f"move_base {name}: {value!r} must be a finite number > 0")


@dataclass
class _RobotWait:
    """Blocked by robot ``blocker`` without progress since ``since``; where both stood then (``anchors``:
    the blocker, this robot)."""

    blocker: str
    since: float
    anchors: tuple[tuple[float, float], tuple[float, float]]
    yielding: bool = False
    tried: bool = False        # looked for a spot to yield to (once per wait)


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
    def for_floor(cls, floor: Floor, radius: float, limits: Limits, config: NavConfig | None = None,
                  log: Logger | None = None, **kwargs) -> MoveBaseCore:
        """A core for a robot of ``radius`` on a building's ``floor``: its map, its keep-out zones lethal (what the
        node and the benches run); ``kwargs`` as :meth:`for_robot`'s."""
        return cls.for_robot(floor.map, radius, limits, config, log, keep_out=floor.keep_out_zones, **kwargs)

    @classmethod
    def for_robot(cls, grid: OccupancyMap, radius: float, limits: Limits, config: NavConfig | None = None,
                  log: Logger | None = None, inflation_radius: float | None = None, cost_scaling: float = 3.0,
                  goal_tolerance: float = 0.5, name: str = "",
                  keep_out: Mapping[str, Polygon] | None = None) -> MoveBaseCore:
        """A core with its planner: inscribed radius = ``radius`` + ``footprint_padding``; ``keep_out``: the floor's
        keep-out zones (lethal, as the static map's walls)."""
        config = config or NavConfig()
        padded = radius + config.footprint_padding
        planner = GridPlanner(grid, padded, inflation_radius=max(inflation_radius or radius + 0.7, padded),
                              cost_scaling=cost_scaling, goal_tolerance=goal_tolerance, keep_out=keep_out)
        return cls(planner, limits, radius, config, log, name=name)

    def __init__(self, planner: GridPlanner, limits: Limits, radius: float, config: NavConfig | None = None,
                 log: Logger | None = None, static_planner: Callable[[], GridPlanner] | None = None,
                 name: str = "") -> None:
        self.name = name                     # this robot's name: its priority against other robots
        self.planner = planner
        self.limits = limits
        self.radius = float(radius)
        self.config = config or NavConfig()
        self.log = log or _Null()
        self._static_factory = static_planner or (lambda: GridPlanner(
            planner.grid, planner.robot_radius, planner.inflation_radius, planner.cost_scaling,
            planner.inflation_cost, planner.goal_tolerance, keep_out=planner.keep_out))
        self._static: GridPlanner | None = None
        self._unmarked: GridPlanner | None = None     # walls and obstacles, not robots (who blocks the way?)
        self.state = State.IDLE
        self.goal: Pose2D | None = None
        self.target: tuple[float, float] | None = None   # where it stops: the goal, or next to a robot on it
        self.path: FollowedPath | None = None
        self.pose: Pose2D | None = None
        self.velocity: Twist2D = ZERO
        self.pose_time: float | None = None
        self.last_cmd: Twist2D = ZERO
        self.plans = 0                       # plans made (for tests and diagnostics)
        self.replans = 0
        self._obstacles: dict[str, Shape] = {}
        self._robots: dict[str, SensedRobot] = {}     # as marked in the costmap
        self._wait: _RobotWait | None = None
        self.speed_limit: float | None = None          # m/s, set_speed_limit (None: the robot's own limits)
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
        self._wait = None
        self._close_wait: _RobotWait | None = None
        self._waited = 0.0                    # s blocked in all during this goal (:meth:`_waiting`)
        self._waited_at: float | None = None  # the last control cycle counted
        self._still_at: Pose2D | None = None  # the stall watchdog: where the robot last moved, and when
        self._still_since = now
        self._stall_recovered = False

    def set_goal(self, goal: Pose2D, now: float) -> None:
        """Start driving to ``goal`` (map frame), replacing any current goal.

        :class:`NavGoalRejected` when the goal is not finite (the node reports it ABORTED, as move_base does
        for an invalid quaternion).
        """
        if not goal.is_finite():
            raise NavGoalRejected(f"goal ({goal.x!r}, {goal.y!r}, {goal.yaw!r}) is not finite (m, m, rad)")
        self.goal = Pose2D(goal.x, goal.y, wrap_angle(goal.yaw))
        self.target = (self.goal.x, self.goal.y)
        self.path = None
        self.state = State.PLANNING
        self._reset_goal_state(now)
        self._need_plan = True
        self.log.info(f"move_base: new goal ({goal.x:.2f}, {goal.y:.2f}, {goal.yaw:.2f})")

    def set_speed_limit(self, speed: float | None) -> None:
        """Drive no faster than ``speed`` m/s from now on (None, 0, or not a positive number: the robot's own
        limits), as Nav2's ``speed_limit`` topic or a local planner's ``max_vel_x`` set by dynamic_reconfigure."""
        ok = speed is not None and math.isfinite(speed) and speed > 0
        self.speed_limit = float(speed) if ok else None

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

    def set_robots(self, robots: Sequence[SensedRobot]) -> bool:
        """The other robots the laser sees now (all of them): marked in the costmap, the others cleared unless
        their place is out of the laser's view; a running path they block is re-planned. True when the marks
        changed."""
        marks: dict[str, SensedRobot] = {}
        if self.pose is not None:
            p = self.pose
            marks = {name: r for name, r in self._robots.items()
                     if abs(wrap_angle(math.atan2(r.y - p.y, r.x - p.x) - p.yaw)) > 0.5 * self.config.laser_fov}
        for robot in robots:
            if not (math.isfinite(robot.x) and math.isfinite(robot.y) and math.isfinite(robot.radius)
                    and robot.radius > 0) or robot.name == self.name:
                continue
            old = self._robots.get(robot.name)
            keep = (old is not None and old.radius == robot.radius
                    and math.hypot(old.x - robot.x, old.y - robot.y) < self.config.robot_mark_step)
            marks[robot.name] = old if keep else robot       # type: ignore[assignment]
        if marks == self._robots:
            return False
        self._robots = marks
        grid = self.planner.grid
        cells = [rasterize(Circle(robot.x, robot.y, robot.radius + self.config.robot_mark_step), grid)
                 for robot in marks.values()]
        if not self.planner.set_sensor_mark_cells(c for c in cells if c is not None):
            return False
        if self.state in (State.FOLLOWING, State.ROTATING) and self.path is not None \
                and self.planner.path_blocked(self.path.remaining(), skip=0.0):
            self._need_plan = True
        return True

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
        if not self._obstacles and not self._robots:
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
            self.target = (self.goal.x, self.goal.y)
        except PlanningError as err:
            path = self._next_to_robot_on_goal()
            if path is None:
                return self._no_plan(err, now)
        return self._new_path(path, now)

    def _next_to_robot_on_goal(self) -> Path | None:
        """A plan to the nearest free spot next to a robot standing on the goal (None: no robot there, or no such
        spot): the spots just outside its mark, this robot's side first; :attr:`target` is then its end."""
        assert self.goal is not None and self.pose is not None
        g, res = self.goal, self.planner.grid.resolution
        pad = self.planner.robot_radius + self.config.robot_mark_step + 2.0 * res
        on_goal = [r for r in self._robots.values() if math.hypot(r.x - g.x, r.y - g.y) < r.radius + pad]
        if not on_goal:
            return None
        occupant = min(on_goal, key=lambda r: math.hypot(r.x - g.x, r.y - g.y))
        toward = math.atan2(self.pose.y - occupant.y, self.pose.x - occupant.x)
        for k in (0, 1, -1, 2, -2, 3, -3, 4, -4, 5, -5, 6, -6, 7, -7, 8):
            a = toward + k * math.pi / 8.0
            for extra in (0.0, 2.0 * res, 4.0 * res):
                spot = (occupant.x + (occupant.radius + pad + extra) * math.cos(a),
                        occupant.y + (occupant.radius + pad + extra) * math.sin(a))
                try:
                    path = self.planner.plan((self.pose.x, self.pose.y), spot)
                except PlanningError:
                    continue
                end = (float(path.points[-1][0]), float(path.points[-1][1]))
                if self.target != end:
                    self.log.info(f"move_base: robot {occupant.name} stands at the goal; stopping next to it at "
                                  f"({end[0]:.2f}, {end[1]:.2f})")
                self.target = end
                return path
        return None

    def _no_plan(self, err: PlanningError, now: float) -> StepResult:
        assert self.goal is not None
        self._plan_error = str(err)
        blocked = self._blocking_robot()
        if blocked is not None:
            return self._blocked_by_robot(*blocked, now)
        if self._permanent(self.goal):
            return self._abort(f"Failed to find a valid plan: {err}")
        if self._plan_fail_since is None:
            self._plan_fail_since = now
            self.log.warning(f"move_base: no plan ({err}); retrying for {self.config.planner_patience:g} s")
        if now - self._plan_fail_since >= self.config.planner_patience:
            return self._abort(f"Failed to find a valid plan. Even after executing recovery behaviors. ({err})")
        self.state = State.PLANNING
        return StepResult(ZERO)

    def _new_path(self, path: Path, now: float) -> StepResult | None:
        self.plans += 1
        if self.path is not None:
            self.replans += 1
        if self._wait is not None:
            self.log.info(f"move_base: the way past robot {self._wait.blocker} is open after "
                          f"{now - self._wait.since:.1f} s, going on")
            self._wait, self._waited_at = None, None
            self.state = State.FOLLOWING
        self.path = FollowedPath(path, self.planner.grid.resolution)
        self._need_plan = False
        self._plan_fail_since = None
        self._progress_best, self._progress_time = math.inf, now
        if self.state is not State.ROTATING:
            self.state = State.FOLLOWING
        return None

    # -- other robots in the way ---------------------------------------------------
    def _blocking_robot(self) -> tuple[SensedRobot, Path] | None:
        """The robot that blocks the way to the goal: the first marked robot along the plan made without the
        robots (returned with it); None when there is no such plan (walls or obstacles block it) or no robot
        is marked."""
        if self.pose is None or self.goal is None or not self._robots:
            return None
        if self._unmarked is None:
            self._unmarked = self._static_factory()
        self._unmarked.set_obstacles(self._obstacles)
        try:
            path = self._unmarked.plan((self.pose.x, self.pose.y), (self.goal.x, self.goal.y))
        except PlanningError:
            return None
        pts = np.asarray(path.densified(self.planner.grid.resolution), dtype=np.float64)
        best: tuple[int, SensedRobot] | None = None
        for robot in self._robots.values():
            d = np.hypot(pts[:, 0] - robot.x, pts[:, 1] - robot.y)
            near = np.nonzero(d < robot.radius + self.planner.robot_radius + self.planner.grid.resolution)[0]
            if near.size and (best is None or int(near[0]) < best[0]):
                best = (int(near[0]), robot)
        if best is not None:
            return best[1], path
        p = self.pose
        return min(self._robots.values(), key=lambda r: math.hypot(r.x - p.x, r.y - p.y)), path

    def _blocked_by_robot(self, blocker: SensedRobot, way: Path, now: float) -> StepResult:
        """No plan while ``blocker`` is in the way (``way``: the plan without robots): yield (the later name, or
        the other after ``yield_timeout`` without progress) or drive on along ``way`` as far as is safe and
        wait; abort after ``robot_patience`` (see the module docstring)."""
        cfg = self.config
        assert self.pose is not None
        if self._waiting(now):
            return self._abort(f"Blocked by robots or people for {self._waited:.0f} s in all (last by robot "
                               f"{blocker.name}): they keep moving but the way never opens")
        wait = self._wait
        here = ((blocker.x, blocker.y), (self.pose.x, self.pose.y))
        if wait is None or wait.blocker != blocker.name:
            wait = self._wait = _RobotWait(blocker.name, now if wait is None else wait.since, here)
            self.log.warning(f"move_base: robot {blocker.name} blocks the way; "
                             + ("yielding to it" if self.name > blocker.name else "waiting for it to yield"))
        if now - wait.since >= cfg.robot_patience:
            return self._abort(f"Blocked by robot {blocker.name} for {now - wait.since:.0f} s: deadlock "
                               f"(robots {self.name or '?'} and {blocker.name} cannot pass each other)")
        self._plan_fail_since = None
        self._progress_time = now          # waiting for a robot is not oscillating
        if any(math.dist(p, q) >= cfg.oscillation_distance for p, q in zip(here, wait.anchors, strict=True)):
            wait.since, wait.anchors = now, here       # one of the two made progress: no deadlock yet
        if not wait.tried and (self.name > blocker.name or now - wait.since >= cfg.yield_timeout):
            wait.tried = True
            wait.yielding = self._start_yield(blocker, way, now)
        self._blocked_since = now          # the safety check stops it near the robot: not stuck
        if not wait.yielding:
            self.state = State.PLANNING
            self.path = FollowedPath(way, self.planner.grid.resolution)
            return self._follow(now, self.pose, 0.0)
        assert self.path is not None
        end = self.path.xy[-1]
        dist = math.hypot(float(end[0]) - self.pose.x, float(end[1]) - self.pose.y)
        if dist <= cfg.xy_goal_tolerance:
            # aside: wait there facing the blocker (so the laser sees it pass; the goal is re-tried every cycle)
            err = wrap_angle(math.atan2(blocker.y - self.pose.y, blocker.x - self.pose.x) - self.pose.yaw)
            return self._command(Twist2D(0.0, 0.0, self._turn_rate(err)) if abs(err) > 0.3 else ZERO)
        return self._follow(now, self.pose, dist)

    def _start_yield(self, blocker: SensedRobot, way: Path, now: float) -> bool:
        """Plan to the nearest reachable spot where ``blocker`` has room to pass: walls at least ``room`` away
        all round, and the narrow stretches (where two robots cannot pass) of ``way`` and of the path there at
        least ``clear`` away, so the blocker can come out of them and turn; False when there is none."""
        assert self.pose is not None
        planner, grid = self.planner, self.planner.grid
        room = planner.robot_radius + 2.0 * (blocker.radius + self.config.footprint_padding) + grid.resolution
        clear = 2.0 * (planner.robot_radius + blocker.radius + self.config.footprint_padding)
        start = (self.pose.x, self.pose.y)
        try:
            ok = planner.reachable(start) & (planner.static_distance >= room)
        except PlanningError:
            ok = np.zeros((grid.height, grid.width), dtype=bool)
        rows, cols = np.nonzero(ok)
        row, col = grid.world_to_cell(*start)
        order = np.argsort((rows - row) ** 2 + (cols - col) ** 2)[:YIELD_CANDIDATES]
        rows, cols = rows[order], cols[order]
        far = np.ones(rows.size, dtype=bool)
        limit = (clear / grid.resolution) ** 2

        def keep_clear_of(points: list[tuple[float, float]]) -> None:
            wr, wc = cells_of(grid, *sample_polyline(points, 2.0 * grid.resolution))
            inside = (wr >= 0) & (wr < grid.height) & (wc >= 0) & (wc < grid.width)
            wr, wc = wr[inside], wc[inside]
            narrow = planner.static_distance[wr, wc] < room
            for r, c in zip(wr[narrow], wc[narrow], strict=True):
                far[:] &= (rows - r) ** 2 + (cols - c) ** 2 >= limit

        keep_clear_of(way.points)
        for _ in range(YIELD_ATTEMPTS):
            if not far.any():
                break
            k = int(np.argmax(far))
            spot = grid.cell_to_world(int(rows[k]), int(cols[k]))
            try:
                path = planner.plan(start, spot)
            except PlanningError:
                far[k] = False
                continue
            before = int(far.sum())
            keep_clear_of(path.points)
            if far[k]:
                self.path = FollowedPath(path, grid.resolution)
                self.state = State.YIELDING
                self._progress_best, self._progress_time = math.inf, now
                self.log.info(f"move_base: yielding to robot {blocker.name}: moving aside to "
                              f"({spot[0]:.2f}, {spot[1]:.2f})")
                return True
            if int(far.sum()) == before:
                far[k] = False
        self.log.warning(f"move_base: no room to yield to robot {blocker.name}: waiting")
        return False

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
        stalled = self._stalled(now)
        if stalled is not None:
            return stalled
        if self._need_plan:
            failed = self._plan(now)
            if failed is not None:
                return failed
        assert self.goal is not None and self.path is not None and self.target is not None
        pose = self.pose
        dist_goal = math.hypot(self.target[0] - pose.x, self.target[1] - pose.y)
        if self.state is State.FOLLOWING and dist_goal <= self.config.xy_goal_tolerance:
            self.state = State.ROTATING
            self._progress_time = now
        if self.state is State.ROTATING:
            return self._rotate_to_goal(now)
        return self._follow(now, pose, dist_goal)

    def _stalled(self, now: float) -> StepResult | None:
        """The stall watchdog (see the module docstring): None while the robot moves, waits for somebody or has
        not stood ``stall_timeout`` yet; a recovery first (logged, the cycle goes on), then ABORTED."""
        cfg, pose = self.config, self.pose
        assert pose is not None
        anchor = self._still_at
        waiting = self._close_wait is not None or self._wait is not None
        if waiting or anchor is None or math.hypot(pose.x - anchor.x, pose.y - anchor.y) >= cfg.stall_distance \
                or abs(wrap_angle(pose.yaw - anchor.yaw)) >= cfg.stall_turn:
            self._still_at, self._still_since = pose, now
            if not waiting and anchor is not None:
                self._stall_recovered = False
            return None
        if now - self._still_since < cfg.stall_timeout:
            return None
        what = (f"the robot has not moved for {now - self._still_since:.0f} s at ({pose.x:.2f}, {pose.y:.2f}) "
                f"({self.state.value}, last command {self.last_cmd.vx:.2f} m/s {self.last_cmd.wz:.2f} rad/s, "
                f"{self.replans} re-plans)")
        if not self._stall_recovered:
            self._stall_recovered, self._still_since = True, now
            self.log.warning(f"move_base: {what}: clearing the costmap (robots and people marked too) and "
                             "re-planning")
            self.clear_costmaps()
            self._robots = {}                  # marked again as the laser sees them (a mark behind may be stale)
            self.planner.set_sensor_mark_cells(())
            self._need_plan = True
            return None
        return self._abort(f"Robot stalled: {what}, also after clearing the costmap and re-planning")

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
        if deviation > cfg.replan_distance and self._wait is None:
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
        if self.speed_limit is not None:
            v_max = min(v_max, self.speed_limit)
        if self.limits.holonomic:
            cmd = self._holonomic(pose, bearing, alpha, v_max, path, index)
        else:
            cmd = self._differential(pose, tx, ty, alpha, v_max)
        safe = self._safe(pose, cmd)
        if safe is None:
            # no forward motion keeps the robot clear: turn on the spot (towards the path) meanwhile
            blocker = self._blocker_near(pose)
            if blocker is not None:
                failed = self._wait_for_blocker(blocker, now)
                if failed is not None:
                    return failed
            elif self._blocked_since is None:
                self._blocked_since = now
                self.log.warning("move_base: no safe velocity, re-planning")
                self._need_plan = True
            elif now - self._blocked_since > cfg.controller_patience:
                return self._abort(f"Failed to find a valid control for {cfg.controller_patience:g} s "
                                   "(robot stuck)")
            return self._command(Twist2D(0.0, 0.0, self._turn_rate(alpha)) if abs(alpha) > 0.1 else ZERO)
        self._blocked_since = None
        if self._close_wait is not None and now - self._close_wait.since >= 1.0:
            self.log.info(f"move_base: passing {self._close_wait.blocker} after "
                          f"{now - self._close_wait.since:.1f} s")
        self._close_wait, self._waited_at = None, None
        return self._command(safe)

    def _blocker_near(self, pose: Pose2D) -> tuple[str, float, float] | None:
        """The robot or person (a run-time disc obstacle) that leaves no safe velocity: the nearest one whose
        disc is within ``blocker_distance`` of the robot's (name, x, y); None when the walls alone stop it."""
        reach = self.radius + self.config.robot_mark_step + self.config.blocker_distance
        found: list[tuple[float, str, float, float]] = []
        for robot in self._robots.values():
            found.append((math.hypot(robot.x - pose.x, robot.y - pose.y) - robot.radius,
                          f"robot {robot.name}", robot.x, robot.y))
        for name, shape in self._obstacles.items():
            if isinstance(shape, Circle):
                found.append((math.hypot(shape.x - pose.x, shape.y - pose.y) - shape.radius,
                              f"person {name}", shape.x, shape.y))
        near = [f for f in found if f[0] <= reach]
        if not near:
            return None
        _, name, x, y = min(near)
        return name, x, y

    def _waiting(self, now: float) -> bool:
        """Count a control cycle spent blocked (consecutive cycles only: the time since the previous one, at most
        a second); True once the goal's ``wait_budget`` is spent. A blocker that moves starts its wait anew, so
        one that keeps moving without ever opening the way (a person stepping aside and back, robots yielding
        to each other in turn) would otherwise hold the robot for ever."""
        if self._waited_at is not None:
            self._waited += min(max(0.0, now - self._waited_at), 1.0)
        self._waited_at = now
        return self._waited >= self.config.wait_budget

    def _wait_for_blocker(self, blocker: tuple[str, float, float], now: float) -> StepResult | None:
        """A robot or person in the way, close: wait for them to pass or make way (re-planning meanwhile), not
        counted as stuck; ABORTED when they have not moved ``oscillation_distance`` for ``robot_patience``."""
        cfg = self.config
        name, x, y = blocker
        if self._waiting(now):
            return self._abort(f"Blocked by robots or people for {self._waited:.0f} s in all (last by {name}): "
                               "they keep moving but the way never opens")
        wait = self._close_wait
        if wait is None or wait.blocker != name:
            wait = self._close_wait = _RobotWait(name, now, ((x, y), (x, y)))
            self.log.warning(f"move_base: {name} is in the way, close: waiting for it to pass or make way "
                             f"(at most {cfg.robot_patience:g} s while it does not move)")
            self._need_plan = True
        elif math.dist((x, y), wait.anchors[0]) >= cfg.oscillation_distance:
            wait.since, wait.anchors = now, ((x, y), (x, y))     # it moves: passing or making way
            self._need_plan = True
        elif now - wait.since >= cfg.robot_patience:
            why = "it neither passed nor made way"
            if name.startswith("robot "):
                why = f"deadlock (robots {self.name or '?'} and {name[6:]} cannot pass each other: {why})"
            return self._abort(f"Blocked by {name} for {now - wait.since:.0f} s: {why}")
        self._blocked_since = None
        self._progress_time = now          # waiting for somebody to pass is not oscillating
        return None

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
