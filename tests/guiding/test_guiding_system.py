"""Guiding across the whole simulated building (multi-master).

Four masters on this session's loopback addresses joined by the relays (6 relays, HMAC), and on
every one `launch/robot.launch sim:=true gui:=false`: simulator + move_base/amcl stand-ins,
goal_manager + multirobot_navigation, tour store. A recorder probe on every master plays the
visitor (visitor/command) and records events, goals, cancels, pending lists, move_base results
and amcl poses. Sim time runs at SPEED x real time.

- a same-floor goal is guided to GOAL_REACHED by the floor's robot alone;
- a floor 0 -> floor 3 goal by the stairs: Tartalo guides to the staircase that minimises the
  whole trip and says GO_TO_FLOOR; MariSorgin waits at the SAME staircase (events, goal, poses),
  Continue is pressed there, it guides on to GOAL_REACHED;
- a cancel at the start floor while MariSorgin drives to the meeting point: CANCELLED_HERE at
  Tartalo, CANCELLED_ELSEWHERE at MariSorgin, both move_base goals preempted, both queues empty,
  MariSorgin stops where it is.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
from sim_stack import (
    ACCEPTED,
    ASSIGNED,
    CANCEL,
    CANCELLED_ELSEWHERE,
    CANCELLED_HERE,
    CONTINUE,
    EVENTS,
    GO_TO_FLOOR,
    GOAL_REACHED,
    GOALS,
    GOING_TO_MEETING,
    MB_RESULT,
    ON_THE_WAY,
    PENDING,
    PREEMPTED,
    ROBOTS,
    SUCCEEDED,
    WAITING_VISITOR,
    SimStack,
    dist,
)

from gidabot_sim.runner.procs import wait_until

pytestmark = [pytest.mark.system, pytest.mark.slow]

SPEED = 20.0            # sim seconds per wall second
HOME = (30.0, 12.0)     # every robot's home in the faculty
TRIP_WALL = 120.0       # wall s allowed for one trip (about 5-15 s at 20x on a quiet machine)


@pytest.fixture(scope="module")
def stack(tmp_path_factory) -> Iterator[SimStack]:
    t0 = time.monotonic()
    with SimStack(tmp_path_factory.mktemp("guiding_system"), speed=SPEED) as st:
        ready = st.wait_ready(timeout=180)
        print(f"\n[guiding] 4 robots' stacks up in {time.monotonic() - t0:.1f} s wall "
              f"(relays and every partner seen after {ready:.1f} s)")
        yield st


def phases(stack: SimStack, goal_uid: str, robot: str, on: str = "Tartalo") -> list[int]:
    """The robot's phases for the trip, as seen on ``on``'s master, in the order they happened.

    goal_manager (uid tag ``gm``) and multirobot_navigation (``nav``) publish on their own
    connections, so a subscriber may get, e.g., ON_THE_WAY before ACCEPTED; the order of each
    node's own events is kept, and the goal_manager's ACCEPTED never comes after the
    navigation's first event in sim time. Returns ACCEPTED (if any) followed by the navigation's
    phases, after checking that (the origin robot's ASSIGNED, the legs' bookkeeping, left out)."""
    events = [e for e in stack.events(on, goal_uid, robot) if e["phase"] != ASSIGNED]
    gm = [e for e in events if e["uid"].split("/")[-1].startswith("gm.")]
    nav = [e for e in events if not e["uid"].split("/")[-1].startswith("gm.")]
    accepted = [e for e in gm if e["phase"] == ACCEPTED]
    if accepted and nav:
        assert accepted[0]["header"]["stamp"] <= nav[0]["header"]["stamp"], (accepted[0], nav[0])
    return [e["phase"] for e in accepted] + [e["phase"] for e in nav] + \
        [e["phase"] for e in gm if e["phase"] != ACCEPTED]


def sim_s(event: dict) -> float:
    return float(event["header"]["stamp"])


@pytest.mark.timeout(300)
def test_same_floor_goal_completes(stack: SimStack) -> None:
    wall0 = time.monotonic()
    mb_since = stack.rec["Tartalo"].count(MB_RESULT)
    uid, since = stack.request("Tartalo", "014")
    done = stack.wait_event("Tartalo", GOAL_REACHED, uid, timeout=TRIP_WALL, since=since)
    first = min(stack.events("Tartalo", uid, "Tartalo"), key=sim_s)
    wall = time.monotonic() - wall0
    print(f"\n[guiding] same floor (Tartalo -> 014): sim {sim_s(done) - sim_s(first):.1f} s, wall {wall:.1f} s")

    assert phases(stack, uid, "Tartalo") == [ACCEPTED, ON_THE_WAY, GOAL_REACHED]
    assert done["location_id"] == "014" and done["floor"] == 0.0
    for other in ROBOTS[1:]:   # every robot got the goal, none of the others keeps it
        stack.rec[other].wait(GOALS, lambda m: m["uid"] == uid, 10, f"the goal at {other}")
        assert stack.events("Tartalo", uid, other) == [], f"{other} took part in a floor-0 trip"
    goal = stack.rec["Tartalo"].latest(GOALS, lambda m: m["uid"] == uid)
    assert goal is not None and (goal["goal_floor"], goal["connector"]) == (0.0, "")
    assert dist(stack.pose("Tartalo"), stack.location("014")) < 0.4
    res = stack.rec["Tartalo"].wait(MB_RESULT, lambda m: True, 10, "Tartalo's move_base result", since=mb_since)
    assert res["status"]["status"] == SUCCEEDED
    wait_until(lambda: stack.pending("Tartalo", "Tartalo")["num"] == 0, 10, "Tartalo's empty queue")


@pytest.mark.timeout(300)
def test_floor0_to_floor3_by_stairs_meets_at_the_same_staircase(stack: SimStack) -> None:
    stack.relocate("Tartalo", *HOME)
    stack.relocate("MariSorgin", *HOME)
    wall0 = time.monotonic()
    uid, since = stack.request("Tartalo", "311", way="stairs")
    goal = stack.rec["Tartalo"].wait(GOALS, lambda m: m["uid"] == uid, 10, "the broadcast goal")
    conn = goal["connector"]
    assert (goal["initial_floor"], goal["goal_floor"], goal["way"], goal["goal_id"]) == (0.0, 3.0, "stairs", "311")

    # the staircase minimises the whole trip (both corridors are straight: lengths ~ distances)
    start = (goal["initial_pose"]["x"], goal["initial_pose"]["y"])
    target = stack.location("311")
    legs = {c.id: dist(start, stack.meeting(c.id, 0)) + dist(stack.meeting(c.id, 3), target)
            for c in stack.building.connectors_between(0, 3, "stairs")}
    assert len(legs) == 2 and conn == min(legs, key=legs.get), (conn, legs)

    # MariSorgin drives to that staircase at once; Tartalo guides there and releases the visitor
    to_meet = stack.wait_event("MariSorgin", GOING_TO_MEETING, uid, timeout=30, on="Tartalo", since=since)
    released = stack.wait_event("Tartalo", GO_TO_FLOOR, uid, timeout=TRIP_WALL, since=since)
    assert (released["connector"], released["target_floor"], released["way"]) == (conn, 3.0, "stairs")
    assert dist(stack.pose("Tartalo"), stack.meeting(conn, 0)) < 0.5, stack.pose("Tartalo")
    waiting = stack.wait_event("MariSorgin", WAITING_VISITOR, uid, timeout=TRIP_WALL, since=since)
    assert to_meet["connector"] == waiting["connector"] == conn
    assert dist(stack.pose("MariSorgin"), stack.meeting(conn, 3)) < 0.5, stack.pose("MariSorgin")

    # the visitor arrives upstairs and presses Continue on MariSorgin's screen
    stack.command("MariSorgin", CONTINUE, goal_uid=uid)
    done = stack.wait_event("MariSorgin", GOAL_REACHED, uid, timeout=TRIP_WALL, since=since)
    wall = time.monotonic() - wall0
    first = min(stack.events("Tartalo", uid, "Tartalo"), key=sim_s)
    print(f"\n[guiding] floor 0 -> 3 by the stairs ({conn}): sim {sim_s(done) - sim_s(first):.1f} s, wall {wall:.1f} s"
          f"; Tartalo released the visitor at sim +{sim_s(released) - sim_s(first):.1f} s, MariSorgin waited "
          f"from +{sim_s(waiting) - sim_s(first):.1f} s")

    assert dist(stack.pose("MariSorgin"), target) < 0.4
    seen_on = {"Tartalo", "MariSorgin"}
    for on in seen_on:   # the same story on both robots' masters
        assert phases(stack, uid, "Tartalo", on) == [ACCEPTED, ON_THE_WAY, GO_TO_FLOOR], on
        assert phases(stack, uid, "MariSorgin", on) == [ACCEPTED, GOING_TO_MEETING, WAITING_VISITOR, ON_THE_WAY,
                                                        GOAL_REACHED], on
    for other in ("Kbot", "Galtxagorri"):
        assert stack.events("Tartalo", uid, other) == [], f"{other} took part in a floor 0 -> 3 trip"
    for r in ("Tartalo", "MariSorgin"):
        wait_until(lambda r=r: stack.pending(r, r)["num"] == 0, 10, f"{r}'s empty queue")


@pytest.mark.timeout(300)
def test_cancel_on_the_start_floor_stops_the_partner(stack: SimStack) -> None:
    stack.relocate("Tartalo", *HOME)
    stack.relocate("MariSorgin", 8.0, 12.0)        # far from the east staircase: a long drive to meet
    mb = {r: stack.rec[r].count(MB_RESULT) for r in ("Tartalo", "MariSorgin")}
    uid, since = stack.request("Tartalo", "311", way="stairs")
    stack.wait_event("Tartalo", ON_THE_WAY, uid, timeout=30, since=since)
    stack.wait_event("MariSorgin", GOING_TO_MEETING, uid, timeout=30)
    goal = stack.rec["MariSorgin"].wait(GOALS, lambda m: m["uid"] == uid, 10, "the goal at MariSorgin")
    meet = stack.meeting(goal["connector"], 3)
    start = (8.0, 12.0)
    wait_until(lambda: dist(stack.pose("MariSorgin"), start) > 1.0, 30, "MariSorgin driving to the meeting point")

    n_t, n_m = stack.rec["Tartalo"].count(EVENTS), stack.rec["MariSorgin"].count(EVENTS)
    pend = {r: stack.rec[r].count(PENDING) for r in ("Tartalo", "MariSorgin")}
    t_cancel = time.monotonic()
    stack.command("Tartalo", CANCEL, goal_uid=uid)
    here = stack.wait_event("Tartalo", CANCELLED_HERE, uid, timeout=20, since=n_t)
    away = stack.wait_event("MariSorgin", CANCELLED_ELSEWHERE, uid, timeout=20, since=n_m)
    t_seen = time.monotonic() - t_cancel
    assert here["goal_uid"] == away["goal_uid"] == uid

    # both move_base goals preempted, both queues empty
    for r in ("Tartalo", "MariSorgin"):
        res = stack.rec[r].wait(MB_RESULT, lambda m: True, 20, f"{r}'s move_base result", since=mb[r])
        assert res["status"]["status"] == PREEMPTED, (r, res["status"])
        stack.rec[r].wait(PENDING, lambda m, r=r: m["robot"] == r and m["num"] == 0, 10, f"{r}'s empty queue",
                          since=pend[r])
        assert stack.pending(r, r)["num"] == 0
    stopped_at = stack.pose("MariSorgin")
    print(f"\n[guiding] cancel at Tartalo: CANCELLED_ELSEWHERE from MariSorgin after {t_seen:.2f} s wall; "
          f"MariSorgin stopped {dist(stopped_at, meet):.1f} m before the meeting point")
    assert dist(stopped_at, meet) > 5.0, "MariSorgin was at the meeting point already: nothing was stopped"

    # it stays there for 20 s of its floor's sim time (negative check: a robot still driving would cover ~10 m
    # in that time; braking from 0.5 m/s at 0.4 m/s^2 takes ~0.3 m)
    sim0 = stack.sim.clocks()["MariSorgin"].sim
    wait_until(lambda: stack.sim.clocks()["MariSorgin"].sim >= sim0 + 20.0, 60, "20 s of MariSorgin's sim time")
    assert dist(stack.pose("MariSorgin"), stopped_at) < 1.0
    for r in ("Tartalo", "MariSorgin"):
        late = [e["phase"] for e in stack.events(r, uid, r, since=n_t if r == "Tartalo" else n_m)]
        assert late == [CANCELLED_HERE if r == "Tartalo" else CANCELLED_ELSEWHERE], (r, late)
    stack.wait_event("MariSorgin", CANCELLED_ELSEWHERE, uid, timeout=10, on="Tartalo")   # relayed to the start floor
