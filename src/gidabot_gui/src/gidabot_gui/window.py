"""The main window of the touch screen, and the controller between it and the core.

Everything here runs in the Qt thread. Input arrives through an
:class:`~gidabot_gui.inbox.Inbox` drained by a timer (the ROS adapter fills it
from its callback threads) or directly through :meth:`MainWindow.feed` in
tests. Output goes through an :class:`Outputs` object (the ROS adapter's
publishers, or a recorder in tests). Decisions are made by the ROS-free core:
:class:`~gidabot_gui.flow.VisitorFlow`, :class:`~gidabot_gui.model.Fleet`,
:class:`~gidabot_gui.texts.Texts`, :mod:`~gidabot_gui.admin`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

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

from gidabot_gui.admin import PasswordCheck, TourDraft, delete_edit, pose_from_drag
from gidabot_gui.editor import PasswordPanel, SearchPanel, TourEditor
from gidabot_gui.errors import GuiError, TourEditError
from gidabot_gui.floor_view import RobotMark
from gidabot_gui.flow import Activity, Mode, Notice, VisitorFlow
from gidabot_gui.i18n import LANGUAGE_NAMES, LANGUAGES, Translator
from gidabot_gui.inbox import Drained, Inbox
from gidabot_gui.model import (
    WAY_LIFT,
    WAY_STAIRS,
    Command,
    EditResultData,
    Fleet,
    InitialPose,
    NavEventData,
    PendingData,
    PoseData,
    RobotStatusData,
    TourEdit,
    TourInfo,
    finite,
)
from gidabot_gui.overlay import Button, CardSpec, Overlay
from gidabot_gui.pages import FloorPage, InfoPage, OfficesPage, ToursPage
from gidabot_gui.places import nearest_place
from gidabot_gui.plans import plan_request, tour_waits, tour_ways
from gidabot_gui.speech import NullSpeaker, Speaker
from gidabot_gui.texts import Texts
from gidabot_gui.theme import ACCENT, DANGER, HEADER_TEXT, MUTED, OFFLINE, OTHER_ROBOT, Theme, icon
from gidabot_gui.widgets import FitLabel, WrapButton, equalize_fonts
from gidabot_navigation.building.model import Building

EVENT_ICONS = {
    "ON_THE_WAY": "walk", "GO_TO_FLOOR": "stairs", "WAITING_VISITOR": "robot", "GOAL_REACHED": "flag",
    "TOUR_STEP_DONE": "flag", "TOUR_FINISHED": "check", "UNREACHABLE": "warning", "NO_ROBOT_ON_FLOOR": "warning",
    "CANCELLED_HERE": "close", "CANCELLED_ELSEWHERE": "close", "TIMEOUT": "warning", "PARTNER_OFFLINE": "warning",
    "REJECTED": "warning", "NO_ANSWER": "warning", "BUSY": "info", "PARTNER_LOST": "warning",
    "PARTNER_BACK": "check",
}
STATE_COLORS = {"idle": "#2E7D32", "guiding": OTHER_ROBOT, "to_meeting": OTHER_ROBOT, "waiting": ACCENT,
                "returning": OTHER_ROBOT, "error": DANGER}
EDIT_RESULT_TIMEOUT = 8.0   # s (wall) to wait for tour_store/edit_result


class Outputs(Protocol):
    """Where the GUI's messages go (the ROS adapter's publishers; a recorder in tests)."""

    def send_command(self, cmd: Command) -> None: ...

    def send_initial_pose(self, pose: InitialPose) -> None: ...

    def send_tour_edit(self, edit: TourEdit) -> None: ...


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


def fmt(value: float, digits: int, language: str) -> str:
    """A number as written in ``language`` (decimal comma in Basque and Spanish)."""
    text = f"{value:.{digits}f}"
    return text.replace(".", ",") if language in ("eu", "es") else text


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
        self.flow = VisitorFlow(building, config.robot, config.visitor_id, config.request_timeout)
        self.texts = Texts(tr, building, config.robot)
        self.tours: list[TourInfo] = []
        self.theme = Theme()
        self.admin_unlocked = False
        self.pending_pose: InitialPose | None = None
        self.pending_edit: tuple[str, float, TourEdit] | None = None    # uid, sent at, edit
        self.banner = ""                  # non-modal notice (GOING_TO_MEETING)
        self.current_notice: Notice | None = None
        self._edit_seq = 0
        self._dirty = True
        self.setWindowTitle(f"GidaBot - {self.robot.name}")
        self._build()
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
        self.mode_btn.clicked.connect(self.toggle_mode)
        self.lang_btn = WrapButton(role="header", key="language", icon=icon("globe", "#FFFFFF"))
        self.lang_btn.clicked.connect(self.show_language_menu)
        self.admin_btn = WrapButton(role="header", key="admin", icon=icon("lock", "#FFFFFF"))
        self.admin_btn.clicked.connect(self.admin_pressed)
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
            page.destination.connect(self.pick_destination)
            page.pose_set.connect(self._pose_dragged)
            page.set_location_done.connect(self._set_location_done)
            self.floor_pages[f.id] = page
            self._add_page(f"floor:{f.label}", page)
            if here:
                self.nav_buttons[f"floor:{f.label}"].marker = ACCENT
        self.offices = OfficesPage(self.tr, self.building)
        self.offices.destination.connect(self.pick_destination)
        self.offices.search_requested.connect(self.show_search)
        self._add_page("offices", self.offices)
        self.tours_page = ToursPage(self.tr, self.building)
        self.tours_page.start.connect(self.start_tour)
        self.tours_page.continue_.connect(lambda: self.press_continue(None))
        self.tours_page.skip.connect(self.skip_to)
        self.tours_page.new_tour.connect(lambda: self.open_editor(None))
        self.tours_page.edit_tour.connect(self.open_editor)
        self.tours_page.delete_tour.connect(self.confirm_delete)
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
        self.continue_btn.clicked.connect(lambda: self.press_continue(None))
        self.cancel_btn = WrapButton(role="danger", key="cancel", icon=icon("close", "#FFFFFF"))
        self.cancel_btn.clicked.connect(self.press_cancel)
        bl.addWidget(self.continue_btn)
        bl.addWidget(self.cancel_btn)
        root.addWidget(self.bottom)
        self.set_location_btn = self.floor_pages[self.robot.floor].set_location_btn
        self.set_location_btn.clicked.connect(self.start_set_location)
        self.overlay = Overlay(self)
        self.overlay.changed.connect(self._overlay_changed)
        self.overlay.resized_for_full.connect(self._place_overlay)
        self.show_page(f"floor:{self.building.floor(self.robot.floor).label}")

    def _overlay_changed(self) -> None:
        self._dirty = True
        self.refresh()

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
        self._dirty = True
        self.refresh()

    @property
    def current_page(self) -> str:
        return self.page_keys[self.pages.currentIndex()]

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
        self._update_header()
        self.nav.update()
        self._dirty = True
        self.refresh()

    def set_language(self, language: str) -> None:
        if self.tr.set_language(language) and self.current_notice is not None and self.overlay.showing \
                and self.overlay.name.startswith("event:"):
            # say the pop-up on screen again, in the language just chosen
            self.speaker.say(self.texts.notice(self.current_notice).speech, language)

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
    def feed(self, kind: str, record: Any) -> None:
        """Handle one record at once (tests; the inbox path calls the same)."""
        now = self.clock()
        if kind in ("status", "pose", "pending", "catalog"):
            self._state(kind, record, now)
        else:
            self._event(kind, record, now)
        self.refresh()

    def drain(self) -> None:
        batch: Drained = self.inbox.drain()
        if not batch:
            return
        now = self.clock()
        for kind, record in batch.states:
            self._state(kind, record, now)
        for kind, record in batch.events:
            self._event(kind, record, now)
        if batch.dropped:
            self.log(f"gui: {batch.dropped} events dropped (inbox full)")
        self.refresh()

    def _state(self, kind: str, record: Any, now: float) -> None:
        if kind == "status":
            assert isinstance(record, RobotStatusData)
            self.fleet.update_status(record, now)
        elif kind == "pose":
            assert isinstance(record, PoseData)
            self.fleet.update_pose(record, now)
        elif kind == "pending":
            assert isinstance(record, PendingData)
            self.fleet.update_pending(record, now)
            if self.overlay.name in ("confirm", "confirm_tour"):
                self.overlay.retranslate()     # waits changed while the visitor reads them
        elif kind == "catalog":
            self.set_tours(record)
        self._dirty = True

    def _event(self, kind: str, record: Any, now: float) -> None:
        if kind == "nav_event":
            assert isinstance(record, NavEventData)
            notice = self.flow.on_event(record, now)
            if notice is not None:
                self.show_notice(notice)
        elif kind == "edit_result":
            assert isinstance(record, EditResultData)
            self._edit_result(record)
        self._dirty = True

    def tick(self) -> None:
        now = self.clock()
        notice = self.flow.tick(now)
        if notice is not None:
            self.show_notice(notice)
        if self.pending_edit is not None and now - self.pending_edit[1] > EDIT_RESULT_TIMEOUT:
            self.pending_edit = None
            self._show_message("edit_result", lambda: self.tr._("No answer"),
                               lambda: self.tr._("The tour store did not answer. Is it running?"), "error")
        self._dirty = True
        self.refresh()

    # ================================================================== display
    def refresh(self) -> None:
        """Bring what is shown up to date (cheap when nothing changed)."""
        if not self._dirty:
            return
        self._dirty = False
        now = self.clock()
        self._update_robots(now)
        self._update_bottom(now)
        self._update_tours_page()
        if self.current_page == "info":
            self._update_info(now)

    def _marks_for(self, floor: float, now: float) -> list[RobotMark]:
        t = self.tr
        marks = []
        for name, live in self.fleet.robots.items():
            if live.robot.floor != floor or live.pose is None:
                continue
            here = name == self.robot.name
            offline = self.fleet.is_offline(name, now)
            label = name
            if offline:
                label = t._("{robot} · offline").format(robot=name)
            elif here:
                label = t._("{robot} · You are here").format(robot=name)
            marks.append(RobotMark(name, *live.pose, live.robot.radius, here, offline, label))
        return marks

    def _update_robots(self, now: float) -> None:
        cur = self.flow.current
        goal = self.building.find_location(cur.goal_id) if cur is not None and cur.goal_id else None
        for fid, page in self.floor_pages.items():
            page.view.set_robots(self._marks_for(fid, now))
            page.view.set_goal((goal.pose.x, goal.pose.y) if goal is not None and goal.floor == fid else None)

    def _here_text(self) -> str:
        t = self.tr
        live = self.fleet.robots[self.robot.name]
        floor = self.texts.floor(self.robot.floor)
        if live.pose is None:
            return t._("Here: {floor}").format(floor=floor)
        place = nearest_place(self.building, self.robot.floor, live.pose[0], live.pose[1])
        if place is None:
            return t._("Here: {floor}").format(floor=floor)
        name = self.texts.place(place.id)
        text = t._("Here: {place}") if place.at else t._("Here: near {place}")
        return text.format(place=name) + f" · {floor}"

    def _trip_text(self) -> str:
        t = self.tr
        cur = self.flow.current
        if cur is None:
            if self.flow.coming is not None or self.banner:
                return self.banner or t._("I am going to meet a visitor.")
            if self.flow.mode is Mode.TOUR:
                return t._("Choose a tour and start it.")
            return t._("Choose a destination: tap a place, or search in Offices.")
        start = self.texts.place(cur.start_id) if cur.start_id else t._("here")
        route = (t._("From: {start} → To: {goal}").format(start=start, goal=self.texts.place(cur.goal_id))
                 if cur.goal_id else t._("From: {start}").format(start=start))
        status = {
            Activity.PENDING: t._("Request sent, waiting for an answer…"),
            Activity.QUEUED: t._("In the queue: the robot will come for you."),
            Activity.GUIDING: t._("On the way: walk behind the robot."),
            Activity.WAITING: t._("Press Continue when you are here."),
            Activity.STEP_DONE: t._("Stop reached: press Continue or choose the next stop."),
        }.get(cur.activity, "")
        return f"{route} · {status}" if status else route

    def _update_bottom(self, _now: float) -> None:
        self.info_here.setText(self._here_text())
        self.info_trip.setText(self._trip_text())
        self.cancel_btn.setVisible(self.flow.can_cancel)
        popup_continue = self.overlay.showing and "continue" in self.overlay.buttons
        self.continue_btn.setVisible(self.flow.can_continue and not popup_continue)
        self._update_header()

    def _update_header(self) -> None:
        t = self.tr
        tour = self.flow.mode is Mode.TOUR
        self.mode_btn.setText(t._("Guided tour") if tour else t._("One destination"))
        self.mode_btn.setIcon(icon("route" if tour else "pin", "#FFFFFF"))
        self.mode_btn.setProperty("mode", self.flow.mode.value)
        self.admin_btn.setText(t._("Lock") if self.admin_unlocked else t._("Admin"))
        self.admin_btn.setIcon(icon("unlock" if self.admin_unlocked else "lock", "#FFFFFF"))
        self.set_location_btn.setVisible(self.admin_unlocked)
        self.tours_page.set_admin(self.admin_unlocked)

    def _update_tours_page(self) -> None:
        tour = self.flow.tour
        progress = (tour.file_name, set(tour.done), tour.running) if tour is not None else None
        self.tours_page.set_progress(progress, self.flow.can_continue, self.flow.can_skip_to,
                                     not self.flow.can_start_tour())

    def _update_info(self, now: float) -> None:
        t, lang = self.tr, self.tr.language
        for name, live in self.fleet.robots.items():
            here = name == self.robot.name
            offline = self.fleet.is_offline(name, now)
            s = live.status
            title = name + (" · " + t._("this robot") if here else "")
            floor = self.texts.floor(live.robot.floor)
            battery = s.battery if s is not None and finite(s.battery) and 0 <= s.battery <= 1 else None
            pending = ""
            color = OFFLINE
            if not self.fleet.ever_seen(name):
                state, motion = t._("No contact yet"), t._("Position unknown")
            elif offline:
                ago = self.fleet.seen_ago(name, now) or 0.0
                state = t._("Offline · last seen {s} s ago").format(s=int(ago))
                motion = t._("Position unknown")
                if live.pose is not None:
                    place = nearest_place(self.building, live.robot.floor, live.pose[0], live.pose[1])
                    where = self.texts.place(place.id) if place is not None else "-"
                    motion = t._("Last known position: {place} (x {x} m, y {y} m)").format(
                        place=where, x=fmt(live.pose[0], 1, lang), y=fmt(live.pose[1], 1, lang))
            else:
                code = s.state if s is not None else ""
                state = self.texts.state(code)
                color = STATE_COLORS.get(code, OFFLINE)
                lin = s.linear if s is not None and finite(s.linear) else 0.0
                ang = s.angular if s is not None and finite(s.angular) else 0.0
                motion = t._("Speed {v} m/s · turning {w} rad/s").format(v=fmt(lin, 2, lang), w=fmt(ang, 2, lang))
                wait = self.fleet.wait_of(name, now)
                if wait is not None:
                    n, w = wait
                    pending = (t.n_("{n} pending request", "{n} pending requests", n).format(n=n) + " · "
                               + self.texts.minutes(w)) if n else t._("No pending requests")
            battery_text = (t._("Battery {percent} %").format(percent=int(round(battery * 100)))
                            if battery is not None else t._("Battery unknown"))
            self.info_page.set_card(name, title=title, floor=floor, state=state, state_color=color, motion=motion,
                                    battery=battery, battery_text=battery_text, pending=pending, here=here,
                                    offline=offline)

    # ================================================================== visitor flow
    def _start_id(self) -> str:
        live = self.fleet.robots[self.robot.name]
        if live.pose is None:
            return ""
        place = nearest_place(self.building, self.robot.floor, live.pose[0], live.pose[1])
        return place.id if place is not None else ""

    def _send(self, cmd: Command | None) -> None:
        if cmd is not None:
            self.outputs.send_command(cmd)
            self._dirty = True
            self.refresh()

    def pick_destination(self, goal_id: str) -> None:
        """The visitor tapped a destination: confirmation with the waits, then the way, then REQUEST."""
        if self.building.find_location(goal_id) is None:
            return
        if self.flow.busy:
            self.show_notice(Notice("BUSY"))
            return
        self.flow.set_mode(Mode.SINGLE)
        self._update_header()

        def build() -> CardSpec:
            plan = plan_request(self.fleet, self.robot.name, goal_id, self.clock())
            text = self.texts.confirm(plan)
            t = self.tr
            return CardSpec(text.title, text.body, "action", "pin",
                            [Button("go", t._("Guide me"), "primary", "play"), Button("back", t._("Back"))])

        def pressed(key: str) -> None:
            if key != "go":
                self.overlay.close_card()
                return
            plan = plan_request(self.fleet, self.robot.name, goal_id, self.clock())
            if plan.changes_floor and len(plan.ways) > 1:
                self._ask_way(lambda way: self._request(goal_id, way), plan.ways)
            else:
                self._request(goal_id, plan.ways[0] if plan.ways else "")

        self.overlay.show_card("confirm", build, pressed)

    def _ask_way(self, then: Callable[[str], None], ways: tuple[str, ...]) -> None:
        def build() -> CardSpec:
            t = self.tr
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
                self.overlay.close_card()

        self.overlay.show_card("way", build, pressed)

    def _request(self, goal_id: str, way: str) -> None:
        self.overlay.close_card()
        try:
            cmd = self.flow.request(goal_id, way, self.tr.language, self.clock(), self._start_id())
        except GuiError as err:
            self.log(f"gui: request refused: {err}")
            self.show_notice(Notice("BUSY"))
            return
        self._send(cmd)

    def start_tour(self, file_name: str) -> None:
        tour = next((x for x in self.tours if x.file_name == file_name), None)
        if tour is None:
            return
        if not self.flow.can_start_tour():
            self.show_notice(Notice("BUSY"))
            return
        self.flow.set_mode(Mode.TOUR)
        self._update_header()

        def build() -> CardSpec:
            text = self.texts.confirm_tour(tour, tour_waits(self.fleet, self.robot.name, tour, self.clock()))
            t = self.tr
            return CardSpec(text.title, text.body, "action", "route",
                            [Button("go", t._("Start the tour"), "primary", "play"), Button("back", t._("Back"))])

        def go(way: str) -> None:
            self.overlay.close_card()
            try:
                cmd = self.flow.start_tour(tour, way, self.tr.language, self.clock(), self._start_id())
            except GuiError as err:
                self.log(f"gui: tour refused: {err}")
                self.show_notice(Notice("BUSY"))
                return
            self._send(cmd)

        def pressed(key: str) -> None:
            if key != "go":
                self.overlay.close_card()
                return
            ways = tour_ways(self.building, self.robot.floor, tour)
            if len(ways) > 1:
                self._ask_way(go, ways)
            else:
                go(ways[0] if ways else "")

        self.overlay.show_card("confirm_tour", build, pressed)

    def press_continue(self, goal_uid: str | None) -> None:
        self.overlay.close_card()
        self.speaker.stop()
        self._send(self.flow.continue_(self.tr.language, self.clock(), goal_uid))

    def skip_to(self, file_name: str, step: int) -> None:
        tour = next((x for x in self.tours if x.file_name == file_name), None)
        if tour is None:
            return
        self._send(self.flow.skip(step, tour.goals, self.tr.language, self.clock()))

    def press_cancel(self) -> None:
        self.overlay.close_card()
        self.speaker.stop()
        self._send(self.flow.cancel(self.tr.language, self.clock()))

    def toggle_mode(self) -> None:
        if self.flow.mode is Mode.SINGLE:
            self.flow.set_mode(Mode.TOUR)
            self.show_page("tours")
        else:
            self.flow.set_mode(Mode.SINGLE)
            self.show_page(f"floor:{self.building.floor(self.robot.floor).label}")
        self._update_header()
        self._dirty = True
        self.refresh()

    def set_tours(self, tours: list[TourInfo]) -> None:
        self.tours = list(tours)
        self.texts.tours = {x.file_name: x for x in self.tours}
        self.tours_page.set_tours(self.tours)

    # ================================================================== notices
    def show_notice(self, notice: Notice) -> None:
        if notice.adopt_language in LANGUAGES and notice.adopt_language != self.tr.language:
            self.tr.set_language(notice.adopt_language)
        if not notice.modal:
            self.banner = self.texts.notice(notice).title if notice.kind == "GOING_TO_MEETING" else ""
            self._dirty = True
            return
        self.banner = ""
        self.current_notice = notice
        if notice.kind == "TOUR_STEP_DONE" and notice.tour_file:
            self.tours_page.select(notice.tour_file)
            self.tours_page.select_stop(notice.tour_step + 1)
        goal_uid = notice.event.goal_uid if notice.event is not None else ""

        def build() -> CardSpec:
            text = self.texts.notice(notice)
            t = self.tr
            shown = [a for a in notice.actions if not (a == "cancel" and notice.kind == "ON_THE_WAY")]
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
                self.overlay.close_card()
                self.show_page("tours")
            else:
                self.overlay.close_card()

        final = notice.final or notice.kind in ("BUSY",)
        auto = 0.0 if "continue" in notice.actions else (
            self.config.final_popup_seconds if final else self.config.info_popup_seconds)
        self.overlay.show_card(f"event:{notice.kind}", build, pressed, auto_close=auto)
        speech = self.texts.notice(notice).speech
        if speech:
            self.speaker.say(speech, self.tr.language)
        self._dirty = True

    def _show_message(self, name: str, title: Callable[[], str], body: Callable[[], str], tone: str) -> None:
        def build() -> CardSpec:
            return CardSpec(title(), body(), tone, "check" if tone == "success" else "warning",
                            [Button("ok", self.tr._("OK"), "primary", "check")])

        self.overlay.show_card(name, build, lambda _k: self.overlay.close_card(),
                               auto_close=self.config.final_popup_seconds)

    # ================================================================== admin
    def admin_pressed(self) -> None:
        if self.config.admin is None:
            return
        if self.admin_unlocked:
            self.lock_admin()
            return
        panel = PasswordPanel(self.tr, self.theme)
        state = {"wrong": False}

        def build() -> CardSpec:
            t = self.tr
            panel.retranslate()
            if state["wrong"]:
                locked = self.config.admin.locked_for(self.clock()) if self.config.admin else 0
                title = (t._("Too many attempts: wait {s} s").format(s=int(math.ceil(locked))) if locked > 0
                         else t._("Wrong password"))
                return CardSpec(title, "", "error", "lock", [], extra=panel, wide=True)
            return CardSpec(t._("Administrator password"), "", "action", "lock", [], extra=panel, wide=True)

        def submitted(password: str) -> None:
            assert self.config.admin is not None
            if self.config.admin.check(password, self.clock()):
                self.overlay.pop_card()
                self.unlock_admin()
            else:
                self.log("gui: wrong administrator password")
                state["wrong"] = True
                panel.field.clear()
                self.overlay.retranslate()

        panel.submitted.connect(submitted)
        panel.back.connect(self.overlay.pop_card)
        self.overlay.push_card("password", build, lambda _k: self.overlay.pop_card())
        self.password_panel = panel

    def unlock_admin(self) -> None:
        if self.config.admin is None:
            return
        self.admin_unlocked = True
        self._update_header()

    def lock_admin(self) -> None:
        self.admin_unlocked = False
        self._stop_set_location()
        self._update_header()

    def start_set_location(self) -> None:
        if not self.admin_unlocked:
            return
        self.show_page(f"floor:{self.building.floor(self.robot.floor).label}")
        self.pending_pose = None
        self.floor_pages[self.robot.floor].start_set_location()

    def _pose_dragged(self, u0: float, v0: float, u1: float, v1: float) -> None:
        if not self.admin_unlocked:
            return
        floor = self.building.floor(self.robot.floor)
        live = self.fleet.robots[self.robot.name]
        default_yaw = live.pose[2] if live.pose is not None else 0.0
        self.pending_pose = pose_from_drag(floor.transform, floor.id, (u0, v0), (u1, v1),
                                           default_yaw=default_yaw)

    def _set_location_done(self, apply: bool) -> None:
        pose = self.pending_pose
        self._stop_set_location()
        if apply and pose is not None and self.admin_unlocked:
            self.outputs.send_initial_pose(pose)
            lang = self.tr.language
            self._show_message("location_sent", lambda: self.tr._("Location sent"),
                               lambda: self.tr._("x = {x} m, y = {y} m, heading {deg}°").format(
                                   x=fmt(pose.x, 2, lang), y=fmt(pose.y, 2, lang),
                                   deg=int(round(math.degrees(pose.yaw)))), "success")

    def _stop_set_location(self) -> None:
        self.pending_pose = None
        self.floor_pages[self.robot.floor].stop_set_location()

    def _next_edit_uid(self) -> str:
        self._edit_seq += 1
        return f"{self.robot.name}/{self.config.visitor_id}/tour-edit/{self._edit_seq}"

    def open_editor(self, file_name: str | None) -> None:
        if not self.admin_unlocked:
            return
        tour = next((x for x in self.tours if x.file_name == file_name), None) if file_name else None
        if tour is not None:
            draft = TourDraft(tour.file_name, tour.name, tour.language or self.tr.language, list(tour.goals),
                              existing=True)
        else:
            draft = TourDraft("", "", self.tr.language, [])
        editor = TourEditor(self.tr, self.building, self.theme, draft)
        self.editor = editor

        def build() -> CardSpec:
            editor.retranslate()
            t = self.tr
            return CardSpec(t._("Edit tour") if draft.existing else t._("New tour"), "", "action", "pencil", [],
                            extra=editor, wide=True, full=True)

        def save() -> None:
            d = editor.collect()
            try:
                edit = d.to_edit(self.building, self._next_edit_uid())
            except TourEditError as err:
                editor.show_error(self.tr._("Not saved: {error}").format(error=str(err)))
                return
            self.outputs.send_tour_edit(edit)
            self.pending_edit = (edit.uid, self.clock(), edit)
            self.overlay.close_card()
            self._show_message("edit_pending", lambda: self.tr._("Saving…"),
                               lambda: d.name or d.file_name, "info")

        editor.save.connect(save)
        editor.closed.connect(self.overlay.close_card)
        self.overlay.show_card("editor", build, lambda _k: self.overlay.close_card())

    def confirm_delete(self, file_name: str) -> None:
        if not self.admin_unlocked:
            return
        tour = next((x for x in self.tours if x.file_name == file_name), None)
        if tour is None:
            return

        def build() -> CardSpec:
            t = self.tr
            return CardSpec(t._("Delete this tour?"), tour.title, "warning", "trash",
                            [Button("delete", t._("Delete"), "danger", "trash"), Button("back", t._("Keep it"))])

        def pressed(key: str) -> None:
            self.overlay.close_card()
            if key == "delete":
                edit = delete_edit(file_name, tour.language or self.tr.language, self._next_edit_uid())
                self.outputs.send_tour_edit(edit)
                self.pending_edit = (edit.uid, self.clock(), edit)

        self.overlay.show_card("confirm_delete", build, pressed)

    def _edit_result(self, res: EditResultData) -> None:
        if self.pending_edit is None or res.uid != self.pending_edit[0]:
            return
        self.pending_edit = None
        name = res.file_name
        if res.ok:
            self._show_message("edit_result",
                               lambda: self.tr._("Tour deleted") if res.deleted else self.tr._("Tour saved"),
                               lambda: self.tr._("{tour}: shared with the other robots.").format(tour=name),
                               "success")
        else:
            self._show_message("edit_result", lambda: self.tr._("The tour store refused it"),
                               lambda: f"{name}: {res.error or res.reason}", "error")

    # ================================================================== search
    def show_search(self) -> None:
        panel = SearchPanel(self.tr, self.building, self.theme, self.offices.query)

        def build() -> CardSpec:
            panel.retranslate()
            return CardSpec(self.tr._("Search by room number or name"), "", "action", "search", [],
                            extra=panel, wide=True)

        def chosen(goal_id: str) -> None:
            self.offices.set_query(panel.field.text())
            self.overlay.close_card()
            self.pick_destination(goal_id)

        def closed() -> None:
            self.offices.set_query(panel.field.text())
            self.overlay.close_card()

        panel.chosen.connect(chosen)
        panel.closed.connect(closed)
        self.search_panel = panel
        self.overlay.show_card("search", build, lambda _k: closed())
        panel.field.setFocus()
