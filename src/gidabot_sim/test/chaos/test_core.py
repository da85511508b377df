"""The chaos core without ROS: schedules, bookkeeping of goals, Table 3, crash logs, obstacles, the table."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_navigation.interface import LEG_COMMITTED, LEG_NONE, LEG_PROPOSED, Node, Phase, global_name, relay_end_name
from gidabot_navigation.tours.tour_file import parse_tour
from gidabot_sim.chaos import core as cc

# callers as the probes record them
GM, NAV, PROBE = (global_name(n) for n in (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.CHAOS_PROBE))

REPO = Path(__file__).resolve().parents[4]


@pytest.fixture(scope="module")
def faculty():
    return load_building(REPO / "maps" / "faculty")


def test_full_schedule_has_every_kind_the_issue_asks_for(faculty) -> None:
    faults = cc.make_schedule(1, faculty, cc.PROFILES["full"])
    assert faults == cc.make_schedule(1, faculty, cc.PROFILES["full"])        # deterministic
    assert faults != cc.make_schedule(2, faculty, cc.PROFILES["full"])
    kinds = [f.kind for f in faults]
    assert len(faults) >= 20
    cuts = [f for f in faults if f.kind in (cc.CUT_IPTABLES, cc.CUT_RELAY_END)]
    assert all(1.0 <= f.duration <= 60.0 for f in cuts)
    assert min(f.duration for f in cuts) <= 3.0 and max(f.duration for f in cuts) >= 45.0
    assert sorted(f.robot for f in faults if f.kind == cc.MASTER_RESTART) == sorted(r.name for r in faculty.robots)
    assert sorted(f.target for f in faults if f.kind == cc.NODE_RESTART) == ["goal_manager", "multirobot_navigation"]
    assert kinds.count(cc.HOSTILE) == 10
    assert len({f.target for f in faults if f.kind == cc.HOSTILE}) == 10
    assert all(cc.hostile_by_name(f.target) for f in faults if f.kind == cc.HOSTILE)
    assert kinds.count(cc.CUT_SUPERVISOR) == 1 and kinds.count(cc.CORRIDOR) == 2 and kinds.count(cc.FREEZE) == 2
    pairs = {(a.name, b.name) for a, b in faculty.relay_pairs()}
    assert all((f.robot, f.other) in pairs for f in faults if f.kind in cc.LINK_CUTS[:2])
    assert all(f.gap == 0.0 for f in faults if f.kind == cc.HOSTILE)
    assert cc.schedule_seconds(faults) > sum(f.duration for f in faults)


def test_quick_profile_has_every_kind(faculty) -> None:
    faults = cc.make_schedule(3, faculty, cc.PROFILES["quick"])
    assert {f.kind for f in faults} == set(cc.KINDS) - set(cc.MACHINES_ONLY) - {cc.PARTITION}
    assert all(f.duration <= 6.0 for f in faults)
    machines = cc.make_schedule(3, faculty, cc.PROFILES["quick"], machines=True)
    assert {f.kind for f in machines} == set(cc.KINDS) - {cc.CLOCK_OFFSET}      # offsets are set at start
    assert all(f.duration <= 15.0 for f in machines)


def test_full_profile_overlaps_faults_and_on_machines_adds_the_network_faults(faculty) -> None:
    loop = cc.make_schedule(1, faculty, cc.PROFILES["full"])
    kinds = [f.kind for f in loop]
    assert kinds.count(cc.MASTERS_DOWN) == 1 and kinds.count(cc.CUT_MASTER_RESTART) == 1
    [long] = [f for f in loop if f.kind == cc.PARTITION]
    assert long.duration > 120.0 and long.active                  # longer than partner_timeout, at the trip
    two = next(f for f in loop if f.kind == cc.MASTERS_DOWN)
    assert two.robot != two.other
    cut = next(f for f in loop if f.kind == cc.CUT_MASTER_RESTART)
    assert cut.target in (cut.robot, cut.other)
    assert not set(kinds) & set(cc.MACHINES_ONLY)
    net = cc.make_schedule(1, faculty, cc.PROFILES["full"], machines=True)
    kinds = [f.kind for f in net]
    assert len(net) >= 20 and {cc.FLAPPING, cc.ONE_WAY, cc.LOSSY, cc.MACHINE_DOWN} <= set(kinds)
    assert kinds.count(cc.PARTITION) == 3
    down = next(f for f in net if f.kind == cc.MACHINE_DOWN)
    assert down.duration >= 300.0 and down.robot == ""            # chosen when injected
    one = next(f for f in net if f.kind == cc.ONE_WAY)
    assert one.robot != one.other


def test_clock_offsets_spread_over_five_minutes_either_way(faculty) -> None:
    offsets = cc.clock_offsets(1, faculty, cc.PROFILES["full"])
    assert sorted(offsets) == sorted(r.name for r in faculty.robots)
    assert min(offsets.values()) == -300.0 and max(offsets.values()) == 300.0
    assert offsets == cc.clock_offsets(1, faculty, cc.PROFILES["full"])


def test_expected_table3_of_the_long_tour_is_the_papers(faculty) -> None:
    tour = parse_tour((REPO / "tours" / "long_tour.tour").read_bytes(), "long_tour.tour", faculty)
    table = cc.expected_table3(faculty, cc.tour_trips(tour, 0.0, faculty))
    assert table == {"Tartalo": (15, 7), "Kbot": (15, 8), "Galtxagorri": (15, 8), "MariSorgin": (15, 6)}


def test_expected_table3_with_two_robots_on_a_floor_and_a_floor_without() -> None:
    """Table 4 on faculty3: 223 and 274 (floor 2, no robot) make one goal; on faculty6 the robots of a floor
    share one row."""
    three, six = (load_building(REPO / "maps" / name) for name in ("faculty3", "faculty6"))
    tour = parse_tour((REPO / "tours" / "real_world.tour").read_bytes(), "real_world.tour", three)
    assert cc.tour_trips(tour, 0.0, three) == [(0, 0), (0, 0), (0, 1), (1, 1), (1, 2), (2, 3), (3, 3)]
    assert cc.expected_table3(three, cc.tour_trips(tour, 0.0, three)) == {
        "Tartalo": (7, 3), "Kbot": (7, 3), "MariSorgin": (7, 2)}
    six_table = cc.expected_table3(six, cc.tour_trips(tour, 0.0, six))
    assert six_table == {"Tartalo": (8, 3), "Kbot+Basajaun": (8, 3), "Galtxagorri+Lamia": (8, 3), "MariSorgin": (8, 2)}
    measured = {"Tartalo": (8, 3), "Kbot": (8, 3), "Basajaun": (8, 0), "Galtxagorri": (8, 1), "Lamia": (8, 2),
                "MariSorgin": (8, 2)}
    assert cc.fold_table3(six, measured) == six_table


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
    fate = cc.Bookkeeping(six, recs).fates()["T/v/1"]
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
    fates = cc.Bookkeeping(faculty, recs).fates()
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
    book = cc.Bookkeeping(faculty, recs)
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
    book = cc.Bookkeeping(faculty, recs)
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
    assert cc.Bookkeeping(faculty, recs).partner_notices() == (3, 2, ["Kbot i"])


def test_crash_tracebacks_tell_crashes_from_library_reports() -> None:
    benign = ("[rospy.internal][WARNING] 2026: Unknown error initiating TCP/IP socket to x: Traceback (most recent "
              "call last):\n  File \"a.py\", line 1, in f\nrosgraph.network.ROSHandshakeException: gone\n\n"
              "[rospy.rosout][ERROR] 2026: Unable to report rosout: [Errno 111] Connection refused\n"
              "Traceback (most recent call last):\n  File \"b.py\", line 2, in g\nKeyError: 'x'\n\n"
              "During handling of the above exception, another exception occurred:\n\n"
              "Traceback (most recent call last):\n  File \"c.py\", line 3, in h\nConnectionRefusedError: no\n"
              "--- Logging error ---\nTraceback (most recent call last):\n  File \"d.py\", line 4\nOSError: x\n")
    assert cc.crash_tracebacks(benign) == []
    crash = ("[rospy.topics][ERROR] 2026: bad callback: <bound method GoalManagerNode._enqueue>\n"
             "Traceback (most recent call last):\n  File \"gm.py\", line 9, in _enqueue\nValueError: boom\n\n"
             "Exception in thread Thread-3:\nTraceback (most recent call last):\n  File \"t.py\"\nRuntimeError: t\n"
             "Traceback (most recent call last):\n  File \"/work/main/nodes/sim\", line 5\nZeroDivisionError: z\n")
    assert cc.crash_tracebacks(crash) == ["ValueError: boom", "RuntimeError: t", "ZeroDivisionError: z"]
    assert cc.tracebacks(benign + crash) == 3


def test_roslaunch_and_supervisor_lines_are_parsed() -> None:
    text = ("\x1b[31m[goal_manager-5] process has died [pid 14940, exit code -9, cmd /x __name:=goal_manager].\n"
            "[multirobot_navigation-6] process has died [pid 77, exit code 1, cmd y].\n"
            "[WARN] [1.0]: relay end Tartalo_Kbot.b exited with -15; restarting in 0.5 s\n")
    assert cc.roslaunch_deaths(text) == [("goal_manager", 14940, -9), ("multirobot_navigation", 77, 1)]
    assert cc.relay_end_exits(text) == [("Tartalo_Kbot.b", -15)]


def test_a_person_in_the_corridor_leaves_a_way_around(faculty) -> None:
    from gidabot_navigation.building.planning import Circle, GridPlanner

    floor = faculty.floor(1.0)
    [robot] = faculty.robots_on(1.0)
    start, goal = (robot.home.x, robot.home.y), (faculty.location("110").pose.x, faculty.location("110").pose.y)
    planner = GridPlanner(floor.map, robot.radius + 0.05)
    plan = planner.plan(start, goal).points
    spot = cc.choose_obstacle(faculty, 1.0, start, plan, robot.radius)
    assert spot is not None
    x, y, r = spot
    assert math.hypot(x - start[0], y - start[1]) > 3.0
    planner.add_obstacle("p", Circle(x, y, r))
    assert math.isfinite(planner.plan(start, goal).length)
    short = [start, (start[0] + 2.0, start[1])]
    assert cc.choose_obstacle(faculty, 1.0, start, short, robot.radius) is None      # too short to block


def _result(faculty, **kw) -> cc.ChaosResult:
    f1 = cc.FaultResult(cc.Fault(cc.CUT_IPTABLES, "Tartalo", "Kbot", duration=5.0), injected=1.0, cleared=6.0,
                        recovery_s=0.4)
    f2 = cc.FaultResult(cc.Fault(cc.HOSTILE, "Kbot", target="goal_nan_pose"), injected=7.0, cleared=7.0,
                        accounted={"goal_manager: Kbot.rejected_pose": 1})
    table = {"Tartalo": (1, 1), "Kbot": (1, 0)}
    fate = cc.GoalFate("T/v/1", "Tartalo", 0.0, 0.0, "008", 0, ["Tartalo"], ["Tartalo"], completed=True)
    args = dict(seed=1, tour="t.tour", speed=5.0, faults=[f1, f2], fates={"T/v/1": fate}, duplicated_cancels={},
                table3_expected=table, table3_measured=dict(table), table3_bags=dict(table), tours_intact=True,
                tours_problems=[], crashes=[], tracebacks={}, hostile_rejected={"guiding.rejected": 3},
                partner_lost=0, partner_answered=0, tour_completed=True, outcome="completed", run_folder="/tmp/x",
                steps=[cc.StepFate(0, ["T/v/1"], completed_by="T/v/1")], table3_bags_expected=dict(table))
    args.update(kw)
    return cc.ChaosResult(**args)


def test_result_json_and_table(faculty) -> None:
    res = _result(faculty)
    doc = res.to_json()
    for key in ("accepted", "completed", "lost", "duplicated", "max_recovery_s", "faults", "table3_bags",
                "node_crashes", "requests"):
        assert key in doc
    assert [f["kind"] for f in doc["faults"]] == [cc.CUT_IPTABLES, cc.HOSTILE]
    assert doc["fault_counts"][cc.CUT_IPTABLES] == 1 and doc["fault_counts"][cc.HOSTILE] == 1
    assert doc["max_recovery_s"] == 0.4 and doc["passed"] and doc["lost"] == 0 and doc["duplicated"] == 0
    assert doc["table3_bags"] == {"Tartalo": [1, 1], "Kbot": [1, 0]}
    text = res.format()
    assert "link_cut_iptables" in text and "RESULT: PASSED" in text
    slow = _result(faculty, crashes=["Kbot/sim died (pid 1, exit code 1)"])
    slow.faults[0].recovery_s = 7.5
    assert "a recovery took 7.5 s" in slow.failures() and "1 node crash(es)" in slow.failures()
    told = _result(faculty, partner_lost=2, partner_answered=1)
    assert any("never followed" in f for f in told.failures())
    unrec = _result(faculty)
    unrec.faults[0].recovered, unrec.faults[0].recovery_s = False, None
    assert unrec.to_json()["max_recovery_s"] == "not recovered" and not unrec.to_json()["passed"]


def test_a_verdict_cannot_pass_a_dropped_trip_an_uncounted_hostile_message_or_unread_bags(faculty) -> None:
    dropped = _result(faculty, steps=[cc.StepFate(0, ["T/v/1"], system_ends=["T/v/1: partner offline from Kbot"])])
    assert any("neither completed nor ended by the visitor" in f and "partner offline from Kbot" in f
               for f in dropped.failures())
    retried = _result(faculty, steps=[cc.StepFate(0, ["T/v/1", "T/v/2"], completed_by="T/v/2",
                                                  system_ends=["T/v/1: partner offline from Kbot"])])
    assert retried.failures() == [] and retried.to_json()["ended_by_system"] == ["T/v/1: partner offline from Kbot"]
    by_visitor = _result(faculty, steps=[cc.StepFate(0, ["T/v/1"], visitor_ends=["T/v/1: cancelled at Kbot"])])
    assert by_visitor.failures() == []
    silent = _result(faculty)
    silent.faults[1].accounted = {}
    assert any("hostile message(s) not rejected and counted" in f for f in silent.failures())
    unread = _result(faculty, bags_error="Kbot.bag: cannot read bag: truncated", table3_bags={})
    assert any("bags could not be read" in f for f in unread.failures())
    off = _result(faculty, table3_bags={"Tartalo": (2, 1), "Kbot": (1, 0)})
    assert any("Table 3 from the bags" in f for f in off.failures())


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
    book = cc.Bookkeeping(faculty, recs)
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
    step_trips = cc.tour_step_trips(tour, 0.0, faculty)
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
    book = cc.Bookkeeping(faculty, recs)
    fates = book.fates()
    steps = book.visit(fates, "t.tour", 2)
    assert all(st.passed for st in steps) and book.retried_routes(steps) == {1: (3.0, 3.0)}
    expected = cc.expected_table3(faculty, cc.trips_with_retries(step_trips, book.retried_routes(steps)))
    assert cc.expected_table3(faculty, list(step_trips.values()))["Tartalo"] == (2, 2)      # the tour alone
    assert expected == {"Tartalo": (2, 1), "Kbot": (2, 0), "Galtxagorri": (2, 0), "MariSorgin": (2, 1)}
    assert book.table3(fates) == expected                                                   # what the probes saw
    assert book.table3_with(expected, fates, book.retried_goals(steps)) == {
        "Tartalo": (3, 2), "Kbot": (3, 0), "Galtxagorri": (3, 0), "MariSorgin": (3, 2)}    # the bags hold T/v/3


def test_hostile_templates_fill_in_robots() -> None:
    h = cc.hostile_by_name("cancel_ghost_robot")
    msg = cc.fill_placeholders(h.msg, "Kbot", "Tartalo")
    assert msg["goal_uid"] == "Tartalo/v/gm.x.1" and msg["origin_robot"] == "Ghost"
    big = cc.fill_placeholders(cc.hostile_by_name("goal_huge_strings").msg, "Kbot", "Tartalo")
    assert big["goal_id"] == ["__repeat__", "9", 300_000]
    with pytest.raises(KeyError):
        cc.hostile_by_name("nope")
