"""Statistics of many visitors from monitor records: waits, outcomes against the visitors' choices, queues."""

from __future__ import annotations

import json
import math

from gidabot_navigation.interface import LEG_COMMITTED, LEG_NONE, LEG_PROPOSED, Phase
from gidabot_sim.report.crowd import CANCELLED, COMPLETED, TIMED_OUT, UNFINISHED, Crowd, percentile
from gidabot_sim.visitor.population import VisitorPlan


def plan(vid: str, robot: str = "Tartalo", **kw) -> VisitorPlan:
    return VisitorPlan(**{"visitor_id": vid, "arrive_s": 0.0, "robot": robot, "way": "stairs", "goal_id": "305",
                          **kw})


def goal(uid: str, visitor: str, t: float, start: str = "Tartalo", goal_robot: str = "", goal_state: int = LEG_NONE,
         attempt: int = 1, step: int = -1, tour: str = "") -> dict:
    return {"kind": "goal", "uid": uid, "visitor_id": visitor, "sim": t, "wall": t / 10, "start_robot": start,
            "start_state": LEG_COMMITTED, "goal_robot": goal_robot, "goal_state": goal_state, "attempt": attempt,
            "tour_step": step, "tour_file": tour}


def event(n: int, robot: str, phase: int, goal_uid: str, t: float) -> dict:
    return {"kind": "event", "uid": f"{robot}/event/{n}", "robot": robot, "phase": phase, "goal_uid": goal_uid,
            "sim": t, "wall": t / 10}


def test_waits_trip_times_outcomes_and_the_verdict() -> None:
    plans = [plan("v1"), plan("v2", cancel_after_s=30.0), plan("v3", no_show=True), plan("v4"), plan("v5")]
    c = Crowd(plans)
    records = [
        goal("T/v1/1", "v1", 100.0, goal_robot="MariSorgin", goal_state=LEG_PROPOSED),
        goal("T/v1/1", "v1", 101.0, goal_robot="MariSorgin", goal_state=LEG_COMMITTED, attempt=2),
        event(1, "Tartalo", Phase.ON_THE_WAY, "T/v1/1", 110.0),            # v1 waited 10 s
        goal("T/v2/1", "v2", 120.0),
        event(2, "Tartalo", Phase.GO_TO_FLOOR, "T/v1/1", 150.0),
        event(3, "Tartalo", Phase.CANCELLED_HERE, "T/v2/1", 150.0),        # v2 cancelled, as it chose
        goal("T/v3/1", "v3", 160.0, goal_robot="MariSorgin", goal_state=LEG_COMMITTED),
        event(4, "MariSorgin", Phase.GOAL_REACHED, "T/v1/1", 250.0),       # v1 completed: trip 150 s
        event(5, "Tartalo", Phase.ON_THE_WAY, "T/v3/1", 200.0),
        event(6, "MariSorgin", Phase.TIMEOUT, "T/v3/1", 500.0),            # v3 never came: as it chose
        goal("T/v4/1", "v4", 300.0),
        event(7, "Tartalo", Phase.TIMEOUT, "T/v4/1", 400.0),               # v4 wanted to arrive: not as chosen
        event(7, "Tartalo", Phase.TIMEOUT, "T/v4/1", 400.0),               # (the same event again: once)
        {"kind": "goal", "uid": "X/other/1", "visitor_id": "stranger", "sim": 1.0},   # not of the population
    ]
    for rec in records:
        c.feed_line(json.dumps(rec))
    assert not c.finished and c.visit_end("v5") == (UNFINISHED, None)
    rows = {v["visitor"]: v for v in c.visitor_rows()}
    assert (rows["v1"]["outcome"], rows["v1"]["wait_s"], rows["v1"]["trip_s"]) == (COMPLETED, 10.0, 150.0)
    assert rows["v2"]["outcome"] == CANCELLED and rows["v2"]["as_chosen"] and rows["v2"]["wait_s"] is None
    assert rows["v3"]["outcome"] == TIMED_OUT and rows["v3"]["as_chosen"] and rows["v3"]["wait_s"] == 40.0
    assert rows["v4"]["outcome"] == TIMED_OUT and not rows["v4"]["as_chosen"]
    s = c.summary(["Tartalo", "MariSorgin"])
    assert (s["visitors"], s["completed"], s["cancelled"], s["timed_out"], s["unfinished"]) == (5, 1, 1, 2, 1)
    assert s["wait_mean_s"] == 25.0 and s["wait_p95_s"] == 40.0
    assert [p.split(" ")[0] for p in s["problems"]] == ["v4", "v5", "v5:"]     # not as chosen; v5: lost too
    assert "visitors: 4 of 5 with a trip, 1 completed" in c.line()


def test_duplicated_goals_of_one_request_fail_the_verdict() -> None:
    c = Crowd([plan("v1")])
    for rec in (goal("T/v1/1", "v1", 1.0), goal("K/v1/2", "v1", 2.0, start="Kbot"),
                event(1, "Tartalo", Phase.GOAL_REACHED, "T/v1/1", 9.0)):
        c.feed(rec)
    s = c.summary(["Tartalo"])
    assert s["completed"] == 1 and s["problems"] == ["v1: 1 duplicated goal(s)"]


def test_legs_busy_fraction_and_queue_length_per_robot() -> None:
    """Lamia gets two goal legs (committed at 10 and 20, ended at 40 and 60) over a run from 0 to 100."""
    c = Crowd([plan("a"), plan("b"), plan("c")])
    for rec in (goal("T/a/1", "a", 0.0),
                goal("T/b/1", "b", 5.0, goal_robot="Lamia", goal_state=LEG_PROPOSED),
                goal("T/b/1", "b", 10.0, goal_robot="Lamia", goal_state=LEG_COMMITTED, attempt=2),
                goal("T/c/1", "c", 20.0, goal_robot="Lamia", goal_state=LEG_COMMITTED),
                event(1, "Lamia", Phase.GOAL_REACHED, "T/b/1", 40.0),
                event(2, "Lamia", Phase.GOAL_REACHED, "T/c/1", 60.0),
                event(3, "Tartalo", Phase.GOAL_REACHED, "T/a/1", 100.0)):
        c.feed(rec)
    lamia, tartalo, idle = c.robot_rows(["Lamia", "Tartalo", "Kbot"])
    assert (lamia["legs_served"], lamia["queue_max"]) == (2, 2)
    assert lamia["busy_fraction"] == 0.5 and math.isclose(lamia["queue_mean"], (30 + 40) / 100)
    assert tartalo["legs_served"] == 3 and tartalo["queue_max"] == 3
    assert idle == {"robot": "Kbot", "legs_served": 0, "busy_fraction": 0.0, "queue_max": 0, "queue_mean": 0.0}
    assert c.finished


def test_percentile_is_the_nearest_rank() -> None:
    assert percentile([5.0, 1.0, 3.0], 95) == 5.0 and percentile([2.0], 50) == 2.0
    assert percentile(list(range(1, 101)), 95) == 95 and math.isnan(percentile([], 95))


def test_a_request_refused_before_any_goal_ends_that_visitors_visit() -> None:
    """MariSorgin refuses a request for 115 (its queue is too long): the visitor who asked it for 115 and has no
    trip yet is refused, not lost; another visitor's request elsewhere is not touched."""
    c = Crowd([plan("a", robot="MariSorgin", goal_id="115"), plan("b", robot="MariSorgin", goal_id="001"),
               plan("c", robot="Kbot", goal_id="115")])
    assert c.feed({"kind": "event", "uid": "M/event/1", "robot": "MariSorgin", "phase": Phase.REJECTED,
                   "goal_uid": "", "location_id": "115", "sim": 50.0, "detail": "could be there in 990 s only"})
    assert not c.feed({"kind": "event", "uid": "M/event/2", "robot": "MariSorgin", "phase": Phase.REJECTED,
                       "goal_uid": "", "location_id": "999", "sim": 51.0})
    s = c.summary(["MariSorgin"])
    rows = {v["visitor"]: v for v in s["per_visitor"]}
    assert rows["a"]["outcome"] == "refused" and not rows["a"]["as_chosen"] and s["refused"] == 1
    assert rows["b"]["outcome"] == rows["c"]["outcome"] == UNFINISHED
    assert s["problems"][0].startswith("a (complete, 115 from MariSorgin): refused")
    assert not any(p.startswith("a:") for p in s["problems"])        # refused, not lost


def test_a_visitor_who_leaves_at_the_screen_chose_so() -> None:
    """v1 is shown 700 s and accepts up to 600 s: it leaves (as chosen, no goal, not lost); v2 is shown 100 s and
    asks: its visit is what counts."""
    c = Crowd([plan("v1", patience_s=600.0), plan("v2", patience_s=600.0)])
    assert c.feed({"kind": "visitor", "event": "left", "visitor": "v1", "robot": "Tartalo", "shown": [0.0, 700.0],
                   "patience_s": 600.0, "sim": 10.0, "detail": "left: shown a wait of 700 s"})
    assert c.feed({"kind": "visitor", "event": "asked", "visitor": "v2", "robot": "Tartalo", "shown": [0.0, 100.0],
                   "patience_s": 600.0, "sim": 11.0})
    assert not c.feed({"kind": "visitor", "event": "left", "visitor": "stranger", "sim": 12.0})
    s = c.summary(["Tartalo"])
    rows = {v["visitor"]: v for v in s["per_visitor"]}
    assert rows["v1"]["outcome"] == "left" and rows["v1"]["as_chosen"] and rows["v1"]["shown_wait_s"] == 700.0
    assert rows["v2"]["outcome"] == UNFINISHED and rows["v2"]["shown_wait_s"] == 100.0
    assert s["left"] == 1 and s["problems"] == ["v2 (complete, 305 from Tartalo): unfinished",
                                                "v2: its request made no goal (lost)"]
    assert "1 left" in c.line()


def test_a_trip_given_up_and_asked_again_is_a_new_request_not_a_duplicate() -> None:
    """v1's trip is given up (PARTNER_OFFLINE: the robot upstairs was offline); v1 asks again 30 s later and
    completes: one visit, completed, asked again once, nothing duplicated. v2 gets two goals at once: duplicated."""
    c = Crowd([plan("v1"), plan("v2")])
    for rec in (goal("T/v1/1", "v1", 10.0, goal_robot="MariSorgin", goal_state=LEG_PROPOSED),
                event(1, "Tartalo", Phase.PARTNER_OFFLINE, "T/v1/1", 14.0),
                goal("T/v1/2", "v1", 44.0, goal_robot="MariSorgin", goal_state=LEG_COMMITTED),
                event(2, "MariSorgin", Phase.GOAL_REACHED, "T/v1/2", 300.0),
                goal("T/v2/1", "v2", 20.0), goal("T/v2/2", "v2", 21.0),
                event(3, "Tartalo", Phase.GOAL_REACHED, "T/v2/1", 90.0)):
        c.feed(rec)
    rows = {v["visitor"]: v for v in c.visitor_rows()}
    assert (rows["v1"]["outcome"], rows["v1"]["asked_again"], rows["v1"]["duplicated"]) == (COMPLETED, 1, 0)
    assert rows["v2"]["duplicated"] == 1
    assert c.summary(["Tartalo"])["problems"] == ["v2: 1 duplicated goal(s)"]


def test_an_event_that_overtakes_its_goal_counts_and_times_are_the_robots_stamps() -> None:
    """The monitor sees Galtxagorri's ON_THE_WAY (stamped 137.4) before the goal (confirmed at 137.0, seen at
    137.7): it is kept until the goal comes; the wait is 0.4 s (stamps), not the time of a later robot's move."""
    c = Crowd([plan("v1", robot="Galtxagorri")])
    first = dict(event(1, "Galtxagorri", Phase.ON_THE_WAY, "G/v1/1", 137.6), stamp=137.4)
    assert not c.feed(first)
    c.feed(dict(goal("G/v1/1", "v1", 137.7, start="Galtxagorri"), stamp=137.0))
    c.feed(dict(event(2, "Kbot", Phase.GOING_TO_MEETING, "G/v1/1", 488.6), stamp=488.5))
    c.feed(dict(event(3, "Kbot", Phase.GOAL_REACHED, "G/v1/1", 583.6), stamp=583.5))
    [row] = c.visitor_rows()
    assert (row["wait_s"], row["trip_s"], row["outcome"]) == (0.4, 446.5, COMPLETED)
