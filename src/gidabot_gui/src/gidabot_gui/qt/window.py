"""The main window of the touch screen: the shell that lays out the screen and hands input to its parts.

Everything here runs in the Qt thread. Input arrives through an
:class:`~gidabot_gui.core.inbox.Inbox` drained by a timer (the ROS adapter fills it
from its callback threads) or directly through :meth:`MainWindow.feed` in
tests. Output goes through an :class:`Outputs` object (the ROS adapter's
publishers, or a recorder in tests).

The shell owns the layout (header, page tabs, pages, bottom bar, pop-up overlay),
the look, the language, the robots' live state (:class:`~gidabot_gui.core.model.Fleet`),
the tour catalog and what is shown of them. Its parts, each with one job:

- :class:`~gidabot_gui.qt.visitor.VisitorController`: destinations, tours, Continue and
  Cancel, the NavEvents' pop-ups and speech;
- :class:`~gidabot_gui.qt.admin_mode.AdminController`: the administrator password, Set location;
- :class:`~gidabot_gui.qt.tour_editing.TourEditController`: the tour editor, deleting tours
  and the tour store's answers.

Each part sees the window only through a Protocol of what it needs
(:class:`~gidabot_gui.qt.visitor.VisitorScreen`, :class:`~gidabot_gui.qt.admin_mode.AdminScreen`,
:class:`~gidabot_gui.qt.tour_editing.TourEditScreen`): a few services (translator, texts, fleet,
outputs, clock) and operations on the screen (pop-ups, pages, refresh), which this window offers.

Decisions are made by the ROS-free core (:mod:`gidabot_gui.core`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from PyQt5.QtCore import Qt, QTimer
from PyQt5.QtWidgets import (
    QButtonGroup,
    QFrame,
    QHBoxLayout,
    QLabel,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from gidabot_gui.core.admin import PasswordCheck
from gidabot_gui.core.flow import Mode, VisitorFlow
from gidabot_gui.core.i18n import LANGUAGE_NAMES, Translator
from gidabot_gui.core.inbox import Drained, Inbox
from gidabot_gui.core.model import Fleet, Outputs, TourInfo
from gidabot_gui.core.status_texts import here_line, mark_label, out_of_service_line, robot_card, trip_line
from gidabot_gui.core.texts import Texts
from gidabot_gui.qt.admin_mode import AdminController
from gidabot_gui.qt.floor_view import RobotMark
from gidabot_gui.qt.overlay import Button, CardSpec, Overlay
from gidabot_gui.qt.pages import FloorPage, InfoPage, OfficesPage, ToursPage
from gidabot_gui.qt.speech import NullSpeaker, Speaker
from gidabot_gui.qt.theme import ACCENT, DANGER, HEADER_TEXT, MUTED, OFFLINE, OTHER_ROBOT, Theme, icon
from gidabot_gui.qt.tour_editing import TourEditController
from gidabot_gui.qt.visitor import VisitorController
from gidabot_gui.qt.widgets import FitLabel, WrapButton, equalize_fonts
from gidabot_navigation.building.model import Building
from gidabot_navigation.guiding.messages import NavEventData, PendingData, PoseData, RobotStatusData, StaffCommandData
from gidabot_navigation.interface import LANGUAGES, RobotState
from gidabot_navigation.tours.tour_store import EditResultData

STATE_COLORS = {RobotState.IDLE: "#2E7D32", RobotState.GUIDING: OTHER_ROBOT, RobotState.TO_MEETING: OTHER_ROBOT,
                RobotState.WAITING: ACCENT, RobotState.RETURNING: OTHER_ROBOT, RobotState.ERROR: DANGER}


class NavBar(QFrame):
    """The row of page buttons ("tabs"); all its labels share one font size."""

    def __init__(self) -> None:
        super().__init__()
        self.setObjectName("nav")
        self.buttons: list[WrapButton] = []

    def paintEvent(self, ev: Any) -> None:  # noqa: N802 - Qt naming
        equalize_fonts(self.buttons)       # children are painted after their parent
        super().paintEvent(ev)


@dataclass
class GuiConfig:
    robot: str
    admin: PasswordCheck | None = None      # None: no admin mode at all
    offline_after: float = 5.0              # s (wall) without status -> offline
    request_timeout: float = 20.0           # s (wall) without an answer to a request
    visitor_id: str = "gui"
    info_popup_seconds: float = 15.0        # informative pop-ups close by themselves
    final_popup_seconds: float = 30.0       # outcome pop-ups close by themselves
    drain_ms: int = 100                     # inbox drain period


class MainWindow(QWidget):
    """GidaBot's touch screen (see the module docstring)."""

    def __init__(self, building: Building, config: GuiConfig, tr: Translator, outputs: Outputs,
                 speaker: Speaker | None = None, clock: Callable[[], float] = time.monotonic,
                 inbox: Inbox | None = None, log: Callable[[str], None] | None = None) -> None:
        super().__init__()
        self.setObjectName("root")
        self.setAttribute(Qt.WA_StyledBackground, True)
        self.building = building
        self.config = config
        self.robot = building.robot(config.robot)
        self.tr = tr
        self.outputs = outputs
        self.speaker: Speaker = speaker or NullSpeaker()
        self.clock = clock
        self.inbox = inbox or Inbox()
        self.log = log or (lambda _m: None)
        self.fleet = Fleet(building, offline_after=config.offline_after)
        self.texts = Texts(tr, building, config.robot)
        self.tours: list[TourInfo] = []
        self.theme = Theme()
        self._dirty = True
        self.setWindowTitle(f"GidaBot - {self.robot.name}")
        self._build()
        flow = VisitorFlow(building, config.robot, config.visitor_id, config.request_timeout)
        self.visitor = VisitorController(self, flow, config.info_popup_seconds, config.final_popup_seconds)
        self.admin = AdminController(self, config.admin, config.robot, building.floor(self.robot.floor))
        self.tour_editing = TourEditController(self, building, config.robot, config.visitor_id)
        self._inputs = self._input_handlers()
        self._wire()
        self.show_home()
        tr.on_change(lambda _lang: self.retranslate())
        self.retranslate()
        self.apply_theme(Theme.for_size(800, 480))
        self.drain_timer = QTimer(self)
        self.drain_timer.timeout.connect(self.drain)
        self.drain_timer.start(config.drain_ms)
        self.tick_timer = QTimer(self)
        self.tick_timer.timeout.connect(self.tick)
        self.tick_timer.start(1000)

    # ================================================================== layout
    def _build(self) -> None:
        root = QVBoxLayout(self)
        root.setContentsMargins(0, 0, 0, 0)
        root.setSpacing(0)
        # header
        self.header = QFrame()
        self.header.setObjectName("header")
        hl = QHBoxLayout(self.header)
        self.brand = QLabel("GidaBot")
        self.brand.setObjectName("brand")
        self.robot_label = FitLabel(size="base", color=HEADER_TEXT, max_lines=2)
        hl.addWidget(self.brand)
        hl.addWidget(self.robot_label, 1)
        self.mode_btn = WrapButton(role="header", key="mode")
        self.lang_btn = WrapButton(role="header", key="language", icon=icon("globe", "#FFFFFF"))
        self.lang_btn.clicked.connect(self.show_language_menu)
        self.admin_btn = WrapButton(role="header", key="admin", icon=icon("lock", "#FFFFFF"))
        self.admin_btn.setVisible(self.config.admin is not None)
        for b in (self.mode_btn, self.lang_btn, self.admin_btn):
            hl.addWidget(b)
        root.addWidget(self.header)
        # navigation (one "tab" per floor, Offices, Guided Tour, Information)
        self.nav = NavBar()
        nl = QHBoxLayout(self.nav)
        nl.setContentsMargins(4, 0, 4, 0)
        nl.setSpacing(2)
        self.nav_group = QButtonGroup(self)
        self.nav_group.setExclusive(True)
        self.nav_buttons: dict[str, WrapButton] = {}
        self.pages = QStackedWidget()
        self.pages.setObjectName("pages")
        self.page_keys: list[str] = []
        self.floor_pages: dict[float, FloorPage] = {}
        for f in self.building.floors:
            here = f.id == self.robot.floor
            page = FloorPage(self.tr, self.building, f, here)
            self.floor_pages[f.id] = page
            self._add_page(f"floor:{f.label}", page)
            if here:
                self.nav_buttons[f"floor:{f.label}"].marker = ACCENT
        self.offices = OfficesPage(self.tr, self.building)
        self._add_page("offices", self.offices)
        self.tours_page = ToursPage(self.tr, self.building)
        self._add_page("tours", self.tours_page)
        self.info_page = InfoPage(self.tr, self.building)
        self._add_page("info", self.info_page)
        for b in self.nav_buttons.values():
            nl.addWidget(b, 1)
        self.nav.buttons = list(self.nav_buttons.values())
        root.addWidget(self.nav)
        root.addWidget(self.pages, 1)
        # bottom bar: navigation info line, Continue, Cancel
        self.bottom = QFrame()
        self.bottom.setObjectName("bottom")
        bl = QHBoxLayout(self.bottom)
        info = QVBoxLayout()
        info.setSpacing(0)
        self.info_here = FitLabel(size="base", bold=True, max_lines=1)
        self.info_trip = FitLabel(size="small", color=MUTED, max_lines=2)
        info.addWidget(self.info_here)
        info.addWidget(self.info_trip)
        bl.addLayout(info, 1)
        self.continue_btn = WrapButton(role="primary", key="continue", icon=icon("play", "#FFFFFF"))
        self.cancel_btn = WrapButton(role="danger", key="cancel", icon=icon("close", "#FFFFFF"))
        bl.addWidget(self.continue_btn)
        bl.addWidget(self.cancel_btn)
        root.addWidget(self.bottom)
        self.set_location_btn = self.floor_pages[self.robot.floor].set_location_btn
        self.overlay = Overlay(self)
        self.overlay.changed.connect(self.changed)
        self.overlay.resized_for_full.connect(self._place_overlay)

    def _wire(self) -> None:
        """Connect the widgets to the parts that act on them."""
        visitor, admin, editing = self.visitor, self.admin, self.tour_editing
        self.mode_btn.clicked.connect(visitor.toggle_mode)
        self.admin_btn.clicked.connect(admin.pressed)
        for page in self.floor_pages.values():
            page.destination.connect(visitor.pick_destination)
            page.pose_set.connect(admin.pose_dragged)
            page.set_location_done.connect(admin.set_location_done)
        self.offices.destination.connect(visitor.pick_destination)
        self.offices.search_requested.connect(lambda: visitor.show_search(self.offices.query))
        self.tours_page.start.connect(visitor.start_tour)
        self.tours_page.continue_.connect(lambda: visitor.press_continue(None))
        self.tours_page.skip.connect(visitor.skip_to)
        self.tours_page.new_tour.connect(lambda: editing.open_editor(None))
        self.tours_page.edit_tour.connect(editing.open_editor)
        self.tours_page.delete_tour.connect(editing.confirm_delete)
        self.continue_btn.clicked.connect(lambda: visitor.press_continue(None))
        self.cancel_btn.clicked.connect(visitor.press_cancel)
        self.set_location_btn.clicked.connect(admin.start_set_location)

    def _add_page(self, key: str, page: QWidget, nav_icon: Any = None) -> None:
        b = WrapButton(role="nav", key=key, icon=nav_icon)
        b.setCheckable(True)
        b.clicked.connect(lambda _=False, k=key: self.show_page(k))
        self.nav_group.addButton(b)
        self.nav_buttons[key] = b
        self.page_keys.append(key)
        self.pages.addWidget(page)

    def show_page(self, key: str) -> None:
        self.nav_buttons[key].setChecked(True)
        self.pages.setCurrentIndex(self.page_keys.index(key))
        self.changed()

    def show_home(self) -> None:
        """The page of this robot's floor."""
        self.show_page(f"floor:{self.building.floor(self.robot.floor).label}")

    def show_tours(self) -> None:
        self.show_page("tours")

    @property
    def current_page(self) -> str:
        return self.page_keys[self.pages.currentIndex()]

    def select_tour_stop(self, file_name: str, step: int) -> None:
        """Select this tour and its stop ``step`` (0-based) on the Guided Tour page."""
        self.tours_page.select(file_name)
        self.tours_page.select_stop(step)

    def set_search_query(self, text: str) -> None:
        self.offices.set_query(text)

    def set_location_mode(self, on: bool) -> None:
        """Admin's Set location on this robot's floor page (shown first), or back to the normal page."""
        if on:
            self.show_home()
        self.floor_pages[self.robot.floor].set_setting_location(on)

    @property
    def admin_unlocked(self) -> bool:
        return self.admin.unlocked

    # ================================================================== pop-ups (the overlay)
    @property
    def popup(self) -> str:
        """The name of the pop-up on screen ("" when none)."""
        return self.overlay.name if self.overlay.showing else ""

    def show_popup(self, name: str, build: Callable[[], CardSpec], pressed: Callable[[str], None],
                   auto_close: float = 0.0) -> None:
        self.overlay.show_card(name, build, pressed, auto_close=auto_close)

    def push_popup(self, name: str, build: Callable[[], CardSpec], pressed: Callable[[str], None]) -> None:
        self.overlay.push_card(name, build, pressed)

    def pop_popup(self) -> None:
        self.overlay.pop_card()

    def close_popup(self) -> None:
        self.overlay.close_card()

    def rebuild_popup(self) -> None:
        self.overlay.retranslate()

    def show_message(self, name: str, title: Callable[[], str], body: Callable[[], str], tone: str) -> None:
        """A pop-up with an OK button that closes by itself after ``final_popup_seconds``."""
        def build() -> CardSpec:
            return CardSpec(title(), body(), tone, "check" if tone == "success" else "warning",
                            [Button("ok", self.tr._("OK"), "primary", "check")])

        self.show_popup(name, build, lambda _k: self.close_popup(), auto_close=self.config.final_popup_seconds)

    # ================================================================== look
    def apply_theme(self, theme: Theme) -> None:
        self.theme = theme
        self.setStyleSheet(theme.style_sheet())
        t = theme
        self.header.layout().setContentsMargins(t.px(12), t.px(6), t.px(8), t.px(6))
        self.header.layout().setSpacing(t.px(8))
        self.bottom.layout().setContentsMargins(t.px(12), t.px(4), t.px(8), t.px(4))
        self.bottom.setFixedHeight(t.touch + t.px(8) + 2)
        for b in self.findChildren(WrapButton):
            if b.role not in ("key",):
                b.set_min_height(t.touch)
        for b in (self.mode_btn, self.lang_btn, self.admin_btn):
            b.set_min_height(t.px(50))
        for f in self.findChildren(FitLabel):
            f.set_theme(t)
        for i in range(self.pages.count()):
            page = self.pages.widget(i)
            page.set_theme(t)
            page.layout().setContentsMargins(t.px(10), t.px(10), t.px(10), t.px(8))
            page.layout().setSpacing(t.px(10))
        self.info_page.set_columns(2 if self.width() < t.px(1500) else 3)
        self.overlay.set_theme(t)
        self._place_overlay()

    def resizeEvent(self, ev: Any) -> None:  # noqa: N802 - Qt naming
        super().resizeEvent(ev)
        theme = Theme.for_size(self.width(), self.height())
        if theme != self.theme:
            self.apply_theme(theme)
        self._place_overlay()

    def _place_overlay(self) -> None:
        """Pop-ups leave the header (language) and the bottom bar (Cancel) reachable; editors take more."""
        top = 0 if (self.overlay.wide or self.overlay.full) else self.header.height()
        bottom = self.height() if self.overlay.full else self.bottom.y()
        self.overlay.setGeometry(0, top, self.width(), max(0, bottom - top))

    def showEvent(self, ev: Any) -> None:  # noqa: N802 - Qt naming
        super().showEvent(ev)
        self._place_overlay()

    # ================================================================== language
    def retranslate(self) -> None:
        t, lang = self.tr, self.tr.language
        for f in self.building.floors:
            self.nav_buttons[f"floor:{f.label}"].setText(f.names[lang])
        self.nav_buttons["offices"].setText(t._("Offices"))
        self.nav_buttons["tours"].setText(t._("Guided Tour"))
        self.nav_buttons["info"].setText(t._("Information"))
        # wider tabs for longer words, so that one font size fits them all
        for i, b in enumerate(self.nav.buttons):
            longest = max((len(w) for w in b.text().split()), default=4)
            self.nav.layout().setStretch(i, longest + 4)
        self.robot_label.setText(t._("I am {robot} · {floor}").format(
            robot=self.robot.name, floor=self.texts.floor(self.robot.floor)))
        self.lang_btn.setText(LANGUAGE_NAMES[lang])
        self.continue_btn.setText(t._("Continue"))
        self.cancel_btn.setText(t._("Cancel"))
        for i in range(self.pages.count()):
            self.pages.widget(i).retranslate()
        self.overlay.retranslate()
        self.update_header()
        self.nav.update()
        self.changed()

    def set_language(self, language: str) -> None:
        if self.tr.set_language(language):
            self.visitor.say_again(language)

    def show_language_menu(self) -> None:
        def build() -> CardSpec:
            t = self.tr
            return CardSpec(t._("Language"), icon="globe",
                            buttons=[Button(f"lang:{code}", LANGUAGE_NAMES[code],
                                            "primary" if code == self.tr.language else "")
                                     for code in LANGUAGES] + [Button("back", t._("Back"))])

        def pressed(key: str) -> None:
            self.overlay.pop_card()          # back to what was on screen, then translate it
            if key.startswith("lang:"):
                self.set_language(key[5:])

        self.overlay.push_card("language", build, pressed)

    # ================================================================== inputs
    def _input_handlers(self) -> dict[str, tuple[type, Callable[[Any, float], object]]]:
        """Each kind of input record: its type and what takes it (record, wall time now)."""
        return {
            "status": (RobotStatusData, self.fleet.update_status),
            "pose": (PoseData, self.fleet.update_pose),
            "pending": (PendingData, self._pending),
            "catalog": (list, lambda tours, _now: self.set_tours(tours)),
            "nav_event": (NavEventData, self.visitor.on_event),
            "edit_result": (EditResultData, lambda res, _now: self.tour_editing.on_result(res)),
            "staff": (StaffCommandData, self.fleet.update_staff),
        }

    def feed(self, kind: str, record: Any) -> None:
        """Handle one record at once (tests; the inbox path calls the same)."""
        self._take(kind, record, self.clock())
        self.refresh()

    def drain(self) -> None:
        batch: Drained = self.inbox.drain()
        if not batch:
            return
        now = self.clock()
        for kind, record in (*batch.states, *batch.events):
            self._take(kind, record, now)
        if batch.dropped:
            self.log(f"gui: {batch.dropped} events dropped (inbox full)")
        self.refresh()

    def _take(self, kind: str, record: Any, now: float) -> None:
        handler = self._inputs.get(kind)
        if handler is None:
            self.log(f"gui: input of unknown kind {kind!r} ignored")
            return
        cls, take = handler
        assert isinstance(record, cls), (kind, record)
        take(record, now)
        self.mark_dirty()

    def _pending(self, record: PendingData, now: float) -> None:
        self.fleet.update_pending(record, now)
        if self.overlay.name in ("confirm", "confirm_tour"):
            self.overlay.retranslate()     # waits changed while the visitor reads them

    def tick(self) -> None:
        now = self.clock()
        self.visitor.tick(now)
        self.tour_editing.tick(now)
        self.changed()

    def set_tours(self, tours: list[TourInfo]) -> None:
        self.tours = list(tours)
        self.texts.tours = {x.file_name: x for x in self.tours}
        self.tours_page.set_tours(self.tours)

    def tour(self, file_name: str) -> TourInfo | None:
        """The tour of the catalog with this file name."""
        return next((x for x in self.tours if x.file_name == file_name), None)

    # ================================================================== display
    def mark_dirty(self) -> None:
        """What is shown must be brought up to date at the next :meth:`refresh`."""
        self._dirty = True

    def changed(self) -> None:
        """Something shown changed: bring the screen up to date now."""
        self._dirty = True
        self.refresh()

    def refresh(self) -> None:
        """Bring what is shown up to date (cheap when nothing changed)."""
        if not self._dirty:
            return
        self._dirty = False
        now = self.clock()
        self._update_robots(now)
        self._update_bottom()
        self._update_tours_page()
        if self.current_page == "info":
            self._update_info(now)

    def _marks_for(self, floor: float, now: float) -> list[RobotMark]:
        marks = []
        for name, live in self.fleet.robots.items():
            if live.robot.floor != floor or live.pose is None:
                continue
            here = name == self.robot.name
            offline = self.fleet.is_offline(name, now)
            label = mark_label(self.texts, name, here, offline)
            marks.append(RobotMark(name, *live.pose, live.robot.radius, here, offline, label))
        return marks

    def _update_robots(self, now: float) -> None:
        cur = self.visitor.flow.current
        goal = self.building.find_location(cur.goal_id) if cur is not None and cur.goal_id else None
        for fid, page in self.floor_pages.items():
            page.view.set_robots(self._marks_for(fid, now))
            page.view.set_goal((goal.pose.x, goal.pose.y) if goal is not None and goal.floor == fid else None)

    def _update_bottom(self) -> None:
        flow = self.visitor.flow
        self.info_here.setText(here_line(self.texts, self.fleet))
        banner = out_of_service_line(self.texts, self.fleet) if flow.current is None else ""
        self.info_trip.setText(trip_line(self.texts, flow, banner or self.visitor.banner))
        self.cancel_btn.setVisible(flow.can_cancel)
        popup_continue = self.overlay.showing and "continue" in self.overlay.buttons
        self.continue_btn.setVisible(flow.can_continue and not popup_continue)
        self.update_header()

    def update_header(self) -> None:
        """The mode and admin buttons (and what admin mode shows on the pages)."""
        t = self.tr
        mode = self.visitor.flow.mode
        tour = mode is Mode.TOUR
        self.mode_btn.setText(t._("Guided tour") if tour else t._("One destination"))
        self.mode_btn.setIcon(icon("route" if tour else "pin", "#FFFFFF"))
        self.mode_btn.setProperty("mode", mode.value)
        unlocked = self.admin.unlocked
        self.admin_btn.setText(t._("Lock") if unlocked else t._("Admin"))
        self.admin_btn.setIcon(icon("unlock" if unlocked else "lock", "#FFFFFF"))
        self.set_location_btn.setVisible(unlocked)
        self.tours_page.set_admin(unlocked)
        for page in self.floor_pages.values():
            page.set_admin(unlocked)

    def _update_tours_page(self) -> None:
        flow = self.visitor.flow
        tour = flow.tour
        progress = (tour.file_name, set(tour.done), tour.running) if tour is not None else None
        self.tours_page.set_progress(progress, flow.can_continue, flow.can_skip_to, not flow.can_start_tour())

    def _update_info(self, now: float) -> None:
        for name in self.fleet.robots:
            card = robot_card(self.texts, self.fleet, name, now)
            self.info_page.set_card(name, title=card.title, floor=card.floor, state=card.state,
                                    state_color=STATE_COLORS.get(card.state_code, OFFLINE), motion=card.motion,
                                    battery=card.battery, battery_text=card.battery_text, pending=card.pending,
                                    here=card.here, offline=card.offline)
