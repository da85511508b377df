"""goal_manager + multirobot_navigation on ONE master (launch/guiding.launch), with a fake move_base.

Tartalo (floor 0) runs its guiding nodes next to tests/guiding/guiding_fake_nav.py (move_base action
server, amcl_pose, odom, battery); a probe plays the visitor (visitor/command), the other
robots (their goals, events and statuses on the shared topics) and records what guiding says.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from probe import Probe

from gidabot_navigation.building.model import load_building
from gidabot_navigation.interface import Node, Topic, global_name
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master, wait_until

pytestmark = pytest.mark.system

REPO = Path(__file__).resolve().parents[2]
FACULTY = REPO / "maps" / "faculty"
LAUNCH = REPO / "launch" / "guiding.launch"
FAKE_NAV = Path(__file__).resolve().parent / "guiding_fake_nav.py"
EVENT, GOAL, CANCEL, CMD = ("gidabot_msgs/NavEvent", "gidabot_msgs/Goal", "gidabot_msgs/Cancel",
                            "gidabot_msgs/VisitorCommand")
STATUS, PENDING = "gidabot_msgs/RobotStatus", "gidabot_msgs/PendingRequests"
(ACCEPTED, ON_THE_WAY, GOAL_REACHED, GO_TO_FLOOR, GOING_TO_MEETING, WAITING_VISITOR, UNREACHABLE, CANCELLED_HERE,
 CANCELLED_ELSEWHERE, TIMEOUT, REJECTED, ASSIGNED) = 0, 1, 2, 3, 4, 5, 6, 8, 9, 10, 12, 18
LEG_PROPOSED, LEG_COMMITTED = 1, 2
REQUEST, CONTINUE, CANCEL_CMD = 0, 1, 2
BLOCKED = "012"                   # the fake move_base cannot reach this room
CONTINUE_TIMEOUT = 2              # s: counted from the start robot's release of the visitor (only the second
                                  # goal of test_goal_floor_meets_the_visitor_and_times_out is released)
OFFLINE_AFTER = 60                # s (wall): one status of each other robot (Robot.statuses) keeps it online
                                  # through a whole test, however loaded the machine (liveness is not tested here)
GM, NAV = global_name(Node.GOAL_MANAGER), global_name(Node.MULTIROBOT_NAVIGATION)
# the guiding nodes that subscribe each topic the probe publishes on: a message is published once they are
# connected (the spoofed pending list, for one, is the navigation node's to reject)
LISTENERS = {Topic.VISITOR_COMMAND: (GM, NAV), Topic.STATUS: (GM, NAV), Topic.NAV_EVENTS: (GM, NAV),
             Topic.GOALS: (GM,), Topic.CANCELS: (GM, NAV), Topic.PENDING: (GM, NAV)}


class Robot:
    def __init__(self, procs: ProcessGroup, probe: Probe, env: dict[str, str]) -> None:
        self.procs, self.probe, self.env = procs, probe, env
        self.n = 0

    def pub(self, topic: str, type_: str, msg: dict) -> None:
        """Publish as the visitor or another robot would, once every guiding node listening to ``topic`` is
        connected."""
        self.probe.pub(topic, type_, msg, to=LISTENERS[topic])

    def command(self, command: int, **fields) -> None:
        self.n += 1
        msg = {"uid": f"Tartalo/test/cmd/{self.n}", "visitor_id": "test", "command": command, "language": "en",
               "tour_step": -1, **fields}
        self.pub(Topic.VISITOR_COMMAND, CMD, msg)

    def statuses(self) -> None:
        """The other robots are alive (their statuses, as the relays would deliver them)."""
        for name, floor in (("Kbot", 1.0), ("Galtxagorri", 2.0), ("MariSorgin", 3.0)):
            self.pub(Topic.STATUS, STATUS, {"robot": name, "floor": floor, "state": "idle"})

    def events(self, goal_uid: str | None = None, since: int = 0) -> list[dict]:
        return [m for m in self.probe.msgs(Topic.NAV_EVENTS, since)
                if goal_uid is None or m["goal_uid"] == goal_uid]

    def wait_phase(self, phase: int, goal_uid: str | None = None, since: int = 0, timeout: float = 30.0,
                   robot: str = "Tartalo") -> dict:
        return self.probe.wait(Topic.NAV_EVENTS, lambda m: m["phase"] == phase and m["robot"] == robot and
                               (goal_uid is None or m["goal_uid"] == goal_uid), timeout,
                               f"phase {phase} for {goal_uid}", since=since)

    def accept(self, goal_uid: str, robot: str, floor: float) -> None:
        """``robot`` (played by the probe) takes the goal leg Tartalo proposes to it (docs/guiding.md)."""
        self.n += 1
        goal = self.probe.wait(Topic.GOALS, lambda m: m["uid"] == goal_uid and m["goal_robot"] == robot
                               and m["goal_state"] == LEG_PROPOSED, 10, f"the goal leg proposed to {robot}")
        self.pub(Topic.NAV_EVENTS, EVENT, {"uid": f"{robot}/event/t.{self.n}", "robot": robot, "floor": floor,
                                           "goal_uid": goal_uid, "phase": ACCEPTED, "leg": "goal",
                                           "attempt": goal["attempt"], "tour_step": -1})

    def idle(self, timeout: float = 20.0) -> dict:
        return self.probe.wait(Topic.STATUS, lambda m: m["state"] == "idle" and m["pending"] == 0, timeout,
                               "Tartalo idle", since=max(0, len(self.probe.msgs(Topic.STATUS)) - 1))


@pytest.fixture(scope="module")
def robot(tmp_path_factory) -> Iterator[Robot]:
    tmp = tmp_path_factory.mktemp("guiding_nodes")
    building = load_building(FACULTY)
    blocked = building.location(BLOCKED).pose
    with ProcessGroup(tmp / "logs") as procs:
        ip = robot_address(0)
        uri = start_master(procs, "master", ip)
        env = ros_env(uri, ip, log_dir=tmp / "logs" / "ros")
        procs.start("fake_nav", [sys.executable, str(FAKE_NAV), "_start:=[30.0, 12.0, 0.0]", "_speed:=12.0",
                                 f"_abort_at:=[[{blocked.x}, {blocked.y}]]"], env)
        procs.start("guiding", ["roslaunch", "--skip-log-check", str(LAUNCH), f"building:={FACULTY}",
                                "robot:=Tartalo", f"continue_timeout:={CONTINUE_TIMEOUT}",
                                f"offline_after:={OFFLINE_AFTER}",
                                "output:=screen"], env)
        with Probe(env, tmp / "logs" / "probe.log") as probe:
            for topic, type_ in ((Topic.NAV_EVENTS, EVENT), (Topic.GOALS, GOAL),
                                 (Topic.CANCELS, CANCEL), (Topic.STATUS, STATUS),
                                 (Topic.PENDING, PENDING), (Topic.POSES, "gidabot_msgs/NavPose"),
                                 (Topic.DIAGNOSTICS, "diagnostic_msgs/DiagnosticArray")):
                probe.sub(topic, type_)
            r = Robot(procs, probe, env)
            # the nodes are up, localised and connected to move_base
            probe.wait(Topic.STATUS, lambda m: m["robot"] == "Tartalo" and m["state"] == "idle"
                       and abs(m["nav_pose"]["position"]["x"] - 30.0) < 0.01 and abs(m["battery"] - 0.8) < 1e-6,
                       60, "Tartalo's status")
            probe.wait(Topic.PENDING, lambda m: m["robot"] == "Tartalo", 30, "Tartalo's pending list")
            yield r


def test_same_floor_request_is_guided_to_the_goal(robot: Robot) -> None:
    n = len(robot.events())
    robot.command(REQUEST, goal_id="001", way="stairs")
    acc = robot.wait_phase(ACCEPTED, since=n)
    uid = acc["goal_uid"]
    goal = robot.probe.wait(Topic.GOALS, lambda m: m["uid"] == uid, 5, "the broadcast goal")
    assert (goal["origin_robot"], goal["initial_floor"], goal["goal_floor"], goal["goal_id"]) == \
        ("Tartalo", 0.0, 0.0, "001")
    assert goal["initial_pose"]["x"] == pytest.approx(30.0, abs=0.01)
    pend = robot.probe.wait(Topic.PENDING, lambda m: m["num"] == 1 and m["goals"][0]["uid"] == uid, 5)
    assert pend["eta"][0] > 0 and pend["wait_new"] == pend["eta"][0]
    robot.probe.wait(Topic.STATUS, lambda m: m["current_goal_uid"] == uid and m["state"] == "guiding", 10)
    robot.wait_phase(GOAL_REACHED, uid)
    # (ASSIGNED comes from the goal_manager, ON_THE_WAY from the navigation: either may arrive first)
    assert [e["phase"] for e in robot.events(uid) if e["phase"] != ASSIGNED] == [ACCEPTED, ON_THE_WAY, GOAL_REACHED]
    [assigned] = [e for e in robot.events(uid) if e["phase"] == ASSIGNED]
    assert (assigned["assignee"], assigned["leg"]) == ("Tartalo", "start")
    robot.idle()
    robot.probe.wait(Topic.POSES, lambda m: m["robot"] == "Tartalo" and m["floor"] == 0.0
                     and abs(m["nav_pose"]["position"]["x"] - 9.0) < 0.01, 5, "the pose at the goal")


def test_cross_floor_request_from_the_start_robot(robot: Robot) -> None:
    robot.statuses()
    n = len(robot.events())
    robot.command(REQUEST, goal_id="301", way="stairs")
    uid = robot.wait_phase(ACCEPTED, since=n)["goal_uid"]
    goal = robot.probe.wait(Topic.GOALS, lambda m: m["uid"] == uid, 5)
    assert goal["connector"] == "stairs_west" and goal["way"] == "stairs" and goal["goal_floor"] == 3.0
    robot.accept(uid, "MariSorgin", 3.0)
    robot.probe.wait(Topic.GOALS, lambda m: m["uid"] == uid and m["goal_state"] == LEG_COMMITTED, 10,
                     "the goal leg committed to MariSorgin")
    otw = robot.wait_phase(ON_THE_WAY, uid)
    assert otw["location_id"] == "stairs_west"
    ev = robot.wait_phase(GO_TO_FLOOR, uid)
    assert (ev["target_floor"], ev["way"], ev["connector"], ev["location_id"]) == (3.0, "stairs", "stairs_west", "301")
    assert ev["assignee"] == "MariSorgin"
    robot.idle()


def test_goal_floor_meets_the_visitor_and_times_out(robot: Robot) -> None:
    """Goals from MariSorgin (floor 3) to floor 0: Tartalo meets the visitor at the staircase."""
    robot.statuses()
    loc = load_building(FACULTY).location("005").pose

    def goal(uid: str) -> dict:
        return {"uid": uid, "origin_robot": "MariSorgin", "visitor_id": "v", "initial_floor": 3.0,
                "initial_pose": {"x": 30.0, "y": 12.0}, "goal_floor": 0.0,
                "goal_pose": {"position": {"x": loc.x, "y": loc.y}, "orientation": {"w": 1.0}}, "way": "stairs",
                "connector": "stairs_west", "start_id": "robot", "goal_id": "005", "language": "eu",
                "tour_file": "", "tour_step": -1, "start_robot": "MariSorgin", "start_state": LEG_COMMITTED,
                "goal_robot": "Tartalo", "goal_state": LEG_COMMITTED, "attempt": 2}

    n = len(robot.events())
    robot.pub(Topic.GOALS, GOAL, goal("MariSorgin/v/t.1"))
    robot.wait_phase(GOING_TO_MEETING, "MariSorgin/v/t.1", since=n)
    robot.wait_phase(WAITING_VISITOR, "MariSorgin/v/t.1", since=n)
    robot.command(CONTINUE, goal_uid="MariSorgin/v/t.1")
    robot.wait_phase(GOAL_REACHED, "MariSorgin/v/t.1", since=n)
    assert robot.events("MariSorgin/v/t.1")[0]["language"] == "eu"
    # a second visitor never shows up: CONTINUE_TIMEOUT s after MariSorgin released them, the trip is dropped
    robot.pub(Topic.GOALS, GOAL, goal("MariSorgin/v/t.2"))
    robot.wait_phase(WAITING_VISITOR, "MariSorgin/v/t.2", since=n)
    robot.pub(Topic.NAV_EVENTS, EVENT, {"uid": "MariSorgin/event/t.1", "robot": "MariSorgin", "floor": 3.0,
                                        "goal_uid": "MariSorgin/v/t.2", "phase": GO_TO_FLOOR, "target_floor": 0.0,
                                        "tour_step": -1})
    robot.wait_phase(TIMEOUT, "MariSorgin/v/t.2", since=n, timeout=15)
    robot.probe.wait(Topic.CANCELS, lambda m: m["goal_uid"] == "MariSorgin/v/t.2" and m["reason"] == "timeout",
                     5, "the timeout cancel")
    robot.idle()


def test_cancel_stops_the_robot(robot: Robot) -> None:
    n = len(robot.events())
    robot.command(REQUEST, goal_id="022", way="stairs")      # 40 m away: a few seconds of driving
    uid = robot.wait_phase(ON_THE_WAY, since=n)["goal_uid"]
    robot.command(CANCEL_CMD, goal_uid="")
    robot.wait_phase(CANCELLED_HERE, uid)
    cancel = robot.probe.wait(Topic.CANCELS, lambda m: m["goal_uid"] == uid, 5, "the broadcast cancel")
    assert (cancel["origin_robot"], cancel["reason"]) == ("Tartalo", "visitor")
    status = robot.idle(10)
    x = status["nav_pose"]["position"]["x"]
    assert x < 45.0, f"the robot went on to the goal (x = {x})"      # stopped on the way to x = 51 m
    assert GOAL_REACHED not in [e["phase"] for e in robot.events(uid)]


def test_aborted_navigation_is_unreachable_and_broadcast(robot: Robot) -> None:
    n = len(robot.events())
    robot.command(REQUEST, goal_id=BLOCKED, way="stairs")
    uid = robot.wait_phase(ACCEPTED, since=n)["goal_uid"]
    ev = robot.wait_phase(UNREACHABLE, uid)
    assert "Failed to find a valid plan" in ev["detail"] or "aborted" in ev["detail"]
    cancel = robot.probe.wait(Topic.CANCELS, lambda m: m["goal_uid"] == uid, 5, "the unreachable cancel")
    assert (cancel["origin_robot"], cancel["reason"]) == ("Tartalo", "unreachable")
    robot.idle()
    # a cancel from the goal floor of another trip tells this visitor
    robot.statuses()
    n = len(robot.events())
    robot.command(REQUEST, goal_id="223", way="lift")
    uid2 = robot.wait_phase(ACCEPTED, since=n)["goal_uid"]
    robot.accept(uid2, "Galtxagorri", 2.0)
    robot.pub(Topic.CANCELS, CANCEL, {"uid": "Galtxagorri/cancel/t.1", "goal_uid": uid2,
                                      "origin_robot": "Galtxagorri", "reason": "visitor"})
    robot.wait_phase(CANCELLED_ELSEWHERE, uid2)
    robot.idle()


def test_hostile_input_never_crashes_the_nodes(robot: Robot) -> None:
    p = robot.probe
    n = len(robot.events())
    for cmd in ({"command": 99}, {"command": REQUEST, "goal_id": "x" * 100000},
                {"command": REQUEST, "goal_id": "999"}, {"command": REQUEST, "goal_id": "001", "way": "rocket"},
                {"command": CONTINUE, "goal_uid": "../../etc"}, {"command": 3, "tour_file": "../../passwd.tour"},
                {"command": 4, "tour_file": "nope.tour", "tour_step": 2 ** 31 - 1},
                {"command": CANCEL_CMD, "goal_uid": "nobody/v/1"}, {"command": REQUEST, "language": "\u0000"}):
        robot.command(**cmd)
    base = {"uid": "Evil/1", "origin_robot": "Kbot", "visitor_id": "v", "initial_floor": 1.0,
            "initial_pose": {"x": 30.0, "y": 12.0}, "goal_floor": 0.0,
            "goal_pose": {"position": {"x": 9.0, "y": 11.4}, "orientation": {"w": 1.0}}, "way": "stairs",
            "connector": "stairs_west", "start_id": "robot", "goal_id": "001", "language": "en", "tour_step": -1}
    hostile = [{"goal_floor": "nan"}, {"initial_floor": "nan"}, {"goal_floor": 1e30}, {"origin_robot": "Evil"},
               {"goal_id": "999"}, {"uid": "u" * 200000}, {"goal_pose": {"position": {"x": "nan", "y": 1.0}}},
               {"connector": "chimney"}, {"tour_file": "../../x.tour", "tour_step": 0}, {"language": "x" * 5000}]
    for i, change in enumerate(hostile):
        msg = {**base, "uid": f"Evil/{i}", **change}
        robot.pub(Topic.GOALS, GOAL, msg)
    robot.pub(Topic.CANCELS, CANCEL, {"uid": "", "goal_uid": "x", "origin_robot": "Evil", "reason": "why"})
    robot.pub(Topic.NAV_EVENTS, EVENT, {"uid": "e/1", "robot": "Tartalo", "floor": "nan", "goal_uid": "",
                                        "phase": 250, "tour_step": -5})
    # the goal manager counted the rejections
    def rejected() -> int:
        for m in reversed(p.msgs(Topic.DIAGNOSTICS)):
            st = m["status"][0]
            if st["name"] == "guiding: goal_manager Tartalo":
                return int({kv["key"]: kv["value"] for kv in st["values"]}.get("rejected", 0))
        return 0
    wait_until(lambda: rejected() >= len(hostile) + 5, 30, "the rejections counted")
    rejected_events = [e for e in robot.events(since=n) if e["phase"] == REJECTED]
    assert len(rejected_events) >= 5 and all(len(e["detail"]) <= 400 for e in rejected_events)
    assert robot.procs.alive("guiding") and robot.procs.alive("fake_nav")
    # a valid request still works; an (empty) pending list of Tartalo published by another node
    # on the way is ignored (only the local goal_manager's counts)
    n = len(robot.events())
    robot.command(REQUEST, goal_id="014", way="stairs")
    uid = robot.wait_phase(ON_THE_WAY, since=n)["goal_uid"]
    robot.pub(Topic.PENDING, PENDING, {"robot": "Tartalo", "num": 0, "eta": []})
    robot.wait_phase(GOAL_REACHED, uid)

    def spoofed_pending() -> int:          # and counted as rejected by the navigation node (a chaos verdict)
        for m in reversed(p.msgs(Topic.DIAGNOSTICS)):
            st = m["status"][0]
            if st["name"] == "guiding: navigation Tartalo":
                return int({kv["key"]: kv["value"] for kv in st["values"]}.get("rejected_pending_sender", 0))
        return 0
    wait_until(lambda: spoofed_pending() >= 1, 30, "the spoofed pending list counted")
    log = (robot.procs.get("guiding").log_path or Path("/dev/null")).read_text(errors="replace")
    assert "Traceback" not in log
