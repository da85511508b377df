"""The visitor's part of the screen (qt/visitor.py) on a fake screen: what it asks, sends, shows and says."""

from __future__ import annotations

import pytest
from gui_fakes import FakeScreen, nav_event

from gidabot_gui.core.flow import LocalNotice, Mode, VisitorFlow
from gidabot_gui.core.i18n import Translator
from gidabot_gui.core.model import TourInfo
from gidabot_gui.qt.visitor import VisitorController, VisitorScreen, notice_popup
from gidabot_navigation.interface import Cmd, Phase

TOUR = TourInfo("real_world.tour", "Real-world tour", "en",
                ((0, "014", "Technicians' Lab"), (0, "008", "Caretakers' Office"), (1, "101", "Secretary's Office"),
                 (2, "223", "M. Larrea's Office")))


@pytest.fixture
def visitor_at(qapp, faculty, locale_dir):
    """(fake screen, controller) of a robot's screen, every robot idle at home."""
    def make(robot: str = "Kbot") -> tuple[FakeScreen, VisitorController]:
        screen = FakeScreen(faculty, robot, Translator("en", locale_dir), tours=(TOUR,))
        screen.feed_all_status()
        flow = VisitorFlow(faculty, robot, "gui-test", request_timeout=20.0)
        return screen, VisitorController(screen, flow, info_popup_seconds=15.0, final_popup_seconds=30.0)

    return make


def test_the_window_and_the_fake_are_visitor_screens(make_gui, visitor_at) -> None:
    screen, _ = visitor_at()
    assert isinstance(screen, VisitorScreen)
    assert isinstance(make_gui("Kbot").window, VisitorScreen)


def test_a_destination_upstairs_is_confirmed_then_the_way_asked_then_requested(visitor_at) -> None:
    screen, visitor = visitor_at("Kbot")
    visitor.pick_destination("223")
    assert screen.popup == "confirm" and not screen.outputs.commands
    card = screen.top.card()
    assert card.title == "M. Larrea's Office (223)" and "Waiting time:" in card.body
    assert screen.top.buttons() == ["go", "back"]
    screen.top.press("go")
    assert screen.popup == "way" and screen.top.buttons() == ["stairs", "lift", "back"]
    screen.top.press("lift")
    assert screen.popup == ""
    (cmd,) = screen.outputs.commands
    assert (cmd.command, cmd.goal_id, cmd.way, cmd.language) == (Cmd.REQUEST, "223", "lift", "en")
    assert cmd.uid == "Kbot/gui-test/cmd/1" and visitor.flow.busy and screen.changes


def test_same_floor_asks_no_way_and_back_sends_nothing(visitor_at) -> None:
    screen, visitor = visitor_at("Kbot")
    visitor.pick_destination("103")
    screen.top.press("back")
    assert screen.popup == "" and not screen.outputs.commands
    visitor.pick_destination("nowhere")
    assert screen.popup == ""
    visitor.pick_destination("103")
    screen.top.press("go")
    (cmd,) = screen.outputs.commands
    assert (cmd.goal_id, cmd.way) == ("103", "")


def test_a_second_destination_while_a_trip_runs_is_refused(visitor_at) -> None:
    screen, visitor = visitor_at("Kbot")
    visitor.pick_destination("103")
    screen.top.press("go")
    visitor.pick_destination("104")
    assert screen.popup == notice_popup(LocalNotice.BUSY) == "event:BUSY"
    assert screen.top.auto_close == 30.0 and screen.top.card().title == "A trip is running"
    assert screen.speaker.said[-1] == ("Finish or cancel the current trip first.", "en")
    assert len(screen.outputs.commands) == 1


def test_events_become_popups_with_speech_and_continue_cancel(visitor_at) -> None:
    screen, visitor = visitor_at("Kbot")
    visitor.pick_destination("103")
    screen.top.press("go")
    uid = "Kbot/gui-test/1"
    visitor.on_event(nav_event(Phase.ON_THE_WAY, "e1", uid, location_id="103"), screen.now)
    assert screen.popup == "event:ON_THE_WAY"
    assert screen.top.buttons() == ["ok"]                     # Cancel stays in the bottom bar
    assert screen.top.auto_close == 15.0
    assert "walk behind me" in screen.top.card().note
    assert screen.speaker.said[-1][0].startswith("Follow me.")
    visitor.press_cancel()
    cmd = screen.outputs.commands[-1]
    assert (cmd.command, cmd.goal_uid) == (Cmd.CANCEL, uid)
    assert screen.popup == "" and screen.speaker.stops == 1


def test_the_visitor_from_another_floor_is_greeted_in_their_language(visitor_at) -> None:
    screen, visitor = visitor_at("Galtxagorri")
    uid = "Kbot/gui-x/1"
    visitor.on_event(nav_event(Phase.GOING_TO_MEETING, "e1", uid, robot="Galtxagorri", connector="lift",
                               location_id="lift", language="es"), screen.now)
    assert screen.popup == ""                                   # a banner, no pop-up
    assert visitor.banner == "I am going to meet a visitor at: Lift."
    visitor.on_event(nav_event(Phase.WAITING_VISITOR, "e2", uid, robot="Galtxagorri", connector="lift",
                               location_id="lift", language="es"), screen.now)
    assert screen.tr.language == "es" and visitor.banner == ""
    assert screen.popup == "event:WAITING_VISITOR" and screen.top.auto_close == 0.0
    assert screen.top.buttons() == ["continue", "cancel"]
    assert screen.speaker.said[-1][1] == "es"
    screen.top.press("continue")
    cmd = screen.outputs.commands[-1]
    assert (cmd.command, cmd.goal_uid, cmd.language) == (Cmd.CONTINUE, uid, "es")
    assert screen.speaker.stops == 1


def test_a_tour_is_started_and_a_stop_offers_the_list(visitor_at) -> None:
    screen, visitor = visitor_at("Tartalo")
    visitor.start_tour("no_such.tour")
    assert screen.popup == ""
    visitor.start_tour("real_world.tour")
    assert visitor.flow.mode is Mode.TOUR and screen.popup == "confirm_tour"
    assert "4 stops on 3 floors" in screen.top.card().body
    screen.top.press("go")
    screen.top.press("stairs")
    cmd = screen.outputs.commands[-1]
    assert (cmd.command, cmd.tour_file, cmd.way) == (Cmd.START_TOUR, "real_world.tour", "stairs")
    g0 = "Tartalo/gui-test/1"
    visitor.on_event(nav_event(Phase.TOUR_STEP_DONE, "e1", g0, robot="Tartalo", tour_file="real_world.tour",
                               tour_step=0, location_id="014"), screen.now)
    assert ("select_tour_stop", "real_world.tour", 1) in screen.ops    # the next stop, selected
    assert screen.top.buttons() == ["continue", "choose_stop", "cancel"]
    screen.top.press("choose_stop")
    assert screen.popup == "" and screen.ops[-1] == ("show_tours",)
    visitor.skip_to("real_world.tour", 2)
    cmd = screen.outputs.commands[-1]
    assert (cmd.command, cmd.tour_step, cmd.goal_id, cmd.goal_uid) == (Cmd.SKIP, 2, "101", g0)


def test_the_mode_button_switches_pages(visitor_at) -> None:
    screen, visitor = visitor_at()
    visitor.toggle_mode()
    assert visitor.flow.mode is Mode.TOUR and screen.ops[-1] == ("show_tours",)
    visitor.toggle_mode()
    assert visitor.flow.mode is Mode.SINGLE and screen.ops[-1] == ("show_home",)


def test_search_keeps_what_was_typed_and_picks(visitor_at) -> None:
    screen, visitor = visitor_at()
    visitor.show_search("lar")
    panel = visitor.search_panel
    assert screen.popup == "search" and screen.top.card().extra is panel and screen.top.card().wide
    assert panel.field.text() == "lar"
    panel.field.setText("larrea")
    panel.chosen.emit("223")
    assert ("set_search_query", "larrea") in screen.ops and screen.popup == "confirm"
    visitor.show_search("larrea")
    visitor.search_panel.closed.emit()
    assert screen.popup == "" and screen.ops[-1] == ("set_search_query", "larrea")


def test_no_answer_in_time(visitor_at) -> None:
    screen, visitor = visitor_at()
    visitor.pick_destination("103")
    screen.top.press("go")
    visitor.tick(screen.now + 10.0)
    assert screen.popup == ""
    visitor.tick(screen.now + 21.0)
    assert screen.popup == "event:NO_ANSWER" and not visitor.flow.busy


def test_a_language_switch_says_the_event_on_screen_again(visitor_at) -> None:
    screen, visitor = visitor_at()
    visitor.pick_destination("103")
    visitor.say_again("eu")
    assert not screen.speaker.said                               # a confirmation is not spoken
    screen.top.press("go")
    visitor.on_event(nav_event(Phase.ON_THE_WAY, "e1", "Kbot/gui-test/1", location_id="103"), screen.now)
    screen.tr.set_language("eu")
    visitor.say_again("eu")
    text, language = screen.speaker.said[-1]
    assert language == "eu" and text != screen.speaker.said[0][0]
