"""The /sim node without a master (rospy faked by ``fake_ros``): its parameters, its topics, ROS messages in,
ROS messages out. Its main() on a real master: tests/sim/test_sim_system.py and the rostest
src/gidabot_sim/test/sim_navigation.test."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped, Quaternion, Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock

from gidabot_msgs.msg import Obstacle, StepDone
from gidabot_navigation.errors import ParamError
from gidabot_navigation.interface import Service, Topic
from gidabot_sim.errors import SimConfigError
from gidabot_sim.ros.convert import stamp
from gidabot_sim.world import world_node
from gidabot_sim.world.floor_sim import CMD_VEL, INITIALPOSE, OBSTACLE

FACULTY = str(Path(__file__).resolve().parents[4] / "maps" / "faculty")


@pytest.fixture
def ros(fake_ros):
    fake_ros.params.update({"~building": FACULTY, "~robot": "Kbot", "~speed": "max", "~seed": 3})
    return fake_ros


class Guard:
    def __init__(self, loops: int) -> None:
        self.loops, self.stopped = loops, False

    @property
    def requested(self) -> bool:
        self.loops -= 1
        return self.loops < 0

    def loop_stopped(self) -> None:
        self.stopped = True


def test_parameters_are_read_with_their_defaults_and_checked(ros) -> None:
    config = world_node.read_config()
    assert config.robots == ("Kbot",) and config.speed is None and config.seed == 3 and config.floor is None
    assert (config.step, config.dt, config.odom_rate, config.laser.beams, config.battery.per_km) == (0.1, 0.02, 10.0,
                                                                                                     360, 0.25)
    ros.params.update({"~robots": ["Kbot", "Tartalo"], "~initial_poses": [[20, 12, 0], "40 12 3.1"], "~floor": 1,
                       "~speed": 10, "~seed": -1})
    config = world_node.read_config()
    assert config.robots == ("Kbot", "Tartalo") and config.poses[1].x == 40.0 and config.speed == 10.0
    assert config.seed is None and config.floor == 1
    ros.params["~laser_beams"] = "many"
    with pytest.raises(ParamError, match="/test_node/laser_beams must be a finite number"):
        world_node.read_config()
    del ros.params["~laser_beams"]
    ros.params["~initial_poses"] = [[20, 12, 0]]
    with pytest.raises(SimConfigError, match="~initial_poses"):
        world_node.read_config()


def test_the_node_converts_what_it_receives_and_publishes_what_the_core_emits(ros) -> None:
    node = world_node.SimNode(world_node.read_config())
    assert set(ros.pubs) >= {Topic.ODOM, Topic.BASE_POSE_GROUND_TRUTH, Topic.BASE_SCAN, Topic.BATTERY, Topic.CLOCK,
                             Topic.TF, Topic.TF_STATIC, Topic.MAP, Topic.MAP_METADATA, Topic.SIM_OBSTACLES,
                             Topic.DIAGNOSTICS}
    assert Topic.ROBOTS_SEEN not in ros.pubs                     # one robot: nobody else to see
    assert ros.services[Service.STATIC_MAP](None).map.info.width > 0
    cmd = Twist()
    cmd.linear.x = 0.5
    cmd._connection_header = {"callerid": "/move_base"}
    ros.deliver(Topic.CMD_VEL, cmd)
    assert node.wake.is_set()
    node.sim.tick(node.sim.start_wall)           # the start: the scene and the first stop
    assert node.sim.world.robots[0].cmd.vx == 0.5
    assert ros.pubs[Topic.MAP].sent[0] is node.map_msg and ros.pubs[Topic.MAP_METADATA].sent
    assert [(t.header.frame_id, t.child_frame_id) for t in ros.pubs[Topic.TF_STATIC].sent[0].transforms] == [
        ("base_footprint", "base_link"), ("base_link", "base_laser_link")]
    odom = ros.pubs[Topic.ODOM].sent[-1]
    assert isinstance(odom, Odometry) and (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
    assert ros.pubs[Topic.CLOCK].sent == [Clock(clock=stamp(0.0))]
    assert ros.pubs[Topic.BASE_SCAN].sent[-1].header.frame_id == "base_laser_link"
    assert ros.pubs[Topic.BATTERY].sent[-1].location == "Kbot"
    for k in range(10):
        node.sim.tick(node.sim.start_wall + 0.01 * k)
    assert ros.pubs[Topic.ODOM].sent[-1].pose.pose.position.x > 0.0      # it drove (then braked: no more commands)


def test_bad_messages_are_counted_where_they_are_applied(ros) -> None:
    node = world_node.SimNode(world_node.read_config())
    node.sim.tick(node.sim.start_wall)
    cmd = Twist()
    cmd.angular.z = math.nan
    cmd._connection_header = {"callerid": "/teleop"}
    ros.deliver(Topic.CMD_VEL, cmd)
    pose = PoseWithCovarianceStamped()
    pose.header.frame_id = "odom"
    pose.pose.pose.orientation = Quaternion(0, 0, 0, 1)
    ros.deliver(Topic.INITIALPOSE, pose)
    ros.deliver(Topic.SIM_OBSTACLE, Obstacle(id="door", action=7))
    node.sim.tick(node.sim.start_wall)
    assert node.sim.rejected.counts == {CMD_VEL: 1, INITIALPOSE: 1, OBSTACLE: 1}


def test_obstacles_relocations_and_answers_arrive_in_the_core(ros) -> None:
    node = world_node.SimNode(world_node.read_config())
    node.sim.tick(node.sim.start_wall)
    msg = Obstacle(id="person", action=Obstacle.ADD, shape=Obstacle.CIRCLE, x=40.0, y=12.0, radius=0.25)
    msg.header.frame_id = "map"
    ros.deliver(Topic.SIM_OBSTACLE, msg)
    pose = PoseWithCovarianceStamped()
    pose.header.frame_id = "map"
    pose.pose.pose.position.x, pose.pose.pose.position.y = 20.0, 12.0
    pose.pose.pose.orientation = Quaternion(0, 0, 0, 1)
    ros.deliver(Topic.INITIALPOSE, pose)
    ros.deliver(Topic.SIM_STEP_DONE, StepDone(node="/amcl", session=5, idle=True, inputs=["/base_pose_ground_truth"]))
    node.sim.tick(node.sim.start_wall)
    [person] = ros.pubs[Topic.SIM_OBSTACLES].sent[-1].obstacles
    assert (person.id, person.radius) == ("person", 0.25)
    assert ros.pubs[Topic.BASE_POSE_GROUND_TRUTH].sent[-1].pose.pose.position.x == pytest.approx(20.0)
    assert "/amcl" in node.sim.lockstep.participants


def test_diagnostics_and_the_resume_time_go_out_every_period(ros) -> None:
    node = world_node.SimNode(world_node.read_config())
    node.sim.tick(node.sim.start_wall)
    node.sim.tick(node.sim.start_wall + 1.5)
    [diag] = ros.pubs[Topic.DIAGNOSTICS].sent
    assert diag.status[0].name == "sim: floor 1" and diag.status[0].level == 0
    assert ros.params["~resume_at"] > node.sim.world.time


def test_the_loop_ticks_until_a_signal_then_tells_the_guard_and_closes_the_core(ros, monkeypatch) -> None:
    node = world_node.SimNode(world_node.read_config())
    monkeypatch.setattr(world_node.rospy, "is_shutdown", lambda: False)
    guard = Guard(loops=5)
    node.run(guard)
    assert guard.stopped and node.sim.started and ros.pubs[Topic.CLOCK].sent
