"""Progress of a run from monitor lines: only the visit's own trips, from the robots involved, steer it."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_navigation.guiding.messages import Trip
from gidabot_navigation.interface import (
    LEG_COMMITTED,
    LEG_NONE,
    LEG_PROPOSED,
    Node,
    Phase,
    RobotState,
    global_name,
    relay_end_name,
)
from gidabot_sim.demo.progress import Progress, Visit
from gidabot_sim.report.visits import stops_done

GM, NAV = global_name(Node.GOAL_MANAGER), global_name(Node.MULTIROBOT_NAVIGATION)
TOUR = "long_tour.tour"


def line(**kw) -> str:
    return json.dumps(kw)


def via(robot: str) -> str:
    """The callerid of ``robot``'s messages on Tartalo's master (the monitor's)."""
    if robot not in ("Kbot", "Galtxagorri", "MariSorgin", "Basajaun", "Lamia"):
        raise KeyError(robot)
    return relay_end_name("Tartalo", robot)


def goal(faculty, uid: str, origin: str, goal_id: str, step: int = -1, tour: str = TOUR, **kw) -> dict:
    """A monitor goal record as the monitor writes it (every Trip field, the publisher's node)."""
    start = faculty.robot(origin)
    loc = faculty.location(goal_id)
    cross = start.floor != loc.floor
    goal_robot = faculty.robots_on(loc.floor)[0].name if cross and faculty.has_robot(loc.floor) else ""
    trip = Trip(uid=uid, origin_robot=origin, visitor_id="sim-visitor", initial_floor=start.floor,
                initial_x=start.home.x, initial_y=start.home.y, goal_floor=loc.floor, goal_x=loc.pose.x,
                goal_y=loc.pose.y, goal_yaw=loc.pose.yaw, way="stairs", connector="stairs_west" if cross else "",
                start_id="robot", goal_id=goal_id, language="en", tour_file=tour, tour_step=step,
                start_robot=origin, start_state=LEG_COMMITTED, goal_robot=goal_robot,
                goal_state=LEG_COMMITTED if goal_robot else LEG_NONE, attempt=2)
    rec = {"kind": "goal", "callerid": GM if origin == "Tartalo" else via(origin), "sim": 0.0, "wall": 0.0,
           **asdict(trip)}
    rec.update(kw)
    return rec


def event(robot: str, phase: int, goal_uid: str, sim: float = 0.0, wall: float = 0.0, callerid: str | None = None,
          **kw) -> str:
    return line(kind="event", robot=robot, phase=phase, goal_uid=goal_uid, sim=sim, wall=wall,
                callerid=callerid if callerid is not None else (NAV if robot == "Tartalo" else via(robot)), **kw)


@pytest.fixture(scope="module")
def faculty():
    return load_building(Path(__file__).resolve().parents[4] / "maps" / "faculty")


@pytest.fixture(scope="module")
def faculty3():
    return load_building(Path(__file__).resolve().parents[4] / "maps" / "faculty3")


@pytest.fixture(scope="module")
def faculty6():
    return load_building(Path(__file__).resolve().parents[4] / "maps" / "faculty6")


@pytest.fixture
def tour(faculty) -> Progress:
    return Progress(total_goals=2, visit=Visit(faculty, "Tartalo", TOUR, start_floor=0.0))


def test_tour_progress_and_end(faculty, tour: Progress) -> None:
    p = tour
    g1 = goal(faculty, "Tartalo/sim-visitor/a.1", "Tartalo", "014", 0, sim=100.0, wall=10.0)
    assert p.feed_line(json.dumps(g1))
    assert not p.feed_line(json.dumps(g1))                                   # seen
    p.feed_line(event("Tartalo", 1, g1["uid"], 101, 10.1))
    assert p.line() == "goal 1 of 2 (014 0->0), 0 done | Tartalo: on the way"
    p.feed_line(event("Tartalo", 13, g1["uid"], 150, 15, callerid=NAV))
    g2 = goal(faculty, "Tartalo/sim-visitor/a.2", "Tartalo", "008", 1, sim=160.0, wall=16.0)
    p.feed_line(json.dumps(g2))
    p.feed_line(event("Tartalo", 14, g2["uid"], 300, 30, callerid=GM))
    assert p.finished and p.outcome == "completed" and len(p.completed) == 2
    assert p.sim_seconds() == 200 and p.wall_seconds() == 20


def test_a_failure_of_the_visit_ends_it_and_garbage_is_ignored(faculty) -> None:
    p = Progress(total_goals=1, visit=Visit(faculty, "Tartalo", goal_id="305", start_floor=0.0))
    assert not p.feed_line("not json")
    assert not p.feed_line("[1, 2]")
    g = goal(faculty, "Tartalo/sim-visitor/b.1", "Tartalo", "305", tour="")
    p.feed_line(json.dumps(g))
    p.feed_line(event("MariSorgin", 6, g["uid"], 5, 1, detail="no path"))
    assert p.finished and p.outcome.startswith("unreachable (MariSorgin: no path")


def test_a_visitor_lost_ends_the_visit(faculty) -> None:
    p = Progress(total_goals=1, visit=Visit(faculty, "Tartalo", goal_id="101", start_floor=0.0))
    g = goal(faculty, "Tartalo/sim-visitor/d.1", "Tartalo", "101", tour="")
    p.feed_line(json.dumps(g))
    p.feed_line(event("Tartalo", Phase.SEARCHING_VISITOR, g["uid"], 60, 6))
    assert not p.finished
    p.feed_line(event("Tartalo", Phase.VISITOR_LOST, g["uid"], 120, 12, detail="not found again"))
    assert p.finished and p.outcome == "visitor lost (Tartalo: not found again)" and p.done == 0
    assert p.sim_seconds() == 120


def test_single_target_done(faculty) -> None:
    p = Progress(total_goals=1, visit=Visit(faculty, "Tartalo", goal_id="101", start_floor=0.0))
    g = goal(faculty, "Tartalo/sim-visitor/c.1", "Tartalo", "101", tour="")
    p.feed_line(json.dumps(g))
    p.feed_line(line(kind="status", robot="Kbot", state=RobotState.IDLE))
    p.feed_line(event("Kbot", 2, g["uid"], 50, 5))
    assert p.finished and p.outcome == "completed" and p.states == {"Kbot": "idle"}


def test_start_up_then_goal_numbers_follow_the_tour_step(faculty) -> None:
    p = Progress(total_goals=15, visit=Visit(faculty, "Tartalo", TOUR, start_floor=0.0), robots_total=4)
    assert p.feed_line(line(kind="up", robot="Kbot", sim=0, wall=0))
    assert not p.feed_line(line(kind="up", robot="Kbot", sim=0, wall=0))
    assert p.line() == "starting: 1 of 4 robots up (Kbot)"
    p.feed_line(json.dumps(goal(faculty, "Tartalo/sim-visitor/d.1", "Tartalo", "001", 0, sim=1, wall=1)))
    b = goal(faculty, "Tartalo/sim-visitor/d.2", "Tartalo", "305", 1, sim=2, wall=2)
    p.feed_line(json.dumps(b))
    p.feed_line(event("MariSorgin", 4, b["uid"], 3, 3))
    assert p.line() == "goal 2 of 15 (305 0->3), 0 done | MariSorgin: going to meeting point"
    # a skip cancels the running step: not the end of the visit
    p.feed_line(event("MariSorgin", 9, b["uid"], 4, 4))
    p.feed_line(event("Tartalo", 15, b["uid"], 4, 4))
    assert not p.finished and p.line().endswith("Tartalo: partner lost")


def test_an_unfinished_run_is_measured_up_to_its_newest_record(faculty, tour: Progress) -> None:
    p = tour
    a = goal(faculty, "Tartalo/sim-visitor/e.1", "Tartalo", "014", 0, sim=100.0, wall=10.0)
    p.feed_line(json.dumps(a))
    p.feed_line(event("Tartalo", 1, a["uid"], 160.0, 13.0))
    assert not p.finished and p.sim_seconds() == 60.0 and p.wall_seconds() == 3.0


def test_stops_found_alone_count_as_done(faculty3) -> None:
    """Table 4 on faculty3: steps 4 and 5 are on floor 2 (no robot); the goal of step 4 sends the visitor there,
    step 5 gets no goal; the tour goes on at step 6."""
    assert stops_done({0, 1, 2, 3, 4, 6, 7}, frozenset({4, 5})) == set(range(8))
    assert stops_done({0, 1, 2, 3}, frozenset({4, 5})) == {0, 1, 2, 3}      # not sent there yet
    p = Progress(total_goals=8, visit=Visit(faculty3, "Tartalo", TOUR, start_floor=0.0), alone=frozenset({4, 5}))
    for k, goal_id, phase in ((3, "113", 13), (4, "223", 7), (6, "301", 13), (7, "305", 14)):
        g = goal(faculty3, f"Kbot/sim-visitor/g{k}", "Kbot", goal_id, k, sim=k, wall=k)
        p.feed_line(json.dumps(g))
        robot = "Kbot" if phase in (Phase.NO_ROBOT_ON_FLOOR, Phase.TOUR_STEP_DONE) and k < 6 else "MariSorgin"
        p.feed_line(event(robot, phase, g["uid"], k, k))
    assert p.done == 5 and p.finished and p.outcome == "completed"      # steps 3..7 (5: found alone)


def test_a_single_target_on_a_floor_without_robot_is_done_when_the_visitor_is_sent_there(faculty3) -> None:
    p = Progress(total_goals=1, visit=Visit(faculty3, "Tartalo", goal_id="223", start_floor=0.0))
    g = goal(faculty3, "Tartalo/sim-visitor/h.1", "Tartalo", "223", tour="")
    p.feed_line(json.dumps(g))
    p.feed_line(event("Tartalo", 7, g["uid"], 50, 5, callerid=NAV))
    assert p.finished and p.outcome == "completed" and p.done == 1


def test_a_robot_named_by_a_newer_assignment_steers_the_visit(faculty6) -> None:
    """faculty6: the goal leg first proposed to Galtxagorri, then (attempt 3) committed to Lamia: Lamia's events
    count, those of a robot never named (Basajaun) do not."""
    p = Progress(total_goals=1, visit=Visit(faculty6, "Tartalo", goal_id="223", start_floor=0.0))
    g = goal(faculty6, "Tartalo/sim-visitor/i.1", "Tartalo", "223", tour="", goal_state=LEG_PROPOSED)
    assert p.feed_line(json.dumps(g))
    newer = {**g, "goal_robot": "Lamia", "goal_state": LEG_COMMITTED, "attempt": 3}     # the same trip
    assert not p.feed_line(json.dumps(newer))
    assert not p.feed_line(event("Basajaun", 2, g["uid"], 40, 4))
    assert p.feed_line(event("Lamia", 2, g["uid"], 50, 5))
    assert p.finished and p.outcome == "completed"


def test_hostile_traffic_does_not_steer_the_visit(faculty, tour: Progress) -> None:
    """Hostile traffic must not stop the demo (as 'unreachable (Kbot: ... about an unknown trip)'): only the
    visit's own trips, from the robots they involve, published by those robots' nodes, count."""
    p = tour
    mine = goal(faculty, "Tartalo/sim-visitor/f.1", "Tartalo", "305", 0, sim=1, wall=1)   # floor 0 -> 3
    p.feed_line(json.dumps(mine))
    uid = mine["uid"]
    hostile = [
        event("Kbot", 6, "Kbot/x/unknown-trip", detail="about an unknown trip"),          # a trip that does not exist
        event("Kbot", 6, uid, detail="Kbot is not involved (floor 1)"),                   # a robot not involved
        event("MariSorgin", 6, uid, callerid="/hostile", detail="forged on Tartalo's master"),
        event("Tartalo", 6, uid, callerid=via("MariSorgin"), detail="Tartalo's event through a relay"),
        event("Mallory", 6, uid, callerid=via("MariSorgin")),                              # not a robot
        event("MariSorgin", 14, uid, callerid=via("Kbot")),                     # MariSorgin's, via Kbot's relay
        event("Tartalo", 12, "", callerid="/hostile", tour_file=TOUR),                    # a forged refusal
        event("Kbot", 12, "", tour_file=TOUR),                                            # not the start robot
        line(kind="event", robot="MariSorgin", phase="x", goal_uid=uid, callerid=via("MariSorgin")),
    ]
    for text in hostile:
        assert not p.feed_line(text), text
    forged_goals = [
        goal(faculty, "Kbot/v/1", "Kbot", "101", 1, callerid="/hostile"),                  # not from Kbot's relay
        goal(faculty, "Tartalo/v/2", "Tartalo", "014", 1, tour="other.tour"),               # another visit's
        {**goal(faculty, "Tartalo/v/3", "Tartalo", "014", 1), "goal_id": "nowhere"},        # invalid
        goal(faculty, "Tartalo/v/4", "Tartalo", "014", 1, initial_floor=float("nan")),      # invalid
        {"kind": "goal", "uid": "Tartalo/v/5", "callerid": GM, "tour_file": TOUR},          # half a goal
    ]
    for rec in forged_goals:
        assert not p.feed_line(json.dumps(rec)), rec
    assert not p.finished and p.goal_index == 1 and p.ignored == len(hostile) + len(forged_goals)
    # the robots involved, through their own nodes: these do steer it
    assert p.feed_line(event("MariSorgin", 6, uid, detail="no path"))
    assert p.finished and p.outcome.startswith("unreachable (MariSorgin: no path")


def test_the_start_robot_refusing_the_visitor_ends_the_visit(faculty, tour: Progress) -> None:
    assert tour.feed_line(event("Tartalo", 12, "", callerid=GM, tour_file=TOUR, detail="unknown tour"))
    assert tour.finished and tour.outcome.startswith("rejected (Tartalo")
