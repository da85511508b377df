"""The visitor's side of the touch screen (Qt thread): the part of the window that runs the visitor flow.

A destination is tapped (a floor page, Offices, search): confirmation with the waits,
then the way when floors change, then REQUEST. A tour is started, continued, or a later
stop chosen. Continue and Cancel (bottom bar or pop-up). Every NavEvent of this robot
becomes a pop-up and speech. Decisions are the ROS-free
:class:`~gidabot_gui.core.flow.VisitorFlow`'s; this part asks the visitor and shows its notices,
through what :class:`VisitorScreen` offers of the window.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol, runtime_checkable

from gidabot_gui.core.flow import LocalNotice, Mode, Notice, NoticeKind, VisitorFlow
from gidabot_gui.core.model import Fleet, TourInfo
from gidabot_gui.core.places import nearest_place
from gidabot_gui.core.plans import RequestPlan, plan_request, tour_waits, tour_ways
from gidabot_gui.core.texts import PopupText, Texts
from gidabot_gui.errors import GuiError
from gidabot_gui.qt.editor import SearchPanel
from gidabot_gui.qt.overlay import Button, CardSpec
from gidabot_gui.qt.screen import Popups, Services
from gidabot_gui.qt.speech import Speaker
from gidabot_navigation.guiding.messages import CommandData, NavEventData
from gidabot_navigation.interface import LANGUAGES, WAY_LIFT, WAY_STAIRS, Phase

EVENT_POPUP = "event:"      # the pop-ups of notices are named event:<kind name>, e.g. event:WAITING_VISITOR

NOTICE_ICONS: dict[NoticeKind, str] = {
    Phase.ON_THE_WAY: "walk", Phase.GO_TO_FLOOR: "stairs", Phase.WAITING_VISITOR: "robot",
    Phase.GOAL_REACHED: "flag", Phase.TOUR_STEP_DONE: "flag", Phase.TOUR_FINISHED: "check",
    Phase.UNREACHABLE: "warning", Phase.NO_ROBOT_ON_FLOOR: "warning", Phase.CANCELLED_HERE: "close",
    Phase.CANCELLED_ELSEWHERE: "close", Phase.TIMEOUT: "warning", Phase.PARTNER_OFFLINE: "warning",
    Phase.REJECTED: "warning", Phase.PARTNER_LOST: "warning", Phase.PARTNER_BACK: "check",
    Phase.WAITING_FOR_YOU: "robot", Phase.FOLLOW_ME: "walk", Phase.SEARCHING_VISITOR: "warning",
    Phase.VISITOR_LOST: "warning", Phase.PRESS_CONTINUE: "robot",
    LocalNotice.NO_ANSWER: "warning", LocalNotice.BUSY: "info",
}


def notice_popup(kind: NoticeKind) -> str:
    """The name of the pop-up showing a notice of ``kind``."""
    return f"{EVENT_POPUP}{kind.name}"


@runtime_checkable
class VisitorScreen(Services, Popups, Protocol):
    """What the visitor's part needs of the screen (:class:`~gidabot_gui.qt.window.MainWindow` is one)."""

    texts: Texts
    fleet: Fleet
    speaker: Speaker
    log: Callable[[str], None]

    @property
    def popup(self) -> str:
        """The name of the pop-up on screen ("" when none)."""

    def tour(self, file_name: str) -> TourInfo | None:
        """The tour of the catalog with this file name."""

    def show_home(self) -> None:
        """The page of this robot's floor."""

    def show_tours(self) -> None:
        """The Guided Tour page."""

    def select_tour_stop(self, file_name: str, step: int) -> None:
        """Select this tour and its stop ``step`` (0-based) on the Guided Tour page."""

    def set_search_query(self, text: str) -> None:
        """What the Offices page lists: the places matching ``text``."""

    def changed(self) -> None:
        """The flow changed: bring what is shown up to date."""


class VisitorController:
    """The visitor flow of one screen (see the module docstring).

    ``info_popup_seconds``, ``final_popup_seconds``: how long informative and outcome pop-ups stay.
    """

    def __init__(self, screen: VisitorScreen, flow: VisitorFlow, info_popup_seconds: float = 15.0,
                 final_popup_seconds: float = 30.0) -> None:
        self.screen = screen
        self.flow = flow
        self.info_popup_seconds = info_popup_seconds
        self.final_popup_seconds = final_popup_seconds
        self.banner = ""                  # non-modal notice (GOING_TO_MEETING)
        self.current_notice: Notice | None = None
        self.search_panel: SearchPanel | None = None

    # ------------------------------------------------------------------ commands
    def _start_id(self) -> str:
        """The place nearest to this robot (where a trip requested now starts), "" when its pose is unknown."""
        flow = self.flow
        live = self.screen.fleet.robots[flow.robot]
        if live.pose is None:
            return ""
        place = nearest_place(flow.building, flow.floor, live.pose[0], live.pose[1])
        return place.id if place is not None else ""

    def _send(self, cmd: CommandData | None) -> None:
        if cmd is not None:
            self.screen.outputs.send_command(cmd)
            self.screen.changed()

    def _start(self, what: str, make: Callable[[str, float, str], CommandData]) -> None:
        """Close the pop-up and send ``make(language, now, start_id)``: the trip the visitor confirmed. The flow
        refusing it (a trip runs) is logged and told as BUSY."""
        s = self.screen
        s.close_popup()
        try:
            cmd = make(s.tr.language, s.clock(), self._start_id())
        except GuiError as err:
            s.log(f"gui: {what} refused: {err}")
            self.show_notice(Notice(LocalNotice.BUSY))
            return
        self._send(cmd)

    def pick_destination(self, goal_id: str) -> None:
        """The visitor tapped a destination: confirmation with the waits, then the way, then REQUEST."""
        s, flow = self.screen, self.flow
        if flow.building.find_location(goal_id) is None:
            return
        if flow.busy:
            self.show_notice(Notice(LocalNotice.BUSY))
            return

        def plan() -> RequestPlan:
            return plan_request(s.fleet, flow.robot, goal_id, s.clock())

        self._confirm("confirm", Mode.SINGLE, lambda: s.texts.confirm(plan()), "pin", lambda: s.tr._("Guide me"),
                      lambda: plan().ways,
                      lambda way: self._start("request",
                                              lambda lang, now, at: flow.request(goal_id, way, lang, now, at)))

    def start_tour(self, file_name: str) -> None:
        """The visitor chose to start a tour: confirmation with the waits, then the way, then START_TOUR."""
        s, flow = self.screen, self.flow
        tour = s.tour(file_name)
        if tour is None:
            return
        if not flow.can_start_tour():
            self.show_notice(Notice(LocalNotice.BUSY))
            return
        self._confirm("confirm_tour", Mode.TOUR,
                      lambda: s.texts.confirm_tour(tour, tour_waits(s.fleet, flow.robot, tour, s.clock())), "route",
                      lambda: s.tr._("Start the tour"), lambda: tour_ways(flow.building, flow.floor, tour),
                      lambda way: self._start("tour", lambda lang, now, at: flow.start_tour(tour, way, lang, now, at)))

    def _confirm(self, name: str, mode: Mode, text: Callable[[], PopupText], icon: str, go_label: Callable[[], str],
                 ways: Callable[[], tuple[str, ...]], go: Callable[[str], None]) -> None:
        """In ``mode``, the pop-up ``name`` confirming a trip (``text``: what it is and the waits, built at each
        showing); its go button asks the way when ``ways`` offers a choice, then calls ``go(way)``."""
        s = self.screen
        self.flow.set_mode(mode)
        s.changed()

        def build() -> CardSpec:
            shown = text()
            return CardSpec(shown.title, shown.body, "action", icon,
                            [Button("go", go_label(), "primary", "play"), Button("back", s.tr._("Back"))])

        def pressed(key: str) -> None:
            if key != "go":
                s.close_popup()
                return
            choice = ways()
            if len(choice) > 1:
                self._ask_way(go, choice)
            else:
                go(choice[0] if choice else "")

        s.show_popup(name, build, pressed)

    def _ask_way(self, then: Callable[[str], None], ways: tuple[str, ...]) -> None:
        s = self.screen

        def build() -> CardSpec:
            t = s.tr
            buttons = []
            if WAY_STAIRS in ways:
                buttons.append(Button(WAY_STAIRS, t._("By the stairs"), "primary", "stairs"))
            if WAY_LIFT in ways:
                buttons.append(Button(WAY_LIFT, t._("By the lift"), "primary", "lift"))
            buttons.append(Button("back", t._("Back")))
            return CardSpec(t._("How do you want to change floors?"),
                            t._("A robot waits for you on the other floor."), "action", "stairs", buttons)

        def pressed(key: str) -> None:
            if key in (WAY_STAIRS, WAY_LIFT):
                then(key)
            else:
                s.close_popup()

        s.show_popup("way", build, pressed)

    def press_continue(self, goal_uid: str | None) -> None:
        s = self.screen
        s.close_popup()
        s.speaker.stop()
        self._send(self.flow.continue_(s.tr.language, s.clock(), goal_uid))

    def skip_to(self, file_name: str, step: int) -> None:
        s = self.screen
        tour = s.tour(file_name)
        if tour is None:
            return
        self._send(self.flow.skip(step, tour.goals, s.tr.language, s.clock()))

    def press_cancel(self) -> None:
        s = self.screen
        s.close_popup()
        s.speaker.stop()
        self._send(self.flow.cancel(s.tr.language, s.clock()))

    def toggle_mode(self) -> None:
        """The mode button: one destination (this floor's page) or a guided tour (the Guided Tour page)."""
        s = self.screen
        if self.flow.mode is Mode.SINGLE:
            self.flow.set_mode(Mode.TOUR)
            s.show_tours()
        else:
            self.flow.set_mode(Mode.SINGLE)
            s.show_home()
        s.changed()

    def show_search(self, query: str) -> None:
        """The search panel, starting from ``query``; what is typed there is kept for the Offices page."""
        s = self.screen
        panel = SearchPanel(s.tr, self.flow.building, s.theme, query)

        def build() -> CardSpec:
            panel.retranslate()
            return CardSpec(s.tr._("Search by room number or name"), "", "action", "search", [],
                            extra=panel, wide=True)

        def chosen(goal_id: str) -> None:
            closed()
            self.pick_destination(goal_id)

        def closed() -> None:
            s.set_search_query(panel.field.text())
            s.close_popup()

        panel.chosen.connect(chosen)
        panel.closed.connect(closed)
        self.search_panel = panel
        s.show_popup("search", build, lambda _k: closed())
        panel.field.setFocus()

    # ------------------------------------------------------------------ what the guiding nodes say
    def on_event(self, event: NavEventData, now: float) -> None:
        notice = self.flow.on_event(event, now)
        if notice is not None:
            self.show_notice(notice)

    def tick(self, now: float) -> None:
        notice = self.flow.tick(now)
        if notice is not None:
            self.show_notice(notice)

    def show_notice(self, notice: Notice) -> None:
        """A notice as a pop-up, spoken (modal ones), or as the banner of the info line."""
        s = self.screen
        if notice.adopt_language in LANGUAGES and notice.adopt_language != s.tr.language:
            s.tr.set_language(notice.adopt_language)
        if not notice.modal:
            self.banner = s.texts.notice(notice).title if notice.kind is Phase.GOING_TO_MEETING else ""
            s.changed()
            return
        self.banner = ""
        self.current_notice = notice
        if notice.kind is Phase.TOUR_STEP_DONE and notice.tour_file:
            s.select_tour_stop(notice.tour_file, notice.tour_step + 1)
        goal_uid = notice.event.goal_uid if notice.event is not None else ""

        def build() -> CardSpec:
            text = s.texts.notice(notice)
            t = s.tr
            # Cancel of a trip on the way stays in the bottom bar
            shown = [a for a in notice.actions if not (a == "cancel" and notice.kind is Phase.ON_THE_WAY)]
            labels = {"ok": (t._("OK"), "primary" if len(shown) == 1 else "", "check"),
                      "continue": (t._("Continue"), "primary", "play"),
                      "cancel": (t._("Cancel"), "danger", "close"),
                      "choose_stop": (t._("Choose a stop"), "", "route")}
            buttons = [Button(a, *labels[a]) for a in shown if a in labels]
            return CardSpec(text.title, text.body, text.tone, NOTICE_ICONS.get(notice.kind, "info"), buttons,
                            note=text.note, note_icon="walk" if text.note else "")

        def pressed(key: str) -> None:
            if key == "continue":
                self.press_continue(goal_uid or None)
            elif key == "cancel":
                self.press_cancel()
            elif key == "choose_stop":
                s.close_popup()
                s.show_tours()
            else:
                s.close_popup()

        final = notice.final or notice.kind is LocalNotice.BUSY
        auto = 0.0 if "continue" in notice.actions else (
            self.final_popup_seconds if final else self.info_popup_seconds)
        s.show_popup(notice_popup(notice.kind), build, pressed, auto_close=auto)
        speech = s.texts.notice(notice).speech
        if speech:
            s.speaker.say(speech, s.tr.language)
        s.changed()

    def say_again(self, language: str) -> None:
        """The language was just switched: say the pop-up of a notice on screen again, in ``language``."""
        s = self.screen
        if self.current_notice is not None and s.popup.startswith(EVENT_POPUP):
            s.speaker.say(s.texts.notice(self.current_notice).speech, language)
