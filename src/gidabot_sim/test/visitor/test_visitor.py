"""Simulated visitor: leaves, walks, arrives, presses Continue, skips, finishes."""

from __future__ import annotations

from gidabot_navigation.interface import Cmd, Phase
from gidabot_sim.visitor import visitor


def cfg(robot: str, floor: float, **kw) -> visitor.VisitorConfig:
    return visitor.VisitorConfig(robot=robot, floor=floor, **kw)


def test_only_start_floor_starts_the_tour() -> None:
    t0 = visitor.VisitorCore(cfg("Tartalo", 0, tour_file="real_world.tour"))
    t3 = visitor.VisitorCore(cfg("MariSorgin", 3, tour_file="real_world.tour"))
    [cmd] = t0.start(0.0)
    assert cmd.command == Cmd.START_TOUR and cmd.tour_file == "real_world.tour" and cmd.way == "stairs"
    assert t3.start(0.0) == [] and not t3.present
    assert t0.start(1.0) == []  # once


def test_single_target_request() -> None:
    core = visitor.VisitorCore(cfg("Tartalo", 0, goal_id="014", way="lift", language="eu"))
    [cmd] = core.start(0.0)
    assert (cmd.command, cmd.goal_id, cmd.way, cmd.language) == (Cmd.REQUEST, "014", "lift", "eu")
    core.on_event(50.0, "e1", "Tartalo", Phase.GOAL_REACHED, "g1", 0, 0)
    assert core.finished and core.outcome == "goal reached"


def test_cross_floor_walk_then_continue() -> None:
    up = visitor.VisitorCore(cfg("MariSorgin", 3, stairs_s_per_floor=20.0, think_s=2.0))
    # the robot up there arrives first and waits
    up.on_event(10.0, "e1", "MariSorgin", Phase.WAITING_VISITOR, "g1", 3, 3)
    assert up.step(10.0) == []
    # the start robot sends the visitor up three floors at t = 12
    up.on_event(12.0, "e2", "Tartalo", Phase.GO_TO_FLOOR, "g1", 0, 3)
    assert up.step(71.0) == []            # 12 + 60 s of stairs not over yet
    assert up.step(72.0) == []            # arrived: Continue after thinking
    [cmd] = up.step(74.0)
    assert (cmd.command, cmd.goal_uid) == (Cmd.CONTINUE, "g1") and up.present


def test_visitor_late_robot_later() -> None:
    core = visitor.VisitorCore(cfg("Kbot", 1, way="lift", lift_wait_s=25, lift_s_per_floor=5, think_s=0))
    core.on_event(0.0, "e1", "Tartalo", Phase.GO_TO_FLOOR, "g", 0, 1)      # arrives at 30
    core.on_event(40.0, "e2", "Kbot", Phase.WAITING_VISITOR, "g", 1, 1)    # robot gets there at 40
    [cmd] = core.step(40.0)
    assert cmd.command == Cmd.CONTINUE


def test_leaving_and_duplicates() -> None:
    core = visitor.VisitorCore(cfg("Tartalo", 0))
    assert core.present
    core.on_event(5.0, "e1", "Tartalo", Phase.GO_TO_FLOOR, "g", 0, 2)
    assert not core.present
    core.on_event(5.0, "e2", "Galtxagorri", Phase.WAITING_VISITOR, "g", 2, 2)  # another floor's robot
    assert core.step(1000.0) == []
    other = visitor.VisitorCore(cfg("Galtxagorri", 2, think_s=0))
    for _ in range(2):  # a duplicated event is handled once
        other.on_event(5.0, "e1", "Tartalo", Phase.GO_TO_FLOOR, "g", 0, 2)
        other.on_event(6.0, "e3", "Galtxagorri", Phase.WAITING_VISITOR, "g", 2, 2)
    assert len(other.step(100.0)) == 1


def test_tour_steps_continue_and_skip() -> None:
    core = visitor.VisitorCore(cfg("Kbot", 1, tour_file="t.tour", skips=((3, 5),), think_s=1.0))
    core.on_event(10.0, "a", "Kbot", Phase.TOUR_STEP_DONE, "g2", 1, 1, tour_step=2)
    [cmd] = core.step(11.0)
    assert cmd.command == Cmd.CONTINUE and cmd.tour_file == "t.tour"
    core.on_event(20.0, "b", "Kbot", Phase.TOUR_STEP_DONE, "g3", 1, 1, tour_step=3)
    [cmd] = core.step(21.0)
    assert (cmd.command, cmd.tour_step) == (Cmd.SKIP, 5)
    core.on_event(30.0, "c", "Kbot", Phase.TOUR_FINISHED, "g5", 1, 1, tour_step=5, tour_file="t.tour")
    assert core.finished and core.outcome == "tour finished"


def test_failures_end_the_visit() -> None:
    for phase in (Phase.UNREACHABLE, Phase.TIMEOUT, Phase.CANCELLED_ELSEWHERE):
        core = visitor.VisitorCore(cfg("Kbot", 1))
        core.on_event(1.0, "x", "Tartalo", phase, "g", 0, 1)
        assert core.finished


def test_walk_time() -> None:
    c = cfg("R", 0, stairs_s_per_floor=20, lift_wait_s=25, lift_s_per_floor=5)
    assert c.walk_time(0, 3) == 60
    assert visitor.VisitorConfig(robot="R", floor=0, way="lift").walk_time(3, 0) == 25 + 15


def test_arriving_on_another_floor_never_restarts_the_tour() -> None:
    up = visitor.VisitorCore(cfg("MariSorgin", 3, tour_file="long_tour.tour", think_s=0.0))
    up.on_event(10.0, "e1", "Tartalo", Phase.GO_TO_FLOOR, "g2", 0, 3)
    up.on_event(20.0, "e2", "MariSorgin", Phase.WAITING_VISITOR, "g2", 3, 3)
    [cmd] = up.step(70.0)
    assert cmd.command == Cmd.CONTINUE and up.present
    up.on_event(90.0, "e3", "MariSorgin", Phase.TOUR_STEP_DONE, "g2", 3, 3, tour_step=1)
    assert up.present
    assert up.start(91.0) == []                       # present, but not the start floor
    assert [c.command for c in up.step(91.0)] == [Cmd.CONTINUE]


def test_answers_to_other_commands_do_not_end_the_visit() -> None:
    core = visitor.VisitorCore(cfg("Kbot", 1, tour_file="t.tour"))
    # somebody typed an unknown room, or a hostile tour file name, at Kbot's screen
    core.on_event(1.0, "r1", "Kbot", Phase.REJECTED, "", 1, 1, tour_file="", location_id="999")
    core.on_event(2.0, "r2", "Kbot", Phase.REJECTED, "", 1, 1, tour_file="../x.tour")
    core.on_event(3.0, "r3", "Tartalo", Phase.UNREACHABLE, "Tartalo/x/1", 0, 1, tour_file="")
    assert not core.finished
    core.on_event(4.0, "r4", "Kbot", Phase.REJECTED, "", 1, 1, tour_file="t.tour")     # our START_TOUR refused
    assert core.finished
    single = visitor.VisitorCore(cfg("Tartalo", 0, goal_id="014"))
    single.on_event(1.0, "s1", "Tartalo", Phase.REJECTED, "", 0, 0, tour_file="", location_id="zzz")
    assert not single.finished
    single.on_event(2.0, "s2", "Tartalo", Phase.UNREACHABLE, "", 0, 0, tour_file="", location_id="014")
    assert single.finished


def test_a_request_refused_because_a_partner_is_offline_is_asked_again() -> None:
    core = visitor.VisitorCore(cfg("Kbot", 1, tour_file="t.tour", retry_s=30.0, retry_for_s=100.0))
    core.on_event(10.0, "p1", "Kbot", Phase.PARTNER_OFFLINE, "", 1, 3, tour_step=4, tour_file="t.tour")
    assert not core.finished and core.step(39.0) == []
    [cmd] = core.step(40.0)
    assert (cmd.command, cmd.tour_file, cmd.tour_step) == (Cmd.SKIP, "t.tour", 4) and core.retries == 1
    core.on_event(41.0, "p2", "Kbot", Phase.PARTNER_OFFLINE, "", 1, 3, tour_step=4, tour_file="t.tour")
    core.on_event(42.0, "a1", "Kbot", Phase.ACCEPTED, "Kbot/v/1", 1, 3, tour_step=4, tour_file="t.tour")
    core.on_event(200.0, "p3", "Kbot", Phase.PARTNER_OFFLINE, "", 1, 3, tour_step=5, tour_file="t.tour")
    assert not core.finished                          # the clock restarted at the accepted goal
    core.on_event(301.0, "p4", "Kbot", Phase.PARTNER_OFFLINE, "", 1, 3, tour_step=5, tour_file="t.tour")
    assert core.finished and "gave up" in core.outcome
    start = visitor.VisitorCore(cfg("Tartalo", 0, tour_file="t.tour", retry_s=5.0))
    start.on_event(1.0, "q", "Tartalo", Phase.PARTNER_OFFLINE, "", 0, 1, tour_step=0, tour_file="t.tour")
    assert [c.command for c in start.step(6.0)] == [Cmd.START_TOUR]


def test_a_refusal_at_another_robot_does_not_end_the_visit_here() -> None:
    """Tartalo refused a step (its partner offline, nothing queued) and asks again itself; the node of the floor
    the person reaches later must still ask again for a trip that is given up there."""
    kw = dict(tour_file="t.tour", retry_s=30.0, think_s=0.0)
    galtx = visitor.VisitorCore(cfg("Galtxagorri", 2, **kw))
    galtx.on_event(10.0, "r", "Tartalo", Phase.PARTNER_OFFLINE, "", 0, 1, tour_step=1, tour_file="t.tour")
    assert not galtx.finished
    galtx.on_event(100.0, "d", "Galtxagorri", Phase.TOUR_STEP_DONE, "Kbot/v/2", 2, 2, tour_step=2,
                   tour_file="t.tour")
    galtx.step(100.0)
    galtx.on_event(120.0, "o", "Galtxagorri", Phase.PARTNER_OFFLINE, "Galtxagorri/v/3", 2, 0, tour_step=3,
                   tour_file="t.tour")
    assert [(c.command, c.tour_step) for c in galtx.step(150.0)] == [(Cmd.SKIP, 3)]


def test_a_trip_a_robot_gave_up_is_asked_for_again_where_the_person_is() -> None:
    kw = dict(tour_file="t.tour", retry_s=30.0, think_s=0.0, stairs_s_per_floor=20.0)
    # the start robot's floor still has the person (never released): it asks again for the same step
    here = visitor.VisitorCore(cfg("Tartalo", 0, **kw))
    here.on_event(1.0, "o", "Kbot", Phase.PARTNER_OFFLINE, "Tartalo/v/1", 1, 1, tour_step=3, tour_file="t.tour")
    assert not here.finished and here.step(30.0) == []
    [cmd] = here.step(31.0)
    assert (cmd.command, cmd.tour_step) == (Cmd.SKIP, 3) and here.retries == 1
    # the goal floor: the person was sent there (GO_TO_FLOOR known), asks again after arriving
    there = visitor.VisitorCore(cfg("Kbot", 1, **kw))
    there.on_event(5.0, "g", "Tartalo", Phase.GO_TO_FLOOR, "Tartalo/v/1", 0, 1, tour_step=3)   # arrives at 25
    there.on_event(6.0, "w", "Kbot", Phase.WAITING_VISITOR, "Tartalo/v/1", 1, 1, tour_step=3)
    there.on_event(10.0, "o", "Kbot", Phase.PARTNER_OFFLINE, "Tartalo/v/1", 1, 1, tour_step=3, tour_file="t.tour")
    assert not there.finished and there.step(54.0) == []          # no Continue for the given-up trip
    assert [(c.command, c.tour_step) for c in there.step(55.0)] == [(Cmd.SKIP, 3)]
    # the person's release comes after the news (a partition held it): asked again after arriving then
    late = visitor.VisitorCore(cfg("Kbot", 1, **kw))
    late.on_event(10.0, "o", "Kbot", Phase.PARTNER_OFFLINE, "Tartalo/v/1", 1, 1, tour_step=0, tour_file="t.tour")
    assert late.step(100.0) == [] and not late.present
    late.on_event(100.0, "g", "Tartalo", Phase.GO_TO_FLOOR, "Tartalo/v/1", 0, 1, tour_step=0)   # arrives at 120
    assert late.step(149.0) == []
    assert [c.command for c in late.step(150.0)] == [Cmd.START_TOUR]
    # a floor the person is not on, and is not sent to, does nothing
    away = visitor.VisitorCore(cfg("Galtxagorri", 2, **kw))
    away.on_event(1.0, "o", "Kbot", Phase.PARTNER_OFFLINE, "Tartalo/v/1", 1, 1, tour_step=3, tour_file="t.tour")
    assert away.step(1000.0) == [] and not away.finished


def test_two_robots_on_the_start_floor_one_starts() -> None:
    kbot = visitor.VisitorCore(cfg("Kbot", 1, start_floor=1, start_robot="Kbot", goal_id="101"))
    basajaun = visitor.VisitorCore(cfg("Basajaun", 1, start_floor=1, start_robot="Kbot", goal_id="101"))
    assert len(kbot.start(0.0)) == 1 and basajaun.start(0.0) == [] and not basajaun.present


def test_stops_on_a_floor_without_robot_are_visited_alone() -> None:
    """Table 4 on faculty3: Kbot (floor 1) sends the visitor to 223 and 274 on floor 2 (no robot); the visitor
    spends visit_s at each, then walks to floor 3, where MariSorgin waits for step 6."""
    floors = (0, 0, 1, 1, 2, 2, 3, 3)
    up = visitor.VisitorCore(cfg("MariSorgin", 3, tour_file="real_world.tour", think_s=2.0, visit_s=60.0,
                           robot_floors=(0, 1, 3)))
    up.on_tour(floors)
    kbot = visitor.VisitorCore(cfg("Kbot", 1, tour_file="real_world.tour", robot_floors=(0, 1, 3)))
    kbot.on_tour(floors)
    kbot.present = True
    for core in (up, kbot):
        core.on_event(100.0, "e1", "Kbot", Phase.NO_ROBOT_ON_FLOOR, "g4", 1, 2, 4, tour_file="real_world.tour",
                      location_id="223")
    assert not kbot.present and not kbot.finished
    # 20 s to floor 2, 60 s at 223, 60 s at 274, 20 s to floor 3: there at 260
    assert up.step_arrivals == {6: 260.0}
    up.on_event(150.0, "e2", "MariSorgin", Phase.WAITING_VISITOR, "g6", 3, 3, 6, tour_file="real_world.tour")
    assert up.step(259.0) == [] and up.step(260.0) == []
    [cmd] = up.step(262.0)
    assert (cmd.command, cmd.goal_uid) == (Cmd.CONTINUE, "g6")


def test_a_tour_ending_on_a_floor_without_robot_ends_the_visit() -> None:
    kbot = visitor.VisitorCore(cfg("Kbot", 1, tour_file="t.tour", robot_floors=(0, 1, 3)))
    kbot.on_event(10.0, "e1", "Kbot", Phase.TOUR_FINISHED, "g", 1, 2, 3, tour_file="t.tour", location_id="223")
    assert kbot.finished and kbot.outcome == "tour finished"


def test_a_single_target_on_a_floor_without_robot_ends_the_visit() -> None:
    tartalo = visitor.VisitorCore(cfg("Tartalo", 0, goal_id="223"))
    tartalo.on_event(10.0, "e1", "Tartalo", Phase.NO_ROBOT_ON_FLOOR, "g", 0, 2, location_id="223")
    assert tartalo.finished and "alone" in tartalo.outcome and not tartalo.present


def test_a_visitor_who_cancels_presses_cancel_for_its_latest_trip_at_its_start_robot() -> None:
    start = visitor.VisitorCore(cfg("Kbot", 1, start_floor=1, start_robot="Kbot", goal_id="305", cancel_after_s=40.0,
                              visitor_id="visitor3"))
    [ask] = start.start(100.0)
    assert ask.command == Cmd.REQUEST and start.step(139.0) == []
    assert start.step(141.0) == []               # no trip yet: nothing to cancel
    start.on_goal("Kbot/visitor3/1")
    [cmd] = start.step(142.0)
    assert (cmd.command, cmd.goal_uid) == (Cmd.CANCEL, "Kbot/visitor3/1")
    assert start.step(200.0) == []               # once
    done = visitor.VisitorCore(cfg("Kbot", 1, start_floor=1, goal_id="104", cancel_after_s=40.0))
    done.start(0.0)
    done.on_goal("g")
    done.on_event(30.0, "e1", "Kbot", Phase.GOAL_REACHED, "g", 1, 1)
    assert done.finished and done.step(100.0) == []  # reached first: no cancel


def test_a_no_show_never_continues_at_the_meeting_point() -> None:
    up = visitor.VisitorCore(cfg("MariSorgin", 3, start_floor=0, start_robot="Tartalo", no_show=True, think_s=0))
    up.on_event(10.0, "e1", "MariSorgin", Phase.WAITING_VISITOR, "g1", 3, 3)
    up.on_event(12.0, "e2", "Tartalo", Phase.GO_TO_FLOOR, "g1", 0, 3)
    assert up.step(1000.0) == []
    up.on_event(1300.0, "e3", "MariSorgin", Phase.TIMEOUT, "g1", 3, 3)
    assert up.finished


def test_a_visitor_shown_a_wait_beyond_its_patience_does_not_confirm() -> None:
    patient = visitor.VisitorCore(cfg("Tartalo", 0, goal_id="305", patience_s=600.0))
    [cmd] = patient.start(0.0, (30.0, 590.0))
    assert cmd.command == Cmd.REQUEST and not patient.left and patient.shown == (30.0, 590.0)
    hurried = visitor.VisitorCore(cfg("Tartalo", 0, goal_id="305", patience_s=600.0))
    assert hurried.start(0.0, (30.0, 601.0)) == [] and hurried.left and hurried.finished
    assert "601 s" in hurried.outcome and "600 s" in hurried.outcome
    assert hurried.step(1000.0) == []                     # nothing more: it went away
    unknown = visitor.VisitorCore(cfg("Tartalo", 0, goal_id="305", patience_s=10.0))
    assert len(unknown.start(0.0, (None, None))) == 1     # nothing shown it could judge: it confirms
    anyone = visitor.VisitorCore(cfg("Tartalo", 0, goal_id="305"))
    assert len(anyone.start(0.0, (5000.0,))) == 1        # no patience set: waits however long


def test_the_screen_shows_the_waits_the_robot_will_decide_on() -> None:
    """faculty6: at Tartalo's screen, a trip to 223 (floor 2): Tartalo itself for the start leg, Galtxagorri (nearer
    the west stairs) for the goal leg; once Galtxagorri's queue is long, Lamia, with a longer wait than before."""
    from pathlib import Path

    from gidabot_navigation.building.model import load_building
    from gidabot_navigation.guiding.messages import Trip

    building = load_building(Path(__file__).resolve().parents[4] / "maps" / "faculty6")
    screen = visitor.Screen(building)
    for r in building.robots:
        screen.on_status(r.name, 100.0, (r.home.x, r.home.y))
    start, goal = screen.waits("Tartalo", "223", "stairs", 100.0)
    assert start == 0.0 and goal is not None and goal > 0
    busy = Trip(uid="Galtxagorri/x/1", origin_robot="Galtxagorri", visitor_id="x", initial_floor=2.0,
                initial_x=30.0, initial_y=12.0, goal_floor=2.0, goal_x=63.0, goal_y=12.0, goal_yaw=0.0, way="stairs",
                connector="", start_id="robot", goal_id="231", language="en", start_robot="Galtxagorri",
                start_state=2, attempt=2)
    screen.on_pending("Galtxagorri", [busy], 2000.0, 100.0)
    _, later = screen.waits("Tartalo", "223", "stairs", 100.0)
    assert later is not None and later > goal and later < 2000.0      # Lamia, not Galtxagorri's 2000 s
    assert screen.waits("Tartalo", "223", "stairs", 200.0) == (None, None)   # nobody heard for 100 s: unknown
    assert screen.waits("Tartalo", "nowhere", "stairs", 100.0) == ()
