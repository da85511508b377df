"""A robot taken out of service by staff (goal_manager.py ``on_staff``, assignment.py rule 6), on maps/faculty6.

faculty6: Tartalo on floor 0, Kbot and Basajaun on floor 1, Galtxagorri and Lamia on floor 2, MariSorgin alone on
floor 3. The staff commands come from Kbot's dashboard. Each test checks the legs' invariant from what the robots
published (:func:`audit_legs`): no leg served by two robots, no leg left unserved without a visible end.
"""

from __future__ import annotations

from dataclasses import replace

from guiding_support import DASHBOARD, GM, GUI, TS, Bus, from_robot

from gidabot_navigation.guiding.assignment import audit_legs
from gidabot_navigation.guiding.goal_manager import GoalManagerConfig, GoalManagerCore
from gidabot_navigation.guiding.messages import StaffCommandData, Trip
from gidabot_navigation.interface import LEG_COMMITTED, LEG_GOAL, LEG_NONE, Phase, StaffCmd
from gidabot_navigation.senders import SCOPE_STAFF, make_uid


def bus6(faculty6, **kw) -> Bus:
    bus = Bus(faculty6, **kw)
    bus.status_all()
    return bus


def newest(bus: Bus, uid: str) -> Trip:
    return max((g for g in bus.goals if g.uid == uid), key=lambda g: g.attempt)


def trip_to(bus: Bus, goal_id: str) -> str:
    [uid] = {g.uid for g in bus.goals if g.goal_id == goal_id}
    return uid


def check_invariant(bus: Bus) -> None:
    audit = audit_legs(bus.goals, bus.events)
    assert audit.double_served == [], audit.double_served


def test_a_robot_out_of_service_hands_its_queued_leg_to_the_other_robot_of_its_floor(faculty6) -> None:
    bus = bus6(faculty6, auto_move=False)
    bus.staff("Kbot", "Lamia", out=True)            # Lamia out: the next goal leg of floor 2 queues at Galtxagorri
    bus.request("Galtxagorri", "231")               # Galtxagorri guides its own visitor east (its queue's head)
    bus.request("Tartalo", "223")
    uid = trip_to(bus, "223")
    assert (newest(bus, uid).goal_robot, newest(bus, uid).goal_state) == ("Galtxagorri", LEG_COMMITTED)
    assert all(e.robot != "Lamia" for e in bus.events if e.goal_uid == uid)    # never asked while out
    own = trip_to(bus, "231")
    assert bus.queue_of("Galtxagorri") == [own, uid]

    bus.staff("Kbot", "Lamia", out=False, version=2)              # Lamia back
    bus.staff("Kbot", "Galtxagorri", out=True, detail="battery swap")
    # Galtxagorri finishes what it is doing (its own visitor) and hands back the leg it had not started, saying why
    assert bus.queue_of("Galtxagorri") == [own]
    [back] = [e for e in bus.events if e.robot == "Galtxagorri" and e.goal_uid == uid and e.phase == Phase.DECLINED]
    assert back.leg == LEG_GOAL and "out of service" in back.detail and "battery swap" in back.detail
    # the requester gives the leg to the other robot of the floor through the assignment
    trip = newest(bus, uid)
    assert (trip.goal_robot, trip.goal_state) == ("Lamia", LEG_COMMITTED)
    assert uid in bus.queue_of("Lamia")
    assert any(e.phase == Phase.ASSIGNED and e.assignee == "Lamia" and e.goal_uid == uid for e in bus.events)
    assert Phase.GOING_TO_MEETING in bus.phases("Lamia", uid)
    assert Phase.GOING_TO_MEETING not in bus.phases("Galtxagorri", uid)
    check_invariant(bus)


def test_a_robot_out_of_service_is_proposed_no_leg_and_back_in_service_it_is(faculty6) -> None:
    bus = bus6(faculty6, auto_move=False)
    bus.staff("Kbot", "Galtxagorri", out=True)
    bus.request("Tartalo", "223")                   # Galtxagorri would be first at the meeting point
    uid = trip_to(bus, "223")
    assert newest(bus, uid).goal_robot == "Lamia"
    assert all(e.robot != "Galtxagorri" for e in bus.events if e.goal_uid == uid)
    bus.staff("Kbot", "Galtxagorri", out=False, version=2)
    bus.request("Kbot", "223")
    again = [g.uid for g in bus.goals if g.goal_id == "223" and g.uid != uid][0]
    assert newest(bus, again).goal_robot == "Galtxagorri"
    check_invariant(bus)


def test_a_floor_left_with_no_robot_in_service_sends_the_visitor_alone(faculty6) -> None:
    bus = bus6(faculty6)
    bus.staff("Kbot", "MariSorgin", out=True)       # the only robot of floor 3
    bus.request("Tartalo", "305")
    uid = trip_to(bus, "305")
    trip = newest(bus, uid)
    assert (trip.goal_robot, trip.goal_state) == ("", LEG_NONE)
    assert all(e.robot != "MariSorgin" for e in bus.events if e.goal_uid == uid)
    # Tartalo guides the visitor to the stairs and tells them to go on alone, as on a floor without robot
    assert bus.phases("Tartalo", uid)[-1] == Phase.NO_ROBOT_ON_FLOOR
    assert "find 305 yourself" in bus.last("Tartalo", Phase.NO_ROBOT_ON_FLOOR).detail
    check_invariant(bus)


def test_a_goal_leg_handed_back_with_no_robot_left_in_service_sends_the_visitor_alone(faculty6) -> None:
    bus = bus6(faculty6, auto_move=False)
    bus.request("MariSorgin", "331")                # MariSorgin busy with its own visitor
    bus.request("Tartalo", "305")
    uid = trip_to(bus, "305")
    assert (newest(bus, uid).goal_robot, newest(bus, uid).goal_state) == ("MariSorgin", LEG_COMMITTED)
    bus.staff("Kbot", "MariSorgin", out=True)
    assert uid not in bus.queue_of("MariSorgin")
    trip = newest(bus, uid)
    assert (trip.goal_robot, trip.goal_state) == ("", LEG_NONE)
    assert uid in bus.queue_of("Tartalo")          # the start leg goes on; the goal leg is nobody's
    assert len(bus.robots["Tartalo"].gm.assigner) == 1 or uid not in bus.robots["Tartalo"].gm.assigner
    check_invariant(bus)


def test_a_visitor_at_a_robot_out_of_service_is_told_so(faculty6) -> None:
    bus = bus6(faculty6, auto_move=False)
    bus.staff("Basajaun", "Kbot", out=True, detail="cleaning")
    bus.request("Kbot", "101")
    refused = bus.last("Kbot", Phase.REJECTED)
    assert "Kbot is out of service" in refused.detail and "cleaning" in refused.detail
    assert bus.queue_of("Kbot") == [] and not bus.goals
    bus.staff("Basajaun", "Kbot", out=False, version=2)
    bus.request("Kbot", "101")
    assert bus.goals and bus.goals[-1].start_robot == "Kbot"


def test_older_replayed_and_spoofed_staff_commands_change_nothing(faculty6) -> None:
    bus = bus6(faculty6, auto_move=False)
    gm = bus.robots["Tartalo"].gm
    bus.staff("Kbot", "Lamia", out=True, version=5)
    assert not gm.in_service("Lamia")
    bus.staff("Kbot", "Lamia", out=False, version=4)         # older: the one in force stays
    bus.staff("Kbot", "Lamia", out=True, version=5)          # a replay
    assert not gm.in_service("Lamia")
    bus.staff("Basajaun", "Lamia", out=False, version=5)     # same version, an earlier robot name: not in force
    assert not gm.in_service("Lamia")
    bus.staff("MariSorgin", "Lamia", out=False, version=5)   # same version, a later robot name: in force
    assert gm.in_service("Lamia")
    spoof = StaffCommandData(uid=make_uid("Tartalo", SCOPE_STAFF, "dash"), robot="Tartalo", user="eve",
                             command=StaffCmd.OUT_OF_SERVICE, target_robot="Tartalo", version=9)
    kbot = from_robot(gm, "Kbot")
    assert gm.on_staff(spoof, bus.now_ros, bus.now_wall, sender=kbot) == [] and gm.in_service("Tartalo")
    assert gm.gate.counts["foreign"] == 1
    bad = replace(spoof, uid=make_uid("Kbot", SCOPE_STAFF, "dash"), robot="Kbot", command=7)
    assert gm.on_staff(bad, bus.now_ros, bus.now_wall, sender=kbot) == [] and gm.stats["rejected_command"] == 1


def test_a_staff_command_is_taken_only_from_the_dashboard_of_the_robot_it_speaks_for(faculty6) -> None:
    bus = bus6(faculty6, auto_move=False)
    gm = bus.robots["Tartalo"].gm
    cmd = StaffCommandData(uid=make_uid("Tartalo", SCOPE_STAFF, "dash"), robot="Tartalo", user="eve",
                           command=StaffCmd.OUT_OF_SERVICE, target_robot="Kbot", version=3)
    for node in (GM, GUI, TS, "/rostopic_1234"):      # another node of Tartalo's, or none of its: impostors
        assert gm.on_staff(cmd, bus.now_ros, bus.now_wall, sender=node) == [] and gm.in_service("Kbot")
    assert gm.gate.counts["impostor"] == 4
    wrong = replace(cmd, uid=make_uid("Kbot", SCOPE_STAFF, "dash"))       # a uid of another robot
    assert gm.on_staff(wrong, bus.now_ros, bus.now_wall, sender=DASHBOARD) == [] and gm.in_service("Kbot")
    assert gm.gate.counts["wrong_namespace"] == 1
    gm.on_staff(cmd, bus.now_ros, bus.now_wall, sender=DASHBOARD)
    assert not gm.in_service("Kbot")
    back = replace(cmd, uid=make_uid("Kbot", SCOPE_STAFF, "dash"), robot="Kbot", command=StaffCmd.BACK_IN_SERVICE,
                   version=4)
    gm.on_staff(back, bus.now_ros, bus.now_wall, sender=DASHBOARD)      # Kbot's, but from Tartalo's dashboard
    assert not gm.in_service("Kbot") and gm.gate.counts["foreign"] == 1
    gm.on_staff(back, bus.now_ros, bus.now_wall, sender=from_robot(gm, "Kbot"))     # relayed from Kbot
    assert gm.in_service("Kbot")


def test_out_of_service_survives_a_restart_of_the_goal_manager(faculty6) -> None:
    bus = bus6(faculty6, auto_move=False)
    bus.staff("Kbot", "Galtxagorri", out=True)
    state = bus.robots["Tartalo"].gm.state()
    again = GoalManagerCore(faculty6, GoalManagerConfig(robot="Tartalo"), bus.log, bus.now_wall)
    again.load_state(state)
    assert not again.in_service("Galtxagorri") and again.in_service("Lamia")


def test_a_leg_committed_to_a_robot_already_out_of_service_is_handed_back(faculty6) -> None:
    """Lamia accepted a proposal, then staff took it out before the commit reached it: it hands the leg back."""
    bus = bus6(faculty6, auto_move=False)
    bus.request("Galtxagorri", "231")                              # Galtxagorri busy: the goal leg goes to Lamia
    bus.tap = lambda sender, robot, what: "keep" if (sender == "Tartalo" and robot == "Lamia"
                                                     and getattr(getattr(what, "trip", None), "goal_state", None)
                                                     == LEG_COMMITTED) else "pass"
    bus.request("Tartalo", "223")
    uid = trip_to(bus, "223")
    assert (newest(bus, uid).goal_robot, newest(bus, uid).goal_state) == ("Lamia", LEG_COMMITTED)
    bus.tap = None
    bus.staff("Kbot", "Lamia", out=True)
    for _ in range(len(bus.kept)):
        bus.release()
    bus.pump()
    assert any(e.robot == "Lamia" and e.goal_uid == uid and e.phase == Phase.DECLINED for e in bus.events)
    assert uid not in bus.queue_of("Lamia")
    assert (newest(bus, uid).goal_robot, newest(bus, uid).goal_state) == ("Galtxagorri", LEG_COMMITTED)
    check_invariant(bus)


def test_a_commit_that_crossed_the_hand_back_is_not_served_even_back_in_service(faculty6) -> None:
    """Lamia handed back a proposal it had accepted; Tartalo's commit to it was under way (relays keep each link's
    order, so it arrives before the snapshot giving the leg to Galtxagorri). Lamia, back in service meanwhile,
    hands that commit back again and never serves the leg."""
    bus = bus6(faculty6, auto_move=False)
    bus.request("Galtxagorri", "231")
    bus.tap = lambda sender, robot, what: "keep" if (sender == "Tartalo" and robot == "Lamia"
                                                     and isinstance(getattr(what, "trip", None), Trip)) else "pass"
    bus.request("Tartalo", "223")
    uid = trip_to(bus, "223")
    proposal = [k for k in bus.kept if k[1].trip.goal_state != LEG_COMMITTED]
    assert proposal                                   # the proposal is kept too: deliver it first
    bus.release(0)
    bus.pump()
    assert uid in bus.queue_of("Lamia")               # accepted (the commit is on its way)
    bus.tap = lambda sender, robot, what: "keep" if (sender == "Tartalo" and robot == "Lamia"
                                                     and isinstance(getattr(what, "trip", None), Trip)) else "pass"
    bus.staff("Kbot", "Lamia", out=True)              # hands it back: Tartalo moves the leg to Galtxagorri
    assert uid not in bus.queue_of("Lamia")
    bus.tap = None
    bus.staff("Kbot", "Lamia", out=False, version=2)
    while bus.kept:                                   # the commit to Lamia, then the newer attempts, in order
        bus.release(0)
        bus.pump()
    assert uid not in bus.queue_of("Lamia")
    assert Phase.GOING_TO_MEETING not in bus.phases("Lamia", uid)
    assert bus.phases("Lamia", uid).count(Phase.DECLINED) == 2          # the proposal, then the crossing commit
    assert (newest(bus, uid).goal_robot, newest(bus, uid).goal_state) == ("Galtxagorri", LEG_COMMITTED)
    check_invariant(bus)
