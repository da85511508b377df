"""System test of the people node on a simulated floor (one master on loopback): it reads no laser until this
robot's guiding core (a probe named as it) wants people watched, and refuses that wish from anyone else; a
person standing behind the robot (a run-time disc obstacle of the simulator) is tracked and locked as the
visitor, lost once it is gone; with no wish left it lets the laser go; the node stops on SIGINT; the simulated
visitor's body (put on the floor as the visitor node does, ``/sim/visitor_body``) follows the robot driving along
the corridor and stays locked and SEEN behind it."""

from __future__ import annotations

import math
import signal
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml
from probe import Probe

from gidabot_navigation.building.model import load_building, relocate_building
from gidabot_navigation.interface import Node, Sight, Topic
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master, wait_until

pytestmark = pytest.mark.system
REPO = Path(__file__).resolve().parents[2]
FACULTY = REPO / "maps" / "faculty"
SIM_LAUNCH = REPO / "launch" / "sim_floor.launch"
PEOPLE = REPO / "src" / "gidabot_navigation" / "nodes" / "people"
ROBOT = "Kbot"
ROBOT_AT = (20.0, 12.0)                # facing +x, in the corridor of floor 1
# behind and to the left, inside the view of the simulated laser (270 degrees: it does not see straight behind)
PERSON_AT = (19.65, 12.95)
EXIT_BOUND = 10.0                      # s: it stops on SIGINT (here with the simulator running on a loaded machine)
NAVIGATION = Node.MULTIROBOT_NAVIGATION    # the one node whose wishes the people node hears


@pytest.fixture
def procs(tmp_path: Path) -> Iterator[ProcessGroup]:
    with ProcessGroup(tmp_path / "logs") as group:
        yield group


def _floor(procs: ProcessGroup, tmp_path: Path, fov: float = 1.5 * math.pi, *args: str) -> tuple[Path, dict[str, str]]:
    """Kbot's master, its building (with the simulator's laser of ``fov`` declared), the simulated floor (``args``:
    more launch arguments)."""
    ip = robot_address([r.name for r in load_building(FACULTY).robots].index(ROBOT))
    uri = start_master(procs, "master", ip)
    building = relocate_building(FACULTY, tmp_path / "building", {ROBOT: uri})
    doc = yaml.safe_load(building.read_text())
    kbot = next(r for r in doc["robots"] if r["name"] == ROBOT)
    kbot["sensors"] = {"laser": {"fov": fov, "mount": [0.1, 0.0, 0.0]}}     # the simulator's laser
    building.write_text(yaml.safe_dump(doc, sort_keys=False))
    env = ros_env(uri, ip, log_dir=tmp_path / "ros")
    procs.start("floor", ["roslaunch", "--skip-log-check", str(SIM_LAUNCH), f"building:={building}",
                          f"robot:={ROBOT}", f"initial_pose:=[{ROBOT_AT[0]}, {ROBOT_AT[1]}, 0.0]", "seed:=5",
                          f"laser_fov:={fov}", *args], env)
    return building, env


def _people_status(m: dict) -> dict[str, str] | None:
    """The people node's diagnostics values in a /diagnostics message, None if not its."""
    return next(({kv["key"]: kv["value"] for kv in s["values"]} for s in m["status"]
                 if s["name"] == f"people: {ROBOT}"), None)


def _obstacle(action: int, x: float = 0.0, y: float = 0.0) -> dict:
    return {"header": {"frame_id": "map"}, "id": "visitor", "action": action, "shape": 0, "x": x, "y": y,
            "radius": 0.22}


@pytest.mark.timeout(300)
def test_a_person_behind_the_robot_is_locked_as_the_visitor_and_lost_when_gone(procs: ProcessGroup,
                                                                               tmp_path: Path) -> None:
    building, env = _floor(procs, tmp_path)
    procs.start("people", [sys.executable, str(PEOPLE), f"_building:={building}", f"_robot:={ROBOT}",
                           "_visitor_lost_after:=1.0", "_lock_half_angle:=1.4"], env)
    with Probe(env, tmp_path / "probe.log", timeout=60, name=NAVIGATION) as probe:
        probe.sub(Topic.PEOPLE_TRACKS, "gidabot_msgs/PersonArray")
        probe.sub(Topic.PEOPLE_VISITOR, "gidabot_msgs/VisitorTrack")
        probe.sub(Topic.DIAGNOSTICS, "diagnostic_msgs/DiagnosticArray")
        probe.pub(Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle", _obstacle(0, *PERSON_AT), to=["/sim"])
        with Probe(env, tmp_path / "forger.log", timeout=60) as forger:       # anyone else's wishes are refused
            forger.pub(Topic.PEOPLE_WATCH, "std_msgs/Bool", {"data": True}, to=["/people"], latch=True)
            refused = probe.wait(Topic.DIAGNOSTICS, lambda m: (_people_status(m) or {}).get("refused_impostor", "0")
                                 != "0", 30, "the forged wish refused")
        assert _people_status(refused)["laser"] == "False"
        assert not probe.msgs(Topic.PEOPLE_TRACKS), "tracks while nobody wanted people watched"
        probe.pub(Topic.PEOPLE_WATCH, "std_msgs/Bool", {"data": True}, to=["/people"], latch=True)
        probe.wait(Topic.PEOPLE_TRACKS, lambda m: any(math.dist((p["position"]["x"], p["position"]["y"]), PERSON_AT)
                                                      < 0.15 for p in m["people"]), 90, "the person tracked")
        assert all(not any(math.dist((p["position"]["x"], p["position"]["y"]), PERSON_AT) > 0.5 for p in m["people"])
                   for m in probe.msgs(Topic.PEOPLE_TRACKS)), "a track where nobody is (walls, door frames)"
        probe.pub(Topic.PEOPLE_VISITOR_LOCK, "std_msgs/Bool", {"data": True}, to=["/people"], latch=True)
        seen = probe.wait(Topic.PEOPLE_VISITOR, lambda m: m["sight"] == Sight.SEEN, 30, "the visitor seen")
        assert seen["id"] > 0 and seen["behind"] == pytest.approx(ROBOT_AT[0] - PERSON_AT[0], abs=0.1)
        assert seen["distance"] == pytest.approx(math.dist(ROBOT_AT, PERSON_AT), abs=0.1)
        diag = probe.wait(Topic.DIAGNOSTICS, lambda m: any(s["name"] == f"people: {ROBOT}" and
                                                           int(dict((kv["key"], kv["value"]) for kv in s["values"])
                                                               ["scans"]) > 0 for s in m["status"]), 30, "diagnostics")
        status = next(s for s in diag["status"] if s["name"] == f"people: {ROBOT}")
        assert status["level"] == 0, status                                 # the declared laser is the scans'
        since = len(probe.msgs(Topic.PEOPLE_VISITOR))
        probe.pub(Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle", _obstacle(1), to=["/sim"])
        lost = probe.wait(Topic.PEOPLE_VISITOR, lambda m: m["sight"] == Sight.LOST, 30, "the visitor lost", since)
        assert lost["id"] == seen["id"] and lost["last_seen"]["position"]["x"] == pytest.approx(PERSON_AT[0], abs=0.1)
        sights = [m["sight"] for m in probe.msgs(Topic.PEOPLE_VISITOR, since)]
        assert Sight.HIDDEN in sights[:sights.index(Sight.LOST)]
        probe.pub(Topic.PEOPLE_VISITOR_LOCK, "std_msgs/Bool", {"data": False}, to=["/people"], latch=True)
        since = len(probe.msgs(Topic.DIAGNOSTICS))
        probe.pub(Topic.PEOPLE_WATCH, "std_msgs/Bool", {"data": False}, to=["/people"], latch=True)
        probe.wait(Topic.DIAGNOSTICS, lambda m: (_people_status(m) or {}).get("laser") == "False", 30,
                   "the laser let go", since)
    procs.signal("people", signal.SIGINT)      # its 2 s bound with a frozen master: tests/foundation/test_node_exit.py
    wait_until(lambda: not procs.alive("people"), EXIT_BOUND, "the people node's exit", interval=0.05)


GOAL = (32.0, 12.0)                     # along the corridor: the visitor's body follows the robot there


@pytest.mark.timeout(300)
def test_the_people_tracker_tracks_the_simulated_visitor_s_body_behind_the_guiding_robot(procs: ProcessGroup,
                                                                                        tmp_path: Path) -> None:
    building, env = _floor(procs, tmp_path, 2 * math.pi, "speed:=2")    # a laser that sees right behind
    procs.start("people", [sys.executable, str(PEOPLE), f"_building:={building}", f"_robot:={ROBOT}"], env)
    with Probe(env, tmp_path / "probe.log", timeout=60, name=NAVIGATION) as probe:
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
                          "the visitor seen behind the robot at the goal", since)
        assert late["id"] == seen["id"]                     # the same track all the way
        assert late["position"]["x"] > ROBOT_AT[0] + 5.0    # it followed
        sights = [m["sight"] for m in probe.msgs(Topic.PEOPLE_VISITOR)]
        assert sights.count(Sight.SEEN) >= 0.9 * len(sights[sights.index(Sight.SEEN):]), sights[-50:]
        since = len(probe.msgs(Topic.DIAGNOSTICS))
        diag = probe.wait(Topic.DIAGNOSTICS, lambda m: any(s["name"].startswith("sim: floor") for s in m["status"]),
                          30, "the floor's diagnostics with the body", since)
        values = {kv["key"]: kv["value"] for s in diag["status"] if s["name"].startswith("sim: floor")
                  for kv in s["values"]}
        assert values["people_collisions"] == "0" and values["people"] == "1"
