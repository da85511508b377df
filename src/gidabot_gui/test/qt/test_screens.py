"""Every page in every language at 800x480 and 1280x800: nothing clipped, big touch targets.

Saves the screenshots shown in the README into docs/screenshots/ (override the
directory with GIDABOT_SCREENSHOT_DIR): each page in the three languages at
800x480, the pages in English at 1280x800, and the main pop-ups.
"""

from __future__ import annotations

import pytest
from gui_fakes import nav_event as make_event
from PyQt5.QtCore import QPoint, Qt
from PyQt5.QtTest import QTest

from gidabot_gui.core.model import TourInfo
from gidabot_navigation.guiding.messages import PendingData, RobotStatusData
from gidabot_navigation.interface import Phase

LANGS = ("en", "eu", "es")
PAGES = ("floor:0", "floor:1", "floor:2", "floor:3", "offices", "tours", "info")
TOURS = [
    TourInfo("long_tour.tour", "Long duration tour", "en",
             ((0, "005", "Student Council"), (3, "301", "IXA Lab"), (2, "203", "C. Rodriguez's Office"),
              (1, "103", "Dean's Office"), (2, "205", "J. Abascal's Office"), (3, "303", "B. Sierra's Office"))),
    TourInfo("paper_example.tour", "", "en", ((0, "014", "Computer Technicians 1"), (1, "101", "Secretary's Office"))),
    TourInfo("real_world.tour", "Real-world tour", "en",
             ((0, "014", "Technicians' Lab"), (0, "008", "Caretakers' Office"), (1, "101", "Secretary's Office"),
              (1, "104", "Ada Lovelace Auditorium"), (2, "223", "M. Larrea's Office"),
              (2, "274", "K. Sarasola's Office"), (3, "325", "I. Irigoien's Office"), (3, "305", "RSAIT Lab"))),
]


# (x, y, yaw, linear, angular, battery, state, pending, wait) of each robot
LIVELY = {"Tartalo": (44.0, 12.0, 3.1, 0.42, 0.05, 0.64, "guiding", 2, 210.0),
          "Kbot": (27.5, 12.0, 0.0, 0.0, 0.0, 0.93, "idle", 0, 0.0),
          "Galtxagorri": (35.5, 12.4, 1.57, 0.0, 0.0, 0.18, "waiting", 1, 95.0),
          "MariSorgin": (15.0, 12.0, 0.0, 0.0, 0.0, 0.71, "idle", 0, 0.0)}


def populate(gui, faculty, offline: str = "MariSorgin", where: dict = LIVELY) -> None:
    """A lively building: robots here and there, some busy, one gone offline."""
    w = gui.window
    w.feed("catalog", TOURS)
    for r in faculty.robots:
        x, y, yaw, v, om, bat, state, n, wait = where[r.name]
        w.feed("status", RobotStatusData(r.name, r.floor, x, y, yaw, v, om, bat, state, n, "", wait))
        w.feed("pending", PendingData(r.name, r.floor, n, wait))
    if offline:
        gui.clock.t += 3.0
        for r in faculty.robots:
            if r.name != offline:
                x, y, yaw, v, om, bat, state, n, wait = where[r.name]
                w.feed("status", RobotStatusData(r.name, r.floor, x, y, yaw, v, om, bat, state, n, "", wait))
        gui.clock.t += 9.0
        for r in faculty.robots:
            if r.name != offline:
                x, y, yaw, v, om, bat, state, n, wait = where[r.name]
                w.feed("status", RobotStatusData(r.name, r.floor, x, y, yaw, v, om, bat, state, n, "", wait))
    w.tick()
    gui.process()


@pytest.mark.parametrize("language", LANGS)
def test_pages_in_every_language_at_800x480(make_gui, faculty, text_problems, language) -> None:
    gui = make_gui("Kbot", language=language, size=(800, 480))
    assert gui.window.size().width() == 800 and gui.window.size().height() == 480
    populate(gui, faculty)
    problems = {}
    for page in PAGES:
        gui.window.show_page(page)
        if page == "tours":
            gui.window.tours_page.select("real_world.tour")
        gui.process()
        problems[page] = text_problems(gui.window)
        gui.shot(f"{page.replace(':', '')}-{language}")
    assert not any(problems.values()), problems


@pytest.mark.parametrize("language", LANGS)
def test_pages_in_every_language_at_1280x800(make_gui, faculty, text_problems, language) -> None:
    gui = make_gui("Kbot", language=language, size=(1280, 800), admin_password="x")
    w = gui.window
    populate(gui, faculty)
    w.admin.unlock()                              # admin buttons too
    problems = {}
    for page in PAGES:
        w.show_page(page)
        gui.process()
        problems[page] = text_problems(w)
        if language == "en" and page in ("floor:1", "offices", "tours", "info"):
            gui.shot(f"{page.replace(':', '')}-1280x800")
    assert not any(problems.values()), problems


def nav_event(gui, phase: Phase, goal_uid: str, robot: str = "Kbot", **kw) -> None:
    gui._n = getattr(gui, "_n", 0) + 1
    gui.window.feed("nav_event", make_event(phase, f"{robot}/event/{gui._n}", goal_uid, robot, **kw))
    gui.process()


@pytest.mark.parametrize("language", LANGS)
def test_popups(make_gui, faculty, text_problems, language) -> None:
    """The visitor's pop-ups, in each language (saved in English, and the walk-behind one in all three)."""
    problems = {}

    def check(name: str, gui, save: bool = False) -> None:
        problems[name] = text_problems(gui.window)
        if save or language == "en":
            gui.shot(f"popup-{name}-{language}")

    gui = make_gui("Kbot", language=language)
    populate(gui, faculty)
    w = gui.window
    w.visitor.pick_destination("223")
    check("confirm", gui, save=True)
    gui.press("go")
    check("way", gui)
    gui.press("stairs")
    uid = "Kbot/gui-test/1"
    nav_event(gui, Phase.ACCEPTED, uid, way="stairs", connector="stairs_west", target_floor=2.0, location_id="223")
    nav_event(gui, Phase.ON_THE_WAY, uid, way="stairs", connector="stairs_west", target_floor=2.0,
              location_id="stairs_west")
    check("on_the_way", gui, save=True)
    nav_event(gui, Phase.GO_TO_FLOOR, uid, way="stairs", connector="stairs_west", target_floor=2.0)
    check("go_to_floor", gui, save=True)

    up = make_gui("Galtxagorri", language=language)
    populate(up, faculty)
    nav_event(up, Phase.GOING_TO_MEETING, uid, robot="Galtxagorri", connector="stairs_west",
              location_id="stairs_west", language=language)
    nav_event(up, Phase.WAITING_VISITOR, uid, robot="Galtxagorri", connector="stairs_west",
              location_id="stairs_west", language=language)
    check("waiting_visitor", up, save=True)
    up.press("continue")
    nav_event(up, Phase.ON_THE_WAY, uid, robot="Galtxagorri", location_id="223", language=language)
    nav_event(up, Phase.GOAL_REACHED, uid, robot="Galtxagorri", location_id="223", language=language)
    check("goal_reached", up)

    for phase, extra in ((Phase.UNREACHABLE, {"location_id": "223"}),
                         (Phase.NO_ROBOT_ON_FLOOR, {"target_floor": 3.0, "way": "lift", "location_id": "305"}),
                         (Phase.TIMEOUT, {}), (Phase.PARTNER_OFFLINE, {"target_floor": 3.0}),
                         (Phase.CANCELLED_ELSEWHERE, {}), (Phase.REJECTED, {})):
        g = make_gui("Kbot", language=language)
        populate(g, faculty, offline="")
        g.window.visitor.pick_destination(extra.get("location_id", "103") if extra.get("location_id") != "305"
                                          else "305")
        g.press("go")
        if g.window.overlay.name == "way":
            g.press("lift")
        nav_event(g, Phase.ON_THE_WAY, "Kbot/gui-test/1", location_id=extra.get("location_id", "103"))
        nav_event(g, phase, "Kbot/gui-test/1", **extra)
        assert g.window.overlay.name == f"event:{phase.name}"
        check(phase.name.lower(), g, save=phase in (Phase.UNREACHABLE, Phase.NO_ROBOT_ON_FLOOR))

    t = make_gui("Tartalo", language=language)
    populate(t, faculty)
    t.window.visitor.start_tour("real_world.tour")
    check("confirm_tour", t)
    t.press("go")
    t.press("stairs")
    nav_event(t, Phase.TOUR_STEP_DONE, "Tartalo/gui-test/1", robot="Tartalo", tour_file="real_world.tour",
              tour_step=0, location_id="014")
    check("tour_step_done", t, save=True)
    t.press("choose_stop")
    t.window.tours_page.select_stop(4)
    t.process()
    problems["tour_choose"] = text_problems(t.window)
    if language == "en":
        t.shot("tours-step-done-en")

    m = make_gui("Kbot", language=language)
    populate(m, faculty)
    m.click(m.window.lang_btn)
    check("language", m)
    assert not any(problems.values()), problems


def test_admin_screens(make_gui, faculty, text_problems) -> None:
    problems = {}
    for language in LANGS:
        gui = make_gui("Kbot", language=language, admin_password="robot42")
        populate(gui, faculty)
        w = gui.window
        gui.click(w.admin_btn)
        problems[f"password-{language}"] = text_problems(w)
        if language == "en":
            gui.shot("admin-password-en")
        w.overlay.close_card()
        w.admin.unlock()
        gui.click(w.set_location_btn)
        view = w.floor_pages[1].view
        tf = faculty.floor(1).transform
        m = view.mapping()
        a = m.to_widget(*tf.to_pixel(20.0, 12.0))
        b = m.to_widget(*tf.to_pixel(23.0, 13.0))
        QTest.mousePress(view, Qt.LeftButton, pos=QPoint(round(a[0]), round(a[1])))
        QTest.mouseMove(view, QPoint(round(b[0]), round(b[1])))
        QTest.mouseRelease(view, Qt.LeftButton, pos=QPoint(round(b[0]), round(b[1])))
        gui.process()
        problems[f"set_location-{language}"] = text_problems(w)
        if language == "en":
            gui.shot("admin-set-location-en")
        gui.click(w.floor_pages[1].cancel_set_btn)
        w.show_page("tours")
        w.tours_page.select("real_world.tour")
        gui.click(w.tours_page.edit_btn)
        problems[f"editor-{language}"] = text_problems(w)
        if language == "en":
            gui.shot("admin-tour-editor-en")
        w.tour_editing.editor.name.setFocus()
        gui.process()
        problems[f"editor-keyboard-{language}"] = text_problems(w)
        w.overlay.close_card()
        gui.nav("offices")
        gui.click(w.offices.search)
        w.visitor.search_panel.field.setText("lab")
        gui.process()
        problems[f"search-{language}"] = text_problems(w)
        gui.shot(f"offices-search-{language}") if language == "en" else None
    assert not any(problems.values()), problems


# ------------------------------------------------------------ several robots per floor, floors without robot

# maps/faculty6: two robots on floors 1 and 2; Kbot busy guiding, Basajaun free, Lamia waiting
SIX = {"Tartalo": (44.0, 12.0, 3.1, 0.42, 0.05, 0.64, "guiding", 1, 120.0),
       "Kbot": (20.0, 12.0, 3.1, 0.5, 0.0, 0.93, "guiding", 1, 240.0),
       "Basajaun": (54.0, 12.0, 3.14, 0.0, 0.0, 0.81, "idle", 0, 0.0),
       "Galtxagorri": (30.0, 12.0, 0.0, 0.0, 0.0, 0.55, "idle", 0, 0.0),
       "Lamia": (67.0, 12.0, 0.0, 0.0, 0.0, 0.18, "waiting", 1, 95.0),
       "MariSorgin": (15.0, 12.0, 0.0, 0.0, 0.0, 0.71, "idle", 0, 0.0)}


@pytest.mark.parametrize("language", LANGS)
def test_two_robots_per_floor(make_gui, faculty6, text_problems, language) -> None:
    """Both robots of a floor on its tab, every robot on the Information tab, and the confirmation with the
    robot (and wait) of each leg: Basajaun comes to Kbot's visitor, Lamia meets them on floor 2."""
    gui = make_gui("Kbot", language=language, building=faculty6)
    populate(gui, faculty6, offline="", where=SIX)
    w = gui.window
    problems = {}
    for page in ("floor:1", "floor:2", "info"):
        w.show_page(page)
        gui.process()
        problems[page] = text_problems(w)
        gui.shot(f"faculty6-{page.replace(':', '')}-{language}")
    marks = {m.name for m in w.floor_pages[1.0].view.robots}
    assert marks == {"Kbot", "Basajaun"} and {m.name for m in w.floor_pages[2.0].view.robots} == {"Galtxagorri",
                                                                                                  "Lamia"}
    assert set(w.info_page.cards) == {r.name for r in faculty6.robots}
    w.visitor.pick_destination("231")                  # the east end of floor 2
    gui.process()
    problems["confirm"] = text_problems(w)
    body = w.overlay.body.text()
    assert "Basajaun" in body and "Lamia" in body and "Kbot" not in body, body
    gui.shot(f"faculty6-confirm-{language}")
    gui.press("go")
    gui.press("stairs")
    nav_event(gui, Phase.ASSIGNED, "Kbot/gui-test/1", leg="start", assignee="Basajaun", eta=70.0)
    assert w.overlay.name == "event:ASSIGNED" and "Basajaun" in w.overlay.body.text()
    problems["assigned"] = text_problems(w)
    gui.shot(f"faculty6-popup-assigned-{language}")
    assert not any(problems.values()), problems


@pytest.mark.parametrize("language", LANGS)
def test_a_tour_through_a_floor_without_robot(make_gui, faculty3, text_problems, language) -> None:
    """maps/faculty3: Kbot sends the visitor of Table 4 to 223 and 274 on floor 2 (no robot), then on to floor 3,
    where MariSorgin waits; a tour ending on floor 2 ends there with a goodbye."""
    gui = make_gui("Kbot", language=language, building=faculty3)
    w = gui.window
    w.feed("catalog", TOURS)
    for r in faculty3.robots:
        w.feed("status", RobotStatusData(r.name, r.floor, 30.0, 12.0, 0.0, 0.0, 0.0, 0.9, "idle", 0, "", 0.0))
    w.tick()
    gui.process()
    uid = "Kbot/gui-test/4"
    nav_event(gui, Phase.TOUR_STEP_DONE, "Kbot/gui-test/3", tour_file="real_world.tour", tour_step=3,
              location_id="104")
    gui.press("continue")
    nav_event(gui, Phase.ON_THE_WAY, uid, tour_file="real_world.tour", tour_step=4, location_id="stairs_west",
              connector="stairs_west", way="stairs", target_floor=2.0)
    nav_event(gui, Phase.NO_ROBOT_ON_FLOOR, uid, tour_file="real_world.tour", tour_step=4, location_id="223",
              connector="stairs_west", way="stairs", target_floor=2.0)
    nav_event(gui, Phase.ASSIGNED, "Kbot/gui-test/5", leg="goal", assignee="MariSorgin",
              tour_file="real_world.tour", tour_step=6)
    assert w.overlay.name == "event:NO_ROBOT_ON_FLOOR"
    body = w.overlay.body.text()
    assert "(223)" in body and "(274)" in body and "MariSorgin" in body, body
    problems = {"no_robot": text_problems(w)}
    gui.shot(f"faculty3-popup-no-robot-tour-{language}")
    end = make_gui("Kbot", language=language, building=faculty3)
    end.window.feed("catalog", [TourInfo("ends.tour", "Ends upstairs", "en",
                                         ((1, "101", "Secretary's Office"), (2, "223", "M. Larrea's Office"),
                                          (2, "274", "K. Sarasola's Office")))])
    end.process()
    nav_event(end, Phase.TOUR_FINISHED, "Kbot/gui-test/9", tour_file="ends.tour", tour_step=1, location_id="223",
              connector="lift", way="lift", target_floor=2.0)
    assert end.window.overlay.name == "event:TOUR_FINISHED" and "(274)" in end.window.overlay.body.text()
    problems["tour_ends_there"] = text_problems(end.window)
    end.shot(f"faculty3-popup-tour-ends-there-{language}")
    assert not any(problems.values()), problems
