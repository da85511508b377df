"""Who serves a leg, on six masters (a partition at the decision).

maps/faculty6: six robots, each on its own master, linked by the 15 relays, `launch/robot.launch sim:=true
gui:=false` on every one. A visitor at Tartalo (floor 0) asks for 223 on floor 2 by the stairs: of floor 2's
two robots Galtxagorri (home x 30) is nearer the west staircase's meeting point than Lamia (x 54), so it is
the one proposed. Its links to every other robot are cut with iptables just before the request: it is still
heard a moment ago, so it is asked; it cannot answer; after `answer_timeout` Tartalo gives the leg to Lamia.
The trip is run to its end by Lamia. Then the cut is lifted: the relays deliver the old proposal to
Galtxagorri, which answers it (too late, ignored), sees the newer assignment and drops it.

Checked from what each master received (the goals and events recorded on all six): the goal leg is
committed to Lamia only, only Lamia sent serving phases for it, Galtxagorri never moved for it, every
leg has exactly one robot (`audit_legs`), nothing is left queued.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator

import pytest
from sim_stack import (
    ACCEPTED,
    ASSIGNED,
    CONTINUE,
    EVENTS,
    GO_TO_FLOOR,
    GOAL_REACHED,
    GOALS,
    GOING_TO_MEETING,
    ON_THE_WAY,
    REPO,
    WAITING_VISITOR,
    SimStack,
)

from gidabot_navigation.guiding.assignment import audit_legs
from gidabot_navigation.guiding.messages import Trip
from gidabot_navigation.interface import LEG_COMMITTED, LEG_GOAL, LEG_START, SERVING_PHASES
from gidabot_sim.chaos.faults import LinkCuts
from gidabot_sim.runner.procs import wait_until

pytestmark = [pytest.mark.system, pytest.mark.slow]

FACULTY6 = REPO / "maps" / "faculty6"
SPEED = 20.0
TRIP_WALL = 150.0


@pytest.fixture(scope="module")
def stack(tmp_path_factory) -> Iterator[SimStack]:
    t0 = time.monotonic()
    with SimStack(tmp_path_factory.mktemp("legs_system"), speed=SPEED, building=FACULTY6) as st:
        ready = st.wait_ready(timeout=300)
        print(f"\n[legs] 6 robots' stacks up in {time.monotonic() - t0:.1f} s wall (ready after {ready:.1f} s)")
        yield st


def goal_of(m: dict) -> Trip:
    """A recorded gidabot_msgs/Goal as the guiding cores' Trip (the fields the audit reads)."""
    return Trip(uid=m["uid"], origin_robot=m["origin_robot"], visitor_id=m["visitor_id"],
                initial_floor=m["initial_floor"], initial_x=m["initial_pose"]["x"], initial_y=m["initial_pose"]["y"],
                goal_floor=m["goal_floor"], goal_x=m["goal_pose"]["position"]["x"],
                goal_y=m["goal_pose"]["position"]["y"], goal_yaw=0.0, way=m["way"], connector=m["connector"],
                start_id=m["start_id"], goal_id=m["goal_id"], language=m["language"], start_robot=m["start_robot"],
                start_state=m["start_state"], goal_robot=m["goal_robot"], goal_state=m["goal_state"],
                attempt=m["attempt"])


def everything(stack: SimStack, uid: str) -> tuple[list[Trip], list]:
    """Every goal snapshot and event of the trip recorded on any master (duplicates are fine for the audit)."""
    from gidabot_navigation.guiding.messages import NavEventData

    goals = [goal_of(m) for r in stack.robots for m in stack.rec[r].msgs(GOALS) if m["uid"] == uid]
    events = [NavEventData(uid=m["uid"], robot=m["robot"], floor=m["floor"], goal_uid=m["goal_uid"], phase=m["phase"],
                           leg=m["leg"], attempt=m["attempt"], assignee=m["assignee"])
              for r in stack.robots for m in stack.rec[r].msgs(EVENTS) if m["goal_uid"] == uid]
    return goals, events


def test_the_goal_floor_robot_cut_off_at_the_decision_another_takes_the_leg(stack: SimStack) -> None:
    b = stack.building
    galt = b.robot("Galtxagorri").ip
    others = [r.ip for r in b.robots if r.name != "Galtxagorri"]
    with LinkCuts(tag=f"gidabot-legs-{os.getpid()}") as cuts:
        for ip in others:
            cuts.cut(galt, ip)
        cut_at = time.monotonic()
        uid, since = stack.request("Tartalo", "223", way="stairs")
        answered = time.monotonic() - cut_at         # Galtxagorri still counts as online for a few seconds
        # Lamia gets the goal leg after Galtxagorri's answer_timeout; Tartalo says so
        wait_until(lambda: any(e["phase"] == ASSIGNED and e["leg"] == LEG_GOAL
                               for e in stack.events("Tartalo", uid, "Tartalo", since=since)), 60,
                   "Tartalo's ASSIGNED of the goal leg")
        [lamia] = [e for e in stack.events("Tartalo", uid, "Tartalo", since=since)
                   if e["phase"] == ASSIGNED and e["leg"] == LEG_GOAL]
        assert lamia["assignee"] == "Lamia", lamia
        proposals = [m for m in stack.rec["Tartalo"].msgs(GOALS) if m["uid"] == uid]
        assert any(m["goal_robot"] == "Galtxagorri" for m in proposals), \
            f"Galtxagorri was asked first (the request was answered {answered:.1f} s after the cut)"
        # the trip runs: Tartalo to the staircase, Lamia to its meeting point upstairs, Continue, the goal
        stack.wait_event("Lamia", WAITING_VISITOR, goal_uid=uid, timeout=TRIP_WALL)
        stack.wait_event("Tartalo", GO_TO_FLOOR, goal_uid=uid, timeout=TRIP_WALL)
        assert stack.events("Tartalo", uid, "Tartalo")[-1]["assignee"] == "Lamia"
        stack.command("Lamia", CONTINUE, goal_uid=uid)
        stack.wait_event("Lamia", GOAL_REACHED, goal_uid=uid, timeout=TRIP_WALL)
        assert not stack.events("Galtxagorri", uid, "Galtxagorri")     # cut off: it heard nothing of it
    # the partition heals: Galtxagorri gets the old proposal late, answers, then drops it; it never moves
    wait_until(lambda: any(m["robot"] == "Galtxagorri" for m in stack.events("Tartalo", uid)), 60,
               "Galtxagorri's late answer through the healed relays")
    answer = next(m for m in stack.events("Tartalo", uid) if m["robot"] == "Galtxagorri")

    def emptied() -> bool:
        """Galtxagorri's own pending list, published after its answer (its sim time: a list from before
        does not count, though it may still be the latest recorded), is empty."""
        latest = stack.pending("Galtxagorri", "Galtxagorri")
        return latest is not None and latest["header"]["stamp"] > answer["header"]["stamp"] and latest["goals"] == []
    wait_until(emptied, 60, "Galtxagorri's queue empty again after its late answer")
    galt_events = stack.events("Galtxagorri", uid, "Galtxagorri")
    assert [e["phase"] for e in galt_events] == [ACCEPTED], galt_events
    goals, events = everything(stack, uid)
    audit = audit_legs(goals, events)
    assert audit.double_served == [] and audit.unserved == []
    assert audit.served_by(uid, LEG_GOAL) == "Lamia" and audit.served_by(uid, LEG_START) == "Tartalo"
    assert {g.goal_robot for g in goals if g.goal_state == LEG_COMMITTED} == {"Lamia"}
    assert {e.robot for e in events if e.leg == LEG_GOAL and e.phase in SERVING_PHASES} == {"Lamia"}
    assert not any(e.robot == "Galtxagorri" and e.phase in (GOING_TO_MEETING, ON_THE_WAY) for e in events)
    for r in stack.robots:
        latest = stack.pending(r, r)
        assert latest is not None and uid not in {g["uid"] for g in latest["goals"]}, (r, latest)
