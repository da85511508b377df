"""Message conversions and small helpers shared by the simulator's ROS adapters.

Only message classes are imported here (no rospy), so conversions are testable
without a master.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import genpy
from geometry_msgs.msg import Pose, PoseWithCovarianceStamped, Quaternion, TransformStamped, Twist
from nav_msgs.msg import OccupancyGrid

from gidabot_msgs.msg import Obstacle
from gidabot_navigation.building.geometry import Pose2D, quaternion_to_yaw, yaw_to_quaternion
from gidabot_navigation.building.occupancy import OccupancyMap
from gidabot_navigation.building.planning import Circle, Rectangle, Shape
from gidabot_navigation.interface import Topic
from gidabot_sim.errors import NavGoalRejected, PoseRejected
from gidabot_sim.world.kinematics import Twist2D

MAP_FRAMES = ("map", "/map", "")


def stamp(t: float) -> genpy.Time:
    """A ROS time from sim seconds (clamped at 0: ROS time cannot be negative)."""
    return genpy.Time.from_sec(max(t, 0.0))


def quaternion(yaw: float) -> Quaternion:
    x, y, z, w = yaw_to_quaternion(yaw)
    return Quaternion(x, y, z, w)


def pose_msg(pose: Pose2D) -> Pose:
    msg = Pose()
    msg.position.x, msg.position.y = pose.x, pose.y
    msg.orientation = quaternion(pose.yaw)
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


def twist_of(msg: Twist) -> tuple[float, float, float]:
    return (msg.linear.x, msg.linear.y, msg.angular.z)


def twist_msg(t: Twist2D) -> Twist:
    msg = Twist()
    msg.linear.x, msg.linear.y, msg.angular.z = t.vx, t.vy, t.wz
    return msg


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


def transform(parent: str, child: str, pose: Pose2D, t: float, z: float = 0.0) -> TransformStamped:
    msg = TransformStamped()
    msg.header.frame_id = parent
    msg.header.stamp = stamp(t)
    msg.child_frame_id = child
    msg.transform.translation.x, msg.transform.translation.y, msg.transform.translation.z = pose.x, pose.y, z
    msg.transform.rotation = quaternion(pose.yaw)
    return msg


class CountingLog:
    """Counts rejected inputs by kind and logs the first ``first`` of each kind, then every ``every``-th,
    so hostile input cannot flood the log."""

    def __init__(self, log: Callable[[str], None], first: int = 10, every: int = 100) -> None:
        self.log, self.first, self.every = log, first, every
        self.counts: dict[str, int] = {}

    def reject(self, kind: str, message: str) -> None:
        n = self.counts.get(kind, 0) + 1
        self.counts[kind] = n
        if n <= self.first or n % self.every == 0:
            self.log(f"rejected {kind} (#{n}): {message}")
