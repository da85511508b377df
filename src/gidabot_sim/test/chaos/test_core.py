"""The chaos core without ROS: schedules, bookkeeping of goals, Table 3, crash logs, obstacles, the table."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_navigation.interface import Node, Phase, global_name, relay_end_name
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
    assert {f.kind for f in faults} == set(cc.KINDS)
    assert all(f.duration <= 6.0 for f in faults)


def test_expected_table3_of_the_long_tour_is_the_papers(faculty) -> None:
    tour = parse_tour((REPO / "tours" / "long_tour.tour").read_bytes(), "long_tour.tour", faculty)
    table = cc.expected_table3(faculty, cc.tour_trips(tour, 0.0))
    assert table == {"Tartalo": (15, 7), "Kbot": (15, 8), "Galtxagorri": (15, 8), "MariSorgin": (15, 6)}


def _goal(m: str, uid: str, origin: str, a: float, b: float, caller: str = "", w: float = 0.0) -> dict:
    return {"k": "goal", "m": m, "c": caller or (GM if m == origin else relay_end_name(origin, m)),
            "w": w, "uid": uid, "origin": origin, "initial_floor": a, "goal_floor": b, "goal_id": "x",
            "tour_step": 0}


def _ev(m: str, robot: str, goal: str, phase: int, uid: str, w: float = 0.0) -> dict:
    caller = NAV if m == robot else relay_end_name(robot, m)
    return {"k": "event", "m": m, "c": caller, "w": w, "uid": uid, "robot": robot, "goal_uid": goal, "phase": phase}


ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")


def _everywhere(rec_fn, *args, **kw) -> list[dict]:
    return [rec_fn(m, *args, **kw) for m in ROBOTS]


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
    assert fates["T/v/2"].lost and fates["T/v/2"].duplicated == ["delivered 2 times on Kbot's master"]
    assert fates["K/v/3"].cancelled and not fates["K/v/3"].lost
    assert fates["K/v/4"].duplicated == ["Kbot accepted it 2 times"] and not fates["K/v/4"].lost
    assert book.foreign["event"] == 1
    table = book.table3(fates)
    assert table["Tartalo"] == (3, 2) and table["Kbot"] == (3, 2) and table["MariSorgin"] == (3, 0)
    assert book.duplicated_cancels() == {}


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
    robot = faculty.robot_on(1.0)
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
    f2 = cc.FaultResult(cc.Fault(cc.HOSTILE, "Kbot", target="goal_nan_pose"), injected=7.0, cleared=7.0)
    table = {"Tartalo": (1, 1), "Kbot": (1, 0)}
    fate = cc.GoalFate("T/v/1", "Tartalo", 0.0, 0.0, "008", 0, ["Tartalo"], ["Tartalo"], completed=True)
    args = dict(seed=1, tour="t.tour", speed=5.0, faults=[f1, f2], fates={"T/v/1": fate}, duplicated_cancels={},
                table3_expected=table, table3_measured=dict(table), table3_bags=dict(table), tours_intact=True,
                tours_problems=[], crashes=[], tracebacks={}, hostile_rejected={"guiding.rejected": 3},
                partner_lost=0, partner_answered=0, tour_completed=True, outcome="completed", run_folder="/tmp/x")
    args.update(kw)
    return cc.ChaosResult(**args)


def test_result_json_and_table(faculty) -> None:
    res = _result(faculty)
    doc = res.to_json()
    for key in ("faults", "goals_accepted", "goals_completed", "goals_lost", "goals_duplicated", "max_recovery_s",
                "node_crashes"):
        assert key in doc
    assert doc["faults"][cc.CUT_IPTABLES] == 1 and doc["faults"][cc.HOSTILE] == 1
    assert doc["max_recovery_s"] == 0.4 and doc["passed"] and doc["goals_lost"] == 0
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


def test_hostile_templates_fill_in_robots() -> None:
    h = cc.hostile_by_name("cancel_ghost_robot")
    msg = cc.fill_placeholders(h.msg, "Kbot", "Tartalo")
    assert msg["goal_uid"] == "Tartalo/v/gm.x.1" and msg["origin_robot"] == "Ghost"
    big = cc.fill_placeholders(cc.hostile_by_name("goal_huge_strings").msg, "Kbot", "Tartalo")
    assert big["goal_id"] == ["__repeat__", "9", 300_000]
    with pytest.raises(KeyError):
        cc.hostile_by_name("nope")
