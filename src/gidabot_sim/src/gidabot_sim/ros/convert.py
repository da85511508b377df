"""Every conversion between ROS messages and gidabot_sim's core types (the simulator, the navigation
stand-ins, the simulated visitor), in both directions.

Only message classes are imported here (no rospy), so conversions are testable without a master. A
conversion of a message the node receives checks what the core cannot (frames, finite values, unit
quaternions) and raises the package's error naming the bad field.
"""

from __future__ import annotations

import math

import genpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Pose, PoseStamped, PoseWithCovarianceStamped, Quaternion, TransformStamped, Twist
from nav_msgs.msg import OccupancyGrid, Odometry
from nav_msgs.msg import Path as PathMsg
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import BatteryState, LaserScan
from tf2_msgs.msg import TFMessage

from gidabot_msgs.msg import (
    NavEvent,
    Obstacle,
    ObstacleArray,
    PendingRequests,
    RobotStatus,
    StepDone,
    TourCatalog,
    VisitorCommand,
)
from gidabot_navigation.building.geometry import Pose2D, quaternion_to_yaw, yaw_to_quaternion
from gidabot_navigation.building.occupancy import OccupancyMap
from gidabot_navigation.building.planning import Circle, Path, Rectangle, Shape
from gidabot_navigation.errors import ObstacleError
from gidabot_navigation.guiding.messages import CommandData, NavEventData, Trip
from gidabot_navigation.interface import Topic
from gidabot_navigation.ros.convert import catalog_from_msg, command_to_msg, event_from_msg, trip_from_msg
from gidabot_navigation.tours.tour_store import TourMessage
from gidabot_sim.errors import NavGoalRejected, ObstacleRejected, PoseRejected
from gidabot_sim.navstack.amcl import Estimate
from gidabot_sim.navstack.move_base import SensedRobot
from gidabot_sim.world.floor_sim import (
    ADD,
    CLEAR,
    ERROR,
    OK,
    REMOVE,
    WARN,
    Battery,
    Diagnostics,
    ObstacleChange,
    Obstacles,
    Scan,
    Seen,
    Transforms,
)
from gidabot_sim.world.kinematics import Twist2D
from gidabot_sim.world.lockstep import Answer

MAP_FRAMES = ("map", "/map", "")
ODOM_COVARIANCE = tuple(1e-4 if i in (0, 7, 35) else 0.0 for i in range(36))
ACTIONS = {Obstacle.ADD: ADD, Obstacle.REMOVE: REMOVE, Obstacle.CLEAR: CLEAR}
LEVELS = {OK: DiagnosticStatus.OK, WARN: DiagnosticStatus.WARN, ERROR: DiagnosticStatus.ERROR}


# -- time, poses, velocities ---------------------------------------------------------------------------
def stamp(t: float) -> genpy.Time:
    """A ROS time from sim seconds (clamped at 0: ROS time cannot be negative)."""
    return genpy.Time.from_sec(max(t, 0.0))


def clock_msg(t: float) -> Clock:
    return Clock(clock=stamp(t))


def quaternion(yaw: float) -> Quaternion:
    x, y, z, w = yaw_to_quaternion(yaw)
    return Quaternion(x, y, z, w)


def pose_msg(pose: Pose2D) -> Pose:
    msg = Pose()
    msg.position.x, msg.position.y = pose.x, pose.y
    msg.orientation = quaternion(pose.yaw)
    return msg


def pose_stamped(pose: Pose2D, t: float) -> PoseStamped:
    """``pose`` in the map frame at ``t``."""
    msg = PoseStamped()
    msg.header.frame_id, msg.header.stamp = "map", stamp(t)
    msg.pose = pose_msg(pose)
    return msg


def yaw_of(q: Quaternion, what: str, error: type[Exception] = PoseRejected) -> float:
    """Yaw of ``q``; ``error`` when it is not finite or not (close to) a unit quaternion, as move_base checks."""
    values = (q.x, q.y, q.z, q.w)
    if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values):
        raise error(f"{what}: quaternion {values!r} is not finite")
    norm = math.sqrt(sum(v * v for v in values))
    if norm < 1e-3:
        raise error(f"{what}: quaternion {values!r} has (almost) zero length")
    x, y, z, w = (v / norm for v in values)
    # a rotation about z only: the rotated z axis stays vertical (move_base rejects tilted goals)
    if 1.0 - 2.0 * (x * x + y * y) < math.cos(math.radians(5.0)):
        raise error(f"{what}: quaternion {values!r} is not a rotation about z")
    return quaternion_to_yaw(x, y, z, w)


def pose2d_of(pose: Pose, what: str, error: type[Exception] = PoseRejected) -> Pose2D:
    """A planar pose from a geometry_msgs/Pose; ``error`` for NaN/inf or a bad quaternion."""
    x, y = pose.position.x, pose.position.y
    if not (math.isfinite(x) and math.isfinite(y)):
        raise error(f"{what}: position ({x!r}, {y!r}) is not finite (m)")
    return Pose2D(x, y, yaw_of(pose.orientation, what, error))


def check_map_frame(frame_id: str, what: str, error: type[Exception] = PoseRejected) -> None:
    if frame_id not in MAP_FRAMES:
        raise error(f"{what}: frame {frame_id[:80]!r} is not the map frame 'map'")


def initialpose_to_pose2d(msg: PoseWithCovarianceStamped) -> Pose2D:
    check_map_frame(msg.header.frame_id, Topic.INITIALPOSE)
    return pose2d_of(msg.pose.pose, Topic.INITIALPOSE)


def goal_to_pose2d(frame_id: str, pose: Pose) -> Pose2D:
    check_map_frame(frame_id, "goal", NavGoalRejected)
    return pose2d_of(pose, "goal", NavGoalRejected)


def amcl_pose_of(msg: PoseWithCovarianceStamped) -> tuple[float, Pose2D]:
    """(stamp, pose) of a localisation estimate; :class:`PoseRejected` for a bad pose."""
    return msg.header.stamp.to_sec(), pose2d_of(msg.pose.pose, Topic.AMCL_POSE)


def twist_of(msg: Twist) -> tuple[float, float, float]:
    return (msg.linear.x, msg.linear.y, msg.angular.z)


def twist_msg(t: Twist2D) -> Twist:
    msg = Twist()
    msg.linear.x, msg.linear.y, msg.angular.z = t.vx, t.vy, t.wz
    return msg


def odometry_msg(frame_id: str, child_frame_id: str) -> Odometry:
    """An odometry message of these frames, to be filled by :func:`fill_odometry` at every publication."""
    msg = Odometry()
    msg.header.frame_id, msg.child_frame_id = frame_id, child_frame_id
    msg.pose.covariance = msg.twist.covariance = ODOM_COVARIANCE
    return msg


def fill_odometry(msg: Odometry, pose: Pose2D, vel: Twist2D, t: float) -> Odometry:
    """``msg`` (reused: publishing serialises it at once) set to ``pose`` and body velocity ``vel`` at ``t``."""
    msg.header.stamp = stamp(t)
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    p.x, p.y = pose.x, pose.y
    q.x, q.y, q.z, q.w = yaw_to_quaternion(pose.yaw)
    v = msg.twist.twist
    v.linear.x, v.linear.y, v.angular.z = vel.vx, vel.vy, vel.wz
    return msg


def odometry_of(msg: Odometry, what: str) -> tuple[float, Pose2D, Twist2D]:
    """(stamp, pose, body velocity) of an odometry message; :class:`PoseRejected` for a non-finite value."""
    p, q, v = msg.pose.pose.position, msg.pose.pose.orientation, msg.twist.twist
    values = (p.x, p.y, q.x, q.y, q.z, q.w, v.linear.x, v.linear.y, v.angular.z)
    if not all(math.isfinite(x) for x in values):
        raise PoseRejected(f"{what}: non-finite values {values!r}")
    return (msg.header.stamp.to_sec(), Pose2D(p.x, p.y, quaternion_to_yaw(q.x, q.y, q.z, q.w)),
            Twist2D(v.linear.x, v.linear.y, v.angular.z))


def transform(parent: str, child: str, pose: Pose2D, t: float, z: float = 0.0) -> TransformStamped:
    msg = TransformStamped()
    msg.header.frame_id = parent
    msg.header.stamp = stamp(t)
    msg.child_frame_id = child
    msg.transform.translation.x, msg.transform.translation.y, msg.transform.translation.z = pose.x, pose.y, z
    msg.transform.rotation = quaternion(pose.yaw)
    return msg


def transforms_msg(out: Transforms) -> TFMessage:
    return TFMessage(transforms=[transform(f.parent, f.child, f.pose, f.t, f.z) for f in out.frames])


# -- the simulator ---------------------------------------------------------------------------------------
def occupancy_grid(grid: OccupancyMap, t: float) -> OccupancyGrid:
    """The map as map_server publishes it (frame ``map``, row-major, row 0 at the origin)."""
    msg = OccupancyGrid()
    msg.header.frame_id = "map"
    msg.header.stamp = stamp(t)
    msg.info.map_load_time = stamp(t)
    msg.info.resolution = grid.resolution
    msg.info.width, msg.info.height = grid.width, grid.height
    msg.info.origin = pose_msg(Pose2D(grid.origin_x, grid.origin_y, grid.origin_yaw))
    msg.data = grid.cells.reshape(-1).tolist()
    return msg


def shape_of(msg: Obstacle) -> Shape:
    """The shape of a gidabot_msgs/Obstacle; :class:`ObstacleRejected` naming a bad kind or size."""
    try:
        if msg.shape == Obstacle.CIRCLE:
            return Circle(msg.x, msg.y, msg.radius)
        if msg.shape == Obstacle.RECTANGLE:
            return Rectangle(msg.x, msg.y, msg.width, msg.height, msg.yaw)
    except ObstacleError as err:
        raise ObstacleRejected(str(err)) from err
    raise ObstacleRejected(f"obstacle shape {msg.shape!r}: expected {Obstacle.CIRCLE} (CIRCLE) or "
                           f"{Obstacle.RECTANGLE} (RECTANGLE)")


def obstacle_change_of(msg: Obstacle) -> ObstacleChange:
    """A ``/sim/obstacle`` command (the shape only for ADD); :class:`ObstacleRejected` for another frame than the
    map, an unknown action or a bad shape."""
    check_map_frame(msg.header.frame_id, f"obstacle {msg.id[:64]!r}", ObstacleRejected)
    action = ACTIONS.get(msg.action)
    if action is None:
        raise ObstacleRejected(f"obstacle action {msg.action!r}: expected {Obstacle.ADD} (ADD), {Obstacle.REMOVE} "
                               f"(REMOVE) or {Obstacle.CLEAR} (CLEAR)")
    return ObstacleChange(action, msg.id, shape_of(msg) if action == ADD else None)


def obstacle_msg(obstacle_id: str, shape: Shape) -> Obstacle:
    msg = Obstacle()
    msg.header.frame_id = "map"
    msg.id = obstacle_id
    msg.action = Obstacle.ADD
    msg.x, msg.y = shape.x, shape.y
    if isinstance(shape, Circle):
        msg.shape, msg.radius = Obstacle.CIRCLE, shape.radius
    elif isinstance(shape, Rectangle):
        msg.shape, msg.width, msg.height, msg.yaw = Obstacle.RECTANGLE, shape.width, shape.height, shape.yaw
    return msg


def obstacle_array(items: tuple[tuple[str, Shape], ...], t: float) -> ObstacleArray:
    msg = ObstacleArray()
    msg.header.frame_id = "map"
    msg.header.stamp = stamp(t)
    msg.obstacles = [obstacle_msg(k, s) for k, s in items]
    return msg


def obstacles_msg(out: Obstacles) -> ObstacleArray:
    return obstacle_array(out.items, out.t)


def seen_msg(out: Seen) -> ObstacleArray:
    """The robots a laser sees: id = the robot's name, a CIRCLE of its radius."""
    return obstacle_array(out.robots, out.t)


def obstacle_shapes_of(msg: ObstacleArray) -> tuple[dict[str, Shape], list[str]]:
    """The obstacles of an array by id, and what was wrong with those left out."""
    shapes, problems = {}, []
    for ob in msg.obstacles:
        try:
            shapes[ob.id] = shape_of(ob)
        except ObstacleRejected as err:
            problems.append(f"obstacle {ob.id[:64]!r}: {err}")
    return shapes, problems


def sensed_robots_of(msg: ObstacleArray) -> list[SensedRobot]:
    """The robots of a ``robots_seen`` array (its circles: name and disc)."""
    return [SensedRobot(ob.id, ob.x, ob.y, ob.radius) for ob in msg.obstacles if ob.shape == Obstacle.CIRCLE]


def scan_msg(out: Scan, frame_id: str) -> LaserScan:
    laser = out.laser
    msg = LaserScan()
    msg.header.stamp = stamp(out.t)
    msg.header.frame_id = frame_id
    msg.angle_min, msg.angle_max, msg.angle_increment = laser.angle_min, laser.angle_max, laser.angle_increment
    msg.time_increment = 0.0
    msg.scan_time = out.scan_time
    msg.range_min, msg.range_max = laser.range_min, laser.range_max
    msg.ranges = out.ranges.astype("float32").tolist()
    return msg


def battery_msg(out: Battery) -> BatteryState:
    msg = BatteryState()
    msg.header.stamp = stamp(out.t)
    msg.percentage = out.fraction
    msg.voltage = out.model.voltage(out.fraction)
    msg.current = out.current
    msg.charge = out.model.capacity_ah * out.fraction
    msg.capacity = msg.design_capacity = out.model.capacity_ah
    msg.power_supply_status = BatteryState.POWER_SUPPLY_STATUS_DISCHARGING
    msg.power_supply_health = (BatteryState.POWER_SUPPLY_HEALTH_GOOD if out.fraction > 0.0
                               else BatteryState.POWER_SUPPLY_HEALTH_DEAD)
    msg.power_supply_technology = BatteryState.POWER_SUPPLY_TECHNOLOGY_LION
    msg.present = True
    msg.location = out.name
    return msg


def diagnostics_msg(out: Diagnostics) -> DiagnosticArray:
    status = DiagnosticStatus(level=LEVELS[out.level], name=out.name, message=out.message,
                              hardware_id=out.hardware_id, values=[KeyValue(k, v) for k, v in out.values])
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = stamp(out.t)
    return msg


def answer_of(msg: StepDone) -> Answer:
    """A lockstep participant's answer (checked by the core)."""
    return Answer(msg.node, msg.session, msg.done.to_sec(), msg.idle, tuple(msg.inputs), msg.commands)


def step_done_msg(answer: Answer) -> StepDone:
    return StepDone(node=answer.node, session=answer.session, done=stamp(answer.done), idle=answer.idle,
                    inputs=list(answer.inputs), commands=answer.commands)


# -- the navigation stand-ins ------------------------------------------------------------------------------
def path_msg(path: Path, goal_yaw: float, spacing: float, t: float) -> PathMsg:
    """A plan as navfn returns it: a pose every ``spacing`` m, each facing along the path, the last the goal's yaw."""
    msg = PathMsg()
    msg.header.frame_id = "map"
    msg.header.stamp = stamp(t)
    points = path.densified(spacing)
    for k, (x, y) in enumerate(points):
        if k + 1 < len(points):
            nx, ny = points[k + 1]
            yaw = math.atan2(ny - y, nx - x)
        else:
            yaw = goal_yaw
        pose = PoseStamped()
        pose.header = msg.header
        pose.pose = pose_msg(Pose2D(x, y, yaw))
        msg.poses.append(pose)
    return msg


def plan_msg(found: tuple[Path, float] | None, spacing: float, t: float) -> PathMsg:
    """make_plan's answer: the path found and its goal's yaw as :func:`path_msg`; for none, an empty plan."""
    if found is not None:
        return path_msg(found[0], found[1], spacing, t)
    msg = PathMsg()
    msg.header.frame_id, msg.header.stamp = "map", stamp(t)
    return msg


def plan_request_of(req: object) -> tuple[Pose2D | None, Pose2D, float]:
    """(start, goal, tolerance) of a nav_msgs/GetPlan request: start None (empty frame_id) is the robot's pose;
    :class:`NavGoalRejected` for a bad pose or frame."""
    goal = goal_to_pose2d(req.goal.header.frame_id, req.goal.pose)  # type: ignore[attr-defined]
    start = req.start  # type: ignore[attr-defined]
    return (goal_to_pose2d(start.header.frame_id, start.pose) if start.header.frame_id else None, goal,
            float(req.tolerance))  # type: ignore[attr-defined]


def estimate_msg(estimate: Estimate, frame_id: str) -> PoseWithCovarianceStamped:
    msg = PoseWithCovarianceStamped()
    msg.header.stamp = stamp(estimate.stamp)
    msg.header.frame_id = frame_id
    msg.pose.pose = pose_msg(estimate.pose)
    msg.pose.covariance = list(estimate.covariance)
    return msg


# -- the simulated visitor -----------------------------------------------------------------------------------
def nav_event_of(msg: NavEvent) -> NavEventData:
    return event_from_msg(msg)


def pending_of(msg: PendingRequests, limit: int = 256) -> tuple[str, list[Trip], float]:
    """(robot, its queue's first ``limit`` trips, the wait for a new request) of a robot's pending list."""
    return msg.robot, [trip_from_msg(g) for g in msg.goals[:limit]], msg.wait_new


def status_of(msg: RobotStatus) -> tuple[str, tuple[float, float]]:
    """(robot, its position) of a robot's status."""
    p = msg.nav_pose.position
    return msg.robot, (p.x, p.y)


def tours_of(msg: TourCatalog) -> tuple[TourMessage, ...]:
    return catalog_from_msg(msg).tours


def command_msg(c: CommandData) -> VisitorCommand:
    return command_to_msg(c)
