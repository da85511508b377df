"""Message conversions of the simulator's adapters (no master): map as map_server publishes it from a
map_server map file (origin, thresholds, negate, row flip), poses and quaternions, obstacles."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import Pose, PoseWithCovarianceStamped, Quaternion
from PIL import Image

from gidabot_msgs.msg import Obstacle
from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.occupancy import load_map
from gidabot_navigation.building.planning import Circle, Rectangle
from gidabot_navigation.interface import Topic
from gidabot_sim.errors import NavGoalRejected, PoseRejected
from gidabot_sim.ros import convert as ru
from gidabot_sim.world.world import obstacle_shape


def write_map(tmp_path: Path, pixels: np.ndarray, **doc) -> Path:
    Image.fromarray(pixels.astype(np.uint8)).save(tmp_path / "m.pgm")
    data = {"image": "m.pgm", "resolution": 0.1, "origin": [-2.0, 3.0, 0.0], "negate": 0,
            "occupied_thresh": 0.65, "free_thresh": 0.196, **doc}
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(data))
    return tmp_path / "m.yaml"


def test_the_map_topic_follows_map_server(tmp_path: Path) -> None:
    # image row 0 is the top: a black pixel top-left, grey (unknown) bottom-right
    pixels = np.full((3, 4), 254)
    pixels[0, 0] = 0
    pixels[2, 3] = 205
    grid = load_map(write_map(tmp_path, pixels))
    msg = ru.occupancy_grid(grid, 12.5)
    assert (msg.info.width, msg.info.height) == (4, 3) and msg.info.resolution == pytest.approx(0.1)
    assert (msg.info.origin.position.x, msg.info.origin.position.y) == (-2.0, 3.0)
    assert msg.header.frame_id == "map" and msg.header.stamp.to_sec() == pytest.approx(12.5)
    # data is row-major from the origin (the image's bottom row first)
    assert msg.data[3] == -1 and msg.data[2 * 4 + 0] == 100 and msg.data.count(0) == 10
    negated = load_map(write_map(tmp_path, 255 - pixels, negate=1))
    assert ru.occupancy_grid(negated, 0.0).data == msg.data
    rotated = load_map(write_map(tmp_path, pixels, origin=[1.0, 1.0, math.pi / 2]))
    q = ru.occupancy_grid(rotated, 0.0).info.origin.orientation
    assert (q.z, q.w) == pytest.approx((math.sin(math.pi / 4), math.cos(math.pi / 4)))


def test_poses_and_quaternions_are_checked() -> None:
    pose = ru.pose_msg(Pose2D(1.0, 2.0, 0.5))
    assert ru.pose2d_of(pose, "p") == Pose2D(1.0, 2.0, pytest.approx(0.5))
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = "map"
    msg.pose.pose = pose
    assert ru.initialpose_to_pose2d(msg).x == 1.0
    unnormalised = Pose()
    unnormalised.orientation = Quaternion(0, 0, 2, 2)     # ints, not unit length: fine
    assert ru.pose2d_of(unnormalised, "p").yaw == pytest.approx(math.pi / 2)
    for q, text in [(Quaternion(0, 0, 0, 0), "zero length"), (Quaternion(math.nan, 0, 0, 1), "not finite"),
                    (Quaternion(1, 0, 0, 0), "rotation about z")]:
        bad = Pose()
        bad.orientation = q
        with pytest.raises(PoseRejected, match=text):
            ru.pose2d_of(bad, Topic.INITIALPOSE)
    msg.header.frame_id = "odom"
    with pytest.raises(PoseRejected, match="not the map frame"):
        ru.initialpose_to_pose2d(msg)
    msg.pose.pose.position.x = math.inf
    with pytest.raises(NavGoalRejected, match="not finite"):
        ru.goal_to_pose2d("map", msg.pose.pose)


def test_obstacles_round_trip_and_rejections_are_counted() -> None:
    for shape in (Circle(1.0, 2.0, 0.3), Rectangle(4.0, 5.0, 0.2, 3.0, 0.1)):
        msg = ru.obstacle_msg("o", shape)
        assert msg.action == Obstacle.ADD and msg.header.frame_id == "map"
        assert obstacle_shape(msg.shape, msg.x, msg.y, msg.yaw, msg.radius, msg.width, msg.height) == shape
    lines: list[str] = []
    log = ru.CountingLog(lines.append, first=2, every=5)
    for k in range(10):
        log.reject(Topic.CMD_VEL, f"bad {k}")
    assert log.counts == {Topic.CMD_VEL: 10} and len(lines) == 4 and lines[-1].startswith("rejected cmd_vel (#10)")
