"""The goal_manager node's ROS adapter without a master: ROS messages fed to its callbacks come out, through
the core, as the messages it publishes (fake publishers); its state file is written before it publishes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseWithCovarianceStamped
from node_support import FakeRos, fake_ros, phases, spin

from gidabot_navigation.guiding import goal_manager_node
from gidabot_navigation.guiding.goal_manager import GoalManagerConfig
from gidabot_navigation.guiding.goal_manager_node import GoalManagerNode, Params
from gidabot_navigation.guiding.messages import CancelData, CommandData, PendingData, RobotStatusData
from gidabot_navigation.interface import (
    LEG_COMMITTED,
    REASON_VISITOR,
    Cmd,
    Node,
    Phase,
    RobotState,
    Topic,
    relay_end_name,
)
from gidabot_navigation.ros import convert
from gidabot_navigation.tours.tour_store import CatalogData, TourMessage

REPO = Path(__file__).resolve().parents[4]
FACULTY = REPO / "maps" / "faculty"
RELAY = relay_end_name("Tartalo", "Kbot")


@pytest.fixture
def ros(monkeypatch: pytest.MonkeyPatch) -> FakeRos:
    return fake_ros(monkeypatch, goal_manager_node)


@pytest.fixture
def node(ros: FakeRos, tmp_path: Path) -> GoalManagerNode:
    return GoalManagerNode(Params(str(FACULTY), GoalManagerConfig(robot="Kbot"), pending_period=1.0,
                                  state_dir=str(tmp_path)))



def request(ros: FakeRos, goal_id: str, uid: str = "Kbot/v/cmd/1", stamp: float = 99.0) -> None:
    ros.feed(Topic.VISITOR_COMMAND, convert.command_to_msg(CommandData(command=Cmd.REQUEST, uid=uid, visitor_id="v",
                                                               goal_id=goal_id, way="stairs", language="eu",
                                                               stamp=stamp)), "/gui")


def test_a_request_becomes_a_goal_the_pending_list_and_a_saved_state(ros: FakeRos, node: GoalManagerNode,
                                                                      tmp_path: Path) -> None:
    request(ros, "104")
    spin(node)
    [goal] = [convert.trip_from_msg(m) for m in ros.sent(Topic.GOALS)]
    assert (goal.origin_robot, goal.goal_id, goal.language, goal.start_robot, goal.start_state) == (
        "Kbot", "104", "eu", "Kbot", LEG_COMMITTED)
    assert goal.stamp == 100.0                       # the ROS time it was made
    assert Phase.ASSIGNED in phases(ros)
    pending = convert.pending_from_msg(ros.sent(Topic.PENDING)[-1])
    assert (pending.robot, pending.num, [t.uid for t in pending.goals]) == ("Kbot", 1, [goal.uid])
    assert pending.eta[0] > 0 and pending.stamp == 100.0
    saved = json.loads((tmp_path / f"{Node.GOAL_MANAGER}.json").read_text())
    assert goal.uid in json.dumps(saved)
    # the same command replayed (same uid and stamp) makes nothing new
    request(ros, "104")
    spin(node)
    assert len(ros.sent(Topic.GOALS)) == 1


def test_a_bad_request_is_rejected_and_not_kept(ros: FakeRos, node: GoalManagerNode, tmp_path: Path) -> None:
    request(ros, "nowhere")
    spin(node)
    assert phases(ros) == [Phase.REJECTED] and ros.sent(Topic.GOALS) == []
    state = tmp_path / f"{Node.GOAL_MANAGER}.json"
    assert not state.exists() or "nowhere" not in state.read_text()     # a REJECTED answer is not in the outbox


def test_a_cancel_from_another_robot_drops_the_goal(ros: FakeRos, node: GoalManagerNode) -> None:
    request(ros, "104")
    spin(node)
    [goal] = ros.sent(Topic.GOALS)
    ros.feed(Topic.GOALS, goal, "/goal_manager")            # its own goal, back on the topic
    cancel = CancelData(uid="Tartalo/cancel/x.1", goal_uid=goal.uid, origin_robot="Tartalo", reason=REASON_VISITOR,
                        stamp=101.0)
    ros.feed(Topic.CANCELS, convert.cancel_to_msg(cancel), RELAY)
    spin(node)
    assert phases(ros)[-1] == Phase.CANCELLED_ELSEWHERE
    assert convert.pending_from_msg(ros.sent(Topic.PENDING)[-1]).goals == ()


def test_statuses_pending_lists_poses_and_the_catalog_reach_the_core(ros: FakeRos, node: GoalManagerNode) -> None:
    tartalo = RobotStatusData("Tartalo", 0.0, 12.5, 11.0, 0.0, 0.0, 0.0, 0.9, RobotState.IDLE, 0)
    ros.feed(Topic.STATUS, convert.status_to_msg(tartalo), RELAY)
    ros.feed(Topic.PENDING, convert.pending_to_msg(PendingData("Tartalo", 0.0, 0, 42.5, stamp=100.0)), RELAY)
    own = PendingData("Kbot", 1.0, 0, 999.0)
    ros.feed(Topic.PENDING, convert.pending_to_msg(own), "/goal_manager")     # its own list: the core's already
    pose = PoseWithCovarianceStamped()
    pose.pose.pose.position.x, pose.pose.pose.position.y, pose.pose.pose.orientation.w = 20.5, 12.0, 1.0
    ros.feed(Topic.AMCL_POSE, pose, "/amcl")
    tour = TourMessage(file_name="paper_example.tour", tour_name="Tour",
                       tour_goals_info=("0, 014, Computer Technicians 1", "1, 101, Secretary's Office"))
    ros.feed(Topic.TOUR_CATALOG, convert.catalog_to_msg(CatalogData("Kbot", (tour,))), "/tour_store")
    spin(node)
    view = node.core.fleet["Tartalo"]
    assert view.pose == (12.5, 11.0) and view.wait_new == 42.5
    assert "Kbot" not in node.core.fleet
    assert node.core.pose == (20.5, 12.0, 0.0)
    assert len(node.core.tours) == 1


def test_diagnostics_say_what_the_node_counted(ros: FakeRos, node: GoalManagerNode) -> None:
    request(ros, "nowhere")
    spin(node)
    [diag] = ros.sent(Topic.DIAGNOSTICS)
    [status] = diag.status
    values = {kv.key: kv.value for kv in status.values}
    assert (status.name, status.hardware_id) == ("guiding: goal_manager Kbot", "Kbot")
    assert status.level == DiagnosticStatus.OK
    assert values["queue_dropped"] == "0" and "rejected" in status.message


def test_what_was_not_published_before_a_restart_is_published_by_the_next_node(ros: FakeRos, node: GoalManagerNode,
                                                                              tmp_path: Path) -> None:
    def killed(_actions: object) -> None:
        raise RuntimeError("killed")           # the node dies after saving its state, before publishing

    node.execute = killed
    request(ros, "104")
    with pytest.raises(RuntimeError, match="killed"):
        spin(node)
    assert ros.sent(Topic.GOALS) == []
    again = GoalManagerNode(node.params)
    [goal] = [convert.trip_from_msg(m) for m in ros.sent(Topic.GOALS)]
    assert goal.goal_id == "104" and [t.uid for t in again.core.queue] == [goal.uid]
