"""The tour_store node's ROS adapter without a master: raw messages fed to its callbacks (as rospy.AnyMsg
delivers them) come out, through the store, as the tours, index, catalog and edit results it publishes."""

from __future__ import annotations

from pathlib import Path

import pytest
from node_support import FakeRos, fake_ros, raw, spin

from gidabot_msgs.msg import TourIndex
from gidabot_navigation.interface import Topic, relay_end_name
from gidabot_navigation.ros import convert
from gidabot_navigation.tours import tour_store_node
from gidabot_navigation.tours.tour_store import IndexEntry, StoreLimits, TourIndexData, TourMessage
from gidabot_navigation.tours.tour_store_node import Params, TourStoreNode

REPO = Path(__file__).resolve().parents[4]
FACULTY = REPO / "maps" / "faculty"
TOURS = REPO / "tours"
RELAY = relay_end_name("Tartalo", "Kbot")
OPEN_DAY = TourMessage(uid="Kbot/gui/tour-edit/1", file_name="open_day.tour", tour_name="Open day", language="en",
                       floor=1.0, tour_goals_info=("1, 101, Secretary's Office", "0, 014, Computer Technicians 1"))


@pytest.fixture
def ros(monkeypatch: pytest.MonkeyPatch) -> FakeRos:
    return fake_ros(monkeypatch, tour_store_node)


@pytest.fixture
def node(ros: FakeRos, tmp_path: Path):
    n = TourStoreNode(Params(str(FACULTY), "Kbot", str(tmp_path / "tours"), str(TOURS), "en", 1.0,
                             StoreLimits(max_message_bytes=4096)))
    yield n
    n.store.close()


def files(ros: FakeRos) -> list[str]:
    return [t.file_name for t in convert.catalog_from_msg(ros.sent(Topic.TOUR_CATALOG)[-1]).tours]


def test_it_starts_with_its_seed_tours(ros: FakeRos, node: TourStoreNode) -> None:
    assert files(ros) == sorted(p.name for p in TOURS.glob("*.tour"))
    index = convert.index_from_msg(ros.sent(Topic.TOUR_INDEX)[-1])
    assert index.robot == "Kbot" and sorted(e.file_name for e in index.entries) == files(ros)


def test_an_admin_edit_is_stored_shared_and_answered(ros: FakeRos, node: TourStoreNode, tmp_path: Path) -> None:
    ros.now = 150.0
    ros.feed(Topic.TOUR_EDIT, raw(convert.tour_to_msg(OPEN_DAY)), "/gui")
    spin(node)
    [result] = [convert.edit_result_from_msg(m) for m in ros.sent(Topic.TOUR_EDIT_RESULT)]
    assert (result.uid, result.file_name, result.ok, result.reason, result.stamp) == (
        OPEN_DAY.uid, "open_day.tour", True, "", 150.0)
    [shared] = [convert.tour_from_msg(m) for m in ros.sent(Topic.TOURS)]
    assert (shared.file_name, shared.editor_robot, shared.version, shared.stamp) == (
        "open_day.tour", "Kbot", result.version, 150.0)
    assert shared.uid.startswith("Kbot/tour/")
    assert "open_day.tour" in files(ros) and (tmp_path / "tours" / "open_day.tour").is_file()


def test_a_refused_edit_is_answered_with_its_reason(ros: FakeRos, node: TourStoreNode) -> None:
    bad = TourMessage(uid="Kbot/gui/tour-edit/2", file_name="bad.tour", tour_name="Bad", language="en",
                      tour_goals_info=("9, 999, Nowhere",))
    ros.feed(Topic.TOUR_EDIT, raw(convert.tour_to_msg(bad)), "/gui")
    ros.feed(Topic.TOUR_EDIT, raw(convert.tour_to_msg(TourMessage(uid="Kbot/gui/tour-edit/3", file_name="x.tour",
                                                          tour_goals_info=("a" * 5000,)))), "/gui")
    spin(node)
    results = [convert.edit_result_from_msg(m) for m in ros.sent(Topic.TOUR_EDIT_RESULT)]
    assert [(r.uid, r.ok, r.reason) for r in results] == [("Kbot/gui/tour-edit/2", False, "content"),
                                                          ("", False, "oversized")]
    assert ros.sent(Topic.TOURS) == [] and node.store.counters["rejected_oversized"] == 1


def test_tours_of_other_robots_are_applied_and_broken_bytes_refused(ros: FakeRos, node: TourStoreNode) -> None:
    theirs = TourMessage(uid="Tartalo/tour/b.1", origin_robot="Tartalo", editor_robot="Tartalo",
                         version=1_700_000_000_000_000_000, language="en", floor=1.0, tour_name="Open day",
                         file_name="open_day.tour", tour_goals_info=OPEN_DAY.tour_goals_info)
    ros.feed(Topic.TOURS, raw(convert.tour_to_msg(theirs)), RELAY)
    broken = raw(convert.tour_to_msg(theirs), RELAY)
    broken._buff = broken._buff[:-3]
    ros.feed(Topic.TOURS, broken, RELAY)
    spin(node)
    assert "open_day.tour" in files(ros)
    assert node.store.counters["accepted"] == 1 and node.store.counters["rejected_encoding"] == 1


def test_a_peer_lacking_tours_gets_them_again(ros: FakeRos, node: TourStoreNode) -> None:
    lacking = TourIndexData("Tartalo", (IndexEntry("real_world.tour", 1, "", False),))
    ros.feed(Topic.TOUR_INDEX, raw(convert.index_to_msg(lacking)), RELAY)
    bad = TourIndex(robot="Tartalo", file_names=["a.tour", "b.tour"], versions=[1], editor_robots=[""], deleted=[])
    ros.feed(Topic.TOUR_INDEX, raw(bad), RELAY)
    spin(node)
    resent = sorted(convert.tour_from_msg(m).file_name for m in ros.sent(Topic.TOURS))
    assert resent == sorted(p.name for p in TOURS.glob("*.tour") if p.name != "real_world.tour")
    assert node.store.counters["rejected_index"] == 1


def test_the_periodic_work_publishes_the_index_and_diagnostics(ros: FakeRos, node: TourStoreNode) -> None:
    indexes = len(ros.sent(Topic.TOUR_INDEX))
    node.tick()
    assert len(ros.sent(Topic.TOUR_INDEX)) == indexes + 1
    [diag] = ros.sent(Topic.DIAGNOSTICS)
    [status] = diag.status
    values = {kv.key: kv.value for kv in status.values}
    assert status.name == "tour_store: Kbot" and values["tours"] == str(len(files(ros)))
    assert values["queue_dropped"] == "0"
