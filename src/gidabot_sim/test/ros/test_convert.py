"""Message conversions of gidabot_sim's adapters (no master): map as map_server publishes it from a
map_server map file (origin, thresholds, negate, row flip), poses and quaternions, obstacles, the simulator's
outputs, lockstep answers, plans, estimates, the visitor's messages."""

from __future__ import annotations

import math
from pathlib import Path as FilePath

import numpy as np
import pytest
import yaml
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Pose, PoseWithCovarianceStamped, Quaternion
from PIL import Image
from sensor_msgs.msg import BatteryState

from gidabot_msgs.msg import Goal, NavEvent, Obstacle, ObstacleArray, PendingRequests, RobotStatus, VisitorCommand
from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.occupancy import load_map
from gidabot_navigation.building.planning import Circle, Path, Rectangle
from gidabot_navigation.guiding.messages import CommandData
from gidabot_navigation.interface import Cmd, Phase, Topic
from gidabot_sim.errors import NavGoalRejected, ObstacleRejected, PoseRejected
from gidabot_sim.navstack.amcl import Estimate
from gidabot_sim.navstack.move_base import SensedRobot
from gidabot_sim.ros import convert
from gidabot_sim.world import floor_sim as fs
from gidabot_sim.world.kinematics import Twist2D
from gidabot_sim.world.lockstep import Answer
from gidabot_sim.world.rejections import CountingLog
from gidabot_sim.world.world import BatteryModel, LaserSpec


def write_map(tmp_path: FilePath, pixels: np.ndarray, **doc) -> FilePath:
    Image.fromarray(pixels.astype(np.uint8)).save(tmp_path / "m.pgm")
    data = {"image": "m.pgm", "resolution": 0.1, "origin": [-2.0, 3.0, 0.0], "negate": 0,
            "occupied_thresh": 0.65, "free_thresh": 0.196, **doc}
    (tmp_path / "m.yaml").write_text(yaml.safe_dump(data))
    return tmp_path / "m.yaml"


def test_the_map_topic_follows_map_server(tmp_path: FilePath) -> None:
    # image row 0 is the top: a black pixel top-left, grey (unknown) bottom-right
    pixels = np.full((3, 4), 254)
    pixels[0, 0] = 0
    pixels[2, 3] = 205
    grid = load_map(write_map(tmp_path, pixels))
    msg = convert.occupancy_grid(grid, 12.5)
    assert (msg.info.width, msg.info.height) == (4, 3) and msg.info.resolution == pytest.approx(0.1)
    assert (msg.info.origin.position.x, msg.info.origin.position.y) == (-2.0, 3.0)
    assert msg.header.frame_id == "map" and msg.header.stamp.to_sec() == pytest.approx(12.5)
    # data is row-major from the origin (the image's bottom row first)
    assert msg.data[3] == -1 and msg.data[2 * 4 + 0] == 100 and msg.data.count(0) == 10
    negated = load_map(write_map(tmp_path, 255 - pixels, negate=1))
    assert convert.occupancy_grid(negated, 0.0).data == msg.data
    rotated = load_map(write_map(tmp_path, pixels, origin=[1.0, 1.0, math.pi / 2]))
    q = convert.occupancy_grid(rotated, 0.0).info.origin.orientation
    assert (q.z, q.w) == pytest.approx((math.sin(math.pi / 4), math.cos(math.pi / 4)))


def test_poses_and_quaternions_are_checked() -> None:
    pose = convert.pose_msg(Pose2D(1.0, 2.0, 0.5))
    assert convert.pose2d_of(pose, "p") == Pose2D(1.0, 2.0, pytest.approx(0.5))
    msg = PoseWithCovarianceStamped()
    msg.header.frame_id = "map"
    msg.pose.pose = pose
    assert convert.initialpose_to_pose2d(msg).x == 1.0
    unnormalised = Pose()
    unnormalised.orientation = Quaternion(0, 0, 2, 2)     # ints, not unit length: fine
    assert convert.pose2d_of(unnormalised, "p").yaw == pytest.approx(math.pi / 2)
    for q, text in [(Quaternion(0, 0, 0, 0), "zero length"), (Quaternion(math.nan, 0, 0, 1), "not finite"),
                    (Quaternion(1, 0, 0, 0), "rotation about z")]:
        bad = Pose()
        bad.orientation = q
        with pytest.raises(PoseRejected, match=text):
            convert.pose2d_of(bad, Topic.INITIALPOSE)
    msg.header.frame_id = "odom"
    with pytest.raises(PoseRejected, match="not the map frame"):
        convert.initialpose_to_pose2d(msg)
    msg.pose.pose.position.x = math.inf
    with pytest.raises(NavGoalRejected, match="not finite"):
        convert.goal_to_pose2d("map", msg.pose.pose)


def test_obstacles_round_trip_and_rejections_are_counted() -> None:
    for shape in (Circle(1.0, 2.0, 0.3), Rectangle(4.0, 5.0, 0.2, 3.0, 0.1)):
        msg = convert.obstacle_msg("o", shape)
        assert msg.action == Obstacle.ADD and msg.header.frame_id == "map"
        assert convert.shape_of(msg) == shape
    lines: list[str] = []
    log = CountingLog(lines.append, first=2, every=5)
    for k in range(10):
        log.reject(Topic.CMD_VEL, f"bad {k}")
    assert log.counts == {Topic.CMD_VEL: 10} and len(lines) == 4 and lines[-1].startswith("rejected cmd_vel (#10)")


def test_obstacle_commands_are_checked_field_by_field() -> None:
    circle = Obstacle(id="p", action=Obstacle.ADD, shape=Obstacle.CIRCLE, x=1.0, y=2.0, radius=0.3)
    assert convert.obstacle_change_of(circle) == fs.ObstacleChange(fs.ADD, "p", Circle(1.0, 2.0, 0.3))
    for bad, match in ((Obstacle(id="p", shape=Obstacle.CIRCLE, radius=-1.0), "radius"),
                       (Obstacle(id="p", shape=7, radius=1.0), "shape 7"),
                       (Obstacle(id="p", shape=Obstacle.RECTANGLE, x=math.nan, width=1.0, height=1.0), "finite"),
                       (Obstacle(id="p", action=9), "action 9")):
        with pytest.raises(ObstacleRejected, match=match):
            convert.obstacle_change_of(bad)
    remove = Obstacle(id="p", action=Obstacle.REMOVE, shape=7)          # the shape of a removal is not looked at
    assert convert.obstacle_change_of(remove) == fs.ObstacleChange(fs.REMOVE, "p", None)
    assert convert.obstacle_change_of(Obstacle(action=Obstacle.CLEAR)).action == fs.CLEAR
    circle.header.frame_id = "odom"
    with pytest.raises(ObstacleRejected, match="not the map frame"):
        convert.obstacle_change_of(circle)
    array = ObstacleArray(obstacles=[Obstacle(id="a", shape=Obstacle.CIRCLE, x=1.0, y=1.0, radius=0.2),
                                     Obstacle(id="b", shape=Obstacle.CIRCLE, radius=0.0),
                                     Obstacle(id="c", shape=Obstacle.RECTANGLE, width=1.0, height=2.0)])
    shapes, problems = convert.obstacle_shapes_of(array)
    assert list(shapes) == ["a", "c"] and len(problems) == 1 and problems[0].startswith("obstacle 'b': ")
    assert convert.sensed_robots_of(array) == [SensedRobot("a", 1.0, 1.0, 0.2), SensedRobot("b", 0.0, 0.0, 0.0)]


def test_the_simulator_s_outputs_as_messages() -> None:
    odom = convert.fill_odometry(convert.odometry_msg("odom", "base_footprint"), Pose2D(1.0, 2.0, 0.5),
                                 Twist2D(0.3, 0.0, 0.1), 4.5)
    assert convert.odometry_of(odom, "odom") == (4.5, Pose2D(1.0, 2.0, pytest.approx(0.5)), Twist2D(0.3, 0.0, 0.1))
    assert odom.pose.covariance[0] == 1e-4 and odom.child_frame_id == "base_footprint"
    odom.twist.twist.angular.z = math.nan
    with pytest.raises(PoseRejected, match="odom: non-finite values"):
        convert.odometry_of(odom, "odom")
    battery = convert.battery_msg(fs.Battery(0, "Kbot", BatteryModel(), 0.0, -0.8, 3.0))
    assert battery.power_supply_health == BatteryState.POWER_SUPPLY_HEALTH_DEAD and battery.location == "Kbot"
    assert (battery.design_capacity, battery.voltage, battery.header.stamp.to_sec()) == (20.0, 11.0, 3.0)
    half = convert.battery_msg(fs.Battery(0, "Kbot", BatteryModel(), 0.5, -2.0, 3.0))
    assert (half.charge, half.voltage, half.current) == pytest.approx((10.0, 11.85, -2.0))
    scan = convert.scan_msg(fs.Scan(0, LaserSpec(beams=4), np.array([1.0, np.inf, 2.0, 3.0]), 2.0, 0.1), "laser")
    assert scan.ranges[1] == math.inf and scan.header.frame_id == "laser" and scan.scan_time == pytest.approx(0.1)
    diag = convert.diagnostics_msg(fs.Diagnostics(fs.ERROR, "sim: floor 1", "deadlock", "A,B", (("k", "v"),), 7.0))
    assert diag.status[0].level == DiagnosticStatus.ERROR and diag.status[0].values[0].key == "k"
    seen = convert.seen_msg(fs.Seen(0, (("Tartalo", Circle(3.0, 4.0, 0.33)),), 1.0))
    assert (seen.obstacles[0].id, seen.obstacles[0].radius, seen.header.frame_id) == ("Tartalo", 0.33, "map")
    tf = convert.transforms_msg(fs.Transforms((fs.Frame("a", "b", Pose2D(1.0, 0.0, 0.0), 1.0, 0.3),)))
    assert tf.transforms[0].transform.translation.z == 0.3
    assert convert.clock_msg(-1.0).clock.to_sec() == 0.0


def test_answers_plans_estimates_and_the_visitor_s_messages() -> None:
    answer = Answer("/move_base", 9, 1.5, False, ("/odom",), 4)
    assert convert.answer_of(convert.step_done_msg(answer)) == answer
    path = Path([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], 2.0)
    msg = convert.path_msg(path, 3.0, 0.5, 2.0)
    yaws = [convert.pose2d_of(p.pose, "plan").yaw for p in msg.poses]
    assert yaws[0] == pytest.approx(0.0) and yaws[-2] == pytest.approx(math.pi / 2) and yaws[-1] == pytest.approx(3.0)
    empty = convert.plan_msg(None, 0.5, 2.0)
    assert empty.poses == [] and empty.header.frame_id == "map"
    assert len(convert.plan_msg((path, 0.0), 0.5, 2.0).poses) > 3
    est = convert.estimate_msg(Estimate(2.0, Pose2D(1.0, 2.0, 0.0), tuple(range(36))), "map")
    assert list(est.pose.covariance) == list(range(36)) and est.header.stamp.to_sec() == 2.0
    cmd = convert.command_msg(CommandData(command=Cmd.CONTINUE, uid="T/v/cmd/1", visitor_id="v", goal_uid="g",
                                          tour_step=2, stamp=5.0))
    assert isinstance(cmd, VisitorCommand) and (cmd.uid, cmd.goal_uid, cmd.tour_step) == ("T/v/cmd/1", "g", 2)
    status = RobotStatus(robot="Kbot")
    status.nav_pose.position.x = 3.0
    assert convert.status_of(status) == ("Kbot", (3.0, 0.0))
    pending = PendingRequests(robot="Kbot", goals=[Goal(uid="K/v/1", goal_floor=1.0)], wait_new=12.0)
    robot, trips, wait = convert.pending_of(pending)
    assert (robot, trips[0].uid, wait) == ("Kbot", "K/v/1", 12.0)
    event = NavEvent(uid="K/e/1", robot="Kbot", phase=Phase.WAITING_VISITOR, detail="waiting", eta=3.0)
    assert (convert.nav_event_of(event).detail, convert.nav_event_of(event).eta) == ("waiting", 3.0)
