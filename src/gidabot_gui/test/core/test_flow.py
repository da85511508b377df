"""The visitor flow at one screen (core.flow): requests, cross-floor trips, tours, skip, cancels, duplicates,
hostile events."""

from __future__ import annotations

import pytest

from gidabot_gui.core.flow import Activity, Mode, Outcome, VisitorFlow
from gidabot_gui.errors import GuiError
from gidabot_navigation.interface import Cmd, Phase

VID = "gui-test"


def test_constants_match_the_messages() -> None:
    from gidabot_msgs.msg import NavEvent, VisitorCommand

    for p in Phase:
        assert getattr(NavEvent, p.name) == p.value
    for c in Cmd:
        assert getattr(VisitorCommand, c.name) == c.value


def test_request_then_events_then_cancel(faculty, ev) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID)
    cmd = flow.request("223", "stairs", "es", 0.0, start_id="104")
    assert (cmd.command, cmd.goal_id, cmd.way, cmd.language, cmd.visitor_id) == (Cmd.REQUEST, "223", "stairs", "es",
                                                                                  VID)
    assert cmd.uid == f"Kbot/{VID}/cmd/1"
    assert flow.busy and flow.can_cancel and flow.current.activity is Activity.PENDING
    with pytest.raises(GuiError):
        flow.request("101", "", "es", 0.0)
    uid = f"Kbot/{VID}/7"
    assert flow.on_event(ev(Phase.ACCEPTED, "Kbot/event/1", uid), 1.0) is None
    assert flow.current.uid == uid and flow.current.activity is Activity.QUEUED
    n = flow.on_event(ev(Phase.ON_THE_WAY, "Kbot/event/2", uid, connector="stairs_west",
                         location_id="stairs_west"), 2.0)
    assert n.kind is Phase.ON_THE_WAY and n.modal and n.goal_id == "223" and not n.adopt_language
    assert flow.on_event(ev(Phase.ON_THE_WAY, "Kbot/event/2", uid), 2.0) is None      # duplicate uid
    assert flow.on_event(ev(Phase.ON_THE_WAY, "Tartalo/event/2", "x", robot="Tartalo"), 2.0) is None
    cancel = flow.cancel("es", 3.0)
    assert (cancel.command, cancel.goal_uid) == (Cmd.CANCEL, uid)
    assert not flow.busy
    n = flow.on_event(ev(Phase.CANCELLED_HERE, "Kbot/event/3", uid), 3.5)
    assert n.kind is Phase.CANCELLED_HERE and n.final and n.modal


def test_go_to_floor_ends_the_trip_here(faculty, ev) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID)
    flow.request("223", "lift", "en", 0.0)
    uid = f"Kbot/{VID}/1"
    flow.on_event(ev(Phase.ON_THE_WAY, "e1", uid), 1.0)
    n = flow.on_event(ev(Phase.GO_TO_FLOOR, "e2", uid, way="lift", target_floor=2.0, connector="lift"), 2.0)
    assert n.kind is Phase.GO_TO_FLOOR and n.final and not flow.busy


def test_remote_visitor_arrives_and_continues(faculty, ev) -> None:
    flow = VisitorFlow(faculty, "Galtxagorri", VID)
    uid = "Kbot/gui123/4"
    n = flow.on_event(ev(Phase.GOING_TO_MEETING, "g1", uid, robot="Galtxagorri", connector="lift",
                         location_id="lift"), 0.0)
    assert n.kind is Phase.GOING_TO_MEETING and not n.modal
    assert not flow.busy and flow.coming is not None
    n = flow.on_event(ev(Phase.WAITING_VISITOR, "g2", uid, robot="Galtxagorri", language="eu",
                         connector="lift", location_id="lift"), 10.0)
    assert n.kind is Phase.WAITING_VISITOR and n.actions == ("continue", "cancel") and n.adopt_language == "eu"
    assert flow.can_continue
    cmd = flow.continue_("eu", 11.0)
    assert (cmd.command, cmd.goal_uid) == (Cmd.CONTINUE, uid)
    assert flow.current.activity is Activity.GUIDING
    n = flow.on_event(ev(Phase.ON_THE_WAY, "g3", uid, robot="Galtxagorri", language="eu", location_id="223"), 12.0)
    assert n.goal_id == "223" and n.adopt_language == ""
    n = flow.on_event(ev(Phase.GOAL_REACHED, "g4", uid, robot="Galtxagorri", location_id="223"), 60.0)
    assert n.kind is Phase.GOAL_REACHED and n.final and not flow.busy


def test_tour_start_step_skip_continue(faculty, ev, tour) -> None:
    flow = VisitorFlow(faculty, "Tartalo", VID)
    cmd = flow.start_tour(tour, "stairs", "en", 0.0)
    assert (cmd.command, cmd.tour_file, cmd.way) == (Cmd.START_TOUR, "real_world.tour", "stairs")
    assert flow.mode is Mode.TOUR
    g0 = f"Tartalo/{VID}/1"
    flow.on_event(ev(Phase.ON_THE_WAY, "t1", g0, robot="Tartalo", tour_file="real_world.tour", tour_step=0,
                     location_id="014"), 1.0)
    assert not flow.can_skip_to(2)
    n = flow.on_event(ev(Phase.TOUR_STEP_DONE, "t2", g0, robot="Tartalo", tour_file="real_world.tour",
                         tour_step=0, location_id="014"), 2.0)
    assert n.kind is Phase.TOUR_STEP_DONE and "continue" in n.actions and "choose_stop" in n.actions
    assert flow.tour.last_done == 0 and flow.can_continue
    assert not flow.can_skip_to(0) and flow.can_skip_to(2)
    cmd = flow.skip(2, tour.goals, "en", 3.0)
    assert (cmd.command, cmd.tour_file, cmd.tour_step, cmd.goal_id, cmd.goal_uid) == (
        Cmd.SKIP, "real_world.tour", 2, "101", g0)
    assert flow.current.activity is Activity.PENDING and flow.tour.running == 2
    g2 = f"Tartalo/{VID}/2"
    flow.on_event(ev(Phase.ON_THE_WAY, "t3", g2, robot="Tartalo", tour_file="real_world.tour", tour_step=2,
                     location_id="stairs_west"), 4.0)
    n = flow.on_event(ev(Phase.GO_TO_FLOOR, "t4", g2, robot="Tartalo", tour_file="real_world.tour", tour_step=2,
                         target_floor=1.0), 5.0)
    assert n.final and not flow.busy and flow.tour is None


def test_step_done_at_another_robot_and_continue(faculty, ev, tour) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID)
    g = "Tartalo/guiA/3"
    n = flow.on_event(ev(Phase.TOUR_STEP_DONE, "k1", g, tour_file="real_world.tour", tour_step=2,
                         location_id="101", language="es"), 0.0)
    assert n.adopt_language == "es" and flow.tour.file_name == "real_world.tour" and flow.mode is Mode.TOUR
    cmd = flow.continue_("es", 1.0)
    assert (cmd.command, cmd.goal_uid, cmd.tour_file) == (Cmd.CONTINUE, g, "real_world.tour")
    # the next step is issued by this robot's goal manager with the GUI's visitor id... or the tour's
    n = flow.on_event(ev(Phase.ON_THE_WAY, "k2", "Kbot/guiA/9", tour_file="real_world.tour", tour_step=3,
                         location_id="stairs_west"), 2.0)
    assert n is not None and flow.current.uid == "Kbot/guiA/9"
    n = flow.on_event(ev(Phase.TOUR_FINISHED, "k3", "Kbot/guiA/9", tour_file="real_world.tour", tour_step=3), 3.0)
    assert n.kind is Phase.TOUR_FINISHED and flow.tour is None


def test_rejected_request_and_no_answer(faculty, ev) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID, request_timeout=20.0)
    flow.request("101", "", "en", 0.0)
    n = flow.on_event(ev(Phase.REJECTED, "r1", ""), 1.0)
    assert n.kind is Phase.REJECTED and not flow.busy
    flow.request("101", "", "en", 10.0)
    assert flow.tick(29.0) is None
    n = flow.tick(31.0)
    assert n.kind is Outcome.NO_ANSWER and not flow.busy


def test_unknown_phase_and_foreign_terminal_events(faculty, ev) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID)
    assert flow.on_event(ev(99, "x1", "a/b/1"), 0.0) is None  # type: ignore[arg-type]
    assert flow.rejected == 1
    flow.request("101", "", "en", 0.0)
    flow.on_event(ev(Phase.ON_THE_WAY, "x2", f"Kbot/{VID}/1"), 1.0)
    # another trip this robot held (a remote visitor's) is cancelled: not shown over the running trip
    n = flow.on_event(ev(Phase.CANCELLED_ELSEWHERE, "x3", "Galtxagorri/v/5"), 2.0)
    assert n is not None and not n.modal and flow.busy


def test_partner_lost_and_back_keep_the_trip(faculty, ev) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID)
    flow.request("223", "stairs", "en", 0.0)
    uid = f"Kbot/{VID}/run1.1"
    flow.on_event(ev(Phase.ON_THE_WAY, "p1", uid), 1.0)
    n = flow.on_event(ev(Phase.PARTNER_LOST, "p2", uid, target_floor=2.0), 2.0)
    assert n.kind is Phase.PARTNER_LOST and n.modal and not n.final and flow.busy
    n = flow.on_event(ev(Phase.PARTNER_BACK, "p3", uid, target_floor=2.0), 3.0)
    assert n.kind is Phase.PARTNER_BACK and flow.current.uid == uid


def test_answers_without_goal_uid_end_the_request(faculty, ev) -> None:
    for phase in (Phase.PARTNER_OFFLINE, Phase.UNREACHABLE, Phase.REJECTED):
        flow = VisitorFlow(faculty, "Kbot", VID)
        flow.request("223", "lift", "en", 0.0)
        n = flow.on_event(ev(phase, f"a{phase}", "", target_floor=2.0, location_id="223"), 1.0)
        assert n.kind is phase and n.modal and n.final and not flow.busy


def test_start_again_while_a_tour_waits_at_a_stop(faculty, ev, tour) -> None:
    flow = VisitorFlow(faculty, "Tartalo", VID)
    flow.start_tour(tour, "stairs", "en", 0.0)
    g0 = f"Tartalo/{VID}/1"
    flow.on_event(ev(Phase.TOUR_STEP_DONE, "s1", g0, robot="Tartalo", tour_file=tour.file_name, tour_step=0), 1.0)
    assert flow.can_start_tour()
    cmd = flow.start_tour(tour, "stairs", "en", 2.0)
    assert cmd.command == Cmd.START_TOUR and flow.current.activity is Activity.PENDING
    assert not flow.can_start_tour()
    with pytest.raises(GuiError):
        flow.start_tour(tour, "stairs", "en", 3.0)


def test_another_robot_of_the_floor_comes_for_the_visitor(faculty6, ev) -> None:
    """faculty6: Kbot is busy; Basajaun is assigned the start leg of a trip asked at Kbot's screen. The visitor
    is told who comes, waits here (and may cancel), and the trip leaves this screen when Basajaun guides."""
    flow = VisitorFlow(faculty6, "Kbot", VID)
    flow.request("101", "", "en", 0.0)
    uid = f"Kbot/{VID}/7"
    assert flow.on_event(ev(Phase.DECLINED, "Kbot/event/1", uid, leg="start"), 0.5) is None
    n = flow.on_event(ev(Phase.ASSIGNED, "Kbot/event/2", uid, leg="start", assignee="Basajaun", eta=40.0), 1.0)
    assert n.kind is Phase.ASSIGNED and n.modal and "cancel" in n.actions and n.event.assignee == "Basajaun"
    assert flow.current.activity is Activity.HANDED and flow.can_cancel and flow.busy
    # Basajaun's other events are not this screen's; its pick-up leaves the visitor waiting here
    assert flow.on_event(ev(Phase.GOING_TO_MEETING, "Basajaun/event/1", uid, robot="Basajaun"), 2.0) is None
    assert flow.current is not None
    assert flow.on_event(ev(Phase.ON_THE_WAY, "Basajaun/event/2", uid, robot="Basajaun"), 30.0) is None
    assert flow.current is None and not flow.busy                     # gone with Basajaun


def test_a_helper_that_gives_up_is_told_to_the_waiting_visitor(faculty6, ev) -> None:
    flow = VisitorFlow(faculty6, "Kbot", VID)
    flow.request("101", "", "en", 0.0)
    uid = f"Kbot/{VID}/7"
    flow.on_event(ev(Phase.ASSIGNED, "Kbot/event/2", uid, leg="start", assignee="Basajaun", eta=40.0), 1.0)
    n = flow.on_event(ev(Phase.UNREACHABLE, "Basajaun/event/9", uid, robot="Basajaun"), 5.0)
    assert n.kind is Phase.UNREACHABLE and n.modal and n.final and flow.current is None
    # another robot's assignment of a leg served here, or of the goal leg: nothing to tell
    flow.request("223", "stairs", "en", 10.0)
    uid2 = f"Kbot/{VID}/8"
    flow.on_event(ev(Phase.ACCEPTED, "Kbot/event/3", uid2, leg="start"), 10.5)
    assert flow.on_event(ev(Phase.ASSIGNED, "Kbot/event/4", uid2, leg="start", assignee="Kbot"), 11.0) is None
    assert flow.on_event(ev(Phase.ASSIGNED, "Kbot/event/5", uid2, leg="goal", assignee="Lamia"), 11.0) is None
    assert flow.current.activity is Activity.QUEUED


def test_a_stop_on_a_floor_without_robot_is_told_again_with_the_robot_that_waits_next(faculty3, ev, tour) -> None:
    flow = VisitorFlow(faculty3, "Kbot", VID)
    uid = "Tartalo/v/3"
    flow.on_event(ev(Phase.TOUR_STEP_DONE, "Kbot/event/1", uid, tour_file=tour.file_name, tour_step=2,
                     location_id="101"), 0.0)
    flow.continue_("en", 1.0)
    step3 = f"Kbot/{VID}/5"
    flow.on_event(ev(Phase.ON_THE_WAY, "Kbot/event/2", step3, tour_file=tour.file_name, tour_step=3,
                     location_id="stairs_west"), 2.0)
    alone = flow.on_event(ev(Phase.NO_ROBOT_ON_FLOOR, "Kbot/event/3", step3, tour_file=tour.file_name,
                             tour_step=3, location_id="223", target_floor=2.0), 3.0)
    assert alone.kind is Phase.NO_ROBOT_ON_FLOOR and alone.final and alone.event.assignee == ""
    again = flow.on_event(ev(Phase.ASSIGNED, "Kbot/event/4", f"Kbot/{VID}/6", leg="goal", assignee="MariSorgin",
                             tour_file=tour.file_name, tour_step=4), 3.1)
    assert again.kind is Phase.NO_ROBOT_ON_FLOOR and again.event.assignee == "MariSorgin" and again.tour_step == 3
    assert flow.current is None
