"""The touch screen driven like a visitor and an administrator would (offscreen, no master).

Each test taps the widgets with QTest and asserts on what would be published
(the recorded outputs) and on what is shown (pop-ups, texts, buttons).
"""

from __future__ import annotations

import math

import pytest
from gui_fakes import nav_event
from PyQt5.QtCore import QPoint, Qt
from PyQt5.QtTest import QTest

from gidabot_gui.core.model import TourInfo
from gidabot_navigation.guiding.messages import RobotStatusData
from gidabot_navigation.interface import Cmd, Phase
from gidabot_navigation.tours.tour_store import EditResultData

TOUR = TourInfo("real_world.tour", "Real-world tour", "en",
                ((0, "014", "Technicians' Lab"), (0, "008", "Caretakers' Office"), (1, "101", "Secretary's Office"),
                 (1, "104", "Ada Lovelace Auditorium"), (2, "223", "M. Larrea's Office")))
LONG = TourInfo("long_tour.tour", "Long duration tour", "en",
                ((0, "005", "Student Council"), (3, "301", "IXA Lab"), (2, "203", "C. Rodriguez's Office")))


def event(gui, phase: Phase, goal_uid: str, robot: str = "Kbot", **kw) -> None:
    gui.clock.t += 0.5
    n = getattr(gui, "_ev", 0) + 1
    gui._ev = n
    gui.window.feed("nav_event", nav_event(phase, f"{robot}/event/{n}", goal_uid, robot, **kw))
    gui.process()


@pytest.fixture
def idle_gui(make_gui, faculty):
    """A screen of ``robot`` with every robot idle at home (and ``tours`` in the catalog)."""
    def make(robot: str = "Kbot", tours: tuple | list = (), **kw):
        gui = make_gui(robot, **kw)
        gui.feed_all_status(faculty)
        if tours:
            gui.window.feed("catalog", list(tours))
        return gui

    return make


def continued(gui):
    """Press Continue on the pop-up: the CONTINUE command it sent."""
    gui.press("continue")
    cmd = gui.out.commands[-1]
    assert cmd.command == Cmd.CONTINUE
    return cmd


def test_destination_on_another_floor_by_the_stairs_then_cancel(make_gui, faculty) -> None:
    gui = make_gui("Kbot")
    w = gui.window
    gui.feed_all_status(faculty, pending=1, wait=150.0)
    gui.nav("floor:0")
    assert w.current_page == "floor:0"
    gui.click(w.floor_pages[0].buttons["000"])                    # Main Entrance, ground floor
    assert w.overlay.name == "confirm"
    body = w.overlay.body.text()
    assert "Kbot (this robot): 1 request before yours, about 3 minutes" in body
    # Tartalo's wait, plus its drive to the staircase's meeting point: the robot that meets the visitor there
    assert "Tartalo meets you there: about 4 minutes" in body
    assert w.overlay.title.text() == "Main Entrance (000)"
    assert not gui.out.commands                                    # nothing sent before confirming
    gui.press("go")
    assert w.overlay.name == "way"
    gui.press("stairs")
    assert not w.overlay.showing
    (cmd,) = gui.out.commands
    assert (cmd.command, cmd.goal_id, cmd.way, cmd.language) == (Cmd.REQUEST, "000", "stairs", "en")
    assert w.cancel_btn.isVisible()
    uid = "Kbot/gui-test/1"
    event(gui, Phase.ACCEPTED, uid, way="stairs", connector="stairs_west", target_floor=0.0, location_id="000")
    event(gui, Phase.ON_THE_WAY, uid, way="stairs", connector="stairs_west", target_floor=0.0,
          location_id="stairs_west")
    assert w.overlay.name == "event:ON_THE_WAY"
    assert "Please walk behind me" in w.overlay.note_text.text() and w.overlay.note.isVisible()
    assert "Main Entrance (000)" in w.overlay.body.text()
    assert gui.speaker.said[-1][1] == "en" and "walk behind me" in gui.speaker.said[-1][0]
    assert "To: Main Entrance (000)" in w.info_trip.text()
    gui.click(w.cancel_btn)                                        # reachable under the pop-up
    cancel = gui.out.commands[-1]
    assert (cancel.command, cancel.goal_uid) == (Cmd.CANCEL, uid)
    assert not w.cancel_btn.isVisible()
    event(gui, Phase.CANCELLED_HERE, uid)
    assert w.overlay.name == "event:CANCELLED_HERE"
    assert w.overlay.title.text() == "Trip cancelled"


def test_lift_or_stairs_only_asked_when_floors_change(idle_gui) -> None:
    gui = idle_gui("Kbot")
    gui.click(gui.window.floor_pages[1].buttons["103"])           # Dean's Office, same floor
    gui.press("go")
    (cmd,) = gui.out.commands
    assert (cmd.goal_id, cmd.way) == ("103", "")


def test_go_to_floor_and_the_robot_upstairs(idle_gui) -> None:
    gui = idle_gui("Kbot")
    gui.window.visitor.pick_destination("223")
    gui.press("go")
    gui.press("lift")
    uid = "Kbot/gui-test/1"
    event(gui, Phase.ON_THE_WAY, uid, way="lift", connector="lift", target_floor=2.0, location_id="lift")
    event(gui, Phase.GO_TO_FLOOR, uid, way="lift", connector="lift", target_floor=2.0)
    w = gui.window
    assert w.overlay.name == "event:GO_TO_FLOOR"
    assert "Take the lift (Lift) to: Second floor." in w.overlay.body.text()
    assert "Galtxagorri will wait for you there" in w.overlay.body.text()
    assert not w.cancel_btn.isVisible()                            # the trip goes on upstairs

    up = idle_gui("Galtxagorri", language="en")
    event(up, Phase.GOING_TO_MEETING, uid, robot="Galtxagorri", connector="lift", location_id="lift",
          language="es")
    assert not up.window.overlay.showing
    assert "meet a visitor" in up.window.info_trip.text()
    event(up, Phase.WAITING_VISITOR, uid, robot="Galtxagorri", connector="lift", location_id="lift", language="es")
    assert up.tr.language == "es"                                  # the visitor's language
    assert up.window.overlay.name == "event:WAITING_VISITOR"
    assert "Pulsa Continuar cuando estés aquí." in up.window.overlay.body.text()
    assert up.speaker.said[-1][1] == "es"
    cmd = continued(up)
    assert (cmd.goal_uid, cmd.language) == (uid, "es")


def test_tour_start_step_skip(idle_gui) -> None:
    gui = idle_gui("Tartalo", tours=[LONG, TOUR])
    w = gui.window
    gui.nav("tours")
    page = w.tours_page
    gui.click_row(page.tour_list, 1)
    assert page.selected().file_name == "real_world.tour"
    assert page.stop_list.count() == 5
    assert not page.continue_btn.isEnabled() and not page.skip_btn.isEnabled()
    gui.click(page.start_btn)
    assert w.overlay.name == "confirm_tour"
    assert "5 stops on 3 floors" in w.overlay.body.text()
    gui.press("go")
    gui.press("stairs")
    cmd = gui.out.commands[-1]
    assert (cmd.command, cmd.tour_file, cmd.way) == (Cmd.START_TOUR, "real_world.tour", "stairs")
    assert w.mode_btn.text() == "Guided tour"
    g0 = "Tartalo/gui-test/1"
    event(gui, Phase.ON_THE_WAY, g0, robot="Tartalo", tour_file="real_world.tour", tour_step=0, location_id="014")
    event(gui, Phase.TOUR_STEP_DONE, g0, robot="Tartalo", tour_file="real_world.tour", tour_step=0,
          location_id="014")
    assert w.overlay.name == "event:TOUR_STEP_DONE"
    assert w.overlay.title.text() == "Stop 1 of 5"
    assert "Next stop: Caretakers' Office (008)." in w.overlay.body.text()
    gui.press("choose_stop")
    assert w.current_page == "tours"
    assert page.continue_btn.isEnabled()
    gui.click_row(page.stop_list, 3)                               # Ada Lovelace Auditorium, floor 1
    gui.click(page.skip_btn)
    cmd = gui.out.commands[-1]
    assert (cmd.command, cmd.tour_file, cmd.tour_step, cmd.goal_id, cmd.goal_uid) == (
        Cmd.SKIP, "real_world.tour", 3, "104", g0)
    assert not page.skip_btn.isEnabled()
    assert page.stop_list.item(0).data(Qt.UserRole + 4) == "done"
    assert page.stop_list.item(3).data(Qt.UserRole + 4) == "current"


def test_tour_continue_from_the_popup(idle_gui) -> None:
    gui = idle_gui("Tartalo", tours=[TOUR])
    gui.window.visitor.start_tour("real_world.tour")
    gui.press("go")
    gui.press("stairs")
    g0 = "Tartalo/gui-test/1"
    event(gui, Phase.TOUR_STEP_DONE, g0, robot="Tartalo", tour_file="real_world.tour", tour_step=0)
    cmd = continued(gui)
    assert (cmd.goal_uid, cmd.tour_file) == (g0, "real_world.tour")


def test_switch_language_changes_everything_at_once(idle_gui) -> None:
    gui = idle_gui("Kbot")
    w = gui.window
    w.visitor.pick_destination("223")
    gui.press("go")
    gui.press("stairs")
    event(gui, Phase.ON_THE_WAY, "Kbot/gui-test/1", connector="stairs_west", location_id="stairs_west")
    assert "walk behind me" in w.overlay.note_text.text()
    assert not w.overlay.geometry().intersects(w.header.geometry())      # the language button stays reachable
    assert not w.overlay.geometry().intersects(w.bottom.geometry())      # and so does Cancel
    gui.click(w.lang_btn)
    assert w.overlay.name == "language"
    gui.press("lang:eu")
    assert gui.tr.language == "eu"
    assert w.nav_buttons["offices"].text() == "Bulegoak"
    assert w.nav_buttons["floor:0"].text() == "Beheko solairua"          # from the building file
    assert w.lang_btn.text() == "Euskara"
    assert w.cancel_btn.text() == "Utzi"
    gui.click(w.lang_btn)
    gui.press("lang:es")
    assert w.nav_buttons["tours"].text() == "Visita guiada"
    assert w.floor_pages[1].buttons["101"].text() == "Secretaría"
    assert "Ada Lovelace" in w.info_here.text()
    # a trip pop-up in the new language, spoken with the Spanish voice
    event(gui, Phase.GO_TO_FLOOR, "Kbot/gui-test/1", way="stairs", connector="stairs_west", target_floor=2.0)
    assert "Segunda planta" in w.overlay.body.text()
    assert gui.speaker.said[-1][1] == "es"
    gui.click(w.lang_btn)
    gui.press("lang:en")
    assert "Second floor" in w.overlay.body.text()                    # re-translated on screen


def test_offline_robot_shows_last_known_position(idle_gui, faculty) -> None:
    gui = idle_gui("Kbot")
    w = gui.window
    w.feed("status", RobotStatusData("Tartalo", 0, 9.0, 11.4, 0.0, 0.3, -0.2, 0.15, "guiding", 2, "x", 300.0))
    gui.nav("info")
    card = w.info_page.cards["Tartalo"]
    assert card.state_text == "Guiding a visitor"
    assert card.motion.text() == "Speed 0.30 m/s · turning -0.20 rad/s"
    assert card.battery.value() == 15
    gui.clock.t += 4.0
    for r in faculty.robots:
        if r.name != "Tartalo":
            w.feed("status", RobotStatusData(r.name, r.floor, r.home.x, r.home.y, 0, 0, 0, 0.9, "idle", 0))
    w.tick()
    assert not card.property("offline")
    gui.clock.t += 2.0
    w.tick()
    gui.process()
    assert card.property("offline")
    assert card.state_text == "Offline · last seen 6 s ago"
    assert card.motion.text() == "Last known position: Copy Shop (001) (x 9.0 m, y 11.4 m)"
    marks = w.floor_pages[0].view.robots
    assert [(m.name, m.offline, m.label) for m in marks] == [("Tartalo", True, "Tartalo · offline")]


def test_admin_mode_is_off_without_the_argument(make_gui) -> None:
    gui = make_gui("Kbot")
    assert not gui.window.admin_btn.isVisible()
    gui.window.admin.start_set_location()
    assert not gui.window.floor_pages[1].setbar.isVisible()


def type_text(gui, keyboard, text: str) -> None:
    for ch in text:
        if ch.isupper() and not keyboard.shift:
            gui.click(keyboard.shift_key)
        key = " " if ch == " " else ch.lower()
        gui.click(keyboard.space_key if key == " " else keyboard.keys[key])


def test_admin_password_then_set_location(idle_gui, faculty) -> None:
    gui = idle_gui("Kbot", admin_password="robot42")
    w = gui.window
    assert w.admin_btn.isVisible() and not w.set_location_btn.isVisible()
    gui.click(w.admin_btn)
    panel = w.admin.password_panel
    type_text(gui, panel.keyboard, "robot41")
    gui.click(panel.unlock)
    assert w.overlay.title.text() == "Wrong password"
    assert not w.admin.unlocked and panel.field.text() == ""
    type_text(gui, panel.keyboard, "robot42")
    gui.click(panel.keyboard.done_key)
    assert w.admin.unlocked and not w.overlay.showing
    gui.click(w.set_location_btn)
    page = w.floor_pages[1]
    assert w.current_page == "floor:1" and page.setbar.isVisible() and not page.apply_btn.isEnabled()
    view = page.view
    tf = faculty.floor(1).transform
    m = view.mapping()
    x0, y0 = m.to_widget(*tf.to_pixel(20.0, 12.0))
    x1, y1 = m.to_widget(*tf.to_pixel(20.0, 14.0))                 # heading north: yaw pi/2
    QTest.mousePress(view, Qt.LeftButton, pos=QPoint(round(x0), round(y0)))
    QTest.mouseMove(view, QPoint(round(x1), round(y1)))
    QTest.mouseRelease(view, Qt.LeftButton, pos=QPoint(round(x1), round(y1)))
    gui.process()
    assert not gui.out.poses                                        # only when applied
    gui.click(page.apply_btn)
    (pose,) = gui.out.poses
    px = 1.0 / (tf.scale * m.k)                                     # one screen pixel in metres
    assert pose.floor == 1 and pose.x == pytest.approx(20.0, abs=px) and pose.y == pytest.approx(12.0, abs=px)
    assert pose.yaw == pytest.approx(math.pi / 2, abs=0.05)
    assert w.overlay.name == "location_sent"
    assert not page.setbar.isVisible()
    gui.click(w.admin_btn)                                          # lock again
    assert not w.admin.unlocked and not w.set_location_btn.isVisible()


def test_admin_creates_edits_and_deletes_tours(make_gui) -> None:
    gui = make_gui("Kbot", admin_password="robot42")
    w = gui.window
    w.feed("catalog", [TOUR])
    w.admin.unlock()
    gui.nav("tours")
    page = w.tours_page
    assert page.admin_row.isVisible()
    gui.click(page.new_btn)
    ed = w.tour_editing.editor
    gui.click(ed.save_btn)                                          # empty: refused before sending
    assert not gui.out.edits and "Not saved" in ed.error.text()
    ed.name.setFocus()
    gui.process()
    type_text(gui, ed.keyboard, "Open day")
    ed._name_edited(ed.name.text())
    assert ed.file.text() == "open_day.tour"
    gui.click(ed.keyboard.done_key)
    gui.click(ed.add_btn)
    gui.click(ed.floor_chips[0])
    row = next(i for i in range(ed.picker.count()) if ed.picker.item(i).data(Qt.UserRole) == "014")
    gui.click_row(ed.picker, row)
    gui.click(ed.add_btn)
    gui.click(ed.floor_chips[1])
    row = next(i for i in range(ed.picker.count()) if ed.picker.item(i).data(Qt.UserRole) == "101")
    gui.click_row(ed.picker, row)
    gui.click(ed.up_btn)                                            # 101 first now
    gui.click(ed.save_btn)
    (edit,) = gui.out.edits
    assert (edit.file_name, edit.tour_name, edit.language, edit.floor) == ("open_day.tour", "Open day", "en", 1.0)
    assert edit.goal_lines == ("1, 101, Secretary's Office", "0, 014, Computer Technicians 1")
    assert w.overlay.name == "edit_pending"
    w.feed("edit_result", EditResultData(edit.uid, "open_day.tour", False, True, 123))
    assert w.overlay.name == "edit_result" and w.overlay.title.text() == "Tour saved"
    # a refusal from the store is shown with its reason
    gui.click_row(page.tour_list, 0)
    gui.click(page.edit_btn)
    editor = w.tour_editing.editor
    assert editor.file.isReadOnly() and editor.file.text() == "real_world.tour"
    gui.click(editor.save_btn)
    edit = gui.out.edits[-1]
    assert edit.file_name == "real_world.tour" and len(edit.goal_lines) == 5
    w.feed("edit_result", EditResultData(edit.uid, "real_world.tour", False, False, 0, "in_the_way",
                                         "real_world.tour already exists as a directory"))
    assert w.overlay.title.text() == "The tour store refused it"
    assert "already exists as a directory" in w.overlay.body.text()
    gui.click(page.delete_btn)
    gui.press("delete")
    edit = gui.out.edits[-1]
    assert edit.deleted and edit.file_name == "real_world.tour"


def test_search_offices_and_pick(idle_gui, faculty) -> None:
    gui = idle_gui("Kbot")
    w = gui.window
    gui.nav("offices")
    offices = w.offices
    assert offices.list.count() == len(faculty.locations)
    gui.click(offices.chips[3])
    assert offices.list.count() == len(faculty.locations_on(3))
    gui.click(offices.all_chip)
    gui.click(offices.search)
    panel = w.visitor.search_panel
    type_text(gui, panel.keyboard, "larrea")
    assert panel.results.count() == 1
    gui.click_row(panel.results, 0)
    assert w.overlay.name == "confirm" and "223" in w.overlay.title.text()
    assert offices.query == "larrea" and offices.list.count() == 1
    # accents do not matter, room numbers work
    assert [loc.id for loc in offices.matches("reprografia")] == ["001"]
    assert [loc.id for loc in offices.matches("22")][:2] == ["022", "223"]


def test_busy_robot_refuses_a_second_destination(idle_gui) -> None:
    gui = idle_gui("Kbot")
    gui.window.visitor.pick_destination("103")
    gui.press("go")
    gui.window.visitor.pick_destination("104")
    assert gui.window.overlay.name == "event:BUSY"
    assert len(gui.out.commands) == 1


def test_mode_button_follows_the_mode(make_gui) -> None:
    gui = make_gui("Kbot")
    w = gui.window
    assert w.mode_btn.text() == "One destination" and w.mode_btn.property("mode") == "single"
    gui.click(w.mode_btn)
    assert w.mode_btn.text() == "Guided tour" and w.current_page == "tours"
    assert w.mode_btn.property("mode") == "tour"
    gui.click(w.mode_btn)
    assert w.current_page == "floor:1"


def test_tap_a_room_on_the_blueprint(idle_gui, faculty) -> None:
    gui = idle_gui("Kbot")
    gui.nav("floor:2")
    view = gui.window.floor_pages[2].view
    m = view.mapping()
    x, y = m.to_widget(*faculty.floor(2).transform.to_pixel(37.0, 8.5))     # inside room 223
    QTest.mouseClick(view, Qt.LeftButton, pos=QPoint(round(x), round(y)))
    gui.process()
    assert gui.window.overlay.name == "confirm" and gui.window.overlay.title.text() == "M. Larrea's Office (223)"
    gui.press("back")
    x, y = m.to_widget(*faculty.floor(2).transform.to_pixel(-0.5, 25.0))    # outside the building
    QTest.mouseClick(view, Qt.LeftButton, pos=QPoint(round(x), round(y)))
    gui.process()
    assert not gui.window.overlay.showing
