"""What became of every goal and every request of the visitor, from the probes' records."""

from __future__ import annotations

from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_navigation.interface import LEG_COMMITTED, LEG_NONE, LEG_PROPOSED, Node, Phase, global_name, relay_end_name
from gidabot_navigation.tours.tour_file import parse_tour
from gidabot_sim.chaos.bookkeeping import Bookkeeping
from gidabot_sim.chaos.table3 import expected_table3, tour_step_trips, trips_with_retries

GM, NAV, PROBE = (global_name(n) for n in (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.CHAOS_PROBE))


REPO = Path(__file__).resolve().parents[4]


@pytest.fixture(scope="module")
def faculty():
    return load_building(REPO / "maps" / "faculty")


def _goal(m: str, uid: str, origin: str, a: float, b: float, caller: str = "", w: float = 0.0) -> dict:
    """A goal record whose legs are committed to the (only) robots of floors a and b."""
    return {"k": "goal", "m": m, "c": caller or (GM if m == origin else relay_end_name(origin, m)),
            "w": w, "uid": uid, "origin": origin, "initial_floor": a, "goal_floor": b, "goal_id": "x",
            "tour_step": 0, "attempt": 2, "start_robot": ROBOTS[int(a)], "start_state": LEG_COMMITTED,
            "goal_robot": ROBOTS[int(b)] if a != b else "", "goal_state": LEG_COMMITTED if a != b else LEG_NONE}


def _ev(m: str, robot: str, goal: str, phase: int, uid: str, w: float = 0.0) -> dict:
    caller = NAV if m == robot else relay_end_name(robot, m)
    return {"k": "event", "m": m, "c": caller, "w": w, "uid": uid, "robot": robot, "goal_uid": goal, "phase": phase}


ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")


def _everywhere(rec_fn, *args, **kw) -> list[dict]:
    return [rec_fn(m, *args, **kw) for m in ROBOTS]


def test_bookkeeping_follows_the_assignment_with_two_robots_on_a_floor() -> None:
    """faculty6: a goal broadcast again with each new attempt is not a duplicate; the leg goes to Lamia after
    Galtxagorri answered too late: Lamia is the robot that processed it, Galtxagorri is not involved."""
    six = load_building(REPO / "maps" / "faculty6")
    robots = [r.name for r in six.robots]
    recs: list[dict] = []
    for attempt, (goal_robot, state) in enumerate([("Galtxagorri", LEG_PROPOSED), ("Lamia", LEG_PROPOSED),
                                                   ("Lamia", LEG_COMMITTED)], start=2):
        recs += [{**_goal(m, "T/v/1", "Tartalo", 0.0, 2.0), "attempt": attempt, "goal_robot": goal_robot,
                  "goal_state": state} for m in robots]
    for robot, phase, uid in (("Tartalo", Phase.ACCEPTED, "T/e/1"), ("Galtxagorri", Phase.ACCEPTED, "G/e/1"),
                              ("Lamia", Phase.ACCEPTED, "L/e/1"), ("Tartalo", Phase.GO_TO_FLOOR, "T/e/2"),
                              ("Lamia", Phase.GOAL_REACHED, "L/e/2"), ("Tartalo", Phase.ASSIGNED, "T/e/3")):
        recs += [_ev(m, robot, "T/v/1", phase, uid) for m in robots]
    fate = Bookkeeping(six, recs).fates()["T/v/1"]
    assert fate.involved == ["Tartalo", "Lamia"] and fate.processed_by == ["Tartalo", "Lamia"]
    assert fate.completed and not fate.lost and fate.duplicated == []


def test_a_robot_answers_each_proposal_and_ends_each_leg_once(faculty) -> None:
    """An ACCEPTED answers the proposal of one attempt (a leg proposed again, e.g. after the answer was held by a
    cut link, is answered again); a final event ends one leg (the start robot's GO_TO_FLOOR, then its give-up of
    the goal leg as the origin). Twice the same answer, or two ends of one leg, is a duplicate."""
    def ev(robot: str, goal: str, phase: int, uid: str, leg: str, attempt: int = 0) -> list[dict]:
        return [dict(r, leg=leg, attempt=attempt) for r in _everywhere(_ev, robot, goal, phase, uid)]

    recs = _everywhere(_goal, "T/v/5", "Tartalo", 0.0, 1.0) + _everywhere(_goal, "T/v/6", "Tartalo", 0.0, 1.0)
    recs += ev("Tartalo", "T/v/5", Phase.ACCEPTED, "T/e/50", "start", 1)
    recs += ev("Kbot", "T/v/5", Phase.ACCEPTED, "K/e/50", "goal", 1)
    recs += ev("Kbot", "T/v/5", Phase.ACCEPTED, "K/e/51", "goal", 2)
    recs += ev("Tartalo", "T/v/5", Phase.GO_TO_FLOOR, "T/e/51", "start")
    recs += ev("Tartalo", "T/v/5", Phase.PARTNER_OFFLINE, "T/e/52", "goal")
    recs += ev("Kbot", "T/v/6", Phase.ACCEPTED, "K/e/60", "goal", 1)
    recs += ev("Kbot", "T/v/6", Phase.ACCEPTED, "K/e/61", "goal", 1)
    recs += ev("Kbot", "T/v/6", Phase.TIMEOUT, "K/e/62", "goal")
    recs += ev("Kbot", "T/v/6", Phase.GOAL_REACHED, "K/e/63", "goal")
    fates = Bookkeeping(faculty, recs).fates()
    assert fates["T/v/5"].duplicated == []
    assert fates["T/v/6"].duplicated == ["Kbot accepted it 2 times (its goal leg, attempt 1)",
                                         "Kbot ended it 2 times (its goal leg)"]


def test_bookkeeping_counts_completed_lost_duplicated_and_cancelled(faculty) -> None:
    recs: list[dict] = []
    # g1: Tartalo 0 -> Kbot 1, both accept, Kbot completes
    recs += _everywhere(_goal, "T/v/1", "Tartalo", 0.0, 1.0)
    recs += _everywhere(_ev, "Tartalo", "T/v/1", Phase.ACCEPTED, "T/e/1")
    recs += _everywhere(_ev, "Kbot", "T/v/1", Phase.ACCEPTED, "K/e/1")
    recs += _everywhere(_ev, "Tartalo", "T/v/1", Phase.GO_TO_FLOOR, "T/e/2")
    recs += _everywhere(_ev, "Kbot", "T/v/1", Phase.TOUR_STEP_DONE, "K/e/2")
    # g2: accepted only by Tartalo, never completed -> lost; delivered twice on Kbot's master -> duplicated
    recs += _everywhere(_goal, "T/v/2", "Tartalo", 0.0, 1.0)
    recs.append(_goal("Kbot", "T/v/2", "Tartalo", 0.0, 1.0))
    recs += _everywhere(_ev, "Tartalo", "T/v/2", Phase.ACCEPTED, "T/e/3")
    # g3: cancelled: not lost, not in Table 3
    recs += _everywhere(_goal, "K/v/3", "Kbot", 1.0, 1.0)
    recs += [{"k": "cancel", "m": m, "c": GM, "uid": "K/c/1", "goal_uid": "K/v/3", "origin": "Kbot",
              "reason": "visitor"} for m in ROBOTS]
    # g4: Kbot processed it twice (two ACCEPTED with different uids)
    recs += _everywhere(_goal, "K/v/4", "Kbot", 1.0, 1.0)
    recs += _everywhere(_ev, "Kbot", "K/v/4", Phase.ACCEPTED, "K/e/4")
    recs += _everywhere(_ev, "Kbot", "K/v/4", Phase.ACCEPTED, "K/e/5")
    recs += _everywhere(_ev, "Kbot", "K/v/4", Phase.GOAL_REACHED, "K/e/6")
    # hostile input: a goal from the probe and an event claiming to be a robot's, from a probe
    recs.append(_goal("Kbot", "Ghost/v/1", "Ghost", 0.0, 1.0, caller=PROBE))
    recs.append({"k": "event", "m": "Kbot", "c": PROBE, "uid": "x", "robot": "Kbot", "goal_uid": "T/v/2",
                 "phase": Phase.GOAL_REACHED})
    book = Bookkeeping(faculty, recs)
    fates = book.fates()
    assert set(fates) == {"T/v/1", "T/v/2", "K/v/3", "K/v/4"}
    assert fates["T/v/1"].completed and not fates["T/v/1"].lost and fates["T/v/1"].processed_by == ["Tartalo", "Kbot"]
    assert fates["T/v/2"].lost and fates["T/v/2"].duplicated == ["attempt 2 delivered 2 times on Kbot's master"]
    assert fates["K/v/3"].cancelled and not fates["K/v/3"].lost
    assert fates["K/v/4"].duplicated == ["Kbot accepted it 2 times"] and not fates["K/v/4"].lost
    assert book.foreign["event"] == 1
    table = book.table3(fates)
    assert table["Tartalo"] == (3, 2) and table["Kbot"] == (3, 2) and table["MariSorgin"] == (3, 0)
    assert book.duplicated_cancels() == {}


def test_a_goal_its_restarted_goal_manager_published_again_is_no_duplicate_but_a_double_delivery_is(faculty) -> None:
    """The quick chaos run on machines, seed 3: Tartalo's goal_manager was killed 0.45 s after it published
    attempt 3 of a goal; the restarted process published its outbox (that goal, the ASSIGNED event) again, with
    the same uids. Tartalo's probe saw attempt 3 twice from /goal_manager (a new connection: a new process), the
    relays forwarded it once (every other master once), Kbot accepted that proposal once: counted apart, not
    as a duplicate. Twice on one connection, or twice from a relay end, stays a duplicate."""
    def goals_of(uid: str, conns: list[int], caller: str = GM, on: str = "Tartalo") -> list[dict]:
        recs = [dict(_goal(m, uid, "Tartalo", 0.0, 1.0), attempt=3, n=1) for m in ROBOTS if m != on]
        return recs + [dict(_goal(on, uid, "Tartalo", 0.0, 1.0, caller=caller), attempt=3, n=n) for n in conns]

    recs = goals_of("T/v/9", [4, 11]) + goals_of("T/v/10", [4, 4]) + goals_of("T/v/11", [3])
    recs += goals_of("T/v/12", [2, 6], caller=relay_end_name("Tartalo", "Kbot"), on="Kbot")[-2:]
    recs += [{k: v for k, v in r.items() if k != "n"} for r in goals_of("T/v/13", [4, 11])]    # an old run's records
    for uid in ("T/v/9", "T/v/10", "T/v/11", "T/v/12", "T/v/13"):
        recs += _everywhere(_ev, "Tartalo", uid, Phase.ACCEPTED, f"{uid}/e/1")
        recs += _everywhere(_ev, "Kbot", uid, Phase.ACCEPTED, f"{uid}/e/2")
        recs += _everywhere(_ev, "Kbot", uid, Phase.TOUR_STEP_DONE, f"{uid}/e/3")
    cancel = {"k": "cancel", "c": GM, "uid": "T/c/1", "goal_uid": "T/v/9", "origin": "Tartalo", "reason": "offline"}
    recs += [dict(cancel, m=m, n=1) for m in ROBOTS] + [dict(cancel, m="Tartalo", n=12)]
    recs += [dict(cancel, uid="T/c/2", goal_uid="T/v/10", m=m, n=1) for m in ROBOTS]
    recs += [dict(cancel, uid="T/c/2", goal_uid="T/v/10", m="Kbot", n=1)]
    book = Bookkeeping(faculty, recs)
    fates = book.fates()
    assert fates["T/v/9"].duplicated == [] and fates["T/v/9"].republished == [
        f"attempt 3 published 2 times on Tartalo's master by {GM}, each on a new connection"]
    assert fates["T/v/10"].duplicated == ["attempt 3 delivered 2 times on Tartalo's master"]
    assert fates["T/v/11"].duplicated == [] and fates["T/v/11"].republished == []
    assert fates["T/v/12"].duplicated == ["attempt 3 delivered 2 times on Kbot's master"]
    assert fates["T/v/13"].duplicated == ["attempt 3 delivered 2 times on Tartalo's master"]
    assert book.duplicated_cancels() == {"T/c/2": ["delivered 2 times on Kbot's master"]}
    assert book.duplicated_cancels(republished=True) == {"T/c/1": ["published 2 times on Tartalo's master"]}


def test_partner_notices_must_be_answered(faculty) -> None:
    recs = [_ev("Kbot", "Kbot", "g", Phase.PARTNER_LOST, "a", 1.0),
            _ev("Kbot", "Kbot", "g", Phase.PARTNER_BACK, "b", 2.0),
            _ev("Kbot", "Kbot", "h", Phase.PARTNER_LOST, "c", 3.0),
            _ev("Kbot", "Kbot", "h", Phase.GOAL_REACHED, "d", 4.0),
            _ev("Kbot", "Kbot", "i", Phase.PARTNER_LOST, "e", 5.0)]
    assert Bookkeeping(faculty, recs).partner_notices() == (3, 2, ["Kbot i"])


def test_steps_of_the_visit_know_completions_retries_system_ends_and_refusals(faculty) -> None:
    tour = {"tour_file": "t.tour"}
    recs: list[dict] = []
    # step 0: Tartalo -> Kbot, given up by Kbot (partner offline, cancel reason offline), asked again, completed
    recs += [dict(r, **tour, tour_step=0, w=1.0) for r in _everywhere(_goal, "T/v/1", "Tartalo", 0.0, 1.0)]
    recs += _everywhere(_ev, "Tartalo", "T/v/1", Phase.ACCEPTED, "T/e/1")
    recs += _everywhere(_ev, "Kbot", "T/v/1", Phase.ACCEPTED, "K/e/1")
    recs += _everywhere(_ev, "Kbot", "T/v/1", Phase.PARTNER_OFFLINE, "K/e/2", w=5.0)
    recs += [{"k": "cancel", "m": m, "c": "/goal_manager", "uid": "K/c/1", "goal_uid": "T/v/1", "origin": "Kbot",
              "reason": "offline"} for m in ROBOTS]
    recs += [dict(r, **tour, tour_step=0, w=9.0) for r in _everywhere(_goal, "K/v/2", "Kbot", 1.0, 1.0)]
    recs += _everywhere(_ev, "Kbot", "K/v/2", Phase.ACCEPTED, "K/e/3")
    recs += _everywhere(_ev, "Kbot", "K/v/2", Phase.TOUR_STEP_DONE, "K/e/4")
    # step 1: refused twice (no goal: the next robot offline), never completed
    recs += [dict(r, **tour, tour_step=1) for r in _everywhere(_ev, "Kbot", "", Phase.PARTNER_OFFLINE, "K/e/5")]
    recs += [dict(r, **tour, tour_step=1) for r in _everywhere(_ev, "Kbot", "", Phase.PARTNER_OFFLINE, "K/e/6")]
    book = Bookkeeping(faculty, recs)
    fates = book.fates()
    assert fates["T/v/1"].system_ended and not fates["T/v/1"].lost
    steps = book.visit(fates, "t.tour", 2)
    assert steps[0].passed and steps[0].goals == ["T/v/1", "K/v/2"] and steps[0].completed_by == "K/v/2"
    assert steps[0].system_ends == ["T/v/1: partner offline from Kbot"]
    assert not steps[1].passed and steps[1].refusals == 2 and "no goal was ever made" in steps[1].describe()
    assert book.retried_goals(steps) == ["T/v/1"]


def test_table3_counts_a_retried_step_as_the_trip_that_completed_it(faculty) -> None:
    """The full chaos run on machines, seed 1: Tartalo was cut off 150 s during step 2 (floor 0 -> 301 on floor
    3); MariSorgin gave the trip up after its partner_timeout; the visitor, sent upstairs already, asked again
    at MariSorgin: a trip on floor 3 only. Tartalo processed one goal fewer than the tour's Table 3 says
    (15 / 6 instead of 15 / 7): the expected table counts that step as the retry's trip."""
    tour = parse_tour("Tour: T\n0, 005, Student Council\n3, 301, IXA Lab\n", "t.tour", building=faculty)
    step_trips = tour_step_trips(tour, 0.0, faculty)
    assert step_trips == {0: (0.0, 0.0), 1: (0.0, 3.0)}
    t = {"tour_file": "t.tour"}
    recs = [dict(r, **t, tour_step=0, w=1.0) for r in _everywhere(_goal, "T/v/1", "Tartalo", 0.0, 0.0)]
    recs += _everywhere(_ev, "Tartalo", "T/v/1", Phase.ACCEPTED, "T/e/1")
    recs += _everywhere(_ev, "Tartalo", "T/v/1", Phase.TOUR_STEP_DONE, "T/e/2")
    recs += [dict(r, **t, tour_step=1, w=2.0) for r in _everywhere(_goal, "T/v/3", "Tartalo", 0.0, 3.0)]
    recs += _everywhere(_ev, "Tartalo", "T/v/3", Phase.ACCEPTED, "T/e/3")
    recs += _everywhere(_ev, "MariSorgin", "T/v/3", Phase.ACCEPTED, "M/e/1")
    recs += _everywhere(_ev, "Tartalo", "T/v/3", Phase.GO_TO_FLOOR, "T/e/4")
    recs += _everywhere(_ev, "MariSorgin", "T/v/3", Phase.PARTNER_OFFLINE, "M/e/2", w=150.0)
    recs += [{"k": "cancel", "m": m, "c": GM, "uid": "M/c/1", "goal_uid": "T/v/3", "origin": "MariSorgin",
              "reason": "offline"} for m in ROBOTS]
    recs += [dict(r, **t, tour_step=1, w=200.0) for r in _everywhere(_goal, "M/v/2", "MariSorgin", 3.0, 3.0)]
    recs += _everywhere(_ev, "MariSorgin", "M/v/2", Phase.ACCEPTED, "M/e/3")
    recs += _everywhere(_ev, "MariSorgin", "M/v/2", Phase.TOUR_FINISHED, "M/e/4")
    book = Bookkeeping(faculty, recs)
    fates = book.fates()
    steps = book.visit(fates, "t.tour", 2)
    assert all(st.passed for st in steps) and book.retried_routes(steps) == {1: (3.0, 3.0)}
    expected = expected_table3(faculty, trips_with_retries(step_trips, book.retried_routes(steps)))
    assert expected_table3(faculty, list(step_trips.values()))["Tartalo"] == (2, 2)      # the tour alone
    assert expected == {"Tartalo": (2, 1), "Kbot": (2, 0), "Galtxagorri": (2, 0), "MariSorgin": (2, 1)}
    assert book.table3(fates) == expected                                                   # what the probes saw
    assert book.table3_with(expected, fates, book.retried_goals(steps)) == {
        "Tartalo": (3, 2), "Kbot": (3, 0), "Galtxagorri": (3, 0), "MariSorgin": (3, 2)}    # the bags hold T/v/3
