"""Who serves a leg (guiding/assignment.py) against every failure case of docs/guiding.md, *Who serves a leg*.

The six robots of maps/faculty6 run their goal managers and navigations on the test bus (no ROS, no clock:
wall and ROS time are advanced by the tests). A visitor at Tartalo (floor 0) asks for room 223 on floor 2,
by the stairs: the west staircase; of floor 2's robots Galtxagorri (home x 30) can be at its meeting point
first, Lamia (home x 54) next. Each test breaks the network in one way and checks the invariant from what
the robots published (:func:`audit_legs`): no leg is ever served by two robots, and a leg nobody serves
belongs to a trip that ended visibly.
"""

from __future__ import annotations

import random
from dataclasses import replace

import pytest
from guiding_support import Bus

from gidabot_navigation.errors import GuidingError
from gidabot_navigation.guiding.assignment import AssignConfig, Assigner, GaveUp, LegBook, Publish, audit_legs
from gidabot_navigation.guiding.goal_manager import GoalManagerConfig, GoalManagerCore
from gidabot_navigation.guiding.messages import NavEventData, SendEvent, SendGoal, Trip
from gidabot_navigation.guiding.trips import Candidate
from gidabot_navigation.interface import (
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_NONE,
    LEG_PROPOSED,
    LEG_START,
    SERVING_PHASES,
    Phase,
)

GOAL_FLOOR = ("Galtxagorri", "Lamia")


def bus6(faculty6, **kw) -> Bus:
    bus = Bus(faculty6, auto_move=False, **kw)
    bus.status_all()
    return bus


def the_trip(bus: Bus) -> str:
    [uid] = {g.uid for g in bus.goals}
    return uid


def newest(bus: Bus, uid: str) -> Trip:
    return max((g for g in bus.goals if g.uid == uid), key=lambda g: g.attempt)


def served(bus: Bus, uid: str, leg: str) -> set[str]:
    """The robots that sent a serving phase (GOING_TO_MEETING, ON_THE_WAY, ...) for ``leg``."""
    return {e.robot for e in bus.events if e.goal_uid == uid and e.leg == leg and e.phase in SERVING_PHASES}


def check_invariant(bus: Bus) -> None:
    audit = audit_legs(bus.goals, bus.events)
    assert audit.double_served == [], audit.double_served
    assert audit.unserved == [], audit.unserved


def wait(bus: Bus, seconds: float) -> None:
    """``seconds`` of wall (and ROS) time pass; every robot hears the robots it is not cut off from."""
    bus.heartbeat()
    bus.tick(ros_dt=seconds, wall_dt=seconds)
    bus.heartbeat()


def moved_for(bus: Bus, robot: str, uid: str) -> bool:
    return any(e.robot == robot and e.goal_uid == uid and e.phase in (Phase.GOING_TO_MEETING, Phase.ON_THE_WAY)
               for e in bus.events)


# ------------------------------------------------------------------------------------------ no fault

def test_the_robot_first_at_the_meeting_point_takes_the_goal_leg(faculty6) -> None:
    bus = bus6(faculty6)
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    trip = newest(bus, uid)
    assert (trip.connector, trip.start_robot, trip.start_state, trip.goal_robot, trip.goal_state) == (
        "stairs_west", "Tartalo", LEG_COMMITTED, "Galtxagorri", LEG_COMMITTED)
    assigned = [e for e in bus.events if e.phase == Phase.ASSIGNED]
    assert [(e.robot, e.leg, e.assignee) for e in assigned] == [("Tartalo", LEG_START, "Tartalo"),
                                                                ("Tartalo", LEG_GOAL, "Galtxagorri")]
    assert assigned[1].eta > 0 and assigned[1].attempt == trip.attempt
    # ACCEPTED: once per leg, from the robot that serves it; Lamia is never involved
    assert [(e.robot, e.leg) for e in bus.events if e.phase == Phase.ACCEPTED] == [("Tartalo", LEG_START),
                                                                           ("Galtxagorri", LEG_GOAL)]
    assert bus.queue_of("Lamia") == [] and bus.robots["Lamia"].moves == []
    assert moved_for(bus, "Galtxagorri", uid)
    # the trip runs to its end; every leg served by exactly one robot
    bus.finish_move("Galtxagorri")
    bus.finish_move("Tartalo")
    bus.pump()
    assert bus.last("Tartalo", Phase.GO_TO_FLOOR).assignee == "Galtxagorri"
    bus.cont("Galtxagorri", uid)
    bus.finish_move("Galtxagorri")
    bus.pump()
    assert bus.phases("Galtxagorri", uid)[-1] == Phase.GOAL_REACHED
    assert served(bus, uid, LEG_GOAL) == {"Galtxagorri"} and served(bus, uid, LEG_START) == {"Tartalo"}
    check_invariant(bus)
    assert all(len(r.gm.assigner) == 0 for r in bus.robots.values())      # the requester closed the trip


def test_a_robot_queue_moves_the_goal_leg_to_the_other_robot(faculty6) -> None:
    bus = bus6(faculty6)
    bus.request("Galtxagorri", "231")            # Galtxagorri goes east first (x 63)
    bus.request("Tartalo", "223")
    uid = [g.uid for g in bus.goals if g.origin_robot == "Tartalo"][0]
    assert newest(bus, uid).goal_robot == "Lamia"
    check_invariant(bus)


def test_a_busy_robot_gets_help_from_the_other_robot_of_its_floor(faculty6) -> None:
    """Kbot is busy for a while; Basajaun, free, comes to Kbot's visitor (the visitor sees who and how long)."""
    bus = bus6(faculty6)
    bus.request("Kbot", "119")                   # Kbot's visitor: the far east end of floor 1
    assert bus.phases("Kbot")[-1] == Phase.ON_THE_WAY
    bus.robots["Kbot"].gm.on_pose(40.0, 12.0, 0.0)  # guiding east, on its way
    bus.request("Kbot", "101")                   # a second visitor at Kbot's screen: the west end
    uid = [g.uid for g in bus.goals if g.goal_id == "101"][0]
    trip = newest(bus, uid)
    assert (trip.start_robot, trip.start_state) == ("Basajaun", LEG_COMMITTED)
    [helper] = [e for e in bus.events if e.phase == Phase.ASSIGNED and e.goal_uid == uid]
    assert helper.robot == "Kbot" and helper.assignee == "Basajaun" and helper.eta > 0
    assert bus.phases("Basajaun", uid) == [Phase.ACCEPTED, Phase.GOING_TO_MEETING]        # driving to the visitor
    assert uid not in bus.queue_of("Kbot")
    check_invariant(bus)


def test_a_free_robot_guides_its_own_visitor(faculty6) -> None:
    bus = bus6(faculty6)
    bus.request("Basajaun", "101")
    trip = newest(bus, the_trip(bus))
    assert trip.start_robot == "Basajaun" and trip.goal_state == LEG_NONE


def test_a_declined_leg_goes_to_the_next_robot(faculty6) -> None:
    bus = bus6(faculty6)
    galt = bus.robots["Galtxagorri"].gm
    galt.cfg = replace(galt.cfg, max_queue=1)
    bus.request("Galtxagorri", "201")            # ends near the west staircase, fills its queue
    bus.request("Tartalo", "223")
    uid = [g.uid for g in bus.goals if g.origin_robot == "Tartalo"][0]
    [declined] = [e for e in bus.events if e.phase == Phase.DECLINED]
    assert (declined.robot, declined.goal_uid, declined.leg) == ("Galtxagorri", uid, LEG_GOAL)
    assert "queue of Galtxagorri is full" in declined.detail
    assert newest(bus, uid).goal_robot == "Lamia" and newest(bus, uid).goal_state == LEG_COMMITTED
    check_invariant(bus)


def test_a_leg_every_robot_declined_waits_and_is_served_once_there_is_room(faculty6) -> None:
    """Both robots of floor 2 decline the goal leg (queues full): it is neither given up nor left unserved; it
    waits, is proposed again every requeue_after, and the first robot with room takes it, alone."""
    bus = bus6(faculty6)
    for robot in GOAL_FLOOR:
        gm = bus.robots[robot].gm
        gm.cfg = replace(gm.cfg, max_queue=1)
    bus.request("Galtxagorri", "201")
    bus.request("Lamia", "231")
    bus.request("Tartalo", "223")
    uid = [g.uid for g in bus.goals if g.origin_robot == "Tartalo"][0]
    assert sorted(e.robot for e in bus.events if e.phase == Phase.DECLINED) == sorted(GOAL_FLOOR)
    assert uid in bus.robots["Tartalo"].gm.assigner and not bus.phases("Tartalo", uid).count(Phase.PARTNER_OFFLINE)
    for _ in range(3):
        wait(bus, 3.5)                                        # a second round: both still full
    assert len([e for e in bus.events if e.phase == Phase.DECLINED]) == 4
    assert newest(bus, uid).goal_state == LEG_PROPOSED
    bus.finish_move("Lamia")                                  # Lamia's own visitor is there: room
    bus.pump()
    for _ in range(3):
        wait(bus, 3.5)
    trip = newest(bus, uid)
    assert (trip.goal_robot, trip.goal_state) == ("Lamia", LEG_COMMITTED)
    assert moved_for(bus, "Lamia", uid) and not moved_for(bus, "Galtxagorri", uid)
    check_invariant(bus)


def test_no_online_robot_on_the_goal_floor_answers_at_once(faculty6) -> None:
    bus = bus6(faculty6)
    bus.tick(wall_dt=10.0)
    bus.status_all(["Tartalo", "Kbot", "Basajaun", "MariSorgin"])
    bus.request("Tartalo", "223")
    assert bus.goals == [] and bus.phases("Tartalo") == [Phase.PARTNER_OFFLINE]
    assert "no robot of floor 2 is online" in bus.last("Tartalo", Phase.PARTNER_OFFLINE).detail
    assert "Lamia: no status for 10 s" in bus.last("Tartalo", Phase.PARTNER_OFFLINE).detail
    assert all(not r.gm.queue for r in bus.robots.values())


def test_an_offline_robot_is_not_asked(faculty6) -> None:
    bus = bus6(faculty6)
    bus.tick(wall_dt=10.0)
    bus.status_all([r for r in bus.robots if r != "Galtxagorri"])
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    assert newest(bus, uid).goal_robot == "Lamia"
    assert not any(e.robot == "Galtxagorri" for e in bus.events)


# --------------------------------------------------------------------------- the chosen robot cut off

def test_chosen_robot_partitioned_at_the_decision_another_takes_the_leg(faculty6) -> None:
    """Galtxagorri is cut off just as the visitor confirms: still heard a moment ago, it is proposed the leg,
    does not answer in time, Lamia gets it. When the partition heals, Galtxagorri receives the old proposal
    (the relays queued it), answers it late, sees the newer attempt and drops it: it never moves."""
    bus = bus6(faculty6)
    bus.down.add("Galtxagorri")
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    assert (newest(bus, uid).goal_robot, newest(bus, uid).goal_state) == ("Galtxagorri", LEG_PROPOSED)
    wait(bus, 1.0)
    assert newest(bus, uid).goal_robot == "Galtxagorri"        # still within the 3 s to answer
    wait(bus, 2.5)
    trip = newest(bus, uid)
    assert (trip.goal_robot, trip.goal_state) == ("Lamia", LEG_COMMITTED)
    assert moved_for(bus, "Lamia", uid)
    bus.link_up("Galtxagorri")
    bus.pump()
    wait(bus, 1.0)
    assert [e.phase for e in bus.events if e.robot == "Galtxagorri"] == [Phase.ACCEPTED]    # late, and ignored
    assert bus.queue_of("Galtxagorri") == [] and bus.robots["Galtxagorri"].moves == []
    assert bus.robots["Galtxagorri"].gm.stats["superseded"] == 1
    assert served(bus, uid, LEG_GOAL) == {"Lamia"}
    check_invariant(bus)


def test_chosen_robot_cut_off_after_accepting_its_answer_late(faculty6) -> None:
    """Galtxagorri's ACCEPTED is delayed past the timeout: Lamia gets the leg; Galtxagorri holds only an
    unconfirmed proposal, never runs it, drops it on the newer attempt; the late ACCEPTED changes nothing."""
    bus = bus6(faculty6)
    bus.tap = lambda s, r, a: "keep" if s == "Galtxagorri" and r == "Tartalo" and isinstance(a, SendEvent) \
        and a.event.phase == Phase.ACCEPTED else "pass"
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    assert bus.queue_of("Galtxagorri") == [uid] and not moved_for(bus, "Galtxagorri", uid)
    wait(bus, 3.5)
    assert newest(bus, uid).goal_robot == "Lamia" and newest(bus, uid).goal_state == LEG_COMMITTED
    assert bus.queue_of("Galtxagorri") == []                   # dropped on the newer attempt
    bus.release()                                              # the late ACCEPTED reaches Tartalo
    bus.pump()
    wait(bus, 5.0)
    assert newest(bus, uid).goal_robot == "Lamia" and served(bus, uid, LEG_GOAL) == {"Lamia"}
    check_invariant(bus)


def test_chosen_robot_cut_off_after_the_commit_acts_late_but_alone(faculty6) -> None:
    """The leg is committed to Galtxagorri, then Galtxagorri is cut off before the commit reaches it: it waits
    (it never acts on a proposal), nobody else is asked (a commit is final); when the partition heals it goes."""
    bus = bus6(faculty6)
    bus.tap = lambda s, r, a: "keep" if r == "Galtxagorri" and isinstance(a, SendGoal) \
        and a.trip.goal_state == LEG_COMMITTED else "pass"
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    assert newest(bus, uid).goal_robot == "Galtxagorri" and newest(bus, uid).goal_state == LEG_COMMITTED
    assert not moved_for(bus, "Galtxagorri", uid)
    for _ in range(5):
        wait(bus, 3.0)
    assert {g.goal_robot for g in bus.goals} == {"Galtxagorri"} and not any(e.robot == "Lamia" for e in bus.events)
    bus.release()
    bus.pump()
    assert moved_for(bus, "Galtxagorri", uid) and served(bus, uid, LEG_GOAL) == {"Galtxagorri"}
    check_invariant(bus)


def kbot_cut_then_proposed_a_leg(faculty) -> tuple[Bus, str]:
    """Kbot cut off for 4.8 s (still online), then a visitor asks at Tartalo for floor 1: Kbot is proposed the leg."""
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.down.add("Kbot")
    bus.tick(wall_dt=4.8)
    bus.request("Tartalo", "101")
    return bus, the_trip(bus)


def test_a_robot_that_goes_offline_just_after_it_was_proposed_a_leg_still_has_time_to_answer(faculty) -> None:
    """The quick chaos run (seed 4): a 4.7 s cut between Tartalo and Kbot healed; the visitor asked at Tartalo
    for floor 1 at once. Kbot, last heard 4.8 s before, was proposed the goal leg; 0.25 s later it counted as
    offline (5 s without status) and Tartalo gave the trip up (PARTNER_OFFLINE) although Kbot's status and its
    ACCEPTED arrived 0.5 s after the proposal. It now has the usual answer_timeout (3 s)."""
    bus, uid = kbot_cut_then_proposed_a_leg(faculty)
    assert (newest(bus, uid).goal_robot, newest(bus, uid).goal_state) == ("Kbot", LEG_PROPOSED)
    bus.tick(wall_dt=0.25)                                    # Kbot: no status for 5.05 s
    assert Phase.PARTNER_OFFLINE not in bus.phases("Tartalo", uid) and newest(bus, uid).goal_robot == "Kbot"
    bus.tick(wall_dt=0.25)
    bus.link_up("Kbot")                                       # the cut healed: its status and answer arrive
    wait(bus, 0.0)
    bus.pump()
    trip = newest(bus, uid)
    assert (trip.goal_robot, trip.goal_state) == ("Kbot", LEG_COMMITTED) and moved_for(bus, "Kbot", uid)
    assert Phase.PARTNER_OFFLINE not in bus.phases(goal_uid=uid)


def test_a_robot_still_offline_when_its_time_to_answer_is_over_is_passed_over(faculty) -> None:
    bus, uid = kbot_cut_then_proposed_a_leg(faculty)
    bus.tick(wall_dt=3.0)
    off = bus.last("Tartalo", Phase.PARTNER_OFFLINE)
    assert off.goal_uid == uid and "Kbot is offline" in off.detail and "no status for 8 s" in off.detail


def test_both_goal_floor_robots_cut_off_the_trip_is_given_up_visibly(faculty6) -> None:
    bus = bus6(faculty6)
    bus.down.update(GOAL_FLOOR)
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    for _ in range(3):
        wait(bus, 3.0)
    off = bus.last("Tartalo", Phase.PARTNER_OFFLINE)
    assert off.goal_uid == uid and off.leg == LEG_GOAL
    assert "Galtxagorri did not answer within 3 s" in off.detail and "Lamia" in off.detail
    assert bus.queue_of("Tartalo") == [] and [c.reason for c in bus.cancels] == ["offline"]
    bus.link_up("Galtxagorri")
    bus.link_up("Lamia")
    bus.pump()
    wait(bus, 1.0)
    assert not moved_for(bus, "Galtxagorri", uid) and not moved_for(bus, "Lamia", uid)
    assert bus.queue_of("Galtxagorri") == [] and bus.queue_of("Lamia") == []
    check_invariant(bus)


def test_requester_cut_off_after_proposing(faculty6) -> None:
    """Tartalo is cut off as it proposes: nobody's answer reaches it; it gives up (its visitor is told) and the
    proposals the others got late are never confirmed, so nobody serves the goal leg."""
    bus = bus6(faculty6)
    bus.down.add("Tartalo")
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    for _ in range(4):
        wait(bus, 3.0)
    assert bus.last("Tartalo", Phase.PARTNER_OFFLINE).goal_uid == uid
    bus.link_up("Tartalo")
    bus.pump()
    wait(bus, 1.0)
    assert all(bus.queue_of(r) == [] for r in bus.robots)
    assert not moved_for(bus, "Lamia", uid) and served(bus, uid, LEG_GOAL) <= {"Galtxagorri"}
    check_invariant(bus)


# ------------------------------------------------------------------------- lost, duplicated, reordered

def test_lost_answer_and_lost_newer_attempt_the_proposal_expires(faculty6) -> None:
    """Galtxagorri's ACCEPTED and every later goal to it are lost: it keeps an unconfirmed proposal, never runs
    it, and forgets it after proposal_ttl."""
    bus = bus6(faculty6)
    lost = {"on": False}

    def tap(s: str, r: str, a: object) -> str:
        if s == "Galtxagorri" and isinstance(a, SendEvent) and a.event.phase == Phase.ACCEPTED:
            lost["on"] = True
            return "drop"
        return "drop" if lost["on"] and r == "Galtxagorri" and isinstance(a, SendGoal) else "pass"

    bus.tap = tap
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    wait(bus, 3.5)
    assert newest(bus, uid).goal_robot == "Lamia" and bus.queue_of("Galtxagorri") == [uid]
    assert not moved_for(bus, "Galtxagorri", uid)
    wait(bus, 60.0)
    assert bus.queue_of("Galtxagorri") == [] and bus.robots["Galtxagorri"].gm.stats["proposals_expired"] == 1
    check_invariant(bus)


def test_a_lost_proposal_moves_on_after_the_timeout(faculty6) -> None:
    bus = bus6(faculty6)
    bus.tap = lambda s, r, a: "drop" if r == "Galtxagorri" and isinstance(a, SendGoal) else "pass"
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    wait(bus, 3.5)
    assert newest(bus, uid).goal_robot == "Lamia" and newest(bus, uid).goal_state == LEG_COMMITTED
    check_invariant(bus)


def test_duplicated_messages_change_nothing(faculty6) -> None:
    bus = bus6(faculty6)
    bus.tap = lambda s, r, a: "dup"
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    assert newest(bus, uid).goal_robot == "Galtxagorri"
    assert len([e for e in bus.events if e.phase == Phase.ACCEPTED]) == 2
    assert len([e for e in bus.events if e.phase == Phase.ASSIGNED]) == 2
    assert len(bus.robots["Galtxagorri"].moves) == 1
    check_invariant(bus)


def test_reordered_attempts_the_newest_wins(faculty6) -> None:
    """Every goal to Galtxagorri is held; the leg moves to Lamia; then Galtxagorri receives the attempts newest
    first: the older ones (one of them a proposal to it) are ignored, it never answers nor moves."""
    bus = bus6(faculty6)
    bus.tap = lambda s, r, a: "keep" if r == "Galtxagorri" and isinstance(a, SendGoal) else "pass"
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    wait(bus, 3.5)
    assert newest(bus, uid).goal_robot == "Lamia"
    while bus.kept:
        bus.release(len(bus.kept) - 1)
        bus.pump()
    assert not any(e.robot == "Galtxagorri" for e in bus.events) and bus.queue_of("Galtxagorri") == []
    assert bus.robots["Galtxagorri"].gm.stats["duplicates"] >= 1
    check_invariant(bus)


# ---------------------------------------------------------------------------------------------- restarts

def restart_gm(bus: Bus, robot: str) -> None:
    """The goal manager of ``robot`` restarts and resumes its saved state (docs/guiding.md, restarts)."""
    old = bus.robots[robot].gm
    new = GoalManagerCore(bus.building, old.cfg, bus.log, bus.now_wall, boot="r")
    new.load_state(old.state())
    for r in bus.robots:
        new.on_status(r, bus.now_wall)
    bus.robots[robot].gm = new


def test_chosen_robot_restarts_between_accepting_and_the_commit(faculty6) -> None:
    bus = bus6(faculty6)
    bus.tap = lambda s, r, a: "keep" if r == "Galtxagorri" and isinstance(a, SendGoal) \
        and a.trip.goal_state == LEG_COMMITTED else "pass"
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    restart_gm(bus, "Galtxagorri")
    assert bus.queue_of("Galtxagorri") == [uid]
    bus.release()
    bus.pump()
    assert moved_for(bus, "Galtxagorri", uid)
    assert [e.phase for e in bus.events if e.robot == "Galtxagorri"].count(Phase.ACCEPTED) == 1
    check_invariant(bus)


def test_requester_restarts_while_a_proposal_is_out(faculty6) -> None:
    bus = bus6(faculty6)
    bus.tap = lambda s, r, a: "keep" if s == "Galtxagorri" and isinstance(a, SendEvent) \
        and a.event.phase == Phase.ACCEPTED else "pass"
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    restart_gm(bus, "Tartalo")
    assert uid in bus.robots["Tartalo"].gm.assigner
    bus.release()                                    # the answer reaches the restarted requester in time
    bus.pump()
    assert newest(bus, uid).goal_robot == "Galtxagorri" and newest(bus, uid).goal_state == LEG_COMMITTED
    check_invariant(bus)


# -------------------------------------------------------------------- cancels and tours through empty floors

def test_a_cancel_during_the_assignment_leaves_nothing_anywhere(faculty6) -> None:
    bus = bus6(faculty6)
    bus.down.add("Galtxagorri")
    bus.request("Tartalo", "223")
    uid = the_trip(bus)
    bus.cancel("Tartalo", uid)
    assert bus.last("Tartalo", Phase.CANCELLED_HERE).goal_uid == uid
    wait(bus, 5.0)
    bus.link_up("Galtxagorri")
    bus.pump()
    assert all(bus.queue_of(r) == [] and len(bus.robots[r].gm.assigner) == 0 for r in bus.robots)
    assert not moved_for(bus, "Galtxagorri", uid)            # it got the proposal, then the cancel
    check_invariant(bus)


# ----------------------------------------------------------------------------------- any mix of faults

@pytest.mark.parametrize("seed", range(40))
def test_any_mix_of_faults_never_gives_a_leg_twice(faculty6, seed: int) -> None:
    """Random drops, duplicates, delays (kept and released in random order) and partitions, with two
    visitors at once; then everything is delivered and time passes. No leg ever has two robots."""
    rng = random.Random(seed)
    bus = bus6(faculty6)

    def tap(s: str, r: str, a: object) -> str:
        return rng.choices(["pass", "drop", "dup", "keep"], [70, 5, 10, 15])[0]

    bus.tap = tap
    if rng.random() < 0.5:
        bus.down.add(rng.choice(GOAL_FLOOR))
    bus.request("Tartalo", "223")
    bus.request(rng.choice(["Kbot", "Basajaun"]), rng.choice(["207", "229", "101", "301"]))
    for _ in range(12):
        if bus.kept and rng.random() < 0.6:
            bus.release(rng.randrange(len(bus.kept)))
        if bus.down and rng.random() < 0.3:
            bus.link_up(next(iter(bus.down)))
        for r in bus.robots.values():                # the robots that run a leg get to the next stage
            if r.active is not None and rng.random() < 0.5:
                bus.finish_move(r.name)
        bus.pump()
        wait(bus, rng.choice([0.5, 1.0, 3.5]))
    for robot in list(bus.down):
        bus.link_up(robot)
    while bus.kept:
        bus.release(rng.randrange(len(bus.kept)))
        bus.pump()
    audit = audit_legs(bus.goals, bus.events)
    assert audit.double_served == [], (seed, audit.double_served)
    for uid, leg in audit.legs:
        committed = {g.committed(leg) for g in bus.goals if g.uid == uid} - {""}
        assert len(committed) <= 1, (seed, uid, leg, committed)
        assert served(bus, uid, leg) <= committed, (seed, uid, leg)


# ------------------------------------------------------------------------------------- the cores alone

def test_assigner_commits_only_the_current_candidate() -> None:
    trip = Trip(uid="A/v/1", origin_robot="A", visitor_id="v", initial_floor=0.0, initial_x=0.0, initial_y=0.0,
                goal_floor=1.0, goal_x=1.0, goal_y=1.0, goal_yaw=0.0, way="stairs", connector="s", start_id="robot",
                goal_id="g", language="en")
    ranking = {LEG_START: [Candidate("A", 0.0)], LEG_GOAL: [Candidate("B", 10.0), Candidate("C", 20.0)]}
    a = Assigner("A", AssignConfig(), lambda t, leg, ex, now: [c for c in ranking[leg] if c.robot not in ex])
    [pub] = a.open(trip, [LEG_START, LEG_GOAL], 0.0)
    assert isinstance(pub, Publish) and pub.trip.attempt == 1 and pub.trip.goal_robot == "B"
    assert [type(o).__name__ for o in a.on_answer("A/v/1", LEG_START, "A", 1, True, 0.0, "", 0.0)] == [
        "Publish", "Assigned"]
    assert a.on_answer("A/v/1", LEG_GOAL, "C", 1, True, 5.0, "", 0.5) == []        # not asked
    assert a.tick(2.0, lambda r: True) == []
    [moved] = a.tick(3.0, lambda r: True)                                            # B silent for 3 s
    assert moved.trip.goal_robot == "C" and moved.trip.attempt == 3
    assert a.on_answer("A/v/1", LEG_GOAL, "B", 1, True, 5.0, "", 3.1) == []         # too late
    assert a.on_answer("A/v/1", LEG_GOAL, "C", 2, True, 5.0, "", 3.1) == []         # an older attempt
    outs = a.on_answer("A/v/1", LEG_GOAL, "C", 3, True, 7.0, "", 3.2)
    assert [type(o).__name__ for o in outs] == ["Publish", "Assigned"]
    assert outs[0].trip.goal_state == LEG_COMMITTED and outs[0].trip.attempt == 4
    assert a.on_answer("A/v/1", LEG_GOAL, "C", 3, False, 0.0, "", 3.3) == []        # committed is final
    assert a.tick(100.0, lambda r: False) == []                                      # even if C goes offline


def test_assigner_gives_up_when_nobody_is_left_and_survives_a_restart() -> None:
    trip = Trip(uid="A/v/1", origin_robot="A", visitor_id="v", initial_floor=0.0, initial_x=0.0, initial_y=0.0,
                goal_floor=1.0, goal_x=1.0, goal_y=1.0, goal_yaw=0.0, way="stairs", connector="s", start_id="robot",
                goal_id="g", language="en")
    rank = lambda t, leg, ex, now: [c for c in [Candidate("B", 1.0)] if c.robot not in ex]  # noqa: E731
    a = Assigner("A", AssignConfig(answer_timeout=2.0), rank)
    a.open(trip, [LEG_GOAL], 10.0)
    b = Assigner("A", AssignConfig(answer_timeout=2.0), rank)
    b.load_state(a.state())
    assert "A/v/1" in b
    # B declines (its queue is full): nobody else on the floor, but B is there: the leg waits, then a new round
    assert b.on_answer("A/v/1", LEG_GOAL, "B", 1, False, 0.0, "queue full", 11.0) == []
    assert "A/v/1" in b and b.tick(20.0, lambda r: True) == []
    c = Assigner("A", AssignConfig(answer_timeout=2.0), rank)      # restarts while the leg waits
    c.load_state(b.state())
    [again] = c.tick(21.0, lambda r: True)
    assert isinstance(again, Publish) and again.trip.goal_robot == "B" and again.trip.attempt == 2
    # B goes offline and does not answer within answer_timeout: nobody declined this round, nobody is left: given
    # up, visibly (offline alone is no reason yet: its status and its answer may come together)
    assert c.tick(21.5, lambda r: r != "B") == []
    [gave_up] = c.tick(23.0, lambda r: r != "B")
    assert isinstance(gave_up, GaveUp) and "B declined (queue full)" in gave_up.detail and "B is offline" in \
        gave_up.detail and "A/v/1" not in c
    assert b.open(trip, [LEG_GOAL], 0.0)[0].trip.goal_robot == "B"
    assert isinstance(Assigner("A", AssignConfig(), lambda *x: []).open(trip, [LEG_GOAL], 0.0)[0], GaveUp)


def test_leg_book_keeps_the_newest_attempt_and_expires_unconfirmed_proposals() -> None:
    book = LegBook("B")
    t = Trip(uid="A/v/1", origin_robot="A", visitor_id="v", initial_floor=0.0, initial_x=0.0, initial_y=0.0,
             goal_floor=1.0, goal_x=1.0, goal_y=1.0, goal_yaw=0.0, way="stairs", connector="s", start_id="robot",
             goal_id="g", language="en", attempt=2)
    assert book.newer(t) and not book.newer(t) and not book.newer(replace(t, attempt=1))
    assert book.newer(replace(t, attempt=3))
    assert book.first_answer(t.uid, LEG_GOAL) and not book.first_answer(t.uid, LEG_GOAL)
    book.holding(t.uid, 100.0)
    assert book.expired(159.0, 60.0) == [] and book.expired(160.0, 60.0) == [t.uid]
    book.holding(t.uid, 500.0)
    assert book.expired(10.0, 60.0) == []            # the clock went back (reboot): counted from now
    again = LegBook("B")
    again.load_state(book.state(100))
    assert not again.newer(replace(t, attempt=3)) and again.answered(t.uid, LEG_GOAL)


def test_assign_config_is_checked() -> None:
    with pytest.raises(GuidingError, match="answer_timeout"):
        AssignConfig(answer_timeout=0)
    with pytest.raises(GuidingError, match="max_wait"):
        AssignConfig(max_wait=float("nan"))
    GoalManagerConfig(robot="Kbot", assign=AssignConfig(helper_gain=0.0))


def test_audit_finds_a_leg_served_twice_and_a_leg_left_unserved() -> None:
    t = Trip(uid="A/v/1", origin_robot="A", visitor_id="v", initial_floor=0.0, initial_x=0.0, initial_y=0.0,
             goal_floor=1.0, goal_x=1.0, goal_y=1.0, goal_yaw=0.0, way="stairs", connector="s", start_id="robot",
             goal_id="g", language="en", start_robot="A", start_state=LEG_COMMITTED, goal_robot="B",
             goal_state=LEG_PROPOSED, attempt=1)

    def ev(robot: str, phase: int, leg: str, n: int, **kw) -> NavEventData:
        return NavEventData(uid=f"{robot}/event/{n}", robot=robot, floor=1.0, goal_uid=t.uid, phase=phase, leg=leg,
                            **kw)

    audit = audit_legs([t], [ev("A", Phase.ON_THE_WAY, LEG_START, 1)])
    assert audit.unserved == [("A/v/1", LEG_GOAL)] and audit.served_by("A/v/1", LEG_START) == "A"
    events = [ev("A", Phase.ASSIGNED, LEG_GOAL, 2, assignee="B"), ev("B", Phase.GOING_TO_MEETING, LEG_GOAL, 3),
              ev("C", Phase.WAITING_VISITOR, LEG_GOAL, 4)]
    audit = audit_legs([t], events)
    assert audit.double_served == [("A/v/1", LEG_GOAL, ["B", "C"])] and audit.unserved == []
    assert audit.served_by("A/v/1", LEG_GOAL) == ""
