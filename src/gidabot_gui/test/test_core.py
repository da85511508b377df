"""The GUI's ROS-free core: fleet, visitor flow, texts, admin checks, inbox (no Qt, no master)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from gidabot_gui.admin import PasswordCheck, TourDraft, pose_from_drag, sha256_hex, slug_file_name
from gidabot_gui.errors import ConfigError, GuiError, TourEditError
from gidabot_gui.flow import Activity, Mode, VisitorFlow
from gidabot_gui.i18n import Translator
from gidabot_gui.inbox import Inbox
from gidabot_gui.model import (
    Fleet,
    NavEventData,
    PendingData,
    PoseData,
    RobotStatusData,
    TourInfo,
)
from gidabot_gui.plans import plan_request, tour_ways
from gidabot_gui.texts import Texts
from gidabot_navigation.interface import Cmd, Phase

VID = "gui-test"
TOUR = TourInfo("real_world.tour", "Real-world tour", "en",
                ((0, "014", "Technicians' Lab"), (0, "008", "Caretakers' Office"), (1, "101", "Secretary's Office"),
                 (2, "223", "M. Larrea's Office")))


def status(robot: str, floor: float, x: float = 30.0, y: float = 12.0, **kw: object) -> RobotStatusData:
    base = dict(yaw=0.0, linear=0.0, angular=0.0, battery=0.9, state="idle", pending=0)
    base.update(kw)
    return RobotStatusData(robot, floor, x, y, **base)  # type: ignore[arg-type]


def ev(phase: Phase, uid: str, goal_uid: str = "", robot: str = "Kbot", **kw: object) -> NavEventData:
    return NavEventData(uid=uid, robot=robot, phase=int(phase), goal_uid=goal_uid, **kw)  # type: ignore[arg-type]


def test_constants_match_the_messages() -> None:
    from gidabot_msgs.msg import NavEvent, VisitorCommand

    for p in Phase:
        assert getattr(NavEvent, p.name) == p.value
    for c in Cmd:
        assert getattr(VisitorCommand, c.name) == c.value


# ---------------------------------------------------------------------- fleet
def test_fleet_offline_after_five_seconds_of_wall_time(faculty) -> None:
    fleet = Fleet(faculty, offline_after=5.0)
    assert fleet.is_offline("Kbot", 0.0)          # never seen
    fleet.update_status(status("Kbot", 1), 100.0)
    assert not fleet.is_offline("Kbot", 104.9)
    assert fleet.is_offline("Kbot", 105.1)
    assert fleet.robots["Kbot"].pose == (30.0, 12.0, 0.0)   # last known position kept
    assert fleet.wait_of("Kbot", 105.1) is None


def test_fleet_rejects_unknown_robots_and_nan(faculty) -> None:
    fleet = Fleet(faculty)
    assert not fleet.update_status(status("Nobody", 1), 1.0)
    assert not fleet.update_pose(PoseData("Kbot", 1, math.nan, 1.0, 0.0), 1.0)
    assert not fleet.update_status(status("Kbot", 1, x=math.inf), 1.0)
    assert fleet.rejected == 3
    assert fleet.robots["Kbot"].pose is None


def test_plan_shows_both_robots_and_ways(faculty) -> None:
    fleet = Fleet(faculty)
    fleet.update_status(status("Kbot", 1, pending=1, busy_for=200.0), 10.0)
    fleet.update_status(status("Galtxagorri", 2), 10.0)
    fleet.update_pending(PendingData("Galtxagorri", 2, 2, 400.0), 10.0)
    plan = plan_request(fleet, "Kbot", "223", 11.0)
    assert plan.changes_floor and plan.ways == ("stairs", "lift")
    here, goal = plan.waits
    assert (here.robot, here.here, here.num, here.wait_s) == ("Kbot", True, 1, 200.0)
    assert (goal.robot, goal.num, goal.wait_s) == ("Galtxagorri", 2, 400.0)
    same = plan_request(fleet, "Kbot", "101", 11.0)
    assert not same.changes_floor and same.ways == () and len(same.waits) == 1


def test_plan_without_robot_on_goal_floor(faculty) -> None:
    building = replace(faculty, robots=tuple(r for r in faculty.robots if r.name != "MariSorgin"))
    plan = plan_request(Fleet(building), "Kbot", "301", 0.0)
    assert not plan.robot_on_goal_floor and [w.robot for w in plan.waits] == ["Kbot"]
    assert not plan.waits[0].known                    # no status yet: not available


def test_tour_ways(faculty) -> None:
    assert tour_ways(faculty, 0, TourInfo("a.tour", "", "en", ((0, "014", "x"),))) == ()
    assert tour_ways(faculty, 1, TOUR) == ("stairs", "lift")


# ---------------------------------------------------------------------- flow
def test_request_then_events_then_cancel(faculty) -> None:
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
    assert n.kind == "ON_THE_WAY" and n.modal and n.goal_id == "223" and not n.adopt_language
    assert flow.on_event(ev(Phase.ON_THE_WAY, "Kbot/event/2", uid), 2.0) is None      # duplicate uid
    assert flow.on_event(ev(Phase.ON_THE_WAY, "Tartalo/event/2", "x", robot="Tartalo"), 2.0) is None
    cancel = flow.cancel("es", 3.0)
    assert (cancel.command, cancel.goal_uid) == (Cmd.CANCEL, uid)
    assert not flow.busy
    n = flow.on_event(ev(Phase.CANCELLED_HERE, "Kbot/event/3", uid), 3.5)
    assert n.kind == "CANCELLED_HERE" and n.final and n.modal


def test_go_to_floor_ends_the_trip_here(faculty) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID)
    flow.request("223", "lift", "en", 0.0)
    uid = f"Kbot/{VID}/1"
    flow.on_event(ev(Phase.ON_THE_WAY, "e1", uid), 1.0)
    n = flow.on_event(ev(Phase.GO_TO_FLOOR, "e2", uid, way="lift", target_floor=2.0, connector="lift"), 2.0)
    assert n.kind == "GO_TO_FLOOR" and n.final and not flow.busy


def test_remote_visitor_arrives_and_continues(faculty) -> None:
    flow = VisitorFlow(faculty, "Galtxagorri", VID)
    uid = "Kbot/gui123/4"
    n = flow.on_event(ev(Phase.GOING_TO_MEETING, "g1", uid, robot="Galtxagorri", connector="lift",
                         location_id="lift"), 0.0)
    assert n.kind == "GOING_TO_MEETING" and not n.modal
    assert not flow.busy and flow.coming is not None
    n = flow.on_event(ev(Phase.WAITING_VISITOR, "g2", uid, robot="Galtxagorri", language="eu",
                         connector="lift", location_id="lift"), 10.0)
    assert n.kind == "WAITING_VISITOR" and n.actions == ("continue", "cancel") and n.adopt_language == "eu"
    assert flow.can_continue
    cmd = flow.continue_("eu", 11.0)
    assert (cmd.command, cmd.goal_uid) == (Cmd.CONTINUE, uid)
    assert flow.current.activity is Activity.GUIDING
    n = flow.on_event(ev(Phase.ON_THE_WAY, "g3", uid, robot="Galtxagorri", language="eu", location_id="223"), 12.0)
    assert n.goal_id == "223" and n.adopt_language == ""
    n = flow.on_event(ev(Phase.GOAL_REACHED, "g4", uid, robot="Galtxagorri", location_id="223"), 60.0)
    assert n.kind == "GOAL_REACHED" and n.final and not flow.busy


def test_tour_start_step_skip_continue(faculty) -> None:
    flow = VisitorFlow(faculty, "Tartalo", VID)
    cmd = flow.start_tour(TOUR, "stairs", "en", 0.0)
    assert (cmd.command, cmd.tour_file, cmd.way) == (Cmd.START_TOUR, "real_world.tour", "stairs")
    assert flow.mode is Mode.TOUR
    g0 = f"Tartalo/{VID}/1"
    flow.on_event(ev(Phase.ON_THE_WAY, "t1", g0, robot="Tartalo", tour_file="real_world.tour", tour_step=0,
                     location_id="014"), 1.0)
    assert not flow.can_skip_to(2)
    n = flow.on_event(ev(Phase.TOUR_STEP_DONE, "t2", g0, robot="Tartalo", tour_file="real_world.tour",
                         tour_step=0, location_id="014"), 2.0)
    assert n.kind == "TOUR_STEP_DONE" and "continue" in n.actions and "choose_stop" in n.actions
    assert flow.tour.last_done == 0 and flow.can_continue
    assert not flow.can_skip_to(0) and flow.can_skip_to(2)
    cmd = flow.skip(2, TOUR.goals, "en", 3.0)
    assert (cmd.command, cmd.tour_file, cmd.tour_step, cmd.goal_id, cmd.goal_uid) == (
        Cmd.SKIP, "real_world.tour", 2, "101", g0)
    assert flow.current.activity is Activity.PENDING and flow.tour.running == 2
    g2 = f"Tartalo/{VID}/2"
    flow.on_event(ev(Phase.ON_THE_WAY, "t3", g2, robot="Tartalo", tour_file="real_world.tour", tour_step=2,
                     location_id="stairs_west"), 4.0)
    n = flow.on_event(ev(Phase.GO_TO_FLOOR, "t4", g2, robot="Tartalo", tour_file="real_world.tour", tour_step=2,
                         target_floor=1.0), 5.0)
    assert n.final and not flow.busy and flow.tour is None


def test_step_done_at_another_robot_and_continue(faculty) -> None:
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
    assert n.kind == "TOUR_FINISHED" and flow.tour is None


def test_rejected_request_and_no_answer(faculty) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID, request_timeout=20.0)
    flow.request("101", "", "en", 0.0)
    n = flow.on_event(ev(Phase.REJECTED, "r1", ""), 1.0)
    assert n.kind == "REJECTED" and not flow.busy
    flow.request("101", "", "en", 10.0)
    assert flow.tick(29.0) is None
    n = flow.tick(31.0)
    assert n.kind == "NO_ANSWER" and not flow.busy


def test_unknown_phase_and_foreign_terminal_events(faculty) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID)
    assert flow.on_event(ev(99, "x1", "a/b/1"), 0.0) is None  # type: ignore[arg-type]
    assert flow.rejected == 1
    flow.request("101", "", "en", 0.0)
    flow.on_event(ev(Phase.ON_THE_WAY, "x2", f"Kbot/{VID}/1"), 1.0)
    # another trip this robot held (a remote visitor's) is cancelled: not shown over the running trip
    n = flow.on_event(ev(Phase.CANCELLED_ELSEWHERE, "x3", "Galtxagorri/v/5"), 2.0)
    assert n is not None and not n.modal and flow.busy


# ---------------------------------------------------------------------- texts
KINDS = [p.name for p in Phase if p not in (Phase.ACCEPTED,)] + ["NO_ANSWER", "BUSY"]


@pytest.mark.parametrize("language", ["eu", "en", "es"])
def test_every_notice_has_a_complete_text(faculty, locale_dir, language) -> None:
    from gidabot_gui.flow import Notice

    tr = Translator(language, locale_dir)
    texts = Texts(tr, faculty, "Kbot")
    texts.tours = {TOUR.file_name: TOUR}
    for kind in KINDS:
        for way in ("stairs", "lift"):
            e = ev(Phase.ON_THE_WAY, "u", "g", way=way, target_floor=2.0, connector="lift", location_id="223",
                   tour_file=TOUR.file_name, tour_step=1)
            t = texts.notice(Notice(kind, e, goal_id="223", tour_file=TOUR.file_name, tour_step=1))
            assert t.title, kind
            for part in (t.title, t.body, t.speech):
                assert "{" not in part and "}" not in part, (kind, part)
    walk = texts.notice(Notice("ON_THE_WAY", ev(Phase.ON_THE_WAY, "u", "g"), goal_id="223"))
    assert walk.note and walk.speech


def test_walk_behind_and_floor_change_texts(faculty, locale_dir) -> None:
    from gidabot_gui.flow import Notice

    texts = Texts(Translator("en", locale_dir), faculty, "Kbot")
    t = texts.notice(Notice("ON_THE_WAY", ev(Phase.ON_THE_WAY, "u", "g", connector="lift"), goal_id="223"))
    assert "walk behind me" in t.note and "M. Larrea's Office (223)" in t.body and "Lift" in t.body
    t = texts.notice(Notice("GO_TO_FLOOR", ev(Phase.GO_TO_FLOOR, "u", "g", way="stairs", target_floor=2.0,
                                               connector="stairs_west")))
    assert "stairs" in t.body and "Second floor" in t.body and "Galtxagorri will wait for you" in t.body
    t = texts.notice(Notice("WAITING_VISITOR", ev(Phase.WAITING_VISITOR, "u", "g")))
    assert "Press Continue when you are here" in t.body
    es = Texts(Translator("es", locale_dir), faculty, "Kbot")
    t = es.notice(Notice("GO_TO_FLOOR", ev(Phase.GO_TO_FLOOR, "u", "g", way="lift", target_floor=3.0)))
    assert "Tercera planta" in t.body and "ascensor" in t.body.lower()


def test_waits_in_minutes(faculty, locale_dir) -> None:
    texts = Texts(Translator("en", locale_dir), faculty, "Kbot")
    assert texts.minutes(None) == "wait unknown"
    assert texts.minutes(10) == "can start now"
    assert texts.minutes(300) == "about 5 minutes"
    es = Texts(Translator("es", locale_dir), faculty, "Kbot")
    assert es.minutes(300) == "unos 5 minutos"


# ---------------------------------------------------------------------- admin
def test_password_check() -> None:
    with pytest.raises(ConfigError, match="SHA-256"):
        PasswordCheck("secret")
    check = PasswordCheck(sha256_hex("open sesame"))
    assert not check.check("open sesam", 0.0)
    assert check.check("open sesame", 0.0)
    for i in range(5):
        assert not check.check("guess", float(i))
    assert check.locked_for(5.0) > 0
    assert not check.check("open sesame", 5.0)            # locked out, even with the right password
    assert check.check("open sesame", 40.0)
    assert not check.check("x" * 10000, 41.0)


def test_pose_from_drag_inverts_the_blueprint_transform(faculty) -> None:
    floor = faculty.floor(1)
    tf = floor.transform
    u, v = tf.to_pixel(30.0, 12.0)
    pose = pose_from_drag(tf, 1.0, (u, v), (u, v - 40))           # dragged up the image: +y, yaw = pi/2
    assert pose.x == pytest.approx(30.0) and pose.y == pytest.approx(12.0)
    assert pose.yaw == pytest.approx(math.pi / 2)
    pose = pose_from_drag(tf, 1.0, (u, v), (u + 1, v), default_yaw=0.7)
    assert pose.yaw == 0.7


def test_tour_draft_validation(faculty) -> None:
    draft = TourDraft("open_day.tour", "Open day", "en", [(0, "014", "Computer Technicians 1"),
                                                          (1, "101", "Secretary's Office")])
    edit = draft.to_edit(faculty, "Kbot/gui/tour-edit/1")
    assert edit.goal_lines == ("0, 014, Computer Technicians 1", "1, 101, Secretary's Office")
    assert edit.floor == 0 and not edit.deleted
    with pytest.raises(TourEditError, match="'999'"):
        TourDraft("x.tour", "X", "en", [(0, "999", "Nowhere")]).validate(faculty)
    with pytest.raises(TourEditError, match="room 101 is on floor 1, not 0"):
        TourDraft("x.tour", "X", "en", [(0, "101", "Secretary")]).validate(faculty)
    with pytest.raises(TourEditError, match="path separator"):
        TourDraft("../x.tour", "X", "en", [(0, "014", "a")]).validate(faculty)
    with pytest.raises(TourEditError, match="empty tour"):
        TourDraft("x.tour", "X", "en", []).validate(faculty)
    assert slug_file_name("Visita a la Facultad: ¡Día abierto!") == "visita_a_la_facultad_dia_abierto.tour"


# ---------------------------------------------------------------------- inbox
def test_inbox_keeps_latest_state_and_every_event() -> None:
    inbox = Inbox(max_events=3)
    for i in range(10):
        inbox.put_state("status", "Kbot", i)
    inbox.put_state("status", "Tartalo", 1)
    for i in range(5):
        inbox.put_event("nav_event", i)
    out = inbox.drain()
    assert out.states == [("status", 9), ("status", 1)]
    assert [r for _k, r in out.events] == [2, 3, 4] and out.dropped == 2
    assert not inbox.drain()


def test_partner_lost_and_back_keep_the_trip(faculty) -> None:
    flow = VisitorFlow(faculty, "Kbot", VID)
    flow.request("223", "stairs", "en", 0.0)
    uid = f"Kbot/{VID}/run1.1"
    flow.on_event(ev(Phase.ON_THE_WAY, "p1", uid), 1.0)
    n = flow.on_event(ev(Phase.PARTNER_LOST, "p2", uid, target_floor=2.0), 2.0)
    assert n.kind == "PARTNER_LOST" and n.modal and not n.final and flow.busy
    n = flow.on_event(ev(Phase.PARTNER_BACK, "p3", uid, target_floor=2.0), 3.0)
    assert n.kind == "PARTNER_BACK" and flow.current.uid == uid


def test_answers_without_goal_uid_end_the_request(faculty) -> None:
    for phase in (Phase.PARTNER_OFFLINE, Phase.UNREACHABLE, Phase.REJECTED):
        flow = VisitorFlow(faculty, "Kbot", VID)
        flow.request("223", "lift", "en", 0.0)
        n = flow.on_event(ev(phase, f"a{phase}", "", target_floor=2.0, location_id="223"), 1.0)
        assert n.kind == phase.name and n.modal and n.final and not flow.busy


def test_start_again_while_a_tour_waits_at_a_stop(faculty) -> None:
    flow = VisitorFlow(faculty, "Tartalo", VID)
    flow.start_tour(TOUR, "stairs", "en", 0.0)
    g0 = f"Tartalo/{VID}/1"
    flow.on_event(ev(Phase.TOUR_STEP_DONE, "s1", g0, robot="Tartalo", tour_file=TOUR.file_name, tour_step=0), 1.0)
    assert flow.can_start_tour()
    cmd = flow.start_tour(TOUR, "stairs", "en", 2.0)
    assert cmd.command == Cmd.START_TOUR and flow.current.activity is Activity.PENDING
    assert not flow.can_start_tour()
    with pytest.raises(GuiError):
        flow.start_tour(TOUR, "stairs", "en", 3.0)
