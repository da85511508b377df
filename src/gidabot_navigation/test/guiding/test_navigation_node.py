"""The multirobot_navigation node's ROS adapter without a master: the pending list of its goal manager (a fake
publisher's message fed to its callback) becomes a move_base goal on a fake action client, move_base's result
a GOAL_REACHED event; status and pose come out as RobotStatus and NavPose."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import actionlib
import pytest
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseWithCovarianceStamped
from guiding_support import ListLog, shared_planner
from node_support import FakeRos, fake_ros, phases, spin

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.guiding import navigation_node
from gidabot_navigation.guiding.goal_manager import GoalManagerConfig, GoalManagerCore
from gidabot_navigation.guiding.messages import CancelData, CommandData, PendingData, SendGoal
from gidabot_navigation.guiding.navigation import NavigationConfig
from gidabot_navigation.guiding.navigation_node import NavigationNode, Params
from gidabot_navigation.interface import REASON_VISITOR, Cmd, Node, Phase, RobotState, Sight, Topic, global_name
from gidabot_navigation.perception.people import LastSeen, VisitorReport, VisitorTrackData
from gidabot_navigation.ros import convert
from gidabot_navigation.senders import make_uid

REPO = Path(__file__).resolve().parents[4]
FACULTY = REPO / "maps" / "faculty"
GOAL_MANAGER = global_name(Node.GOAL_MANAGER)


class FakeHandle:
    def __init__(self) -> None:
        self.state = actionlib.CommState.WAITING_FOR_GOAL_ACK
        self.terminal = GoalStatus.PENDING
        self.cancelled = False
        self.comm_state_machine = SimpleNamespace(latest_result=None)

    def get_comm_state(self) -> int:
        return self.state

    def get_terminal_state(self) -> int:
        return self.terminal

    def get_goal_status_text(self) -> str:
        return ""

    def cancel(self) -> None:
        self.cancelled = True


class FakeActionClient:
    """move_base, connected: every goal sent is kept with its handle and transition callback."""

    def __init__(self, *_args: object) -> None:
        self.goals: list[tuple[object, FakeHandle, object]] = []
        self.last_status_msg = SimpleNamespace(_connection_header={"callerid": "/move_base"})
        connected = SimpleNamespace(impl=SimpleNamespace(connections=[SimpleNamespace(endpoint_id="/move_base")]))
        self.pub_goal = self.pub_cancel = connected

    def send_goal(self, goal: object, transition_cb: object) -> FakeHandle:
        handle = FakeHandle()
        self.goals.append((goal, handle, transition_cb))
        return handle

    def finish(self, status: int = GoalStatus.SUCCEEDED) -> None:
        _goal, handle, done = self.goals[-1]
        handle.state, handle.terminal = actionlib.CommState.DONE, status
        done(handle)


@pytest.fixture
def ros(monkeypatch: pytest.MonkeyPatch) -> FakeRos:
    bus = fake_ros(monkeypatch, navigation_node)
    monkeypatch.setattr(navigation_node.actionlib, "ActionClient", FakeActionClient)
    return bus


@pytest.fixture
def node(ros: FakeRos, tmp_path: Path) -> NavigationNode:
    return NavigationNode(Params(str(FACULTY), NavigationConfig(robot="Kbot"), status_rate=2.0, pose_rate=5.0,
                                 move_base=Topic.MOVE_BASE, frame_id="map", state_dir=str(tmp_path)))


@pytest.fixture(scope="module")
def pending() -> PendingData:
    """Kbot's goal manager with one trip on floor 1, committed to Kbot."""
    building = load_building(FACULTY)
    gm = GoalManagerCore(building, GoalManagerConfig(robot="Kbot"), ListLog(), 0.0,
                         planner=shared_planner(building))
    home = building.robot("Kbot").home
    gm.on_pose(home.x, home.y, home.yaw)
    acts = gm.on_command(CommandData(command=Cmd.REQUEST, uid="Kbot/v/cmd/1", goal_id="104", visitor_id="v",
                                     stamp=90.0), 90.0, 0.0, sender="/gui")
    for trip in [a.trip for a in acts if isinstance(a, SendGoal)]:
        gm.on_goal(trip, 90.0, 0.0, sender=GOAL_MANAGER)
    snap = gm.pending(95.0)
    assert len(snap.goals) == 1 and snap.goals[0].committed("start") == "Kbot"
    return snap



def test_a_trip_of_its_queue_is_driven_to_its_goal(ros: FakeRos, node: NavigationNode, pending: PendingData,
                                                    tmp_path: Path) -> None:
    client = node.client
    ros.feed(Topic.PENDING, convert.pending_to_msg(pending), GOAL_MANAGER)
    spin(node)
    [(goal, _handle, _cb)] = client.goals
    target = goal.target_pose
    place = load_building(FACULTY).location("104").pose
    assert target.header.frame_id == "map"
    assert (target.pose.position.x, target.pose.position.y) == pytest.approx((place.x, place.y))
    assert convert.yaw_of(target.pose.orientation) == pytest.approx(place.yaw)
    assert phases(ros) == [Phase.ON_THE_WAY]
    assert pending.goals[0].uid in (tmp_path / f"{Node.MULTIROBOT_NAVIGATION}.json").read_text()
    ros.now = 130.0
    client.finish(GoalStatus.SUCCEEDED)
    spin(node)
    assert phases(ros) == [Phase.ON_THE_WAY, Phase.GOAL_REACHED]
    reached = convert.event_from_msg(ros.sent(Topic.NAV_EVENTS)[-1])
    assert (reached.robot, reached.goal_uid, reached.stamp) == ("Kbot", pending.goals[0].uid, 130.0)


def test_a_pending_list_not_from_its_goal_manager_is_ignored(ros: FakeRos, node: NavigationNode,
                                                             pending: PendingData) -> None:
    ros.feed(Topic.PENDING, convert.pending_to_msg(pending), "/mallory")
    spin(node)
    assert node.client.goals == [] and node.core.refusals()["impostor"] == 1
    node.publish_diagnostics()
    [status] = ros.sent(Topic.DIAGNOSTICS)[-1].status
    values = {kv.key: kv.value for kv in status.values}
    assert (values["refused_impostor"], values["refused"]) == ("1", "1")


def test_a_cancel_stops_move_base(ros: FakeRos, node: NavigationNode, pending: PendingData) -> None:
    ros.feed(Topic.PENDING, convert.pending_to_msg(pending), GOAL_MANAGER)
    spin(node)
    [(_goal, handle, _cb)] = node.client.goals
    handle.state = actionlib.CommState.ACTIVE
    cancel = CancelData(uid=make_uid("Kbot", "cancel", "gm"), goal_uid=pending.goals[0].uid, origin_robot="Kbot",
                        reason=REASON_VISITOR)
    ros.feed(Topic.CANCELS, convert.cancel_to_msg(cancel), GOAL_MANAGER)
    spin(node)
    assert handle.cancelled and node.core.leg is None


def test_only_a_continue_reaches_the_core(ros: FakeRos, node: NavigationNode) -> None:
    for n, cmd in enumerate((Cmd.REQUEST, Cmd.CONTINUE, Cmd.CANCEL)):
        press = CommandData(command=cmd, uid=f"Kbot/v/cmd/{n}", stamp=1.0)
        ros.feed(Topic.VISITOR_COMMAND, convert.command_to_msg(press), "/gui")
    spin(node)
    assert json.dumps(node.core.state()).count("Kbot/v/cmd/") == 1      # the Continue's key only


def test_status_and_pose(ros: FakeRos, node: NavigationNode) -> None:
    amcl = PoseWithCovarianceStamped()
    amcl.pose.pose.position.x, amcl.pose.pose.position.y = 20.5, 12.0
    amcl.pose.pose.orientation.z, amcl.pose.pose.orientation.w = math.sin(0.25), math.cos(0.25)
    ros.feed(Topic.AMCL_POSE, amcl, "/amcl")
    spin(node)
    node.publish_status()
    node.publish_pose()
    status = convert.status_from_msg(ros.sent(Topic.STATUS)[-1])
    assert (status.robot, status.floor, status.state, status.frame_id, status.stamp) == (
        "Kbot", 1.0, RobotState.IDLE, "map", 100.0)
    assert (status.x, status.y, status.yaw) == pytest.approx((20.5, 12.0, 0.5))
    pose = convert.pose_from_msg(ros.sent(Topic.POSES)[-1])
    assert (pose.robot, pose.floor, pose.frame_id) == ("Kbot", 1.0, "map")
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((20.5, 12.0, 0.5))
    ros.feed(Topic.STATUS, ros.sent(Topic.STATUS)[-1], "/multirobot_navigation")     # its own: heard
    spin(node)
    assert node.core.liveness.last_heard("Kbot") is not None


def test_move_base_gone_is_the_error_state(ros: FakeRos, node: NavigationNode) -> None:
    node.client.last_status_msg = None
    node._next_diag = 0.0                 # diagnostics due
    spin(node)
    node.publish_status()
    assert convert.status_from_msg(ros.sent(Topic.STATUS)[-1]).state == RobotState.ERROR
    [diag] = ros.sent(Topic.DIAGNOSTICS)
    [status] = diag.status
    assert (status.name, status.level, status.message) == ("guiding: navigation Kbot", DiagnosticStatus.WARN,
                                                          RobotState.ERROR)


def test_the_visitor_s_pace_in_and_out(ros: FakeRos, node: NavigationNode, pending: PendingData) -> None:
    """Guiding locks the visitor's track; a visitor falling behind caps the speed, one far behind stops the robot
    (a goal on the spot facing them, WAITING_FOR_YOU); the end of the leg unlocks and says how it went."""
    assert [m.data for m in ros.sent(Topic.PEOPLE_VISITOR_LOCK)] == [False]
    assert [m.data for m in ros.sent(Topic.PEOPLE_WATCH)] == [False]
    assert [m.data for m in ros.sent(Topic.MOVE_BASE_SPEED_LIMIT)] == [0.0]
    ros.feed(Topic.PENDING, convert.pending_to_msg(pending), GOAL_MANAGER)
    spin(node)
    assert [m.data for m in ros.sent(Topic.PEOPLE_VISITOR_LOCK)] == [False, True]
    assert [m.data for m in ros.sent(Topic.PEOPLE_WATCH)] == [False, True]
    home = load_building(FACULTY).robot("Kbot").home

    def visitor(dist: float, t: float) -> None:
        x, y = home.x - dist * math.cos(home.yaw), home.y - dist * math.sin(home.yaw)
        report = VisitorReport(Sight.SEEN, track_id=3, x=x, y=y, vx=0.5, vy=0.0, distance=dist, behind=dist,
                               bearing=math.pi, unseen=0.0, last_seen=LastSeen(Pose2D(x, y, 0.0), t), confidence=0.9)
        ros.feed(Topic.PEOPLE_VISITOR, convert.visitor_track_to_msg(VisitorTrackData(report, t)), "/people")
        spin(node)

    node.core.on_pose(home.x, home.y, home.yaw)
    visitor(1.2, 100.0)
    visitor(3.0, 101.0)
    assert ros.sent(Topic.MOVE_BASE_SPEED_LIMIT)[-1].data == pytest.approx(0.3)
    visitor(5.0, 102.0)
    assert phases(ros)[-1] == Phase.WAITING_FOR_YOU and ros.sent(Topic.MOVE_BASE_SPEED_LIMIT)[-1].data == 0.0
    assert node.client.goals[0][1].cancelled and len(node.client.goals) == 2      # stopped; turned on the spot
    visitor(1.0, 110.0)
    assert phases(ros)[-1] == Phase.FOLLOW_ME and len(node.client.goals) == 3
    node.client.finish(GoalStatus.SUCCEEDED)
    spin(node)
    assert phases(ros)[-1] == Phase.GOAL_REACHED
    assert ros.sent(Topic.PEOPLE_VISITOR_LOCK)[-1].data is False
    assert ros.sent(Topic.PEOPLE_WATCH)[-1].data is False            # the trip is over: the laser may rest
    pace = [s for m in ros.sent(Topic.DIAGNOSTICS) for s in m.status if s.name == "guiding: pace Kbot"]
    values = {kv.key: kv.value for kv in pace[-1].values}
    assert (values["goal_uid"], values["waits"], values["slowdowns"]) == (pending.goals[0].uid, "1", "1")
