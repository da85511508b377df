"""System tests of the simulated floor (masters on loopback): launch file, the floors' clocks on one timeline
(ceiling, drift bound), lockstep with a frozen move_base, run-time obstacles seen by the laser, hostile input,
the laser only when subscribed, several robots (their own topics, seeing each other, a collision counted once,
two robots driven by their move_base crossing each other in a corridor)."""

from __future__ import annotations

import json
import math
import os
import signal
import time
import xmlrpc.client
from collections.abc import Iterator
from pathlib import Path

import pytest
from probe import Probe

from gidabot_navigation.building.model import load_building, relocate_building
from gidabot_navigation.interface import Node, Topic, global_name
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master, wait_until
from gidabot_sim.world.timeline import Timeline

pytestmark = pytest.mark.system
REPO = Path(__file__).resolve().parents[2]
FACULTY = REPO / "maps" / "faculty"
SIM_LAUNCH = REPO / "launch" / "sim_floor.launch"
SIM_NODE = REPO / "src" / "gidabot_sim" / "nodes" / "world"
TWO_ROBOTS_LAUNCH = Path(__file__).resolve().parent / "two_robots.launch"
DIAG = "diagnostic_msgs/DiagnosticArray"
SIM, MOVE_BASE = [global_name(Node.SIM)], [global_name(Node.MOVE_BASE)]


@pytest.fixture
def procs(tmp_path: Path) -> Iterator[ProcessGroup]:
    with ProcessGroup(tmp_path / "logs") as group:
        yield group


def floor_master(procs: ProcessGroup, tmp_path: Path, robot: str) -> tuple[Path, dict[str, str]]:
    """A master on the robot's test address and the building relocated to it."""
    index = [r.name for r in load_building(FACULTY).robots].index(robot)
    ip = robot_address(index)
    uri = start_master(procs, f"master_{robot}", ip)
    building = relocate_building(FACULTY, tmp_path / f"building_{robot}", {robot: uri})
    return building, ros_env(uri, ip, log_dir=tmp_path / "ros" / robot)


def launch_floor(procs: ProcessGroup, env: dict[str, str], building: Path, robot: str, **args: str) -> None:
    """sim_floor.launch with exactly the arguments robot.launch passes (plus extras)."""
    argv = ["roslaunch", "--skip-log-check", str(SIM_LAUNCH), f"building:={building}", f"robot:={robot}"]
    argv += [f"{k}:={v}" for k, v in args.items()]
    procs.start(f"floor_{robot}", argv, env)


def sim_diag(probe: Probe) -> dict[str, str]:
    for msg in reversed(probe.msgs(Topic.DIAGNOSTICS)):
        for status in msg["status"]:
            if status["name"].startswith("sim: "):
                return {kv["key"]: kv["value"] for kv in status["values"]}
    return {}


def test_floors_on_one_timeline_keep_under_the_ceiling_and_within_the_drift_bound(procs: ProcessGroup,
                                                                                  tmp_path: Path) -> None:
    speed, start_wall = 10.0, time.time() + 4.0
    robots = ("Kbot", "Galtxagorri")
    timeline = Timeline.create(tmp_path / "timeline", 2, ceiling=speed, max_drift=1.0, peer_timeout=5.0,
                               start_wall=start_wall)
    probes = []
    try:
        for slot, robot in enumerate(robots):
            building, env = floor_master(procs, tmp_path, robot)
            launch_floor(procs, env, building, robot, speed=f"{speed:g}", start_wall=f"{start_wall:.3f}",
                         timeline=str(timeline.path), timeline_slot=str(slot))
            probe = Probe(env, tmp_path / f"probe_{robot}.log")
            probe.sub(Topic.CLOCK, "rosgraph_msgs/Clock")
            probes.append(probe)
        assert all(not p.msgs(Topic.CLOCK) for p in probes) or time.time() >= start_wall   # nothing before the start
        for p in probes:
            p.wait(Topic.CLOCK, lambda m: m["clock"] > 5.0, 30, "sim time past 5 s")
        before = min(c.sim for c in timeline.clocks())
        for _ in range(20):
            wall = time.time()
            clocks = [c.sim for c in timeline.clocks()]
            for clock in clocks:                   # a ceiling: never ahead of it (the pacer's slack: 50 ms)
                assert clock <= (wall - start_wall + 0.05) * speed + 0.1, (clocks, wall - start_wall)
            assert abs(clocks[0] - clocks[1]) <= 1.0 + 1e-6
            time.sleep(0.1)
        # both floors go on (how close to the ceiling depends on the machine's load: bench sim measures that);
        # a frozen floor holds the other within the bound
        assert min(c.sim for c in timeline.clocks()) > before
        pid = int(timeline.read(0).pid)
        os.kill(pid, signal.SIGSTOP)               # Kbot's simulator
        try:
            time.sleep(2.0)
            frozen, other = (c.sim for c in timeline.clocks())
            assert 0.0 < other - frozen <= 1.0 + 1e-6
        finally:
            os.kill(pid, signal.SIGCONT)
        wait_until(lambda: timeline.clocks()[0].sim > frozen + 5.0, 10, "the floor to go on")
        assert timeline.clocks()[0].behind >= 1.9                  # it has been behind its ceiling that long
    finally:
        for p in probes:
            p.close()
        timeline.close()


def test_lockstep_waits_for_move_base_and_goes_on_without_it_when_it_is_frozen(procs: ProcessGroup,
                                                                              tmp_path: Path) -> None:
    # a 5x ceiling: the 40 m goal takes about 60 s of sim time, 12 s of wall time, so the 1 Hz diagnostics show
    # move_base driving well before it gets there (at no ceiling the goal could end before the first of them)
    building, env = floor_master(procs, tmp_path, "Kbot")
    launch_floor(procs, env, building, "Kbot", speed="5", initial_pose="[20.0, 12.0, 0.0]", seed="3")
    with Probe(env, tmp_path / "probe.log") as probe:
        probe.sub(Topic.DIAGNOSTICS, DIAG)
        probe.sub(Topic.MOVE_BASE_RESULT, "move_base_msgs/MoveBaseActionResult")
        probe.sub(Topic.AMCL_POSE, "geometry_msgs/PoseWithCovarianceStamped")
        probe.wait(Topic.AMCL_POSE, lambda m: True, 60, Topic.AMCL_POSE)
        goal = {"header": {"frame_id": "map"}, "pose": {"position": {"x": 60.0, "y": 12.0}, "orientation": {"w": 1}}}
        probe.pub(Topic.MOVE_BASE_SIMPLE_GOAL, "geometry_msgs/PoseStamped", goal, to=MOVE_BASE)

        def move_base() -> dict[str, int]:
            return json.loads(sim_diag(probe).get("participant /move_base", "{}"))

        wait_until(lambda: move_base().get("idle") == 0 and move_base().get("answered", 0) > 20, 30,
                   "move_base driving in step")
        before = sim_diag(probe)
        assert not probe.msgs(Topic.MOVE_BASE_RESULT), "the goal ended before move_base could be frozen"
        pid = node_pid(env, global_name(Node.MOVE_BASE))
        os.kill(pid, signal.SIGSTOP)               # move_base, while it drives
        try:
            # the world waits 2 s (the participant timeout) for it, then goes on without it
            wait_until(lambda: move_base().get("timeouts") == 1, 20, "the world to stop waiting for move_base")
            stopped = sim_diag(probe)
            wait_until(lambda: float(sim_diag(probe)["sim_time"]) > float(stopped["sim_time"]) + 5.0, 20,
                       "the world to go on without move_base")
            going = sim_diag(probe)
        finally:
            os.kill(pid, signal.SIGCONT)
        mb = json.loads(going["participant /move_base"])
        assert mb["timeouts"] == 1 and mb["absent"] == 1 and mb["missed"] > 0 and mb["idle"] == 0, mb
        assert float(stopped["wait_controllers_s"]) - float(before["wait_controllers_s"]) >= 1.9
        assert not probe.msgs(Topic.MOVE_BASE_RESULT)                # frozen, it could not have got there
        result = probe.wait(Topic.MOVE_BASE_RESULT, lambda m: True, 60, "the goal's end")
        assert result["status"]["status"] == 3, result        # back in step, it got there
        wait_until(lambda: move_base().get("absent") == 0, 10, "move_base back in step")
        assert move_base()["sessions"] == 1
        assert json.loads(sim_diag(probe)["participant /amcl"])["timeouts"] == 0


def node_pid(env: dict[str, str], node: str) -> int:
    master = xmlrpc.client.ServerProxy(env["ROS_MASTER_URI"])
    _code, _msg, uri = master.lookupNode("/test", node)
    _code, _msg, pid = xmlrpc.client.ServerProxy(uri).getPid("/test")
    return int(pid)


def test_obstacles_laser_battery_and_hostile_input(procs: ProcessGroup, tmp_path: Path) -> None:
    building, env = floor_master(procs, tmp_path, "Kbot")
    launch_floor(procs, env, building, "Kbot", speed="5", initial_pose="[20.0, 12.0, 0.0]", seed="2")
    with Probe(env, tmp_path / "probe.log") as probe:
        probe.sub(Topic.DIAGNOSTICS, DIAG)
        probe.sub(Topic.AMCL_POSE, "geometry_msgs/PoseWithCovarianceStamped")
        probe.sub(Topic.SIM_OBSTACLES, "gidabot_msgs/ObstacleArray")
        probe.sub(Topic.MAP_METADATA, "nav_msgs/MapMetaData")
        amcl = probe.wait(Topic.AMCL_POSE, lambda m: True, 60, Topic.AMCL_POSE)["pose"]["pose"]["position"]
        assert math.hypot(amcl["x"] - 20.0, amcl["y"] - 12.0) < 0.2          # the launch's initial pose
        meta = probe.wait(Topic.MAP_METADATA, lambda m: True, 10)
        assert (meta["width"], meta["height"], meta["origin"]["position"]["x"]) == (1480, 520, -1.0)
        # nobody listens to base_scan: no scan is made
        wait_until(lambda: float(sim_diag(probe).get("sim_time", 0)) > 5.0, 30, "sim time")
        assert sim_diag(probe)["laser_scans"] == "0"
        probe.sub(Topic.BASE_SCAN, "sensor_msgs/LaserScan")
        scan = probe.wait(Topic.BASE_SCAN, lambda m: True, 10, "a scan")
        ahead = len(scan["ranges"]) // 2
        angle = scan["angle_min"] + ahead * scan["angle_increment"]
        free_ahead = scan["ranges"][ahead]
        assert free_ahead > 10.0                                              # down the corridor
        # a person 2 m ahead: the laser sees it, the latched obstacle list has it
        probe.pub(Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle",
                  {"id": "person", "action": 0, "shape": 0, "x": 22.0, "y": 12.0, "radius": 0.25}, to=SIM)
        probe.wait(Topic.SIM_OBSTACLES, lambda m: [o["id"] for o in m["obstacles"]] == ["person"], 10)
        n = len(probe.msgs(Topic.BASE_SCAN))
        seen = probe.wait(Topic.BASE_SCAN, lambda m: m["ranges"][ahead] < 2.0, 10, "the person", since=n)
        expected = (2.0 - 0.25 - 0.1) / math.cos(angle)                       # laser 0.1 m ahead of the centre
        assert seen["ranges"][ahead] == pytest.approx(expected, abs=0.08)
        # hostile and malformed input: counted, logged, ignored; the node keeps running
        bad_obstacles = [
            {"id": "x" * 500, "action": 0, "shape": 0, "x": 25.0, "y": 12.0, "radius": 0.2},
            {"id": "not-a-number", "action": 0, "shape": 0, "x": "nan", "y": 12.0, "radius": 0.2},
            {"id": "huge", "action": 0, "shape": 1, "x": 25.0, "y": 12.0, "width": 1e9, "height": 1.0},
            {"id": "onto", "action": 0, "shape": 0, "x": 20.2, "y": 12.0, "radius": 0.3},   # on the robot
            {"id": "what", "action": 9, "shape": 0, "x": 25.0, "y": 12.0, "radius": 0.2},
            {"id": "ghost", "action": 1},                                                # nothing to remove
            {"id": "tri", "action": 0, "shape": 5, "x": 25.0, "y": 12.0, "radius": 0.2},
        ]
        for msg in bad_obstacles:
            probe.pub(Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle", msg, to=SIM)
        for twist in ({"linear": {"x": "nan"}}, {"angular": {"z": "nan"}}):
            probe.pub(Topic.CMD_VEL, "geometry_msgs/Twist", twist, to=SIM)
        wait_until(lambda: sim_diag(probe).get("rejected_obstacle") == str(len(bad_obstacles))
                   and sim_diag(probe).get("rejected_cmd_vel") == "2", 20, "the rejections counted")
        assert [o["id"] for o in probe.msgs(Topic.SIM_OBSTACLES)[-1]["obstacles"]] == ["person"]
        probe.pub(Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle", {"action": 2}, to=SIM)   # CLEAR
        probe.wait(Topic.SIM_OBSTACLES, lambda m: m["obstacles"] == [], 10, "cleared")
        n = len(probe.msgs(Topic.BASE_SCAN))
        probe.wait(Topic.BASE_SCAN, lambda m: m["ranges"][ahead] > 10.0, 10, "the corridor free again", since=n)
        assert procs.alive("floor_Kbot")
        assert int(sim_diag(probe)["laser_scans"]) > 0


def test_several_robots_on_one_floor_get_their_own_topics(procs: ProcessGroup, tmp_path: Path) -> None:
    building, env = floor_master(procs, tmp_path, "Kbot")
    procs.start("sim", ["python3", str(SIM_NODE), f"__name:={Node.SIM}", f"_building:={building}",
                        "_robots:=[Kbot, Tartalo]", "_floor:=1.0", "_speed:=2",
                        "_initial_poses:=[[20.0, 12.0, 0.0], [21.5, 12.0, 3.14159]]"],
                ros_env(env["ROS_MASTER_URI"], env["ROS_IP"], log_dir=tmp_path / "ros" / "multi"))
    with Probe(env, tmp_path / "probe.log") as probe:
        probe.sub(Topic.DIAGNOSTICS, DIAG)
        for i in (0, 1):
            probe.sub(f"robot_{i}/{Topic.BASE_POSE_GROUND_TRUTH}", "nav_msgs/Odometry")
            probe.sub(f"robot_{i}/{Topic.BATTERY}", "sensor_msgs/BatteryState")
            probe.sub(f"robot_{i}/{Topic.ROBOTS_SEEN}", "gidabot_msgs/ObstacleArray")
        # each laser sees the other (they face each other): its obstacle layer's input
        seen = probe.wait(f"robot_0/{Topic.ROBOTS_SEEN}", lambda m: m["obstacles"], 60, "Kbot sees Tartalo")
        assert [(o["id"], o["x"], o["radius"]) for o in seen["obstacles"]] == [
            ("Tartalo", pytest.approx(21.5), pytest.approx(0.33))]
        seen = probe.wait(f"robot_1/{Topic.ROBOTS_SEEN}", lambda m: m["obstacles"], 20, "Tartalo sees Kbot")
        assert [o["id"] for o in seen["obstacles"]] == ["Kbot"]
        for i, x in ((0, 20.0), (1, 21.5)):
            truth = probe.wait(f"robot_{i}/{Topic.BASE_POSE_GROUND_TRUTH}", lambda m: True, 60, f"robot_{i}")
            assert truth["pose"]["pose"]["position"]["x"] == pytest.approx(x)
            assert truth["child_frame_id"] == f"robot_{i}/base_footprint"
            assert probe.wait(f"robot_{i}/{Topic.BATTERY}", lambda m: True, 20)["location"] == ("Kbot", "Tartalo")[i]
        # robot_0 drives into robot_1 (commands every ~0.1 s sim, within the 0.2 s timeout): it stops touching it
        deadline = time.monotonic() + 20.0
        while int(sim_diag(probe).get("stalls", 0)) < 1:
            assert time.monotonic() < deadline, "no collision between the robots"
            probe.pub("robot_0/" + Topic.CMD_VEL, "geometry_msgs/Twist", {"linear": {"x": 0.5}}, to=SIM)
            time.sleep(0.04)
        truth = "robot_0/" + Topic.BASE_POSE_GROUND_TRUTH
        n = len(probe.msgs(truth))
        x0 = probe.wait(truth, lambda m: True, 10, since=n)["pose"]["pose"]["position"]["x"]
        assert 21.5 - 0.3 - 0.33 - 0.01 <= x0 <= 21.5 - 0.3 - 0.33 + 0.06    # Kbot 0.3 m, Tartalo 0.33 m
        # pushing on is the same contact: counted once, in the diagnostics
        for _ in range(10):
            probe.pub("robot_0/" + Topic.CMD_VEL, "geometry_msgs/Twist", {"linear": {"x": 0.5}}, to=SIM)
            time.sleep(0.04)
        wait_until(lambda: sim_diag(probe).get("robot_collisions") == "1", 10, "the collision counted")
        assert sim_diag(probe)["robot_deadlocks"] == "0"


def test_two_robots_driven_by_their_move_base_cross_each_other_without_a_collision(procs: ProcessGroup,
                                                                                   tmp_path: Path) -> None:
    building, env = floor_master(procs, tmp_path, "Kbot")
    # head-on along the 3 m corridor of floor 1: Kbot (robot_0) east, Tartalo (robot_1) west
    procs.start("floor", ["roslaunch", "--skip-log-check", str(TWO_ROBOTS_LAUNCH), f"building:={building}"], env)
    goals = {0: (40.0, 12.0, 0.0, 1.0), 1: (20.0, 12.0, 1.0, 0.0)}       # x, y (m), quaternion z, w: east, west
    with Probe(env, tmp_path / "probe.log") as probe:
        probe.sub(Topic.DIAGNOSTICS, DIAG)
        for i in goals:
            probe.sub(f"robot_{i}/{Topic.MOVE_BASE_RESULT}", "move_base_msgs/MoveBaseActionResult")
            probe.sub(f"robot_{i}/{Topic.AMCL_POSE}", "geometry_msgs/PoseWithCovarianceStamped")
        for i in goals:
            probe.wait(f"robot_{i}/{Topic.AMCL_POSE}", lambda m: True, 60, f"robot_{i}'s amcl_pose")
        for i, (x, y, z, w) in goals.items():
            pose = {"position": {"x": x, "y": y}, "orientation": {"z": z, "w": w}}
            goal = {"header": {"frame_id": "map"}, "pose": pose}
            probe.pub(f"robot_{i}/{Topic.MOVE_BASE_SIMPLE_GOAL}", "geometry_msgs/PoseStamped", goal,
                      to=[f"/robot_{i}/{Node.MOVE_BASE}"])
        for i in goals:
            result = probe.wait(f"robot_{i}/{Topic.MOVE_BASE_RESULT}", lambda m: True, 120, f"robot_{i}'s goal")
            assert result["status"]["status"] == 3, result                 # SUCCEEDED
        diag = sim_diag(probe)
        assert diag["robot_collisions"] == "0" and diag["robot_deadlocks"] == "0", diag
        assert diag["deadlocked"] == ""
