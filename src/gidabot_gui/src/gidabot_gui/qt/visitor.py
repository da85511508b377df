"""The visitor's side of the touch screen (Qt thread): the part of the window that runs the visitor flow.

A destination is tapped (a floor page, Offices, search): confirmation with the waits,
then the way when floors change, then REQUEST. A tour is started, continued, or a later
stop chosen. Continue and Cancel (bottom bar or pop-up). Every NavEvent of this robot
becomes a pop-up and speech. Decisions are the ROS-free
:class:`~gidabot_gui.core.flow.VisitorFlow`'s; this part asks the visitor and shows its notices.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from gidabot_gui.core.flow import Mode, Notice, Outcome, VisitorFlow
from gidabot_gui.core.places import nearest_place
from gidabot_gui.core.plans import plan_request, tour_waits, tour_ways
from gidabot_gui.errors import GuiError
from gidabot_gui.qt.editor import SearchPanel
from gidabot_gui.qt.overlay import Button, CardSpec
from gidabot_navigation.guiding.messages import CommandData, NavEventData
from gidabot_navigation.interface import LANGUAGES, WAY_LIFT, WAY_STAIRS, Phase

if TYPE_CHECKING:
    from gidabot_gui.qt.window import MainWindow

EVENT_ICONS = {
    Phase.ON_THE_WAY: "walk", Phase.GO_TO_FLOOR: "stairs", Phase.WAITING_VISITOR: "robot", Phase.GOAL_REACHED: "flag",
    Phase.TOUR_STEP_DONE: "flag", Phase.TOUR_FINISHED: "check", Phase.UNREACHABLE: "warning",
    Phase.NO_ROBOT_ON_FLOOR: "warning", Phase.CANCELLED_HERE: "close", Phase.CANCELLED_ELSEWHERE: "close",
    Phase.TIMEOUT: "warning", Phase.PARTNER_OFFLINE: "warning", Phase.REJECTED: "warning",
    Outcome.NO_ANSWER: "warning", Outcome.BUSY: "info", Phase.PARTNER_LOST: "warning", Phase.PARTNER_BACK: "check",
}


class VisitorController:
    """The visitor flow of one screen (see the module docstring)."""

    def __init__(self, screen: MainWindow) -> None:
        self.screen = screen
        config = screen.config
        self.flow = VisitorFlow(screen.building, config.robot, config.visitor_id, config.request_timeout)
        self.banner = ""                  # non-modal notice (GOING_TO_MEETING)
        self.current_notice: Notice | None = None
        self.search_panel: SearchPanel | None = None

    # ------------------------------------------------------------------ commands
    def _start_id(self) -> str:
        s = self.screen
        live = s.fleet.robots[s.robot.name]
        if live.pose is None:
            return ""
        place = nearest_place(s.building, s.robot.floor, live.pose[0], live.pose[1])
        return place.id if place is not None else ""

    def _send(self, cmd: CommandData | None) -> None:
        if cmd is not None:
            self.screen.outputs.send_command(cmd)
            self.screen.changed()

    def pick_destination(self, goal_id: str) -> None:
        """The visitor tapped a destination: confirmation with the waits, then the way, then REQUEST."""
        s = self.screen
        if s.building.find_location(goal_id) is None:
            return
        if self.flow.busy:
            self.show_notice(Notice(Outcome.BUSY))
            return
        self.flow.set_mode(Mode.SINGLE)
        s.update_header()

        def build() -> CardSpec:
            plan = plan_request(s.fleet, s.robot.name, goal_id, s.clock())
            text = s.texts.confirm(plan)
            t = s.tr
            return CardSpec(text.title, text.body, "action", "pin",
                            [Button("go", t._("Guide me"), "primary", "play"), Button("back", t._("Back"))])

        def pressed(key: str) -> None:
            if key != "go":
                s.overlay.close_card()
                return
            plan = plan_request(s.fleet, s.robot.name, goal_id, s.clock())
            if plan.changes_floor and len(plan.ways) > 1:
                self._ask_way(lambda way: self._request(goal_id, way), plan.ways)
            else:
                self._request(goal_id, plan.ways[0] if plan.ways else "")

        s.overlay.show_card("confirm", build, pressed)

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
                s.overlay.close_card()

        s.overlay.show_card("way", build, pressed)

    def _request(self, goal_id: str, way: str) -> None:
        s = self.screen
        s.overlay.close_card()
        try:
            cmd = self.flow.request(goal_id, way, s.tr.language, s.clock(), self._start_id())
        except GuiError as err:
            s.log(f"gui: request refused: {err}")
            self.show_notice(Notice(Outcome.BUSY))
            return
        self._send(cmd)

    def start_tour(self, file_name: str) -> None:
        s = self.screen
        tour = s.tour(file_name)
        if tour is None:
            return
        if not self.flow.can_start_tour():
            self.show_notice(Notice(Outcome.BUSY))
            return
        self.flow.set_mode(Mode.TOUR)
        s.update_header()

        def build() -> CardSpec:
            text = s.texts.confirm_tour(tour, tour_waits(s.fleet, s.robot.name, tour, s.clock()))
            t = s.tr
            return CardSpec(text.title, text.body, "action", "route",
                            [Button("go", t._("Start the tour"), "primary", "play"), Button("back", t._("Back"))])

        def go(way: str) -> None:
            s.overlay.close_card()
            try:
                cmd = self.flow.start_tour(tour, way, s.tr.language, s.clock(), self._start_id())
            except GuiError as err:
                s.log(f"gui: tour refused: {err}")
                self.show_notice(Notice(Outcome.BUSY))
                return
            self._send(cmd)

        def pressed(key: str) -> None:
            if key != "go":
                s.overlay.close_card()
                return
            ways = tour_ways(s.building, s.robot.floor, tour)
            if len(ways) > 1:
                self._ask_way(go, ways)
            else:
                go(ways[0] if ways else "")

        s.overlay.show_card("confirm_tour", build, pressed)

    def press_continue(self, goal_uid: str | None) -> None:
        s = self.screen
        s.overlay.close_card()
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
        s.overlay.close_card()
        s.speaker.stop()
        self._send(self.flow.cancel(s.tr.language, s.clock()))

    def toggle_mode(self) -> None:
        s = self.screen
        if self.flow.mode is Mode.SINGLE:
            self.flow.set_mode(Mode.TOUR)
            s.show_page("tours")
        else:
            self.flow.set_mode(Mode.SINGLE)
            s.show_home()
        s.update_header()
        s.changed()

    def show_search(self) -> None:
        s = self.screen
        offices = s.offices
        panel = SearchPanel(s.tr, s.building, s.theme, offices.query)

        def build() -> CardSpec:
            panel.retranslate()
            return CardSpec(s.tr._("Search by room number or name"), "", "action", "search", [],
                            extra=panel, wide=True)

        def chosen(goal_id: str) -> None:
            offices.set_query(panel.field.text())
            s.overlay.close_card()
            self.pick_destination(goal_id)

        def closed() -> None:
            offices.set_query(panel.field.text())
            s.overlay.close_card()

        panel.chosen.connect(chosen)
        panel.closed.connect(closed)
        self.search_panel = panel
        s.overlay.show_card("search", build, lambda _k: closed())
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
        s = self.screen
        if notice.adopt_language in LANGUAGES and notice.adopt_language != s.tr.language:
            s.tr.set_language(notice.adopt_language)
        if not notice.modal:
            self.banner = s.texts.notice(notice).title if notice.kind is Phase.GOING_TO_MEETING else ""
            s.mark_dirty()
            return
        self.banner = ""
        self.current_notice = notice
        if notice.kind is Phase.TOUR_STEP_DONE and notice.tour_file:
            s.tours_page.select(notice.tour_file)
            s.tours_page.select_stop(notice.tour_step + 1)
        goal_uid = notice.event.goal_uid if notice.event is not None else ""

        def build() -> CardSpec:
            text = s.texts.notice(notice)
            t = s.tr
            shown = [a for a in notice.actions if not (a == "cancel" and notice.kind is Phase.ON_THE_WAY)]
            labels = {"ok": (t._("OK"), "primary" if len(shown) == 1 else "", "check"),
                      "continue": (t._("Continue"), "primary", "play"),
                      "cancel": (t._("Cancel"), "danger", "close"),
                      "choose_stop": (t._("Choose a stop"), "", "route")}
            # Cancel of a trip on the way stays in the bottom bar
            buttons = [Button(a, *labels[a]) for a in shown if a in labels]
            return CardSpec(text.title, text.body, text.tone, EVENT_ICONS.get(notice.kind, "info"), buttons,
                            note=text.note, note_icon="walk" if text.note else "")

        def pressed(key: str) -> None:
            if key == "continue":
                self.press_continue(goal_uid or None)
            elif key == "cancel":
                self.press_cancel()
            elif key == "choose_stop":
                s.overlay.close_card()
                s.show_page("tours")
            else:
                s.overlay.close_card()

        final = notice.final or notice.kind is Outcome.BUSY
        auto = 0.0 if "continue" in notice.actions else (
            s.config.final_popup_seconds if final else s.config.info_popup_seconds)
        s.overlay.show_card(f"event:{notice.name}", build, pressed, auto_close=auto)
        speech = s.texts.notice(notice).speech
        if speech:
            s.speaker.say(speech, s.tr.language)
        s.mark_dirty()

    def say_again(self, language: str) -> None:
        """The language was just switched: say the pop-up of an event on screen again, in ``language``."""
        ov = self.screen.overlay
        if self.current_notice is not None and ov.showing and ov.name.startswith("event:"):
            self.screen.speaker.say(self.screen.texts.notice(self.current_notice).speech, language)
