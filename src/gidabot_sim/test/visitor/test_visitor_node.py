"""The visitor node without a master (rospy faked): parameters, statuses and events in, the visitor's commands
out, subscriptions dropped once not needed. On real masters: tests/guiding/test_tour_mode_system.py and the demo."""

from __future__ import annotations

from pathlib import Path

import pytest

from gidabot_msgs.msg import Goal, NavEvent, RobotStatus, Tour, TourCatalog, VisitorCommand
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import ParamError
from gidabot_navigation.interface import Cmd, Phase, Topic
from gidabot_sim.errors import SimConfigError
from gidabot_sim.ros.convert import stamp
from gidabot_sim.visitor import visitor_node

ROOT = Path(__file__).resolve().parents[4]
FACULTY6 = ROOT / "maps" / "faculty6"


@pytest.fixture
def ros(fake_ros):
    fake_ros.params.update({"~building": str(FACULTY6), "~robot": "Tartalo", "~goal_id": "223", "~start_delay": 1.0})
    return fake_ros


def statuses(ros) -> None:
    for robot in load_building(FACULTY6).robots:
        ros.deliver(Topic.STATUS, RobotStatus(robot=robot.name))


def test_the_visitor_asks_once_every_robot_is_up_and_the_statuses_are_dropped(ros) -> None:
    node = visitor_node.VisitorNode()
    assert not ros.subscribed(Topic.GOALS) and not ros.subscribed(Topic.PENDING)
    assert not ros.subscribed(Topic.TOUR_CATALOG)
    [tick] = ros.timers
    ros.now = 5.0
    statuses(ros)
    tick(None)
    assert ros.pubs[Topic.VISITOR_COMMAND].sent == [] and not ros.subscribed(Topic.STATUS)
    ros.now = 6.0
    tick(None)
    [cmd] = ros.pubs[Topic.VISITOR_COMMAND].sent
    assert isinstance(cmd, VisitorCommand) and (cmd.command, cmd.goal_id, cmd.uid) == (
        Cmd.REQUEST, "223", "Tartalo/sim-visitor/cmd/1")
    assert cmd.header.stamp.to_sec() == 6.0 and node.station.cores["sim-visitor"].started
    event = NavEvent(uid="Tartalo/e/1", robot="Tartalo", phase=Phase.UNREACHABLE, goal_uid="g1", location_id="223")
    event.header.stamp = stamp(7.0)
    ros.deliver(Topic.NAV_EVENTS, event)
    assert node.station.cores["sim-visitor"].finished


def test_a_population_follows_the_goals_and_a_tour_the_catalog(ros) -> None:
    ros.params.update({"~tour_file": "real_world.tour", "~goal_id": "",
                       "~population": [{"visitor_id": "v1", "arrive_s": 0.0, "robot": "Tartalo", "way": "stairs",
                                        "tour_file": "real_world.tour"}]})
    node = visitor_node.VisitorNode()
    assert ros.subscribed(Topic.GOALS) and ros.subscribed(Topic.TOUR_CATALOG)
    ros.deliver(Topic.GOALS, Goal(uid="Tartalo/v1/1", visitor_id="v1"))
    assert node.station.cores["v1"].goal_uids == ["Tartalo/v1/1"]
    lines = (ROOT / "tours" / "real_world.tour").read_text().splitlines()
    ros.deliver(Topic.TOUR_CATALOG, TourCatalog(tours=[Tour(file_name="real_world.tour", tour_name="Real-world tour",
                                                            tour_goals_info=lines[1:])]))
    ros.timers[0](None)
    assert not ros.subscribed(Topic.TOUR_CATALOG) and node.station.cores["v1"].tour_floors


def test_bad_parameters_are_refused_naming_them(ros) -> None:
    ros.params["~way"] = "rope"
    with pytest.raises(SimConfigError, match="~way"):
        visitor_node.VisitorNode()
    ros.params.update({"~way": "lift", "~think": -1.0})
    with pytest.raises(ParamError, match="think"):
        visitor_node.VisitorNode()
