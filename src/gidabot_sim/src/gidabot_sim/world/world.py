"""The simulated world of one floor (ROS-free): robots, walls, run-time obstacles, laser, battery.

Stage-like: the floor is its map_server map (occupied and unknown cells are solid),
robots are discs driven by velocity commands within their limits, physics advances
in fixed steps of ``dt`` sim seconds (:meth:`World.advance_to`). A move that would
push a robot into a wall, an obstacle or another robot is refused (the robot
stalls, its velocity drops to zero), so robots never overlap anything; a move that
increases the clearance is always allowed, so a robot can back out.

With several robots on a floor (and only then: one robot costs nothing more) the world also
watches pairs of robots: a *collision* is a move refused because of another robot, counted once
per contact (the pair must part by ``CONTACT_RELEASE`` before it counts again); a *deadlock* is
two robots within ``DEADLOCK_NEAR`` of each other, at least one of them active (its navigation
has a goal, :meth:`World.set_active`), neither moving ``DEADLOCK_PROGRESS`` for ``deadlock_time``
sim seconds. Both are counted and reported as :class:`WorldEvent` (:meth:`World.take_events`).
:meth:`World.seen_robots` tells which other robots a robot's laser sees (its obstacle layer).

*Mates* (:meth:`World.add_mate`) are robots of the floor that another process simulates (each robot
runs its own simulator on its own master; :mod:`gidabot_sim.world.mates` shares their poses): this
world never moves them by its physics, it carries each along the velocity its simulator last wrote
(:meth:`World.set_mate`) and otherwise treats it as any robot: its laser sees it, its robots collide
with it (counted here when this world's robot is the one stopped; a contact where both robots drove
counts in both worlds), deadlocks with it are watched. Pairs of two mates are their own worlds' business.

Run-time obstacles (a person, a closed door) are :class:`~gidabot_navigation.building.planning.Circle`
and :class:`~gidabot_navigation.building.planning.Rectangle` shapes rasterised into the solid
mask: the laser sees them and robots collide with them. The floor's keep-out zones (``keep_out``: the
top of a staircase, a glass wall) are solid for the robots' bodies only: a robot cannot drive into
one, but the laser does not see it (as a real laser does not see a drop or glass).

Each robot keeps an odometry pose in its ``odom`` frame, integrated from the same
motion (no drift), which does not jump when the robot is teleported (``initialpose``):
as on a real robot carried elsewhere, only the localisation changes.
"""

from __future__ import annotations

import math
import re
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from gidabot_navigation.building.geometry import Polygon, Pose2D, wrap_angle
from gidabot_navigation.building.model import Floor
from gidabot_navigation.building.occupancy import FREE, OccupancyMap
from gidabot_navigation.building.planning import Circle, Rectangle, Shape, keep_out_mask, rasterize
from gidabot_sim.errors import ObstacleRejected, PoseRejected, SimConfigError
from gidabot_sim.world.kinematics import (
    ZERO,
    Limits,
    Twist2D,
    accelerate,
    check_twist,
    clamp_velocity,
    compose,
    integrate,
)
from gidabot_sim.world.raycast import RayCaster, beam_angles, disc_hits

MAX_OBSTACLES = 200
CONTACT_RELEASE = 0.05      # m: two robots in contact part when their gap exceeds this (then a new contact counts)
DEADLOCK_NEAR = 1.0         # m: gap between two robots' discs below which they may block each other
DEADLOCK_PROGRESS = 0.5     # m: a robot that moved this far since the pair met has made progress
MAX_EVENTS = 100            # world events kept until taken (the oldest are dropped)
OBSTACLE_ID_RE = re.compile(r"^[A-Za-z0-9_.\-/]{1,64}\Z")


@dataclass(frozen=True)
class LaserSpec:
    """A planar laser: ``beams`` over ``fov`` rad centred ahead, mounted at (x, y, yaw) on base_link."""

    beams: int = 360
    fov: float = 1.5 * math.pi        # rad (270 degrees)
    range_min: float = 0.05           # m
    range_max: float = 20.0           # m
    noise: float = 0.01               # m, standard deviation of the range noise
    x: float = 0.1                    # m, mount position on base_link
    y: float = 0.0
    yaw: float = 0.0

    def __post_init__(self) -> None:
        if not (isinstance(self.beams, int) and 1 <= self.beams <= 10000):
            raise SimConfigError(f"laser beams: {self.beams!r} must be an integer in 1..10000")
        if not (math.isfinite(self.fov) and 0 < self.fov <= 2 * math.pi):
            raise SimConfigError(f"laser fov: {self.fov!r} must be in (0, 2 pi] rad")
        if not (math.isfinite(self.range_max) and 0 <= self.range_min < self.range_max):
            raise SimConfigError(f"laser range: {self.range_min!r}..{self.range_max!r} must satisfy "
                                 "0 <= range_min < range_max (m)")
        if not (math.isfinite(self.noise) and self.noise >= 0):
            raise SimConfigError(f"laser noise: {self.noise!r} must be >= 0 (m)")

    @property
    def angle_min(self) -> float:
        return -self.fov / 2.0

    @property
    def angle_max(self) -> float:
        # a full circle must not repeat its first beam
        return self.fov / 2.0 - (self.fov / self.beams if self.fov >= 2 * math.pi - 1e-9 else 0.0)

    @property
    def angle_increment(self) -> float:
        return (self.angle_max - self.angle_min) / max(self.beams - 1, 1)

    def angles(self) -> np.ndarray:
        """Beam angles in the laser frame (rad)."""
        return beam_angles(self.angle_min, self.angle_max, self.beams)


@dataclass(frozen=True)
class BatteryModel:
    """Battery drain: ``idle_per_hour`` of a full charge per hour (electronics, always) plus ``per_km``
    of a full charge per km driven; voltage interpolates linearly from empty to full."""

    start: float = 1.0               # fraction 0..1 at start
    idle_per_hour: float = 0.05      # fraction per hour
    per_km: float = 0.25             # fraction per km
    voltage_empty: float = 11.0      # V
    voltage_full: float = 12.7       # V
    capacity_ah: float = 20.0        # Ah (design capacity, reported)

    def __post_init__(self) -> None:
        for name in ("start", "idle_per_hour", "per_km", "voltage_empty", "voltage_full", "capacity_ah"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise SimConfigError(f"battery {name}: {value!r} must be a finite number >= 0")
        if self.start > 1.0:
            raise SimConfigError(f"battery start: {self.start!r} must be a fraction in 0..1")

    def voltage(self, fraction: float) -> float:
        return self.voltage_empty + (self.voltage_full - self.voltage_empty) * fraction


@dataclass(frozen=True)
class RobotSpec:
    name: str
    radius: float              # m
    limits: Limits
    laser: LaserSpec = field(default_factory=LaserSpec)
    battery: BatteryModel = field(default_factory=BatteryModel)

    def __post_init__(self) -> None:
        if not (isinstance(self.radius, (int, float)) and math.isfinite(self.radius) and 0 < self.radius < 5):
            raise SimConfigError(f"robot {self.name}: radius {self.radius!r} must be in (0, 5) m")


@dataclass
class SimRobot:
    """State of one simulated robot."""

    spec: RobotSpec
    pose: Pose2D                       # ground truth in the map frame
    odom: Pose2D = Pose2D(0.0, 0.0, 0.0)   # pose in its odom frame (starts at the origin)
    vel: Twist2D = ZERO                # actual body velocity
    cmd: Twist2D = ZERO                # last command (clamped to the limits)
    cmd_time: float | None = None      # sim time the last command arrived
    battery: float = 1.0               # fraction 0..1
    odometer: float = 0.0              # m driven
    stalled: bool = False
    stalls: int = 0                    # number of times a move was refused
    active: bool = False               # its navigation has a goal (deadlock watch)
    mate: bool = False                 # simulated by another process: moved by set_mate, never by this physics
    mate_base: tuple[float, float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    #                                    x, y, yaw, vx, vy (map frame) at sim time t: a mate's last known motion


@dataclass(frozen=True)
class WorldEvent:
    """Something the world reports about two robots (logged by the node)."""

    kind: str                  # COLLISION, DEADLOCK or DEADLOCK_RESOLVED
    robots: tuple[str, str]    # names, in name order
    time: float                # sim s
    text: str


COLLISION = "collision"
MATE_EXTRAPOLATION = 0.5      # sim s a mate is carried along its last velocity, at most (gidabot_sim.world.mates)
DEADLOCK = "deadlock"
DEADLOCK_RESOLVED = "deadlock_resolved"


@dataclass
class _Standoff:
    """Two robots near each other: since when without progress, from where."""

    since: float
    anchors: tuple[tuple[float, float], tuple[float, float]]
    reported: bool = False


class World:
    """One floor: the map, its robots and obstacles, stepped in fixed ``dt`` sim seconds.

    ``cmd_timeout`` (s): a robot without a command for longer brakes to a stop (at its
    acceleration limits). ``rng``: random generator for sensor noise (pass a seeded one for
    repeatable runs). Time advances only by steps (:meth:`step`): it is ``start + steps * dt``,
    without rounding drift. ``keep_out``: the floor's keep-out zones by id (solid for bodies, not for the laser).
    """

    @classmethod
    def of_floor(cls, floor: Floor, **kwargs) -> World:
        """The world of a building's ``floor``: its map and its keep-out zones (the nodes and benches make it so)."""
        return cls(floor.map, keep_out=floor.keep_out_zones, **kwargs)

    def __init__(self, grid: OccupancyMap, dt: float = 0.02, cmd_timeout: float = 0.2,
                 rng: np.random.Generator | None = None, deadlock_time: float = 30.0,
                 keep_out: Mapping[str, Polygon] | None = None) -> None:
        for name, value in (("dt", dt), ("cmd_timeout", cmd_timeout), ("deadlock_time", deadlock_time)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SimConfigError(f"{name}: {value!r} must be a finite number of seconds > 0")
        self.grid = grid
        self.dt = float(dt)
        self.cmd_timeout = float(cmd_timeout)
        self.deadlock_time = float(deadlock_time)
        self.rng = rng if rng is not None else np.random.default_rng()
        self.start = 0.0
        self.steps = 0
        self.robots: list[SimRobot] = []
        self.obstacles: dict[str, Shape] = {}
        self.obstacle_version = 0
        self._static = grid.cells != FREE        # occupied or unknown: solid
        self._keep_out = keep_out_mask(grid, (keep_out or {}).values())
        self._obstacle_mask = np.zeros_like(self._static)
        self._dirty = False
        origin = (grid.origin_x, grid.origin_y, grid.origin_yaw)
        self.caster = RayCaster(self._static, grid.resolution, origin)       # what the laser sees
        # what bodies run into: the same, plus the keep-out zones (its own distance field only when there are any)
        self.bodies = RayCaster(self._static | self._keep_out, grid.resolution, origin) \
            if self._keep_out.any() else self.caster
        self.robot_collisions = 0                  # contacts between two robots (each counted once)
        self.deadlocks = 0                         # deadlocks reported
        self.events: deque[WorldEvent] = deque(maxlen=MAX_EVENTS)
        self._contacts: set[tuple[int, int]] = set()
        self._standoffs: dict[tuple[int, int], _Standoff] = {}

    @property
    def time(self) -> float:
        """Sim seconds."""
        return self.start + self.steps * self.dt

    # -- robots ----------------------------------------------------------------
    def add_robot(self, spec: RobotSpec, pose: Pose2D) -> int:
        """Place a robot at ``pose`` (checked like a teleport); return its index."""
        robot = SimRobot(spec=spec, pose=pose, battery=spec.battery.start)
        self.robots.append(robot)
        index = len(self.robots) - 1
        try:
            robot.pose = self.check_pose(index, pose)
        except PoseRejected:
            self.robots.pop()
            raise
        return index

    def add_mate(self, spec: RobotSpec, pose: Pose2D) -> int:
        """A robot of this floor simulated elsewhere (its own simulator), at ``pose``; returns its index. Not checked
        against this world's robots: it is where its own world says."""
        robot = SimRobot(spec=spec, pose=pose, battery=spec.battery.start, mate=True,
                         mate_base=(pose.x, pose.y, pose.yaw, 0.0, 0.0, self.time))
        self.robots.append(robot)
        return len(self.robots) - 1

    def set_mate(self, index: int, pose: Pose2D, vx: float, vy: float, t: float, active: bool) -> None:
        """Mate ``index`` was at ``pose`` moving at (``vx``, ``vy``) m/s (map frame) at sim time ``t`` (its own
        world's clock); from now on it is carried along that velocity, at most ``MATE_EXTRAPOLATION`` s away from
        ``t``."""
        robot = self.robot(index)
        if not robot.mate:
            raise ValueError(f"robot {robot.spec.name} is simulated here, not a mate")
        values = (pose.x, pose.y, pose.yaw, vx, vy, t)
        if not all(math.isfinite(v) for v in values):
            return
        robot.mate_base, robot.active = values, bool(active)
        self._place_mate(robot, self.time)

    @staticmethod
    def _place_mate(robot: SimRobot, t: float) -> None:
        x, y, yaw, vx, vy, t0 = robot.mate_base
        dt = min(max(t - t0, -MATE_EXTRAPOLATION), MATE_EXTRAPOLATION)
        robot.pose = Pose2D(x + vx * dt, y + vy * dt, yaw)
        robot.vel = ZERO

    @property
    def own(self) -> list[int]:
        """Indices of the robots this world simulates (not mates)."""
        return [i for i, r in enumerate(self.robots) if not r.mate]

    def robot(self, index: int) -> SimRobot:
        if not 0 <= index < len(self.robots):
            raise IndexError(f"robot index {index} out of range 0..{len(self.robots) - 1}")
        return self.robots[index]

    def set_command(self, index: int, vx: float, vy: float, wz: float) -> Twist2D:
        """Command robot ``index`` (body velocity); returns the command clamped to its limits.

        :class:`~gidabot_sim.errors.CommandRejected` for non-finite values (the robot keeps its last command).
        """
        robot = self.robot(index)
        cmd = clamp_velocity(check_twist(vx, vy, wz), robot.spec.limits)
        robot.cmd, robot.cmd_time = cmd, self.time
        return cmd

    def at_rest(self, index: int) -> bool:
        """True when robot ``index`` stands still and has no fresh non-zero command (sensors may slow down)."""
        robot = self.robot(index)
        if not robot.vel.is_zero():
            return False
        return (robot.cmd_time is None or robot.cmd.is_zero()
                or self.time - robot.cmd_time > self.cmd_timeout + 1e-9)

    def set_active(self, index: int, active: bool) -> None:
        """Whether robot ``index``'s navigation has a goal (a robot that has none is parked, never deadlocked)."""
        self.robot(index).active = bool(active)

    def clearance(self, x: float, y: float) -> float:
        """Distance (m) from (x, y) to the nearest edge of a wall, unknown cell, keep-out zone or obstacle (what a
        robot's disc must keep off); 0 off the map."""
        return self.bodies.clearance(x, y)

    def check_pose(self, index: int, pose: Pose2D, nudge: float = 0.5) -> Pose2D:
        """The pose robot ``index`` may be placed at for ``pose``, or :class:`PoseRejected`.

        The centre must be on the map in free space; a disc that touches a wall is moved
        to the nearest spot (within ``nudge`` m) where it fits; another robot in the way
        is an error.
        """
        radius = self.robot(index).spec.radius
        if not pose.is_finite():
            raise PoseRejected(f"pose ({pose.x!r}, {pose.y!r}, {pose.yaw!r}) is not finite (m, m, rad)")
        if not self.grid.contains(pose.x, pose.y):
            w, h = self.grid.size_m
            raise PoseRejected(f"pose ({pose.x:g}, {pose.y:g}) is outside the map (x {self.grid.origin_x:g}.."
                               f"{self.grid.origin_x + w:g}, y {self.grid.origin_y:g}..{self.grid.origin_y + h:g} m)")
        row, col = self.grid.world_to_cell(pose.x, pose.y)
        if self._static[row, col]:
            raise PoseRejected(f"pose ({pose.x:g}, {pose.y:g}) is inside a wall or unknown space")
        if self._keep_out[row, col]:
            raise PoseRejected(f"pose ({pose.x:g}, {pose.y:g}) is inside a keep-out zone")
        if self._obstacle_mask[row, col]:
            raise PoseRejected(f"pose ({pose.x:g}, {pose.y:g}) is inside an obstacle")
        x, y = pose.x, pose.y
        if self.clearance(x, y) < radius:
            spot = self._nearest_fit(row, col, radius, nudge)
            if spot is None:
                raise PoseRejected(f"pose ({pose.x:g}, {pose.y:g}): a robot of radius {radius:g} m does not fit "
                                   f"there nor within {nudge:g} m (walls or obstacles)")
            x, y = spot
        for j, other in enumerate(self.robots):
            if j != index and math.hypot(other.pose.x - x, other.pose.y - y) < radius + other.spec.radius:
                raise PoseRejected(f"pose ({x:g}, {y:g}) overlaps robot {other.spec.name} at "
                                   f"({other.pose.x:.2f}, {other.pose.y:.2f})")
        return Pose2D(x, y, wrap_angle(pose.yaw))

    def _nearest_fit(self, row: int, col: int, radius: float, nudge: float) -> tuple[float, float] | None:
        res = self.grid.resolution
        n = int(math.ceil(nudge / res))
        r0, r1 = max(row - n, 0), min(row + n + 1, self.grid.height)
        c0, c1 = max(col - n, 0), min(col + n + 1, self.grid.width)
        rr, cc = np.mgrid[r0:r1, c0:c1]
        ok = ((self.bodies.dist[r0:r1, c0:c1] - 0.5) * res >= radius) & ((rr - row) ** 2 + (cc - col) ** 2 <= n * n)
        if not ok.any():
            return None
        d2 = np.where(ok, (rr - row) ** 2 + (cc - col) ** 2, np.iinfo(np.int64).max)
        k = int(np.argmin(d2))
        return self.grid.cell_to_world(int(rr.flat[k]), int(cc.flat[k]))

    def teleport(self, index: int, pose: Pose2D) -> Pose2D:
        """Move robot ``index`` to ``pose`` (checked, maybe nudged) and stop it; returns where it was put."""
        robot = self.robot(index)
        placed = self.check_pose(index, pose)
        robot.pose, robot.vel, robot.cmd, robot.cmd_time, robot.stalled = placed, ZERO, ZERO, None, False
        return placed

    # -- obstacles -------------------------------------------------------------
    def add_obstacle(self, obstacle_id: str, shape: Shape, rebuild: bool = True) -> None:
        """Add (or replace) obstacle ``obstacle_id``; :class:`ObstacleRejected` if invalid or on a robot.

        ``rebuild`` False defers the (tens of milliseconds) update of the solid mask to :meth:`rebuild`,
        so a burst of changes costs one update.
        """
        if not isinstance(obstacle_id, str) or not OBSTACLE_ID_RE.match(obstacle_id):
            raise ObstacleRejected(f"obstacle id {str(obstacle_id)[:80]!r}: expected 1..64 characters of "
                                   "letters, digits, '_', '-', '.', '/'")
        if not isinstance(shape, (Circle, Rectangle)):
            raise ObstacleRejected(f"obstacle {obstacle_id!r}: {shape!r} is not a Circle or Rectangle")
        if obstacle_id not in self.obstacles and len(self.obstacles) >= MAX_OBSTACLES:
            raise ObstacleRejected(f"obstacle {obstacle_id!r}: already {MAX_OBSTACLES} obstacles on this floor")
        for robot in self.robots:
            if bool(shape.contains(np.array(robot.pose.x), np.array(robot.pose.y), margin=robot.spec.radius)):
                raise ObstacleRejected(f"obstacle {obstacle_id!r} would overlap robot {robot.spec.name} at "
                                       f"({robot.pose.x:.2f}, {robot.pose.y:.2f})")
        self.obstacles[obstacle_id] = shape
        self._dirty = True
        if rebuild:
            self.rebuild()

    def remove_obstacle(self, obstacle_id: str, rebuild: bool = True) -> bool:
        """Remove obstacle ``obstacle_id``; False when there was none."""
        if self.obstacles.pop(obstacle_id, None) is None:
            return False
        self._dirty = True
        if rebuild:
            self.rebuild()
        return True

    def clear_obstacles(self, rebuild: bool = True) -> int:
        """Remove every obstacle; returns how many there were."""
        count = len(self.obstacles)
        if count:
            self.obstacles.clear()
            self._dirty = True
            if rebuild:
                self.rebuild()
        return count

    def rebuild(self) -> bool:
        """Bring the solid mask (laser, collisions) up to date with the obstacles; True when it changed."""
        if not self._dirty:
            return False
        self._rebuild()
        self._dirty = False
        return True

    def _rebuild(self) -> None:
        mask = np.zeros_like(self._static)
        for shape in self.obstacles.values():
            cells = rasterize(shape, self.grid)
            if cells is not None:
                mask[cells[0]] |= cells[1]
        self._obstacle_mask = mask
        self.caster.update(self._static | mask)
        if self.bodies is not self.caster:
            self.bodies.update(self._static | self._keep_out | mask)
        self.obstacle_version += 1

    # -- physics ---------------------------------------------------------------
    def advance_to(self, target: float) -> int:
        """Step until the world's time reaches ``target`` (within one ``dt``); returns the steps made."""
        if not math.isfinite(target):
            raise ValueError(f"target time {target!r} is not finite")
        steps = 0
        while self.time + self.dt <= target + 1e-9:
            self.step()
            steps += 1
        return steps

    def start_at(self, t: float) -> None:
        """Set the world's time (at start, or when a restarted simulator resumes its floor's timeline)."""
        if not math.isfinite(t):
            raise ValueError(f"start time {t!r} is not finite")
        self.start, self.steps = float(t), 0

    def step(self) -> None:
        """Advance every robot by one ``dt``."""
        t = self.start + (self.steps + 1) * self.dt
        for index, robot in enumerate(self.robots):
            if robot.mate:
                self._place_mate(robot, t)
            else:
                self._step_robot(index, robot, t)
        self.steps += 1
        if len(self.robots) > 1:
            self._watch_pairs(t)

    def _step_robot(self, index: int, robot: SimRobot, t: float) -> None:
        limits = robot.spec.limits
        fresh = robot.cmd_time is not None and t - robot.cmd_time <= self.cmd_timeout + 1e-9
        target = robot.cmd if fresh else ZERO
        vel = ZERO if target is ZERO and robot.vel is ZERO else accelerate(robot.vel, target, limits, self.dt)
        if not vel.is_zero():
            new = integrate(robot.pose, vel, self.dt)
            blocker = self._blocked(index, robot, new)
            if blocker is not None:
                if not robot.stalled:
                    robot.stalls += 1
                robot.stalled, robot.vel = True, ZERO
                if blocker >= 0:
                    self._touch(index, blocker, t)
            else:
                moved = math.hypot(new.x - robot.pose.x, new.y - robot.pose.y)
                robot.odometer += moved
                robot.battery -= robot.spec.battery.per_km * moved / 1000.0
                robot.pose = new
                robot.odom = integrate(robot.odom, vel, self.dt)
                robot.stalled, robot.vel = False, vel
        else:
            robot.vel = ZERO
        robot.battery = max(0.0, robot.battery - robot.spec.battery.idle_per_hour * self.dt / 3600.0)

    def _blocked(self, index: int, robot: SimRobot, new: Pose2D) -> int | None:
        """What refuses the move to ``new``: None (nothing), -1 (a wall or an obstacle) or another robot's index."""
        radius = robot.spec.radius
        after = self.clearance(new.x, new.y)
        if after < radius and after < self.clearance(robot.pose.x, robot.pose.y):
            return -1
        if len(self.robots) == 1:
            return None
        for j, other in enumerate(self.robots):
            if j == index:
                continue
            gap = radius + other.spec.radius
            d_new = math.hypot(other.pose.x - new.x, other.pose.y - new.y)
            if d_new < gap and d_new < math.hypot(other.pose.x - robot.pose.x, other.pose.y - robot.pose.y):
                return j
        return None

    # -- robot pairs (several robots only) ---------------------------------------
    def _names(self, i: int, j: int) -> tuple[str, str]:
        a, b = self.robots[i].spec.name, self.robots[j].spec.name
        return (a, b) if a <= b else (b, a)

    def _touch(self, index: int, other: int, t: float) -> None:
        """Robot ``index`` was stopped by robot ``other``: a collision, unless the two are still in contact."""
        pair = (min(index, other), max(index, other))
        if pair in self._contacts:
            return
        self._contacts.add(pair)
        self.robot_collisions += 1
        mover, hit = self.robots[index], self.robots[other]
        self.events.append(WorldEvent(COLLISION, self._names(index, other), t,
                                      f"robot {mover.spec.name} ran into robot {hit.spec.name} at "
                                      f"({mover.pose.x:.2f}, {mover.pose.y:.2f}) and was stopped"))

    def _watch_pairs(self, t: float) -> None:
        """Contacts that ended; standoffs that made progress, ended or lasted ``deadlock_time`` (a deadlock)."""
        robots = self.robots
        for i in range(len(robots)):
            a = robots[i]
            for j in range(i + 1, len(robots)):
                b = robots[j]
                if a.mate and b.mate:
                    continue                       # watched by their own worlds
                gap = math.hypot(a.pose.x - b.pose.x, a.pose.y - b.pose.y) - a.spec.radius - b.spec.radius
                pair = (i, j)
                if gap > CONTACT_RELEASE:
                    self._contacts.discard(pair)
                standoff = self._standoffs.get(pair)
                if gap >= DEADLOCK_NEAR or not (a.active or b.active):
                    if standoff is not None:
                        self._end_standoff(pair, t, "parted" if gap >= DEADLOCK_NEAR else "no longer driving")
                    continue
                here = ((a.pose.x, a.pose.y), (b.pose.x, b.pose.y))
                if standoff is None:
                    self._standoffs[pair] = _Standoff(t, here)
                    continue
                if any(math.dist(p, q) >= DEADLOCK_PROGRESS for p, q in zip(here, standoff.anchors, strict=True)):
                    if standoff.reported:
                        self._end_standoff(pair, t, "moving again")
                    self._standoffs[pair] = _Standoff(t, here)
                elif not standoff.reported and t - standoff.since >= self.deadlock_time - 1e-9:
                    standoff.reported = True
                    self.deadlocks += 1
                    names = self._names(i, j)
                    self.events.append(WorldEvent(
                        DEADLOCK, names, t, f"deadlock: robots {names[0]} and {names[1]} block each other "
                        f"({gap:.2f} m apart, no progress of {DEADLOCK_PROGRESS:g} m for {t - standoff.since:.1f} s)"))

    def _end_standoff(self, pair: tuple[int, int], t: float, why: str) -> None:
        standoff = self._standoffs.pop(pair)
        if standoff.reported:
            names = self._names(*pair)
            self.events.append(WorldEvent(DEADLOCK_RESOLVED, names, t, f"deadlock of robots {names[0]} and "
                                          f"{names[1]} resolved ({why}) after {t - standoff.since:.1f} s"))

    @property
    def deadlocked(self) -> list[tuple[str, str]]:
        """Pairs of robots (names) in a reported deadlock now."""
        return sorted(self._names(*pair) for pair, s in self._standoffs.items() if s.reported)

    def take_events(self) -> list[WorldEvent]:
        """The events since the last call (oldest first)."""
        events = list(self.events)
        self.events.clear()
        return events

    # -- sensors ---------------------------------------------------------------
    def laser_pose(self, index: int) -> Pose2D:
        robot = self.robot(index)
        laser = robot.spec.laser
        return compose(robot.pose, Pose2D(laser.x, laser.y, laser.yaw))

    def scan(self, index: int, noisy: bool = True) -> np.ndarray:
        """One laser scan of robot ``index``: ranges (m) per beam, ``inf`` = no return (REP 117)."""
        robot = self.robot(index)
        laser = robot.spec.laser
        origin = self.laser_pose(index)
        discs = [(o.pose.x, o.pose.y, o.spec.radius) for j, o in enumerate(self.robots) if j != index]
        ranges = self.caster.cast(origin.x, origin.y, laser.angles() + origin.yaw, laser.range_max, discs)
        if noisy and laser.noise > 0:
            finite = np.isfinite(ranges)
            ranges[finite] += self.rng.normal(0.0, laser.noise, int(finite.sum()))
        finite = np.isfinite(ranges)
        ranges[finite] = np.clip(ranges[finite], laser.range_min, laser.range_max)
        return ranges


    def seen_robots(self, index: int) -> list[int]:
        """Indices of the other robots robot ``index``'s laser sees now (a beam hits their disc before anything
        else, within range and field of view; noise-free): what its obstacle layer may mark."""
        if len(self.robots) == 1:
            return []
        laser = self.robot(index).spec.laser
        origin = self.laser_pose(index)
        angles = laser.angles() + origin.yaw
        seen = []
        for j, other in enumerate(self.robots):
            if j == index:
                continue
            hits = disc_hits(origin.x, origin.y, angles, other.pose.x, other.pose.y, other.spec.radius)
            beams = hits <= laser.range_max
            if not beams.any():
                continue
            discs = [(o.pose.x, o.pose.y, o.spec.radius) for k, o in enumerate(self.robots) if k not in (index, j)]
            others = self.caster.cast(origin.x, origin.y, angles[beams], laser.range_max, discs)
            if bool((hits[beams] < others).any()):
                seen.append(j)
        return seen

