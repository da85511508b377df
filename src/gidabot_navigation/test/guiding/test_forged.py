"""A message speaks only for its sender: forged, squatted and replayed messages never touch a real trip.

The four robots of the faculty run their goal managers and navigations on the test bus; hostile messages are
handed to a robot's cores with the callerid their publisher would have on that robot's master: a probe or
``rostopic pub`` (an impostor), a node named like a relay end that is none of the robot's links, the relay end
of another robot's link (which speaks for that robot only), or the rightful sender with other content.
"""

from __future__ import annotations

import math
from dataclasses import replace

from guiding_support import GUI, Bus, from_robot

from gidabot_navigation.guiding.messages import CancelData, CommandData, NavEventData, SendEvent, SendGoal, Trip
from gidabot_navigation.interface import LEG_COMMITTED, LEG_GOAL, LEG_NONE, LEG_PROPOSED, Cmd, Phase
from gidabot_navigation.senders import make_uid

PROBE = "/chaos_probe"                                # a node on the robot's master that is none of ours
FAKE_RELAYS = ("/gidabot_relay_Kbot_Tartalo",         # the pair in the wrong order
               "/gidabot_relay_Tartalo_Ghost",        # a link to a robot not in the building
               "/gidabot_relay_Galtxagorri_MariSorgin",   # a real link, but none of Kbot's
               "/gidabot_relay_Tartalo_Kbot_2")


def bus4(faculty) -> Bus:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    return bus


def newest(bus: Bus, uid: str) -> Trip:
    return max((g for g in bus.goals if g.uid == uid), key=lambda g: g.attempt)


def answers(bus: Bus, robot: str, uid: str) -> list[int]:
    return [e.phase for e in bus.events if e.robot == robot and e.goal_uid == uid]


def feed(bus: Bus, robot: str, msg: Trip | CancelData | NavEventData, sender: str) -> None:
    """``robot``'s cores get ``msg`` (a goal, cancel or event) as ``sender`` published it on its master."""
    r = bus.robots[robot]
    if isinstance(msg, Trip):
        calls = [r.gm.on_goal]
    elif isinstance(msg, CancelData):
        calls = [r.gm.on_cancel, r.nav.on_cancel]
    else:
        calls = [r.gm.on_nav_event, r.nav.on_nav_event]
    for call in calls:
        bus.run(robot, call(msg, bus.now_ros, bus.now_wall, sender=sender))
    bus.pump()


def finish_trip(bus: Bus, uid: str) -> None:
    """Tartalo's visitor goes to room 301: Tartalo guides to the stairs, MariSorgin meets the visitor there."""
    bus.finish_move("MariSorgin")
    bus.finish_move("Tartalo")
    bus.pump()
    assert answers(bus, "MariSorgin", uid)[-1] == Phase.WAITING_VISITOR
    bus.cont("MariSorgin", uid)
    bus.finish_move("MariSorgin")
    bus.pump()
    assert answers(bus, "MariSorgin", uid)[-1] == Phase.GOAL_REACHED


def test_forged_goals_with_a_real_trips_uid_get_no_answer_and_the_trip_goes_on(faculty) -> None:
    """The fault-injection run of the Table 2 tour: goals reusing the uid of a trip of Tartalo with other content
    (its start leg unassigned; a NaN goal floor) made Tartalo publish REJECTED for its own trip, twice, and the
    tour ended. Wherever they come from, no robot answers them, the trip goes on, and every one is counted."""
    bus = bus4(faculty)
    bus.request("Tartalo", "301")
    uid = bus.goals[0].uid
    real = newest(bus, uid)
    forged = [replace(real, start_robot="", start_state=LEG_NONE, attempt=real.attempt + 1),
              replace(real, goal_floor=math.nan, attempt=real.attempt + 2),
              replace(real, goal_id="104", goal_floor=1.0, goal_robot="Kbot", attempt=real.attempt + 3)]
    hostile = 0
    for robot in bus.robots:
        other = next(r for r in bus.robots if r not in (robot, "Tartalo"))
        for sender in (PROBE, from_robot(bus.robots[robot].gm, other), "/gidabot_relay_Tartalo_Ghost"):
            for trip in forged:
                feed(bus, robot, trip, sender)
                hostile += 1
    assert [e for e in bus.events if e.phase == Phase.REJECTED] == []
    assert newest(bus, uid) == real and bus.queue_of("Tartalo") == [uid] and bus.queue_of("MariSorgin") == [uid]
    finish_trip(bus, uid)
    refused = [bus.robots[r].gm.refusals() for r in bus.robots]
    assert sum(sum(r.values()) for r in refused) == hostile and all(r["conflict"] == 0 for r in refused)


def test_an_invalid_copy_of_a_trip_from_its_rightful_sender_is_dropped_unanswered(faculty) -> None:
    """Through Tartalo's own relay end (a forgery on Tartalo's master under one of Tartalo's node names) an invalid
    goal with the uid of Tartalo's trip reaches Kbot: Kbot drops it, counts it, and answers nothing."""
    bus = bus4(faculty)
    bus.request("Tartalo", "301")
    uid = bus.goals[0].uid
    real = newest(bus, uid)
    kbot = bus.robots["Kbot"].gm
    for bad in (replace(real, start_robot="", start_state=LEG_NONE), replace(real, goal_floor=math.nan)):
        feed(bus, "Kbot", replace(bad, attempt=real.attempt + 1), from_robot(kbot, "Tartalo"))
    assert answers(bus, "Kbot", uid) == [] and kbot.refusals()["invalid"] == 2
    finish_trip(bus, uid)


def test_a_real_uid_with_other_content_is_a_conflict_never_applied_nor_answered(faculty) -> None:
    """Kbot holds Tartalo's trip to room 101 (its goal leg committed to Kbot). A newer attempt of the same uid,
    from the rightful sender but with another trip in it (room 104), is a conflict: dropped, counted, logged once;
    the same goal again is a plain duplicate."""
    bus = bus4(faculty)
    bus.request("Tartalo", "101")
    uid = bus.goals[0].uid
    real = newest(bus, uid)
    assert real.goal_robot == "Kbot" and real.goal_state == LEG_COMMITTED
    kbot = bus.robots["Kbot"].gm
    relay = from_robot(kbot, "Tartalo")
    other = bus.building.location("104")
    forged = replace(real, goal_id="104", goal_x=other.pose.x, goal_y=other.pose.y, goal_yaw=other.pose.yaw,
                     attempt=real.attempt + 5)
    before = list(bus.events)
    for n in range(3):
        feed(bus, "Kbot", replace(forged, attempt=forged.attempt + n), relay)
    assert [t.goal_id for t in kbot.queue] == ["101"] and bus.events == before
    assert kbot.refusals()["conflict"] == 3
    assert sum("came again" in line for _, line in bus.log.lines) == 1
    feed(bus, "Kbot", real, relay)                          # the real goal once more: a duplicate
    assert kbot.refusals()["conflict"] == 3 and bus.events == before


def test_a_squatted_future_uid_does_not_take_the_real_trip(faculty) -> None:
    """Before Tartalo's goal reaches Kbot, goals and a cancel with its uid arrive there: a valid goal with a huge
    attempt and a cancel from a probe, an invalid goal through Tartalo's relay. None of them takes the uid: the real
    goal is answered (ACCEPTED for its own attempt) and served."""
    bus = bus4(faculty)
    bus.tap = lambda s, r, a: "keep" if r == "Kbot" and isinstance(a, SendGoal) else "pass"
    bus.request("Tartalo", "101")
    uid = bus.goals[0].uid
    first = bus.goals[0]
    kbot = bus.robots["Kbot"].gm
    feed(bus, "Kbot", replace(first, attempt=2 ** 31, goal_state=LEG_COMMITTED), PROBE)
    feed(bus, "Kbot", CancelData(make_uid("Tartalo", "cancel", "gm"), uid, "Tartalo", "visitor"), PROBE)
    feed(bus, "Kbot", replace(first, goal_floor=math.nan), from_robot(kbot, "Tartalo"))
    assert kbot.queue == [] and answers(bus, "Kbot", uid) == []
    while bus.kept:
        bus.release()
    bus.pump()
    accepted = [e for e in bus.events if e.robot == "Kbot" and e.goal_uid == uid and e.phase == Phase.ACCEPTED]
    assert [e.attempt for e in accepted] == [first.attempt]
    assert newest(bus, uid).goal_robot == "Kbot" and newest(bus, uid).goal_state == LEG_COMMITTED
    assert [t.uid for t in kbot.queue] == [uid]
    assert kbot.refusals()["impostor"] == 2 and kbot.refusals()["invalid"] == 1


def test_forged_replies_for_a_real_trip_neither_commit_nor_move_nor_end_it(faculty) -> None:
    """Tartalo has proposed the goal leg of its trip to MariSorgin. A forged ACCEPTED (from a probe), DECLINED
    (through Kbot's relay end) or ACCEPTED (from a fake relay end) in MariSorgin's name commits nothing and asks
    nobody else; a forged GOAL_REACHED or REJECTED in Tartalo's own name drops nothing. MariSorgin's real answer
    then commits the leg."""
    bus = bus4(faculty)
    bus.tap = lambda s, r, a: "keep" if s == "MariSorgin" and r == "Tartalo" and isinstance(a, SendEvent) \
        and a.event.phase == Phase.ACCEPTED else "pass"
    bus.request("Tartalo", "301")
    uid = bus.goals[0].uid
    proposal = newest(bus, uid)
    assert proposal.goal_robot == "MariSorgin" and proposal.goal_state == LEG_PROPOSED
    tartalo = bus.robots["Tartalo"].gm

    def reply(robot: str, phase: int) -> NavEventData:
        return NavEventData(uid=make_uid(robot, "event", "gm"), robot=robot, floor=3.0 if robot == "MariSorgin" else 0,
                            goal_uid=uid, phase=phase, leg=LEG_GOAL, attempt=proposal.attempt, eta=1.0)

    feed(bus, "Tartalo", reply("MariSorgin", Phase.ACCEPTED), PROBE)
    feed(bus, "Tartalo", reply("MariSorgin", Phase.DECLINED), from_robot(tartalo, "Kbot"))
    feed(bus, "Tartalo", reply("MariSorgin", Phase.ACCEPTED), "/gidabot_relay_Tartalo_Ghost")
    feed(bus, "Tartalo", replace(reply("Tartalo", Phase.GOAL_REACHED), leg=""), PROBE)
    feed(bus, "Tartalo", replace(reply("Tartalo", Phase.REJECTED), leg=""), from_robot(tartalo, "MariSorgin"))
    assert newest(bus, uid) == proposal
    assert [e for e in bus.events if e.phase == Phase.ASSIGNED and e.leg == LEG_GOAL] == []
    assert bus.queue_of("Tartalo") == [uid]
    assert tartalo.refusals()["impostor"] == 3 and tartalo.refusals()["foreign"] == 2
    bus.release()                                              # MariSorgin's own ACCEPTED, through its relay end
    bus.pump()
    [assigned] = [e for e in bus.events if e.phase == Phase.ASSIGNED and e.leg == LEG_GOAL]
    assert assigned.assignee == "MariSorgin" and newest(bus, uid).goal_state == LEG_COMMITTED
    finish_trip(bus, uid)


def test_goals_from_impostors_and_fake_relay_ends_are_never_answered(faculty) -> None:
    """A goal of Tartalo's proposing a leg to Kbot, published on Kbot's master by a probe, ``rostopic pub``, a node
    named like a relay end that is none of Kbot's links, or Galtxagorri's relay end (which speaks only for
    Galtxagorri): Kbot neither answers nor keeps it. Through Tartalo's relay end it is answered."""
    bus = bus4(faculty)
    bus.tap = lambda s, r, a: "drop" if r == "Kbot" and isinstance(a, SendGoal) else "pass"
    bus.request("Tartalo", "101")
    proposal = bus.goals[0]
    assert proposal.goal_robot == "Kbot" and proposal.goal_state == LEG_PROPOSED
    kbot = bus.robots["Kbot"].gm
    for sender in (PROBE, "/rostopic_4242_1700000000", *FAKE_RELAYS, from_robot(kbot, "Galtxagorri"), ""):
        feed(bus, "Kbot", proposal, sender)
    assert kbot.queue == [] and answers(bus, "Kbot", proposal.uid) == []
    assert kbot.refusals()["impostor"] == 7 and kbot.refusals()["foreign"] == 1
    feed(bus, "Kbot", proposal, from_robot(kbot, "Tartalo"))
    assert answers(bus, "Kbot", proposal.uid) == [Phase.ACCEPTED]


def test_messages_of_robots_not_in_the_building_are_refused(faculty) -> None:
    """A goal, a cancel and an event of 'Ghost' (uids in Ghost's namespace), through Tartalo's relay end or from a
    probe, and statuses that would make an offline robot look online: refused, counted, never answered."""
    bus = bus4(faculty)
    bus.request("Tartalo", "101")
    real = newest(bus, bus.goals[0].uid)
    kbot = bus.robots["Kbot"].gm
    ghost = replace(real, uid=make_uid("Ghost", "v", "gm"), origin_robot="Ghost")
    before = list(bus.events)
    for sender in (from_robot(kbot, "Tartalo"), PROBE):
        feed(bus, "Kbot", ghost, sender)
        feed(bus, "Kbot", CancelData(make_uid("Ghost", "cancel", "gm"), real.uid, "Ghost", "visitor"), sender)
        feed(bus, "Kbot", NavEventData(uid=make_uid("Ghost", "event", "nav"), robot="Ghost", floor=1.0,
                                             goal_uid=real.uid, phase=Phase.GOAL_REACHED), sender)
    # a status of MariSorgin from a probe on Kbot's master does not keep MariSorgin online
    kbot.on_status("MariSorgin", bus.now_wall + 100.0, sender=PROBE)
    assert not kbot.liveness.online("MariSorgin", bus.now_wall + 100.0)
    assert bus.events == before and [t.uid for t in kbot.queue] == [real.uid]
    assert kbot.refusals()["foreign"] == 3 and kbot.refusals()["impostor"] == 4


def test_a_visitor_command_from_a_node_that_is_not_the_gui_is_never_answered(faculty) -> None:
    bus = bus4(faculty)
    tartalo = bus.robots["Tartalo"].gm
    for sender in (PROBE, from_robot(tartalo, "Kbot")):
        for cmd in (CommandData(command=Cmd.REQUEST, goal_id="301", way="stairs"), CommandData(command=99)):
            assert tartalo.on_command(cmd, bus.now_ros, bus.now_wall, sender=sender) == []
    assert tartalo.queue == [] and tartalo.refusals()["impostor"] == 2 and tartalo.refusals()["foreign"] == 2
    assert tartalo.on_command(CommandData(command=Cmd.REQUEST, goal_id="301", way="stairs"), bus.now_ros, bus.now_wall,
                              sender=GUI)


def test_navigation_acts_only_on_its_own_robots_commands_and_the_rightful_cancels(faculty) -> None:
    """MariSorgin drives to the meeting point of Tartalo's trip. A forged cancel (a probe; Kbot's relay end in
    Tartalo's name), a Continue from a probe, a pending list without the trip from a probe, and a forged release
    (GO_TO_FLOOR in Tartalo's name through Kbot's relay end) neither stop nor move it, nor start its timeout."""
    bus = bus4(faculty)
    bus.request("Tartalo", "301")
    uid = bus.goals[0].uid
    mari = bus.robots["MariSorgin"]
    assert mari.active is not None and mari.nav.leg is not None and mari.nav.leg.trip.uid == uid
    nav = mari.nav
    relay_kbot = from_robot(nav, "Kbot")
    cancel = CancelData(make_uid("Tartalo", "cancel", "gm"), uid, "Tartalo", "visitor")
    assert nav.on_cancel(cancel, bus.now_ros, bus.now_wall, sender=PROBE) == []
    assert nav.on_cancel(cancel, bus.now_ros, bus.now_wall, sender=relay_kbot) == []
    assert nav.on_continue(uid, bus.now_ros, bus.now_wall, sender=PROBE) == []
    assert nav.on_pending([], 0.0, bus.now_ros, bus.now_wall, robot="MariSorgin", sender=PROBE) == []
    release = NavEventData(uid=make_uid("Tartalo", "event", "nav"), robot="Tartalo", floor=0.0, goal_uid=uid,
                           phase=Phase.GO_TO_FLOOR)
    assert nav.on_nav_event(release, bus.now_ros, bus.now_wall, sender=relay_kbot) == []
    assert nav.leg is not None and nav.leg.trip.uid == uid and mari.stops == [] and not nav.leg.continued
    assert nav.refusals() == {"impostor": 3, "foreign": 2, "wrong_namespace": 0, "conflict": 0, "invalid": 0}
    # the rightful cancel, from Tartalo's relay end, stops it at once
    acts = nav.on_cancel(cancel, bus.now_ros, bus.now_wall, sender=from_robot(nav, "Tartalo"))
    assert acts and nav.leg is None
