"""Tour mode across the whole simulated building.

The paper's Table 4 tour (`tours/real_world.tour`: 8 goals over 4 floors) runs with the simulated
visitor to TOUR_FINISHED: 4 masters linked by the relays, `launch/robot.launch sim:=true gui:=false`
on every one with the visitor arguments (`visitor:=true visitor_tour:=real_world.tour
visitor_skips:=[[3, 5]]`: one visitor node per floor playing one person, as `gidabot demo` starts it).
After step 3 is done the visitor skips to step 5, so step 4 is never issued. A recorder on
Tartalo's master sees every goal, event and cancel of every robot (through the relays).

Checked: the goals issued are the tour's steps minus the skipped one, in order, each from the robot
where the previous step ended and handled by the robot of its floor; every step is completed
(TOUR_STEP_DONE, the last TOUR_FINISHED) by that robot at that room; every floor change is a
handover at one connector (GO_TO_FLOOR and WAITING_VISITOR name the goal's connector); nothing
failed or was cancelled. Sim and wall times of the tour and of each step are printed.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
from sim_stack import (
    CANCELS,
    EVENTS,
    FAILURES,
    GO_TO_FLOOR,
    GOALS,
    PENDING,
    ROBOTS,
    TOUR_FINISHED,
    TOUR_STEP_DONE,
    WAITING_VISITOR,
    SimStack,
)

from gidabot_navigation.building.model import load_building
from gidabot_navigation.tours.tour_file import parse_tour
from gidabot_sim.runner.procs import wait_until

pytestmark = [pytest.mark.system, pytest.mark.slow]

SPEED = 20.0
TOUR_FILE = "real_world.tour"
SKIP = (3, 5)                 # after step 3 (0-based) is done, go to step 5
TOUR_WALL = 240.0             # wall s allowed for the tour (about 40 s at 20x on a quiet machine)


@pytest.fixture(scope="module")
def stack(tmp_path_factory) -> Iterator[SimStack]:
    visitor = {"visitor": "true", "visitor_tour": TOUR_FILE, "visitor_way": "stairs", "visitor_start_floor": "0",
               "visitor_skips": f"[[{SKIP[0]}, {SKIP[1]}]]"}
    record = {r: (PENDING,) for r in ROBOTS}
    record["Tartalo"] = (EVENTS, GOALS, CANCELS, PENDING)
    # sim time starts 12 s after the launches: the recorders are subscribed before the visitor can start
    with SimStack(tmp_path_factory.mktemp("tour_mode"), speed=SPEED, common_args=visitor, record=record,
                  start_delay=12.0) as st:
        yield st


@pytest.mark.timeout(420)
def test_real_world_tour_with_a_skip_runs_to_the_end(stack: SimStack) -> None:
    t0 = time.monotonic()
    rec = stack.rec["Tartalo"]
    assert rec.msgs(GOALS) == [], "the tour started before the recorder was subscribed"
    building = load_building(stack.sim.building_file)
    tour = parse_tour((stack.sim.seed_tours / TOUR_FILE).read_bytes(), TOUR_FILE, building)
    assert len(tour.goals) == 8 and len({g.floor for g in tour.goals}) == 4
    steps = [k for k in range(len(tour.goals)) if not SKIP[0] < k < SKIP[1]]   # 0, 1, 2, 3, 5, 6, 7
    robot_of = {k: building.robots_on(g.floor)[0].name for k, g in enumerate(tour.goals)}

    def failed(m: dict) -> bool:
        if m["phase"] in FAILURES:
            raise AssertionError(f"the tour failed: {m}")
        return m["phase"] == TOUR_FINISHED
    finished = rec.wait(EVENTS, failed, TOUR_WALL, "TOUR_FINISHED")
    wall = time.monotonic() - t0

    # each goal as last assigned (it is broadcast again with every change of who serves its legs)
    newest: dict[str, dict] = {}
    for g in rec.msgs(GOALS):
        if g["tour_file"] == TOUR_FILE and g["attempt"] >= newest.get(g["uid"], {"attempt": -1})["attempt"]:
            newest[g["uid"]] = g
    goals = sorted(newest.values(), key=lambda g: g["header"]["stamp"])
    events = [e for e in rec.msgs(EVENTS) if e["tour_file"] == TOUR_FILE]
    done = [e for e in events if e["phase"] in (TOUR_STEP_DONE, TOUR_FINISHED)]
    sim0 = goals[0]["header"]["stamp"] if goals else 0.0
    lines = []
    for g in goals:
        end = next((e for e in done if e["goal_uid"] == g["uid"]), None)
        lines.append(f"  step {g['tour_step']} {g['goal_id']} (floor {g['goal_floor']:g}, {g['origin_robot']} -> "
                     f"{robot_of.get(g['tour_step'], '?')}{', ' + g['connector'] if g['connector'] else ''}): done at "
                     f"sim +{(end['header']['stamp'] - sim0) if end else float('nan'):.0f} s")
    print(f"\n[tour mode] {TOUR_FILE} with the skip {SKIP[0]} -> {SKIP[1]}: TOUR_FINISHED after sim "
          f"{finished['header']['stamp'] - sim0:.0f} s, wall {wall:.1f} s (from the stack being up; speed "
          f"{SPEED:g}x)\n" + "\n".join(lines))

    # the goals issued: the tour minus the skipped step, in order, each from where the last one ended
    assert [g["tour_step"] for g in goals] == steps
    assert len({g["uid"] for g in goals}) == len(goals)
    for g in goals:
        want = tour.goals[g["tour_step"]]
        assert (g["goal_id"], g["goal_floor"]) == (want.room, want.floor), g
        assert g["way"] == "stairs"
    assert goals[0]["origin_robot"] == "Tartalo"
    for prev, g in zip(goals, goals[1:], strict=False):
        assert g["origin_robot"] == robot_of[prev["tour_step"]], (prev, g)
        assert g["initial_floor"] == prev["goal_floor"]

    # every step completed by the robot of its floor, at its room; the last one finishes the tour
    assert [(e["goal_uid"], e["robot"], e["location_id"]) for e in done] == \
        [(g["uid"], robot_of[g["tour_step"]], g["goal_id"]) for g in goals]
    assert [e["phase"] for e in done] == [TOUR_STEP_DONE] * (len(steps) - 1) + [TOUR_FINISHED]
    assert finished["goal_uid"] == goals[-1]["uid"] and finished["tour_step"] == steps[-1]

    # floor changes: handed over at the goal's connector (start robot releases, goal robot waits)
    changes = [g for g in goals if g["initial_floor"] != g["goal_floor"]]
    assert len(changes) == 3
    for g in changes:
        mine = [e for e in events if e["goal_uid"] == g["uid"]]
        release = [e for e in mine if e["phase"] == GO_TO_FLOOR]
        wait = [e for e in mine if e["phase"] == WAITING_VISITOR]
        assert [e["robot"] for e in release] == [g["origin_robot"]], mine
        assert [e["robot"] for e in wait] == [robot_of[g["tour_step"]]], mine
        assert release[0]["connector"] == wait[0]["connector"] == g["connector"] != ""

    # nothing failed, nothing was cancelled, and every robot's queue is empty at the end
    assert not [e for e in rec.msgs(EVENTS) if e["phase"] in FAILURES]
    assert rec.msgs(CANCELS) == []
    for r in ROBOTS:
        wait_until(lambda r=r: (stack.pending(r, r) or {}).get("num") == 0, 10, f"{r}'s empty queue")
