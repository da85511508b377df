"""The simulated world of one floor (ROS-free): robots, walls, run-time obstacles, laser, battery.

Stage-like: the floor is its map_server map (occupied and unknown cells are solid),
robots are discs driven by velocity commands within their limits, physics advances
in fixed steps of ``dt`` sim seconds (:meth:`World.advance_to`). A move that would
push a robot into a wall, an obstacle or another robot is refused (the robot
stalls, its velocity drops to zero), so robots never overlap anything; a move that
increases the clearance is always allowed, so a robot can back out.

Run-time obstacles (a person, a closed door) are :class:`~gidabot_navigation.building.planning.Circle`
and :class:`~gidabot_navigation.building.planning.Rectangle` shapes rasterised into the solid
mask: the laser sees them and robots collide with them.

Each robot keeps an odometry pose in its ``odom`` frame, integrated from the same
motion (no drift), which does not jump when the robot is teleported (``initialpose``):
as on a real robot carried elsewhere, only the localisation changes.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from gidabot_navigation.building.geometry import Pose2D, wrap_angle
from gidabot_navigation.building.occupancy import FREE, OccupancyMap
from gidabot_navigation.building.planning import Circle, Rectangle, Shape, rasterize
from gidabot_navigation.errors import ObstacleError
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
from gidabot_sim.world.raycast import RayCaster, beam_angles

MAX_OBSTACLES = 200
OBSTACLE_ID_RE = re.compile(r"^[A-Za-z0-9_.\-/]{1,64}$")


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


class World:
    """One floor: the map, its robots and obstacles, stepped in fixed ``dt`` sim seconds.

    ``cmd_timeout`` (s): a robot without a command for longer brakes to a stop (at its
    acceleration limits). ``rng``: random generator for sensor noise (pass a seeded one for
    repeatable runs). Time advances only by steps (:meth:`step`): it is ``start + steps * dt``,
    without rounding drift.
    """

    def __init__(self, grid: OccupancyMap, dt: float = 0.02, cmd_timeout: float = 0.2,
                 rng: np.random.Generator | None = None) -> None:
        for name, value in (("dt", dt), ("cmd_timeout", cmd_timeout)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise SimConfigError(f"{name}: {value!r} must be a finite number of seconds > 0")
        self.grid = grid
        self.dt = float(dt)
        self.cmd_timeout = float(cmd_timeout)
        self.rng = rng if rng is not None else np.random.default_rng()
        self.start = 0.0
        self.steps = 0
        self.robots: list[SimRobot] = []
        self.obstacles: dict[str, Shape] = {}
        self.obstacle_version = 0
        self._static = grid.cells != FREE        # occupied or unknown: solid
        self._obstacle_mask = np.zeros_like(self._static)
        self._dirty = False
        self.caster = RayCaster(self._static, grid.resolution, (grid.origin_x, grid.origin_y, grid.origin_yaw))

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

    def clearance(self, x: float, y: float) -> float:
        """Distance (m) from (x, y) to the nearest edge of a wall, unknown cell or obstacle; 0 off the map."""
        return self.caster.clearance(x, y)

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
        ok = ((self.caster.dist[r0:r1, c0:c1] - 0.5) * res >= radius) & ((rr - row) ** 2 + (cc - col) ** 2 <= n * n)
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
            self._step_robot(index, robot, t)
        self.steps += 1

    def _step_robot(self, index: int, robot: SimRobot, t: float) -> None:
        limits = robot.spec.limits
        fresh = robot.cmd_time is not None and t - robot.cmd_time <= self.cmd_timeout + 1e-9
        target = robot.cmd if fresh else ZERO
        vel = ZERO if target is ZERO and robot.vel is ZERO else accelerate(robot.vel, target, limits, self.dt)
        if not vel.is_zero():
            new = integrate(robot.pose, vel, self.dt)
            if self._blocked(index, robot, new):
                if not robot.stalled:
                    robot.stalls += 1
                robot.stalled, robot.vel = True, ZERO
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

    def _blocked(self, index: int, robot: SimRobot, new: Pose2D) -> bool:
        radius = robot.spec.radius
        after = self.clearance(new.x, new.y)
        if after < radius and after < self.clearance(robot.pose.x, robot.pose.y):
            return True
        if len(self.robots) == 1:
            return False
        for j, other in enumerate(self.robots):
            if j == index:
                continue
            gap = radius + other.spec.radius
            d_new = math.hypot(other.pose.x - new.x, other.pose.y - new.y)
            if d_new < gap and d_new < math.hypot(other.pose.x - robot.pose.x, other.pose.y - robot.pose.y):
                return True
        return False

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


def obstacle_shape(kind: int, x: float, y: float, yaw: float, radius: float, width: float,
                   height: float) -> Shape:
    """A shape from the fields of a gidabot_msgs/Obstacle (``kind`` 0 = CIRCLE, 1 = RECTANGLE)."""
    try:
        if kind == 0:
            return Circle(x, y, radius)
        if kind == 1:
            return Rectangle(x, y, width, height, yaw)
    except ObstacleError as err:
        raise ObstacleRejected(str(err)) from err
    raise ObstacleRejected(f"obstacle shape {kind!r}: expected 0 (CIRCLE) or 1 (RECTANGLE)")
