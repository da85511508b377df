"""The dashboard's core: the building from what the master carries, offline robots, alerts, cancels, out of service,
tours under way and who may speak for whom (no master, no clock: every input has its time)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from dashboard_support import (
    WALL0,
    cancel,
    cross_trip,
    event,
    local_trip,
    make_core,
    pending,
    relay_diag,
    staff,
    status,
)

from gidabot_navigation.guiding.messages import PoseData, StaffCommandData
from gidabot_navigation.interface import REASON_ADMIN, Phase, RobotState, StaffCmd
from gidabot_navigation.relay.links import LinkData, LinkSummaryData
from gidabot_navigation.tours.tour_store import TourMessage
from gidabot_web.dashboard.dashboard import AlertKind, Liveness, Section
from gidabot_web.errors import Refused

ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")


def hear_all(core, faculty, now: float, **kw) -> None:
    for r in ROBOTS:
        core.on_status(status(faculty, r, **kw), r, now)


def section(core, name: str):
    return json.loads(core.section_json(name))


def alerts(core, kind: AlertKind | None = None) -> list:
    return [a for a in core.alerts.values() if kind is None or a.kind == kind]


# ------------------------------------------------------------------ robots
def test_robots_from_statuses_poses_and_queues(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    guiding = status(faculty, "Galtxagorri", battery=0.5, state=RobotState.GUIDING, x=20.0, y=12.0, current="T/v/1")
    core.on_status(guiding, "Galtxagorri", 1.0)
    core.on_pose(PoseData("Galtxagorri", 2.0, 21.0, 12.5, 1.0), "Galtxagorri", 1.2)
    trip = cross_trip()
    core.on_goal(trip, "Tartalo", 1.3)
    core.on_pending(pending("MariSorgin", 3.0, trip), "MariSorgin", 1.4)
    core.step(1.5, WALL0 + 1.5)
    robots = {r["name"]: r for r in section(core, Section.ROBOTS)}
    g = robots["Galtxagorri"]
    assert (g["x"], g["y"], g["state"], g["battery"], g["live"]) == (21.0, 12.5, "guiding", 0.5, "online")
    u, v = faculty.floor(2.0).transform.to_pixel(21.0, 12.5)
    assert (g["u"], g["v"]) == (round(u, 1), round(v, 1))
    assert robots["MariSorgin"]["queue"] == [{"trip": trip.uid, "eta": 30.0, "goal": "305"}]
    assert robots["Tartalo"]["live"] == "offline" and robots["Tartalo"]["heard_s"] is None   # never heard


def test_an_offline_robot_stays_at_its_last_position_with_the_time_last_heard(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    hear_all(core, faculty, 0.5)
    core.on_status(status(faculty, "Tartalo", x=12.0, y=12.5), "Tartalo", 1.0)
    for r in ROBOTS[1:]:
        core.on_status(status(faculty, r), r, 5.0)
    core.step(5.9, WALL0 + 5.9)
    assert core.robots["Tartalo"].live is Liveness.ONLINE
    core.step(6.1, WALL0 + 6.1)             # 5.1 s without a status
    t = next(r for r in section(core, Section.ROBOTS) if r["name"] == "Tartalo")
    assert (t["live"], t["x"], t["y"], t["heard_s"]) == ("offline", 12.0, 12.5, 5.1)
    [a] = alerts(core, AlertKind.ROBOT_OFFLINE)
    assert (a.subject, a.params, a.active) == ("Tartalo", {"robot": "Tartalo", "why": "offline"}, True)
    core.on_status(status(faculty, "Tartalo"), "Tartalo", 7.0)
    assert core.robots["Tartalo"].live is Liveness.ONLINE and not a.active


def test_a_peer_whose_master_is_down_or_whose_link_is_down_is_not_online(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    hear_all(core, faculty, 10.0)
    core.on_diagnostics([relay_diag("Tartalo", "Kbot", "Kbot", peer_master_up=False),
                         relay_diag("Kbot", "MariSorgin", "Kbot", connected=False)], 10.5)
    core.step(10.6, WALL0 + 10.6)
    live = {r: core.robots[r].live for r in ROBOTS}
    assert live == {"Tartalo": Liveness.MASTER_DOWN, "Kbot": Liveness.ONLINE, "Galtxagorri": Liveness.ONLINE,
                    "MariSorgin": Liveness.LINK_DOWN}
    assert {a.subject: a.params["why"] for a in alerts(core, AlertKind.ROBOT_OFFLINE) if a.active} == {
        "Tartalo": "master_down", "MariSorgin": "link_down"}
    core.on_master(None, 11.0)              # this robot's own master
    assert core.robots["Kbot"].live is Liveness.MASTER_DOWN and not section(core, Section.SERVER)["master_up"]


def test_a_robot_never_heard_is_an_alert_only_after_the_startup_grace(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path, now=100.0)
    core.on_status(status(faculty, "Kbot"), "Kbot", 100.5)
    core.step(129.0, WALL0 + 129.0)
    assert {a.subject for a in alerts(core, AlertKind.ROBOT_OFFLINE)} == {"Kbot"}      # heard, then silent
    core.step(130.1, WALL0 + 130.1)
    assert {a.subject for a in alerts(core, AlertKind.ROBOT_OFFLINE)} == set(ROBOTS)


# ------------------------------------------------------------------ alerts
def test_a_condition_alert_is_raised_once_then_counts_up_until_acknowledged(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    core.on_status(status(faculty, "Kbot", battery=0.15), "Kbot", 1.0)
    core.on_status(status(faculty, "Kbot", battery=0.14), "Kbot", 1.5)      # the same condition: nothing new
    [a] = alerts(core, AlertKind.BATTERY_LOW)
    assert (a.count, a.active, a.params) == (1, True, {"robot": "Kbot", "percent": "15"})
    core.on_status(status(faculty, "Kbot", battery=0.22), "Kbot", 2.0)      # under battery_ok: still low
    assert a.active
    core.on_status(status(faculty, "Kbot", battery=0.3), "Kbot", 3.0)
    assert not a.active
    core.on_status(status(faculty, "Kbot", battery=0.1), "Kbot", 4.0)       # again, not acknowledged: counted
    assert len(alerts(core, AlertKind.BATTERY_LOW)) == 1 and (a.count, a.active) == (2, True)
    core.ack_alert(a.id, "ana", 5.0)
    assert (a.acked_by, a.acked_wall) == ("ana", WALL0 + 5.0)
    core.on_status(status(faculty, "Kbot", battery=0.05), "Kbot", 6.0)      # still the acknowledged condition
    assert len(alerts(core, AlertKind.BATTERY_LOW)) == 1
    core.on_status(status(faculty, "Kbot", battery=0.9), "Kbot", 7.0)
    core.on_status(status(faculty, "Kbot", battery=0.1), "Kbot", 8.0)       # a new occurrence after the ack
    assert [x.count for x in alerts(core, AlertKind.BATTERY_LOW)] == [2, 1]
    assert not core.alerts[a.id].active
    assert [x.id for x in core.open_alerts() if x.kind == AlertKind.BATTERY_LOW] == [
        alerts(core, AlertKind.BATTERY_LOW)[1].id]


def test_occurrences_are_deduplicated_per_trip_until_acknowledged(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    trip = cross_trip()
    core.on_goal(trip, "Tartalo", 1.0)
    core.on_event(event("MariSorgin", Phase.TIMEOUT, trip.uid, leg="goal", connector="stairs_west"), "MariSorgin", 2.0)
    core.on_event(event("Tartalo", Phase.TIMEOUT, trip.uid), "Tartalo", 2.1)       # the partner's echo
    [a] = alerts(core, AlertKind.VISITOR_NO_SHOW)
    assert (a.count, a.active, a.params["robot"], a.params["place"]) == (2, False, "MariSorgin", "stairs_west")
    other = local_trip()
    core.on_goal(other, "Kbot", 3.0)
    core.on_event(event("Kbot", Phase.UNREACHABLE, other.uid, location_id="113"), "Kbot", 3.5)
    [u] = alerts(core, AlertKind.GOAL_UNREACHABLE)
    assert u.params == {"robot": "Kbot", "place": "113", "trip": other.uid}
    with pytest.raises(Refused):
        core.ack_alert(999, "ana", 4.0)
    with pytest.raises(Refused):
        core.ack_alert(True, "ana", 4.0)


def test_a_node_at_a_new_address_was_restarted_and_a_new_master_pid_too(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    core.on_node("/goal_manager", "http://127.0.0.12:40001/", 1.0)
    core.on_node("/goal_manager", None, 2.0)                               # gone for a moment
    core.on_node("/goal_manager", "http://127.0.0.12:40001/", 3.0)          # back at the same address: re-registered
    assert not alerts(core, AlertKind.NODE_RESTARTED)
    core.on_node("/goal_manager", "http://127.0.0.12:40777/", 4.0)
    core.on_master(1234, 4.5)
    core.on_master(None, 5.0)
    core.on_master(1234, 6.0)                                               # the same master answering again
    core.on_master(5678, 7.0)                                               # a new master
    assert [(a.subject, a.params["node"]) for a in alerts(core, AlertKind.NODE_RESTARTED)] == [
        ("/goal_manager", "/goal_manager"), ("master", "master")]


def test_a_link_between_two_online_robots_reported_down_is_an_alert(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    hear_all(core, faculty, 1.0)
    down = LinkData("MariSorgin", known=True, connected=False, down_s=4.0)
    core.on_links(LinkSummaryData("Galtxagorri", (down,)), "Galtxagorri", 1.1)
    core.step(1.2, WALL0 + 1.2)
    [a] = alerts(core, AlertKind.LINK_DOWN)
    assert (a.subject, a.params, a.active) == ("Galtxagorri-MariSorgin", {"a": "Galtxagorri", "b": "MariSorgin"},
                                               True)
    core.on_links(LinkSummaryData("Galtxagorri", (LinkData("MariSorgin", known=True, connected=True),)),
                  "Galtxagorri", 2.0)
    core.step(2.1, WALL0 + 2.1)
    assert not a.active
    # a robot that is down takes its links with it: its offline alert, no link alert
    core.on_links(LinkSummaryData("Galtxagorri", (down,)), "Galtxagorri", 5.0)
    for r in ("Tartalo", "Kbot", "Galtxagorri"):
        core.on_status(status(faculty, r), r, 6.5)
    core.step(6.6, WALL0 + 6.6)
    assert core.robots["MariSorgin"].live is Liveness.OFFLINE
    assert alerts(core, AlertKind.LINK_DOWN)[-1].active is False


def test_the_alert_list_survives_a_restart_acknowledgements_included(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    core.on_status(status(faculty, "Kbot", battery=0.1), "Kbot", 1.0)
    core.on_node("/tour_store", "http://a:1/", 1.0)
    core.on_node("/tour_store", "http://a:2/", 2.0)
    core.ack_alert(alerts(core, AlertKind.BATTERY_LOW)[0].id, "ana", 3.0)
    core.step(3.1, WALL0 + 3.1)
    core.history.close()
    again = make_core(faculty, tmp_path, now=50.0)
    assert [(a.kind, a.acked_by) for a in again.alerts.values()] == [("battery_low", "ana"), ("node_restarted", "")]
    again.on_node("/tour_store", "http://a:3/", 51.0)
    assert again.alerts[2].count == 1        # a restarted dashboard knows no address yet: not a restart


# ------------------------------------------------------------------ trips
def test_a_trips_legs_phases_and_wait_for_the_visitor(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    trip = cross_trip()
    core.on_goal(trip, "Tartalo", 1.0)
    core.on_event(event("Tartalo", Phase.ON_THE_WAY, trip.uid), "Tartalo", 2.0)
    core.on_event(event("MariSorgin", Phase.GOING_TO_MEETING, trip.uid, leg="goal"), "MariSorgin", 2.5)
    core.on_event(event("MariSorgin", Phase.WAITING_VISITOR, trip.uid, leg="goal"), "MariSorgin", 10.0)
    core.on_event(event("Tartalo", Phase.GO_TO_FLOOR, trip.uid), "Tartalo", 11.0)
    core.step(40.0, WALL0 + 40.0)
    [t] = section(core, Section.TRIPS)
    assert (t["uid"], t["goal"], t["connector"], t["outcome"]) == (trip.uid, "305", "stairs_west", "")
    start, goal = t["legs"]
    assert (start["robot"], start["phase"], start["done"]) == ("Tartalo", Phase.GO_TO_FLOOR, True)
    assert (goal["robot"], goal["phase"], goal["waiting_s"], goal["done"]) == ("MariSorgin", Phase.WAITING_VISITOR,
                                                                             30.0, False)
    core.on_event(event("MariSorgin", Phase.ON_THE_WAY, trip.uid, leg="goal"), "MariSorgin", 41.0)
    core.on_event(event("MariSorgin", Phase.GOAL_REACHED, trip.uid, leg="goal"), "MariSorgin", 60.0)
    [t] = section(core, Section.TRIPS)
    assert t["outcome"] == "completed" and t["legs"][1]["waiting_s"] is None


def test_a_trip_known_only_by_its_events_is_shown_too(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    core.on_event(event("MariSorgin", Phase.WAITING_VISITOR, "Tartalo/v9/gm.z.4", leg="goal", target_floor=3.0,
                        connector="stairs_west"), "MariSorgin", 1.0)
    [t] = section(core, Section.TRIPS)
    assert (t["uid"], t["origin"], t["goal_floor"]) == ("Tartalo/v9/gm.z.4", "Tartalo", 3.0)


def test_a_staff_cancel_is_confirmed_when_every_robot_involved_dropped_it(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    trip = cross_trip()
    core.on_goal(trip, "Tartalo", 1.0)
    core.on_pending(pending("Tartalo", 0.0, trip), "Tartalo", 1.1)
    core.on_pending(pending("MariSorgin", 3.0, trip), "MariSorgin", 1.2)
    c = core.cancel_trip(trip.uid, "ana", 2.0)
    assert (c.goal_uid, c.origin_robot, c.reason) == (trip.uid, "Kbot", REASON_ADMIN) and c.uid.startswith("Kbot/")
    with pytest.raises(Refused) as twice:
        core.cancel_trip(trip.uid, "ana", 2.1)
    assert twice.value.status == 409
    [t] = section(core, Section.TRIPS)
    assert t["cancel"] == {"user": "ana", "waiting": ["MariSorgin", "Tartalo"], "dropped": [], "confirmed": False}
    core.on_event(event("MariSorgin", Phase.CANCELLED_ELSEWHERE, trip.uid, leg="goal"), "MariSorgin", 2.5)
    core.on_pending(pending("Tartalo", 0.0, trip), "Tartalo", 2.6)         # not dropped yet
    assert core.trips[trip.uid].cancel.waiting == {"Tartalo"} and not core.trips[trip.uid].cancel.confirmed
    assert core.trips[trip.uid].outcome == "cancelled"           # the history's outcome: the first cancel event
    core.on_pending(pending("Tartalo", 0.0), "Tartalo", 3.0)                # its queue without the trip
    [t] = section(core, Section.TRIPS)
    assert t["cancel"]["confirmed"] and t["cancel"]["dropped"] == ["MariSorgin", "Tartalo"]
    assert t["outcome"] == "cancelled"
    with pytest.raises(Refused) as over:
        core.cancel_trip(trip.uid, "ana", 4.0)
    assert over.value.status == 409
    with pytest.raises(Refused) as unknown:
        core.cancel_trip("Kbot/nobody/gm.x.1", "ana", 4.0)
    assert unknown.value.status == 404


def test_robots_whose_part_is_over_are_not_waited_for(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    trip = cross_trip()
    core.on_goal(trip, "Tartalo", 1.0)
    core.on_event(event("Tartalo", Phase.GO_TO_FLOOR, trip.uid), "Tartalo", 2.0)
    core.cancel_trip(trip.uid, "ana", 3.0)
    assert core.trips[trip.uid].cancel.waiting == {"MariSorgin"}


# ------------------------------------------------------------------ out of service
def test_the_staff_command_with_the_largest_version_is_in_force(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    mine = core.set_service("Tartalo", True, "ana", "wheel noise", 1.0)
    assert (mine.robot, mine.target_robot, mine.command, mine.detail) == ("Kbot", "Tartalo",
                                                                           StaffCmd.OUT_OF_SERVICE, "wheel noise")
    assert mine.uid.startswith("Kbot/staff/") and mine.version >= int(WALL0 * 1e9)
    assert core.out_of_service("Tartalo")
    core.on_staff(staff("Galtxagorri", "Tartalo", False, mine.version - 5), "Galtxagorri", 2.0)   # older
    assert core.out_of_service("Tartalo")
    ahead = mine.version + 10 ** 12                  # a robot whose clock is 1000 s ahead
    core.on_staff(staff("Galtxagorri", "Tartalo", False, ahead), "Galtxagorri", 3.0)
    assert not core.out_of_service("Tartalo")
    again = core.set_service("Tartalo", True, "ana", "", 4.0)
    assert again.version == ahead + 1                 # larger than every version known for Tartalo
    with pytest.raises(Refused):
        core.set_service("Nobody", True, "ana", "", 5.0)
    with pytest.raises(Refused):
        core.set_service("Kbot", True, "ana", "x\x00y", 5.0)
    core.step(6.0, WALL0 + 6.0)
    core.history.close()
    assert make_core(faculty, tmp_path, now=10.0).out_of_service("Tartalo")      # kept across a restart


def test_a_floor_whose_robots_are_all_out_of_service_is_an_alert(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    core.set_service("Galtxagorri", True, "ana", "", 1.0)
    [a] = alerts(core, AlertKind.FLOOR_OUT_OF_SERVICE)
    assert (a.subject, a.active) == ("2", True)
    core.set_service("Galtxagorri", False, "ana", "", 2.0)
    assert not a.active
    robot = next(r for r in section(core, Section.ROBOTS) if r["name"] == "Galtxagorri")
    assert not robot["out_of_service"] and robot["service"]["user"] == "ana"


# ------------------------------------------------------------------ links
def test_this_robots_links_from_its_relay_ends_and_the_summary_it_publishes(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    core.on_diagnostics([relay_diag("Tartalo", "Kbot", "Kbot", resent="3", dropped="1", duplicates_suppressed="2",
                                    queue_depth="7", link_losses="4"),
                         relay_diag("Kbot", "MariSorgin", "Kbot", connected=False),
                         relay_diag("Tartalo", "Galtxagorri", "Tartalo")], 10.0)   # another robot's end
    summary = core.link_summary(11.0)
    assert summary.robot == "Kbot" and [k.peer for k in summary.links] == ["Tartalo", "Galtxagorri", "MariSorgin"]
    t, g, m = summary.links
    assert (t.known, t.connected, t.rtt_ms, t.queued, t.resent, t.dropped, t.duplicates_suppressed, t.link_losses,
            t.heard_s) == (True, True, 1.5, 7, 3, 1, 2, 4, 1.0)
    assert not g.known and (m.known, m.connected, m.down_s) == (True, False, 3.0)
    assert not core.link_summary(16.0).links[0].known          # its end silent for more than diag_stale


def test_link_summaries_speak_only_for_their_robot(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    summary = LinkSummaryData("Galtxagorri", (LinkData("Tartalo", known=True, connected=True),))
    core.on_links(summary, "Tartalo", 1.0)                       # through Tartalo's relay end: not Tartalo's
    core.on_links(LinkSummaryData("Nobody", ()), "Galtxagorri", 1.0)
    core.on_links(LinkSummaryData("Galtxagorri", (LinkData("Nobody"),)), "Galtxagorri", 1.0)
    assert not core.summaries and core.counters == {"refused_foreign": 1, "refused_invalid": 2}
    core.on_links(summary, "Galtxagorri", 2.0)
    assert section(core, Section.LINKS)["others"]["Galtxagorri"]["links"][0]["peer"] == "Tartalo"


# ------------------------------------------------------------------ senders and hostile input
def test_messages_speak_only_for_their_sender(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    trip = cross_trip()
    core.on_status(status(faculty, "Tartalo", battery=0.01), "Kbot", 1.0)           # Kbot's node speaking for Tartalo
    core.on_status(status(faculty, "Tartalo", battery=0.01), None, 1.0)             # not a node of this robot
    core.on_goal(trip, "MariSorgin", 1.0)                                            # only the origin writes a goal
    core.on_event(event("Tartalo", Phase.UNREACHABLE, trip.uid), "Kbot", 1.0)
    core.on_cancel(cancel("Tartalo", trip.uid), "Galtxagorri", 1.0)
    core.on_staff(staff("Tartalo", "Kbot", True, 10), "Kbot", 1.0)
    assert core.counters == {"refused_foreign": 5, "refused_impostor": 1}
    assert not core.trips and not core.alerts and not core.service and core.robots["Tartalo"].heard is None


@pytest.mark.parametrize("bad", [
    {"robot": "Nobody"}, {"x": float("nan")}, {"battery": float("inf")}, {"state": "x" * 100}, {"yaw": "1"}])
def test_invalid_statuses_are_refused(faculty, tmp_path: Path, bad: dict) -> None:
    from dataclasses import replace

    core = make_core(faculty, tmp_path)
    core.on_status(replace(status(faculty, "Kbot"), **bad), bad.get("robot", "Kbot"), 1.0)
    assert core.counters == {"refused_invalid": 1} and core.robots["Kbot"].heard is None


def test_invalid_goals_events_cancels_and_staff_commands_are_refused(faculty, tmp_path: Path) -> None:
    from dataclasses import replace

    core = make_core(faculty, tmp_path)
    core.on_goal(replace(cross_trip(), goal_id="999"), "Tartalo", 1.0)
    core.on_event(replace(event("Kbot", Phase.GOAL_REACHED, "x"), phase=77), "Kbot", 1.0)
    core.on_cancel(replace(cancel("Kbot", "Kbot/v/1"), reason="because"), "Kbot", 1.0)
    core.on_staff(replace(staff("Kbot", "Tartalo", True, 5), uid="Tartalo/staff/1"), "Kbot", 1.0)    # namespace
    core.on_staff(replace(staff("Kbot", "Tartalo", True, 5), command=9), "Kbot", 1.0)
    core.on_staff(StaffCommandData("Kbot/staff/x", "Kbot", "a b", 0, "Tartalo", 5), "Kbot", 1.0)    # user
    assert core.counters == {"refused_invalid": 6} and not core.trips and not core.service


# ------------------------------------------------------------------ tours
def test_a_tour_under_way_follows_its_steps_from_robot_to_robot(faculty, tmp_path: Path) -> None:
    from dataclasses import replace

    core = make_core(faculty, tmp_path)
    core.on_catalog([TourMessage(file_name="paper_example.tour", tour_name="Paper example", language="en",
                                 tour_goals_info=("0, 014, A", "3, 305, B", "1, 113, C"))])
    step0 = replace(cross_trip("Tartalo/v1/gm.t.1"), goal_floor=0.0, goal_x=10.0, goal_y=12.6, goal_yaw=1.5708,
                    goal_id="014", connector="", goal_robot="", goal_state=0, tour_file="paper_example.tour",
                    tour_step=0)
    core.on_goal(step0, "Tartalo", 1.0)
    core.on_event(event("Tartalo", Phase.TOUR_STEP_DONE, step0.uid, tour_file="paper_example.tour", tour_step=0),
                  "Tartalo", 2.0)
    step1 = replace(cross_trip("Tartalo/v1/gm.t.2"), tour_file="paper_example.tour", tour_step=1)
    core.on_goal(step1, "Tartalo", 3.0)
    [run] = section(core, Section.TOURS)
    assert (run["name"], run["done"], run["current"], run["trip"], run["finished"]) == (
        "Paper example", [0], 1, step1.uid, False)
    assert run["steps"] == ["0, 014, A", "3, 305, B", "1, 113, C"]
    core.on_event(event("MariSorgin", Phase.TOUR_STEP_DONE, step1.uid, leg="goal", tour_file="paper_example.tour",
                        tour_step=1), "MariSorgin", 4.0)
    [run] = section(core, Section.TOURS)
    assert run["done"] == [0, 1] and run["at"] == "MariSorgin"
