"""The goal manager core: FIFO, involvement, cancels, partner offline, hostile goals, tour mode."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from guiding_support import Bus, ListLog, catalog_of

from gidabot_navigation.errors import GuidingError
from gidabot_navigation.guiding.goal_manager import GoalManagerConfig, GoalManagerCore
from gidabot_navigation.guiding.messages import CancelData, CommandData, NavEventData, SendCancel, SendEvent, SendGoal
from gidabot_navigation.interface import LEG_COMMITTED, LEG_PROPOSED, REASON_VISITOR, Cmd, Phase

TOURS = Path(__file__).resolve().parents[4] / "tours"


def core(faculty, robot: str = "Tartalo", **cfg) -> GoalManagerCore:
    gm = GoalManagerCore(faculty, GoalManagerConfig(robot=robot, **cfg), ListLog(), now_wall=0.0, boot="t")
    for r in faculty.robots:
        gm.on_status(r.name, 0.0)
    return gm


def events(actions, phase=None):
    out = [a.event for a in actions if isinstance(a, SendEvent)]
    return out if phase is None else [e for e in out if e.phase == phase]


def goals(actions):
    return [a.trip for a in actions if isinstance(a, SendGoal)]


def request(gm, goal_id: str, visitor: str = "v", way: str = "stairs", now_wall: float = 1.0, **kw):
    return gm.on_command(CommandData(command=Cmd.REQUEST, goal_id=goal_id, way=way, language="es", visitor_id=visitor,
                                     **kw), 10.0, now_wall)


def own_event(gm, trip_uid: str, phase: int, n: int, **kw) -> list:
    ev = NavEventData(uid=f"{gm.me}/event/nav.t.{n}", robot=gm.me, floor=gm.robot.floor, goal_uid=trip_uid,
                      phase=phase, **kw)
    return gm.on_nav_event(ev, 20.0, 2.0)


def test_unknown_robot_is_a_clear_error(faculty) -> None:
    with pytest.raises(GuidingError, match="'Nobody' is not in building"):
        GoalManagerCore(faculty, GoalManagerConfig(robot="Nobody"), ListLog(), 0.0)


def test_a_request_becomes_a_broadcast_goal_accepted_here(faculty) -> None:
    gm = core(faculty)
    gm.on_pose(31.0, 12.0, 0.0)
    acts = request(gm, "301")
    [trip] = goals(acts)
    assert (trip.origin_robot, trip.initial_floor, trip.goal_floor, trip.goal_id) == ("Tartalo", 0.0, 3.0, "301")
    assert (trip.initial_x, trip.initial_y, trip.start_id, trip.language) == (31.0, 12.0, "robot", "es")
    assert trip.connector == "stairs_west" and trip.way == "stairs"
    assert trip.uid.startswith("Tartalo/v/")
    [acc] = events(acts, Phase.ACCEPTED)
    assert (acc.goal_uid, acc.robot, acc.target_floor, acc.connector) == (trip.uid, "Tartalo", 3.0, "stairs_west")
    assert [t.uid for t in gm.queue] == [trip.uid]
    # the echo from /gidabot/goals is not queued twice
    assert gm.on_goal(trip, 10.0, 1.0) == [] and len(gm.queue) == 1
    assert gm.stats["received"] == 1 and gm.stats["duplicates"] == 1


def test_two_visitors_are_queued_fifo_with_growing_waits(faculty) -> None:
    gm = core(faculty)
    a = goals(request(gm, "001", visitor="anne"))[0]
    b = goals(request(gm, "022", visitor="bob"))[0]
    assert [t.uid for t in gm.queue] == [a.uid, b.uid]
    snap = gm.pending(10.0)
    assert snap.goals == (a, b) and len(snap.eta) == 2 and 0 < snap.eta[0] < snap.eta[1] == snap.wait_new
    # the head finishes (this robot's navigation says so): bob is next
    v = gm.version
    own_event(gm, a.uid, Phase.ON_THE_WAY, 1)
    own_event(gm, a.uid, Phase.GOAL_REACHED, 2)
    assert [t.uid for t in gm.queue] == [b.uid] and gm.version > v


def test_only_goals_starting_or_ending_here_are_kept(faculty) -> None:
    tartalo, kbot, mari = core(faculty, "Tartalo"), core(faculty, "Kbot"), core(faculty, "MariSorgin")
    trip = goals(request(tartalo, "301"))[0]
    assert events(mari.on_goal(trip, 10.0, 1.0), Phase.ACCEPTED)
    assert kbot.on_goal(trip, 10.0, 1.0) == [] and kbot.queue == [] and kbot.stats["received"] == 1


def test_cancel_of_a_queued_goal_everywhere(faculty) -> None:
    bus = Bus(faculty, navigation=False)
    bus.status_all()
    bus.request("Tartalo", "001")
    bus.request("Tartalo", "301")            # queued behind the first
    first, second = bus.queue_of("Tartalo")
    assert bus.queue_of("MariSorgin") == [second]
    bus.cancel("Tartalo", goal_uid=second)
    assert bus.queue_of("Tartalo") == [first] and bus.queue_of("MariSorgin") == []
    [c] = bus.cancels
    assert (c.goal_uid, c.origin_robot, c.reason) == (second, "Tartalo", REASON_VISITOR)
    assert bus.phases("Tartalo", second) == [Phase.ACCEPTED, Phase.CANCELLED_HERE]
    assert bus.phases("MariSorgin", second) == [Phase.ACCEPTED, Phase.CANCELLED_ELSEWHERE]


def test_cancel_without_uid_means_the_trip_in_progress(faculty) -> None:
    gm = core(faculty)
    a = goals(request(gm, "001"))[0]
    b = goals(request(gm, "022"))[0]
    own_event(gm, a.uid, Phase.ON_THE_WAY, 1)
    acts = gm.on_command(CommandData(command=Cmd.CANCEL), 11.0, 1.0)
    [cancel] = [x.cancel for x in acts if isinstance(x, SendCancel)]
    assert cancel.goal_uid == a.uid and [t.uid for t in gm.queue] == [b.uid]
    assert events(acts, Phase.CANCELLED_HERE)[0].goal_uid == a.uid
    # nothing in progress: the newest goal made here
    acts = gm.on_command(CommandData(command=Cmd.CANCEL), 11.0, 1.0)
    assert gm.queue == [] and events(acts, Phase.CANCELLED_HERE)[0].goal_uid == b.uid
    assert gm.on_command(CommandData(command=Cmd.CANCEL), 11.0, 1.0) == []


def test_a_cancel_that_overtakes_its_goal_wins(faculty) -> None:
    tartalo, mari = core(faculty, "Tartalo"), core(faculty, "MariSorgin")
    trip = goals(request(tartalo, "301"))[0]
    c = CancelData(uid="Tartalo/cancel/gm.t.9", goal_uid=trip.uid, origin_robot="Tartalo", reason="visitor")
    assert mari.on_cancel(c, 10.0, 1.0, from_relay=True) == []
    assert mari.stats["cancel_unknown"] == 1                       # a cancel of a goal never seen is counted
    assert mari.on_goal(trip, 10.0, 1.0) == [] and mari.queue == []
    assert mari.stats["cancelled_before_arrival"] == 1
    # a second copy of the same cancel changes nothing
    assert mari.on_cancel(c, 10.0, 1.0, from_relay=True) == []


def test_cancels_from_other_robots_tell_why(faculty) -> None:
    tartalo, mari = core(faculty, "Tartalo"), core(faculty, "MariSorgin")
    phases = {}
    for i, reason in enumerate(("visitor", "unreachable", "timeout", "offline", "admin")):
        trip = goals(request(tartalo, "301"))[0]
        c = CancelData(uid=f"MariSorgin/cancel/nav.t.{i}", goal_uid=trip.uid, origin_robot="MariSorgin",
                       reason=reason, detail="d")
        phases[reason] = [e.phase for e in events(tartalo.on_cancel(c, 10.0, 1.0, from_relay=True))]
    assert phases == {"visitor": [Phase.CANCELLED_ELSEWHERE], "unreachable": [Phase.UNREACHABLE], "timeout": [10],
                      "offline": [Phase.PARTNER_OFFLINE], "admin": [Phase.CANCELLED_ELSEWHERE]}
    assert mari.stats.get("accepted", 0) == 0


def test_own_navigation_giving_up_is_silent_but_spoofs_are_refused(faculty) -> None:
    gm = core(faculty)
    trip = goals(request(gm, "301"))[0]
    spoof = CancelData(uid="x/cancel/1", goal_uid=trip.uid, origin_robot="Tartalo", reason="unreachable")
    assert gm.on_cancel(spoof, 10.0, 1.0, from_relay=True) == [] and len(gm.queue) == 1
    assert gm.stats["rejected_spoofed"] == 1
    own = CancelData(uid="Tartalo/cancel/nav.t.1", goal_uid=trip.uid, origin_robot="Tartalo", reason="unreachable")
    assert gm.on_cancel(own, 10.0, 1.0) == [] and gm.queue == []
    # a relayed event claiming to be ours does not drop anything either
    trip2 = goals(request(gm, "001"))[0]
    ev = NavEventData(uid="Tartalo/event/evil.1", robot="Tartalo", floor=0.0, goal_uid=trip2.uid,
                      phase=Phase.GOAL_REACHED)
    gm.on_nav_event(ev, 10.0, 1.0, from_relay=True)
    assert [t.uid for t in gm.queue] == [trip2.uid]


def test_a_request_needing_an_offline_robot_is_answered_at_once(faculty) -> None:
    gm = core(faculty, offline_after=5.0)
    for name in ("Tartalo", "Kbot", "Galtxagorri"):
        gm.on_status(name, 100.0)
    acts = request(gm, "301", now_wall=103.0)
    assert goals(acts) == [] and gm.queue == []
    [ev] = events(acts)
    assert ev.phase == Phase.PARTNER_OFFLINE and ev.goal_uid == "" and ev.target_floor == 3.0
    assert "MariSorgin" in ev.detail
    # same floor and floors whose robot is online still work
    assert goals(request(gm, "001", now_wall=103.0)) and goals(request(gm, "223", now_wall=103.0))
    # MariSorgin comes back
    gm.on_status("MariSorgin", 104.0)
    assert goals(request(gm, "301", now_wall=104.5))


def test_robots_never_heard_are_online_only_at_start(faculty) -> None:
    gm = GoalManagerCore(faculty, GoalManagerConfig(robot="Tartalo"), ListLog(), now_wall=50.0)
    assert goals(request(gm, "301", now_wall=52.0))
    assert events(request(gm, "301", now_wall=56.0), Phase.PARTNER_OFFLINE)


def test_what_a_restart_must_still_publish_is_all_but_a_refusal(faculty) -> None:
    gm = core(faculty)
    assert gm.durable(request(gm, "999")) == []      # a refusal changes no state
    made = request(gm, "001")
    assert goals(made) and gm.durable(made) == made


def test_bad_requests_are_rejected_with_a_reason(faculty) -> None:
    gm = core(faculty)
    assert events(request(gm, "999"), Phase.REJECTED)[0].detail == "unknown goal '999'"
    assert events(gm.on_command(CommandData(command=Cmd.REQUEST), 1.0, 1.0), Phase.REJECTED)
    assert events(gm.on_command(CommandData(command=42), 1.0, 1.0), Phase.REJECTED)
    rocket = CommandData(command=Cmd.REQUEST, goal_id="001", way="rocket")
    assert events(gm.on_command(rocket, 1.0, 1.0), Phase.REJECTED)
    assert gm.queue == []
    # an unplannable start (the robot is lost in a wall) is answered as unreachable
    gm.on_pose(0.0, 0.0, 0.0)
    assert events(request(gm, "001"), Phase.UNREACHABLE)


def test_hostile_goals_are_counted_and_only_ours_get_an_event(faculty) -> None:
    tartalo, kbot = core(faculty, "Tartalo"), core(faculty, "Kbot")
    good = goals(request(tartalo, "104"))[0]
    bad = [replace(good, uid="a/1", goal_floor=math.nan), replace(good, uid="a/2", goal_id="x" * 10 ** 6),
           replace(good, uid="a/3", origin_robot="Evil"), replace(good, uid="a/4", goal_floor=9.0),
           replace(good, uid="a/5", goal_id="999"), replace(good, uid="a/6", language="\x00"),
           replace(good, uid="b" * 10 ** 5), replace(good, uid="a/8", initial_x=math.inf),
           replace(good, uid="a/9", tour_file="/etc/passwd", tour_step=0)]
    for trip in bad:
        assert kbot.on_goal(trip, 1.0, 1.0) == []
    assert kbot.queue == [] and kbot.stats["rejected"] == len(bad)
    assert kbot.stats["rejected_not_finite"] == 2 and kbot.stats["rejected_too_long"] == 2
    # a broken goal of our own origin is reported to our visitor
    assert events(tartalo.on_goal(replace(good, uid="Tartalo/v/x", goal_id="999"), 1.0, 1.0), Phase.REJECTED)


def test_a_pending_list_with_a_wait_that_is_not_a_number_is_rejected_and_counted(faculty) -> None:
    """The chaos run's spoofed /gidabot/pending (wait_new -inf, eta nan): it made the robot look idle (wait 0) to
    the others, and nobody counted it. The last good list of that robot is kept."""
    kbot = core(faculty, "Kbot")
    queued = goals(request(core(faculty, "Galtxagorri"), "104"))[0]
    kbot.on_pending("Galtxagorri", [queued], 240.0, 1.0)
    for wait in (-math.inf, math.nan, math.inf, "x"):
        kbot.on_pending("Galtxagorri", [], wait, 2.0)
    view = kbot.fleet["Galtxagorri"]
    assert (view.wait_new, [t.uid for t in view.queue], view.heard) == (240.0, [queued.uid], 1.0)
    assert kbot.stats["rejected_pending"] == 4


def test_a_full_queue_declines_the_leg_waits_and_is_taken_when_there_is_room(faculty) -> None:
    """The only robot of the floor declines the start leg (queue full): the leg is not refused nor left unserved,
    it waits; a new round after requeue_after asks again; once there is room it is accepted."""
    gm = core(faculty, max_queue=2)
    [first] = goals(request(gm, "001"))
    request(gm, "022")
    acts = request(gm, "012")
    [declined] = events(acts, Phase.DECLINED)
    assert len(gm.queue) == 2 and "queue of Tartalo is full" in declined.detail and not events(acts, Phase.REJECTED)
    [waiting] = goals(acts)                    # published: the leg waits for Tartalo's queue
    assert (waiting.start_robot, waiting.start_state) == ("Tartalo", LEG_PROPOSED)
    assert waiting.uid in gm.assigner and gm.tick(10.0, 5.0) == []
    acts = gm.tick(10.0, 11.5)                  # a new round: still full, declined again, still waiting
    assert [e.attempt for e in events(acts, Phase.DECLINED)] == [2] and waiting.uid in gm.assigner
    own_event(gm, first.uid, Phase.GOAL_REACHED, 1)   # room in the queue
    acts = gm.tick(10.0, 22.0)
    assert [e.leg for e in events(acts, Phase.ACCEPTED)] == ["start"] and [g.start_state for g in goals(acts)] == [
        LEG_COMMITTED]
    assert waiting.uid in [t.uid for t in gm.queue] and not [a for a in acts if isinstance(a, SendCancel)]


def test_a_long_queue_is_no_reason_to_decline_unless_max_wait_is_set(faculty) -> None:
    from gidabot_navigation.guiding.assignment import AssignConfig
    [trip] = goals(request(core(faculty), "301"))
    mari = core(faculty, "MariSorgin")
    mari.on_pending("Tartalo", [], 0.0, 1.0)
    for i, target in enumerate(("301", "305", "310", "301", "305") * 3):   # its queue: 15 trips across the floor
        mari.on_command(CommandData(command=Cmd.REQUEST, goal_id=target, visitor_id=f"m{i}"), 10.0, 1.0)
    acts = mari.on_goal(trip, 10.0, 1.0)
    [acc] = events(acts, Phase.ACCEPTED)
    assert acc.eta > 900 and not events(acts, Phase.DECLINED)      # the former fixed limit: 900 s
    strict = core(faculty, "MariSorgin", assign=AssignConfig(max_wait=1.0))
    [dec] = events(strict.on_goal(trip, 10.0, 1.0), Phase.DECLINED)
    assert "more than max_wait 1 s" in dec.detail


def test_a_commit_to_a_full_queue_is_refused_and_cancelled(faculty) -> None:
    gm = core(faculty, max_queue=2)
    request(gm, "001")
    request(gm, "022")
    # a trip committed here while the queue is full (never answered here) is refused and cancelled everywhere
    [down] = goals(request(core(faculty, "Kbot"), "012", visitor="w"))
    assert (down.goal_robot, down.goal_state) == ("Tartalo", LEG_PROPOSED)
    acts = gm.on_goal(replace(down, goal_state=LEG_COMMITTED, attempt=5), 10.0, 1.0)
    assert [a.cancel.reason for a in acts if isinstance(a, SendCancel)] == ["admin"] and len(gm.queue) == 2


# ---------------------------------------------------------------------------- tour mode

@pytest.fixture
def tour_gm(faculty):
    gm = core(faculty, "Kbot")
    gm.on_catalog(catalog_of(faculty, TOURS / "real_world.tour", TOURS / "long_tour.tour"))
    return gm


def start(gm, tour_file: str = "real_world.tour", **kw):
    return gm.on_command(CommandData(command=Cmd.START_TOUR, tour_file=tour_file, way="lift", language="eu",
                                     visitor_id="v", **kw), 10.0, 1.0)


def test_start_tour_issues_step_zero_from_here(tour_gm) -> None:
    [trip] = goals(start(tour_gm))
    assert (trip.tour_file, trip.tour_step, trip.goal_id, trip.initial_floor) == ("real_world.tour", 0, "014", 1.0)
    assert trip.way == "lift" and trip.language == "eu" and trip.connector == "lift"
    unknown = start(tour_gm, "nope.tour")
    assert events(unknown, Phase.REJECTED) and "not in this robot's catalog" in events(unknown)[0].detail


def test_continue_after_a_step_issues_the_next_from_here(tour_gm) -> None:
    # step 2 (101, floor 1) was done here at Kbot
    trip = replace(goals(start(tour_gm))[0], uid="Tartalo/v/9", origin_robot="Tartalo", initial_floor=0.0,
                   goal_floor=1.0, goal_id="101", tour_step=2, connector="lift", initial_x=30.0,
                   start_robot="Tartalo", start_state=LEG_COMMITTED, goal_robot="Kbot", goal_state=LEG_COMMITTED)
    loc = tour_gm.building.location("101")
    trip = replace(trip, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw)
    tour_gm.on_goal(trip, 10.0, 1.0)
    own_event(tour_gm, trip.uid, Phase.TOUR_STEP_DONE, 1, tour_file="real_world.tour", tour_step=2)
    tour_gm.on_pose(20.0, 12.0, 0.0)
    # a Continue for something else (e.g. a meeting point) is not the goal manager's
    assert tour_gm.on_command(CommandData(command=Cmd.CONTINUE, goal_uid="Kbot/x/1"), 11.0, 1.0) == []
    acts = tour_gm.on_command(CommandData(command=Cmd.CONTINUE, goal_uid=trip.uid), 11.0, 1.0)
    [nxt] = goals(acts)
    assert (nxt.tour_step, nxt.goal_id, nxt.initial_floor, nxt.initial_x) == (3, "104", 1.0, 20.0)
    assert nxt.way == "lift" and nxt.language == "eu" and nxt.visitor_id == "v"      # remembered from the step
    # the same Continue again does nothing more
    assert tour_gm.on_command(CommandData(command=Cmd.CONTINUE, goal_uid=trip.uid), 11.0, 1.0) == []


def test_two_visitors_on_the_same_tour_at_one_robot_keep_their_own_steps(tour_gm) -> None:
    """Visitor a finished step 2 here and is about to press Continue; visitor b starts the same tour at this screen
    (many visitors: found on faculty6 seed 2, a's Continue was lost): a's step waits on, its Continue goes on."""
    trip = replace(goals(start(tour_gm))[0], uid="Tartalo/a/9", origin_robot="Tartalo", visitor_id="a",
                   initial_floor=0.0, goal_floor=1.0, goal_id="101", tour_step=2, connector="lift", initial_x=30.0,
                   start_robot="Tartalo", start_state=LEG_COMMITTED, goal_robot="Kbot", goal_state=LEG_COMMITTED)
    loc = tour_gm.building.location("101")
    tour_gm.on_goal(replace(trip, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw), 10.0, 1.0)
    own_event(tour_gm, trip.uid, Phase.TOUR_STEP_DONE, 1, tour_file="real_world.tour", tour_step=2)
    b = tour_gm.on_command(CommandData(command=Cmd.START_TOUR, tour_file="real_world.tour", visitor_id="b"), 10.5, 1.0)
    assert [g.visitor_id for g in goals(b)] == ["b"] and not [a for a in b if isinstance(a, SendCancel)]
    [nxt] = goals(tour_gm.on_command(CommandData(command=Cmd.CONTINUE, goal_uid=trip.uid, visitor_id="a"), 11.0, 1.0))
    assert (nxt.visitor_id, nxt.tour_step, nxt.goal_id) == ("a", 3, "104")
    # b cancels its own tour: a's next step is untouched
    tour_gm.on_command(CommandData(command=Cmd.CANCEL, goal_uid=goals(b)[0].uid, visitor_id="b"), 12.0, 1.0)
    assert nxt.uid in [t.uid for t in tour_gm.queue]


def test_skip_restart_cancel_and_finish(tour_gm) -> None:
    first = goals(start(tour_gm))[0]
    # skip while step 0 is still held here: step 0 is cancelled everywhere, step 5 issued
    acts = tour_gm.on_command(CommandData(command=Cmd.SKIP, tour_file="real_world.tour", tour_step=5, visitor_id="v"),
                              11.0, 1.0)
    assert [a.cancel.goal_uid for a in acts if isinstance(a, SendCancel)] == [first.uid]
    assert not events(acts, Phase.CANCELLED_HERE)                           # the visitor chose it: no pop-up
    [skipped] = goals(acts)
    assert skipped.tour_step == 5 and skipped.goal_id == "274" and [t.uid for t in tour_gm.queue] == [skipped.uid]
    # out-of-range skip
    bad = tour_gm.on_command(CommandData(command=Cmd.SKIP, tour_file="real_world.tour", tour_step=8), 11.0, 1.0)
    assert events(bad, Phase.REJECTED) and "steps 0..7" in events(bad)[0].detail
    # start again: restarts at step 0, cancelling the held step
    acts = start(tour_gm)
    assert [a.cancel.goal_uid for a in acts if isinstance(a, SendCancel)] == [skipped.uid]
    assert goals(acts)[0].tour_step == 0
    # the last step done here; a Continue ends the tour
    last = goals(tour_gm.on_command(CommandData(command=Cmd.SKIP, tour_file="real_world.tour", tour_step=7,
                                                visitor_id="v"), 12.0, 1.0))[0]
    own_event(tour_gm, last.uid, Phase.TOUR_STEP_DONE, 5, tour_file="real_world.tour", tour_step=7)
    fin = tour_gm.on_command(CommandData(command=Cmd.CONTINUE, goal_uid=last.uid), 13.0, 1.0)
    assert [e.phase for e in events(fin)] == [Phase.TOUR_FINISHED] and goals(fin) == []


def test_cancel_after_a_step_ends_the_tour(tour_gm) -> None:
    trip = goals(start(tour_gm, "long_tour.tour"))[0]     # step 0 is on floor 0: Kbot guides to the stairs
    own_event(tour_gm, trip.uid, Phase.ON_THE_WAY, 1)
    own_event(tour_gm, trip.uid, Phase.GO_TO_FLOOR, 2)
    assert tour_gm.queue == []
    tour_gm2 = tour_gm
    t = goals(tour_gm2.on_command(CommandData(command=Cmd.SKIP, tour_file="long_tour.tour", tour_step=3,
                                              visitor_id="v"), 11.0, 1.0))[0]
    assert t.goal_id == "103"                              # floor 1, same floor as Kbot
    own_event(tour_gm2, t.uid, Phase.ON_THE_WAY, 3)
    own_event(tour_gm2, t.uid, Phase.TOUR_STEP_DONE, 4, tour_file="long_tour.tour", tour_step=3)
    acts = tour_gm2.on_command(CommandData(command=Cmd.CANCEL), 12.0, 1.0)
    [ev] = events(acts)
    assert (ev.phase, ev.goal_uid, ev.tour_step, ev.detail) == (Phase.CANCELLED_HERE, t.uid, 3, "tour ended")
    # nothing left to continue
    assert tour_gm2.on_command(CommandData(command=Cmd.CONTINUE), 13.0, 1.0) == []


def test_continue_without_uid_prefers_the_meeting_point(tour_gm) -> None:
    trip = goals(start(tour_gm, "long_tour.tour", tour_step=-1))[0]
    own_event(tour_gm, trip.uid, Phase.TOUR_STEP_DONE, 1, tour_file="long_tour.tour", tour_step=0)
    other = goals(request(core(tour_gm.building, "Tartalo"), "104"))[0]     # a visitor coming up from floor 0
    tour_gm.on_goal(other, 10.0, 1.0)
    own_event(tour_gm, other.uid, Phase.WAITING_VISITOR, 2)
    assert tour_gm.on_command(CommandData(command=Cmd.CONTINUE), 11.0, 1.0) == []   # navigation's Continue
    assert goals(tour_gm.on_command(CommandData(command=Cmd.CONTINUE, goal_uid=trip.uid), 11.0, 1.0))


# ---------------------------------------------------------------------------- before the first catalog

def test_a_tour_command_before_the_first_catalog_waits_for_it(faculty) -> None:
    """A goal manager that has just (re)started hears the visitor's (replayed) command before the tour store's
    latched catalog: it was refused ("not in this robot's catalog (0 tours)") and the tour stalled."""
    gm = core(faculty, "Kbot")
    cmd = CommandData(command=Cmd.START_TOUR, tour_file="real_world.tour", way="lift", uid="Kbot/v/cmd/1", stamp=5.0,
                      visitor_id="v")
    assert gm.on_command(cmd, 10.0, 1.0) == []
    assert gm.on_command(cmd, 10.0, 1.2) == []                  # its replay waits once
    acts = gm.on_catalog(catalog_of(faculty, TOURS / "real_world.tour"), 10.5, 1.5)
    [trip] = goals(acts)
    assert (trip.tour_file, trip.tour_step, trip.goal_id) == ("real_world.tour", 0, "014")
    assert not events(acts, Phase.REJECTED)
    assert gm.on_command(cmd, 11.0, 2.0) == []                  # carried out: remembered
    assert gm.stats["waited_for_catalog"] == 1


def test_a_continue_replayed_to_a_restarted_goal_manager_before_its_catalog_goes_on(faculty) -> None:
    """The chaos run's stall: goal_manager restarted at the end of a tour step; the step's TOUR_STEP_DONE and the
    visitor's Continue were replayed to it before the catalog: the next step is issued once the catalog comes."""
    catalog = catalog_of(faculty, TOURS / "real_world.tour")
    gm = core(faculty, "Kbot")
    gm.on_catalog(catalog)
    trip = goals(gm.on_command(CommandData(command=Cmd.SKIP, tour_file="real_world.tour", tour_step=2, visitor_id="v"),
                               10.0, 1.0))[0]
    assert trip.goal_id == "101"                                  # floor 1: guided by Kbot itself
    own_event(gm, trip.uid, Phase.ON_THE_WAY, 1)
    new = GoalManagerCore(faculty, GoalManagerConfig(robot="Kbot"), ListLog(), now_wall=50.0, boot="t2")
    new.load_state(gm.state())
    done = NavEventData(uid="Kbot/event/nav.t.2", robot="Kbot", floor=1.0, goal_uid=trip.uid,
                        phase=Phase.TOUR_STEP_DONE, tour_file="real_world.tour", tour_step=2, stamp=30.0)
    new.on_nav_event(done, 30.0, 50.1)
    cont = CommandData(command=Cmd.CONTINUE, goal_uid=trip.uid, tour_file="real_world.tour", uid="Kbot/v/cmd/7",
                       stamp=31.0, visitor_id="v")
    assert new.on_command(cont, 31.0, 50.2) == []
    [nxt] = goals(new.on_catalog(catalog, 31.1, 50.3))
    assert (nxt.tour_step, nxt.goal_id) == (3, "104")
    assert new.on_command(cont, 31.2, 50.4) == []                # a later replay of it: handled already


def test_without_a_catalog_tour_commands_are_refused_after_the_wait(faculty) -> None:
    gm = GoalManagerCore(faculty, GoalManagerConfig(robot="Kbot", catalog_wait=10.0), ListLog(), now_wall=0.0,
                         boot="t")
    assert start(gm) == []                                        # at 1.0 s: waits
    assert gm.tick(12.0, 5.0) == []
    [refused] = events(gm.tick(20.0, 10.5), Phase.REJECTED)
    assert "not in this robot's catalog (0 tours)" in refused.detail and refused.tour_file == "real_world.tour"
    late = CommandData(command=Cmd.START_TOUR, tour_file="real_world.tour", visitor_id="v")
    assert events(gm.on_command(late, 21.0, 11.0), Phase.REJECTED)      # later ones at once
    gm.on_catalog(catalog_of(faculty, TOURS / "real_world.tour"))
    for r in faculty.robots:
        gm.on_status(r.name, 12.0)
    assert goals(gm.on_command(late, 22.0, 12.0))


def test_a_tour_going_on_past_a_floor_without_robot_waits_for_the_catalog(faculty3) -> None:
    """NO_ROBOT_ON_FLOOR of a tour trip heard by a restarted goal manager before its catalog: the tour goes on
    (the next stop on a floor with a robot) once the catalog comes, instead of stopping there."""
    catalog = catalog_of(faculty3, TOURS / "real_world.tour")
    gm = core(faculty3, "Kbot")
    gm.on_catalog(catalog)
    trip = goals(gm.on_command(CommandData(command=Cmd.SKIP, tour_file="real_world.tour", tour_step=4, visitor_id="v"),
                               10.0, 1.0))[0]
    assert (trip.goal_id, trip.goal_floor) == ("223", 2.0)          # floor 2 of faculty3 has no robot
    new = GoalManagerCore(faculty3, GoalManagerConfig(robot="Kbot"), ListLog(), now_wall=50.0, boot="t2")
    new.load_state(gm.state())
    alone = NavEventData(uid="Kbot/event/nav.t.3", robot="Kbot", floor=1.0, goal_uid=trip.uid,
                         phase=Phase.NO_ROBOT_ON_FLOOR, tour_file="real_world.tour", tour_step=4, stamp=40.0)
    assert new.on_nav_event(alone, 40.0, 50.1) == []
    [nxt] = goals(new.on_catalog(catalog, 40.2, 50.2))
    assert (nxt.tour_step, nxt.start_id, nxt.initial_floor) == (6, "274", 2.0)
