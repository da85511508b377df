"""The tour_store node on one master: admin edits, remote tours, hostile input, anti-entropy, restart."""

from __future__ import annotations

from pathlib import Path

import pytest
from probe import Probe
from tour_system import FACULTY, REPO, T_NOW, TOUR, VISIT, dir_state, hostile, robot_ip, start_store, tour

from gidabot_navigation.interface import Node, Topic, global_name
from gidabot_sim.runner.procs import ProcessGroup, ros_env, start_master, wait_until

pytestmark = pytest.mark.system
SEEDED = ["long_tour.tour", "paper_example.tour", "real_world.tour"]
STORE = [global_name(Node.TOUR_STORE)]


@pytest.fixture
def one_robot(tmp_path: Path, procs: ProcessGroup):
    """Galtxagorri's master, its tour store (launch file, seeded from tours/) and a probe."""
    uri = start_master(procs, "master", robot_ip(2))
    env = ros_env(uri, robot_ip(2), log_dir=tmp_path / "logs" / "ros")
    tours_dir = tmp_path / "tours"
    start_store(procs, env, "Galtxagorri", FACULTY, tours_dir, name="tour_store")
    with Probe(env, tmp_path / "logs" / "probe.log") as probe:
        for topic, type_ in ((Topic.TOUR_CATALOG, "gidabot_msgs/TourCatalog"), (Topic.TOURS, TOUR),
                             (Topic.TOUR_INDEX, "gidabot_msgs/TourIndex"),
                             (Topic.TOUR_EDIT_RESULT, "gidabot_msgs/TourEditResult"),
                             (Topic.DIAGNOSTICS, "diagnostic_msgs/DiagnosticArray")):
            probe.sub(topic, type_)
        probe.wait(Topic.TOUR_CATALOG, lambda m: len(m["tours"]) == 3, 60, "the seeded catalog")
        yield procs, env, tours_dir, probe


def catalog_names(probe: Probe) -> list[str]:
    return [t["file_name"] for t in probe.msgs(Topic.TOUR_CATALOG)[-1]["tours"]]


def diag(probe: Probe, key: str) -> int:
    msgs = probe.msgs(Topic.DIAGNOSTICS)
    if not msgs:
        return 0
    values = {kv["key"]: kv["value"] for kv in msgs[-1]["status"][0]["values"]}
    return int(values.get(key, 0))


def test_admin_edits_are_stored_shared_and_survive_restart(one_robot) -> None:
    procs, env, tours_dir, probe = one_robot
    assert sorted(dir_state(tours_dir)) == SEEDED
    assert dir_state(tours_dir)["real_world.tour"] == (REPO / "tours" / "real_world.tour").read_bytes()

    probe.pub(Topic.TOUR_EDIT, TOUR, tour("visit.tour", VISIT, name="Open day", uid="gui/1"), to=STORE)
    res = probe.wait(Topic.TOUR_EDIT_RESULT, lambda m: m["uid"] == "gui/1", 30, "edit result")
    assert res["ok"] and res["version"] > 0, res
    assert dir_state(tours_dir)["visit.tour"] == b"Tour: Open day\n" + "\n".join(VISIT).encode() + b"\n"
    shared = probe.wait(Topic.TOURS, lambda m: m["file_name"] == "visit.tour", 5, "the shared tour")
    assert (shared["editor_robot"], shared["origin_robot"], shared["version"]) == ("Galtxagorri", "Galtxagorri",
                                                                                    res["version"])
    assert shared["tour_goals_info"] == VISIT and shared["tour_name"] == "Open day" and shared["floor"] == 0
    probe.wait(Topic.TOUR_CATALOG, lambda m: "visit.tour" in [t["file_name"] for t in m["tours"]], 5)
    probe.wait(Topic.TOUR_INDEX, lambda m: "visit.tour" in m["file_names"], 5)

    probe.pub(Topic.TOUR_EDIT, TOUR, tour("bad.tour", ["0, 999, Nowhere"], uid="gui/2"), to=STORE)
    res = probe.wait(Topic.TOUR_EDIT_RESULT, lambda m: m["uid"] == "gui/2", 30)
    assert not res["ok"] and res["reason"] == "content" and "unknown room '999'" in res["error"]
    assert "bad.tour" not in dir_state(tours_dir)

    probe.pub(Topic.TOUR_EDIT, TOUR, tour("long_tour.tour", [], deleted=True, uid="gui/3"), to=STORE)
    assert probe.wait(Topic.TOUR_EDIT_RESULT, lambda m: m["uid"] == "gui/3", 30)["ok"]
    assert "long_tour.tour" not in dir_state(tours_dir)
    tomb = probe.wait(Topic.TOURS, lambda m: m["file_name"] == "long_tour.tour", 5, "the tombstone")
    assert tomb["deleted"] and tomb["version"] > res["version"]

    before = dir_state(tours_dir)
    procs.stop("tour_store")
    n = len(probe.msgs(Topic.TOUR_CATALOG))
    start_store(procs, env, "Galtxagorri", FACULTY, tours_dir, name="tour_store")
    cat = probe.wait(Topic.TOUR_CATALOG, lambda m: True, 60, "the catalog after restart", since=n)
    assert sorted(t["file_name"] for t in cat["tours"]) == ["paper_example.tour", "real_world.tour", "visit.tour"]
    assert dir_state(tours_dir) == before


def test_remote_tours_hostile_input_and_anti_entropy(one_robot) -> None:
    procs, env, tours_dir, probe = one_robot
    # a valid tour from Kbot is written into the directory
    probe.pub(Topic.TOURS, TOUR, tour("from_kbot.tour", VISIT, editor="Kbot", origin="Kbot", version=T_NOW,
                                             uid="Kbot/tour/x.1"), to=STORE)
    wait_until(lambda: "from_kbot.tour" in dir_state(tours_dir), 30, "Kbot's tour on disk")
    before = dir_state(tours_dir)
    assert sorted(before) == sorted([*SEEDED, "from_kbot.tour"])

    # hostile and malformed tours: every one rejected, counted, nothing touched
    cases = hostile("Kbot")
    for _, msg, _ in cases:
        probe.pub(Topic.TOURS, TOUR, msg, to=STORE)
    wait_until(lambda: diag(probe, "rejected") >= len(cases), 30, f"{len(cases)} rejections")
    assert diag(probe, "rejected") == len(cases)
    for reason in {r for _, _, r in cases}:
        assert diag(probe, f"rejected_{reason}") == sum(1 for _, _, r in cases if r == reason), reason
    assert dir_state(tours_dir) == before
    assert not (tours_dir.parent / "escape.tour").exists() and not Path("/tmp/abs.tour").exists()
    assert catalog_names(probe) == sorted(before)

    # anti-entropy: Kbot's index says it lacks everything -> every record is re-sent
    n = len(probe.msgs(Topic.TOURS))
    probe.pub(Topic.TOUR_INDEX, "gidabot_msgs/TourIndex", {"robot": "Kbot", "file_names": [], "versions": [],
                                                               "editor_robots": [], "deleted": []}, to=STORE)
    wait_until(lambda: {m["file_name"] for m in probe.msgs(Topic.TOURS, n)} >= set(before), 20,
               "the re-sent tours")
