"""System test of the simulated visitor's body on a floor (one master on loopback): the visitor node's directive
puts the body next to the robot, it follows the robot driving along the corridor, and the robot's people tracker
(node ``people`` on its own ``base_scan``) locks it as the visitor and keeps it SEEN behind the robot."""

from __future__ import annotations

import math
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from probe import Probe

from gidabot_navigation.building.model import load_building, relocate_building
from gidabot_navigation.interface import Sight, Topic
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master

pytestmark = pytest.mark.system
REPO = Path(__file__).resolve().parents[2]
FACULTY = REPO / "maps" / "faculty"
SIM_LAUNCH = REPO / "launch" / "sim_floor.launch"
PEOPLE = REPO / "src" / "gidabot_navigation" / "nodes" / "people"
ROBOT = "Kbot"
ROBOT_AT = (20.0, 12.0)                # facing +x, in the corridor of floor 1
GOAL = (32.0, 12.0)
FOV = 2 * math.pi                      # a laser that sees behind: the body walks right behind the robot


@pytest.fixture
def procs(tmp_path: Path) -> Iterator[ProcessGroup]:
    with ProcessGroup(tmp_path / "logs") as group:
        yield group


@pytest.mark.timeout(300)
def test_the_people_tracker_tracks_the_simulated_visitor_s_body_behind_the_guiding_robot(procs: ProcessGroup,
                                                                                        tmp_path: Path) -> None:
    ip = robot_address([r.name for r in load_building(FACULTY).robots].index(ROBOT))
    uri = start_master(procs, "master", ip)
    building = relocate_building(FACULTY, tmp_path / "building", {ROBOT: uri})
    doc = yaml.safe_load(building.read_text())
    kbot = next(r for r in doc["robots"] if r["name"] == ROBOT)
    kbot["sensors"] = {"laser": {"fov": FOV, "mount": [0.1, 0.0, 0.0]}}     # the simulator's laser, below
    building.write_text(yaml.safe_dump(doc, sort_keys=False))
    env = ros_env(uri, ip, log_dir=tmp_path / "ros")
    procs.start("floor", ["roslaunch", "--skip-log-check", str(SIM_LAUNCH), f"building:={building}",
                          f"robot:={ROBOT}", f"initial_pose:=[{ROBOT_AT[0]}, {ROBOT_AT[1]}, 0.0]", "seed:=5",
                          f"laser_fov:={FOV}", "speed:=2"], env)
    procs.start("people", [sys.executable, str(PEOPLE), f"_building:={building}", f"_robot:={ROBOT}"], env)
    with Probe(env, tmp_path / "probe.log", timeout=60) as probe:
        probe.sub(Topic.PEOPLE_VISITOR, "gidabot_msgs/VisitorTrack")
        probe.sub(Topic.BASE_POSE_GROUND_TRUTH, "nav_msgs/Odometry")
        probe.sub(Topic.DIAGNOSTICS, "diagnostic_msgs/DiagnosticArray")
        probe.wait(Topic.BASE_POSE_GROUND_TRUTH, lambda m: True, 90, "the simulated floor")
        probe.pub(Topic.SIM_VISITOR_BODY, "gidabot_msgs/VisitorBody",
                  {"header": {"frame_id": "map"}, "visitor_id": "v1", "mode": 0, "robot": ROBOT, "x": math.nan,
                   "y": math.nan, "started": 0.0, "speed": 1.1, "gap": 1.0, "group": 1, "pause_starts": [],
                   "pause_durations": [], "wander_at": -1.0}, to=["/sim"], latch=True)
        probe.pub(Topic.PEOPLE_VISITOR_LOCK, "std_msgs/Bool", {"data": True}, to=["/people"], latch=True)
        seen = probe.wait(Topic.PEOPLE_VISITOR, lambda m: m["sight"] == Sight.SEEN, 60, "the visitor locked")
        probe.pub(Topic.MOVE_BASE_SIMPLE_GOAL, "geometry_msgs/PoseStamped",
                  {"header": {"frame_id": "map"}, "pose": {"position": {"x": GOAL[0], "y": GOAL[1]},
                                                            "orientation": {"w": 1.0}}}, to=["/move_base"], latch=True)
        probe.wait(Topic.BASE_POSE_GROUND_TRUTH, lambda m: m["pose"]["pose"]["position"]["x"] > GOAL[0] - 1.0, 120,
                   "the robot at its goal")
        since = len(probe.msgs(Topic.PEOPLE_VISITOR))
        late = probe.wait(Topic.PEOPLE_VISITOR, lambda m: m["sight"] == Sight.SEEN and m["behind"] > 0.5, 30,
                          "the visitor seen behind the robot at the goal")
        assert late["id"] == seen["id"]                     # the same track all the way
        assert late["position"]["x"] > ROBOT_AT[0] + 5.0    # it followed
        sights = [m["sight"] for m in probe.msgs(Topic.PEOPLE_VISITOR)]
        assert sights.count(Sight.SEEN) >= 0.9 * len(sights[sights.index(Sight.SEEN):]), sights[-50:]
        assert since > 0
        diag = probe.wait(Topic.DIAGNOSTICS, lambda m: any(s["name"].startswith("sim: floor") for s in m["status"]),
                          30, "the floor's diagnostics")
        values = {kv["key"]: kv["value"] for s in diag["status"] if s["name"].startswith("sim: floor")
                  for kv in s["values"]}
        assert values["people_collisions"] == "0" and values["people"] == "1"
