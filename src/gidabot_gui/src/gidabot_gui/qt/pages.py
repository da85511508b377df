"""The pages of the main window: one per floor, Offices, Guided Tour, Information.

Pages only show what the window gives them and emit what the visitor chose;
the decisions are in the window's parts (visitor, admin mode, tour editing) and the ROS-free core.
"""

from __future__ import annotations

import html
from collections.abc import Callable

from PyQt5.QtCore import QModelIndex, QRect, QSize, Qt, pyqtSignal
from PyQt5.QtGui import QColor, QFont, QFontMetrics, QPainter
from PyQt5.QtWidgets import (
    QButtonGroup,
    QFrame,
    QGridLayout,
    QHBoxLayout,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QProgressBar,
    QScrollArea,
    QSizePolicy,
    QStyle,
    QStyledItemDelegate,
    QStyleOptionViewItem,
    QVBoxLayout,
    QWidget,
)

from gidabot_gui.core.i18n import Translator
from gidabot_gui.core.places import find_locations, location_near
from gidabot_gui.qt.floor_view import FloorView
from gidabot_gui.qt.theme import ACCENT, BORDER, MUTED, OFFLINE, OTHER_ROBOT, PRIMARY, TEXT, Theme, icon
from gidabot_gui.qt.widgets import WRAP, ButtonGrid, FitLabel, WrapButton, fit_font, touch_scroll
from gidabot_navigation.building.model import Building, Floor, Location

KEY, BADGE, MAIN, SIDE, STATE = (Qt.UserRole + i for i in range(5))


class RowDelegate(QStyledItemDelegate):
    """List rows for touch: a badge (room number, step), the name, and a muted side text."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.theme = Theme()
        self.clipped: set[str] = set()

    def sizeHint(self, _option: QStyleOptionViewItem, _index: QModelIndex) -> QSize:  # noqa: N802 - Qt naming
        return QSize(200, self.theme.touch)

    def paint(self, p: QPainter, option: QStyleOptionViewItem, index: QModelIndex) -> None:
        t = self.theme
        r = option.rect
        state = index.data(STATE) or ""
        selected = bool(option.state & QStyle.State_Selected)
        p.save()
        p.setRenderHint(QPainter.Antialiasing)
        bg = QColor("#E3F1EF") if selected else QColor("#FFFFFF")
        if state == "current":
            bg = QColor("#FFF1E4")
        p.fillRect(r, bg)
        p.setPen(QColor(BORDER))
        p.drawLine(r.bottomLeft(), r.bottomRight())
        x = r.left() + t.px(10)
        badge = index.data(BADGE) or ""
        base = QFont(option.font)
        if badge:
            bf = QFont(base)
            bf.setPixelSize(t.font("small"))
            bf.setBold(True)
            fm = QFontMetrics(bf)
            bw = max(fm.horizontalAdvance(badge) + t.px(16), t.px(44))
            bh = fm.height() + t.px(10)
            color = {"done": QColor("#2E7D32"), "current": QColor(ACCENT)}.get(state, QColor(PRIMARY))
            p.setBrush(color)
            p.setPen(Qt.NoPen)
            brect = QRect(x, r.center().y() - bh // 2, bw, bh)
            p.drawRoundedRect(brect, bh / 2, bh / 2)
            p.setFont(bf)
            p.setPen(QColor("#FFFFFF"))
            p.drawText(brect, int(Qt.AlignCenter), badge)
            x += bw + t.px(12)
        side = index.data(SIDE) or ""
        right = r.right() - t.px(12)
        if side:
            sf = QFont(base)
            sf.setPixelSize(t.font("small"))
            sw = min(QFontMetrics(sf).horizontalAdvance(side) + 4, int(r.width() * 0.4))
            srect = QRect(right - sw, r.top(), sw, r.height())
            f, ok = fit_font(sf, srect, side, WRAP | int(Qt.AlignRight | Qt.AlignVCenter), 2)
            if not ok:
                self.clipped.add(side)
            p.setFont(f)
            p.setPen(QColor(MUTED))
            p.drawText(srect, WRAP | int(Qt.AlignRight | Qt.AlignVCenter), side)
            right -= sw + t.px(12)
        main = index.data(MAIN) or ""
        mf = QFont(base)
        mf.setPixelSize(t.font("base"))
        mf.setBold(state == "current")
        mrect = QRect(x, r.top() + 2, max(10, right - x), r.height() - 4)
        f, ok = fit_font(mf, mrect, main, WRAP | int(Qt.AlignLeft | Qt.AlignVCenter), 2)
        if not ok:
            self.clipped.add(main)
        p.setFont(f)
        p.setPen(QColor(TEXT if state != "done" else MUTED))
        p.drawText(mrect, WRAP | int(Qt.AlignLeft | Qt.AlignVCenter), main)
        p.restore()


def make_list(delegate: RowDelegate) -> QListWidget:
    lst = QListWidget()
    lst.setItemDelegate(delegate)
    lst.setUniformItemSizes(True)
    lst.setHorizontalScrollBarPolicy(Qt.ScrollBarAlwaysOff)
    lst.setFocusPolicy(Qt.NoFocus)
    touch_scroll(lst)
    return lst


def row(key: str, main: str, badge: str = "", side: str = "", state: str = "") -> QListWidgetItem:
    item = QListWidgetItem()
    item.setData(KEY, key)
    item.setData(MAIN, main)
    item.setData(BADGE, badge)
    item.setData(SIDE, side)
    item.setData(STATE, state)
    item.setData(Qt.AccessibleTextRole, f"{badge} {main} {side}".strip())
    return item


class Page(QWidget):
    def __init__(self, tr: Translator, building: Building) -> None:
        super().__init__()
        self.setObjectName("page")
        self.setAttribute(Qt.WA_StyledBackground, True)
        self.tr = tr
        self.building = building
        self.theme = Theme()

    def set_theme(self, theme: Theme) -> None:
        self.theme = theme
        for w in self.findChildren(FitLabel):
            w.set_theme(theme)
        for w in self.findChildren(WrapButton):
            if w.role != "key":
                w.set_min_height(theme.touch)
        for d in self.findChildren(RowDelegate):
            d.theme = theme
        for lst in self.findChildren(QListWidget):
            lst.doItemsLayout()

    def retranslate(self) -> None:
        raise NotImplementedError


class GridScroll(QScrollArea):
    """A scroll area around a :class:`ButtonGrid` that tells it the height it may use."""

    def __init__(self, grid: ButtonGrid) -> None:
        super().__init__()
        self.grid = grid
        self.setWidgetResizable(True)
        self.setHorizontalScrollBarPolicy(Qt.ScrollBarAlwaysOff)
        self.setWidget(grid)
        touch_scroll(self)

    def resizeEvent(self, ev: object) -> None:  # noqa: N802 - Qt naming
        self.grid.available_height = self.viewport().height()
        super().resizeEvent(ev)
        self.grid._relayout()


# ---------------------------------------------------------------------- floors
class FloorPage(Page):
    """A floor: blueprint with the robots, and a button per featured location."""

    destination = pyqtSignal(str)
    pose_set = pyqtSignal(float, float, float, float)   # blueprint press/release px
    set_location_done = pyqtSignal(bool)                  # True = apply, False = cancel

    def __init__(self, tr: Translator, building: Building, floor: Floor, here: bool) -> None:
        super().__init__(tr, building)
        self.floor = floor
        self.here = here
        self.locations: list[Location] = [loc for loc in building.locations if loc.floor == floor.id and loc.featured]
        outer = QVBoxLayout(self)
        lay = QHBoxLayout()
        self.left = QVBoxLayout()
        self.setbar = QFrame()
        self.setbar.setObjectName("setbar")
        sb = QHBoxLayout(self.setbar)
        self.set_hint = FitLabel(size="base", max_lines=2)
        self.apply_btn = WrapButton(role="primary", key="apply_location", icon=icon("check", "#FFFFFF"))
        self.apply_btn.clicked.connect(lambda: self.set_location_done.emit(True))
        self.apply_btn.setEnabled(False)
        self.cancel_set_btn = WrapButton(key="cancel_location", icon=icon("close"))
        self.cancel_set_btn.clicked.connect(lambda: self.set_location_done.emit(False))
        sb.addWidget(self.set_hint, 1)
        sb.addWidget(self.apply_btn)
        sb.addWidget(self.cancel_set_btn)
        self.setbar.hide()
        outer.addWidget(self.setbar)
        outer.addLayout(lay, 1)
        self.main_row = lay
        self.view = FloorView(floor)
        self.view.featured = [(loc.pose.x, loc.pose.y) for loc in self.locations]
        self.view.pose_dragged.connect(self._dragged)
        self.view.location_tapped.connect(self._tapped)
        self.left.addWidget(self.view, 1)
        self.legend = QLabel()
        self.legend.setObjectName("muted")
        self.legend.setWordWrap(True)
        self.legend.setTextFormat(Qt.RichText)
        self.under = QWidget()
        under = QHBoxLayout(self.under)
        under.setContentsMargins(0, 0, 0, 0)
        under.addWidget(self.legend, 1)
        # admin: Set location (only on this robot's floor, only when admin mode is unlocked)
        self.set_location_btn = WrapButton(key="set_location", icon=icon("target"))
        self.set_location_btn.hide()
        under.addWidget(self.set_location_btn)
        self.left.addWidget(self.under)
        lay.addLayout(self.left, 16)
        right = QVBoxLayout()
        self.grid = ButtonGrid(max_columns=2, min_width=110)
        self.buttons: dict[str, WrapButton] = {}
        btns = []
        for loc in self.locations:
            b = WrapButton(role="", key=loc.id)
            b.clicked.connect(lambda _=False, i=loc.id: self.destination.emit(i))
            self.buttons[loc.id] = b
            btns.append(b)
        self.grid.set_buttons(btns)
        self.scroll = GridScroll(self.grid)
        right.addWidget(self.scroll, 1)
        lay.addLayout(right, 8)
        self.retranslate()

    def retranslate(self) -> None:
        t, lang = self.tr, self.tr.language
        for loc in self.locations:
            self.buttons[loc.id].setText(loc.name(lang))
        dot = '<span style="color:{c}; font-size:large">&#9679;</span>&nbsp;{t}'
        nb = "&nbsp;"

        self.legend.setText("&nbsp;&nbsp; ".join(
            [html.escape(t._("Tap a place to be guided there."))]
            + [dot.format(c=c, t=html.escape(x).replace(" ", nb)) for c, x in ((ACCENT, t._("This robot")),
                                                          (OTHER_ROBOT, t._("Other robots")),
                                                          (OFFLINE, t._("Offline")))]))
        self.set_hint.setText(t._("Tap the robot's position on the map, then drag towards where it faces."))
        self.set_location_btn.setText(t._("Set location"))
        self.apply_btn.setText(t._("Apply"))
        self.cancel_set_btn.setText(t._("Cancel"))

    def set_theme(self, theme: Theme) -> None:
        super().set_theme(theme)
        self.view.theme = theme
        self.grid.row_height = theme.touch
        self.grid.spacing = theme.px(8)
        self.grid.font_floor = theme.px(15)
        self.grid._relayout()

    def set_admin(self, on: bool) -> None:
        """Admin mode shows the floor's keep-out zones on the blueprint (visitors do not see them)."""
        self.view.set_show_keep_out(on)

    def set_setting_location(self, on: bool) -> None:
        """Admin's Set location (``on``): the whole page for the map, a bar with the instructions, Apply (once a
        pose was dragged) and Cancel; else the legend and the location buttons."""
        self.setbar.setVisible(on)
        self.under.setVisible(not on)
        self.scroll.setVisible(not on)
        self.main_row.setStretch(1, 0 if on else 8)
        self.apply_btn.setEnabled(False)
        self.view.set_setting_pose(on)

    def _dragged(self, u0: float, v0: float, u1: float, v1: float) -> None:
        self.apply_btn.setEnabled(True)
        self.pose_set.emit(u0, v0, u1, v1)

    def _tapped(self, x: float, y: float) -> None:
        """A tap on the blueprint picks the nearest location."""
        loc = location_near(self.building, self.floor.id, x, y)
        if loc is not None:
            self.destination.emit(loc.id)


# ---------------------------------------------------------------------- offices
class OfficesPage(Page):
    """Every destination, per floor, searchable by room number or name."""

    destination = pyqtSignal(str)
    search_requested = pyqtSignal()

    def __init__(self, tr: Translator, building: Building) -> None:
        super().__init__(tr, building)
        self.query = ""
        self.floor_filter: float | None = None
        lay = QVBoxLayout(self)
        top = QHBoxLayout()
        self.search = WrapButton(role="field", key="search", icon=icon("search", MUTED))
        self.search.clicked.connect(self.search_requested.emit)
        self.clear = WrapButton(key="clear", icon=icon("close"))
        self.clear.clicked.connect(lambda: self.set_query(""))
        top.addWidget(self.search, 6)
        top.addWidget(self.clear, 2)
        self.group = QButtonGroup(self)
        self.group.setExclusive(True)
        self.all_chip = WrapButton(role="chip", key="all")
        self.all_chip.setCheckable(True)
        self.all_chip.setChecked(True)
        self.all_chip.clicked.connect(lambda: self.set_floor(None))
        self.group.addButton(self.all_chip)
        top.addWidget(self.all_chip, 4)
        self.chips: dict[float, WrapButton] = {}
        for f in building.floors:
            c = WrapButton(role="chip", key=f"floor:{f.label}")
            c.setCheckable(True)
            c.clicked.connect(lambda _=False, fid=f.id: self.set_floor(fid))
            self.group.addButton(c)
            self.chips[f.id] = c
            top.addWidget(c, 4)
        for c in (self.search, self.clear, self.all_chip, *self.chips.values()):
            c.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Fixed)
            c.setMinimumWidth(40)
        lay.addLayout(top)
        right = lay
        self.delegate = RowDelegate(self)
        self.list = make_list(self.delegate)
        self.list.itemClicked.connect(lambda it: self.destination.emit(it.data(KEY)))
        right.addWidget(self.list, 1)
        self.empty = FitLabel(size="base", color=MUTED, align=int(Qt.AlignCenter))
        right.addWidget(self.empty, 1)
        self.retranslate()

    def set_floor(self, floor: float | None) -> None:
        self.floor_filter = floor
        (self.all_chip if floor is None else self.chips[floor]).setChecked(True)
        self.refresh()

    def set_query(self, text: str) -> None:
        self.query = text
        self.refresh()

    def matches(self, query: str, floor: float | None = None) -> list[Location]:
        return find_locations(self.building, query, self.tr.language, floor)

    def refresh(self) -> None:
        t, lang = self.tr, self.tr.language
        self.list.clear()
        found = self.matches(self.query, self.floor_filter)
        for loc in found:
            f = self.building.floor(loc.floor)
            self.list.addItem(row(loc.id, loc.name(lang), badge=loc.id, side=f.names[lang]))
        self.list.setVisible(bool(found))
        self.empty.setVisible(not found)
        self.empty.setText(t._("No place matches “{text}”.").format(text=self.query))
        self.search.setText(f"“{self.query}”" if self.query else t._("Search"))
        self.search.text_color = QColor(TEXT if self.query else MUTED)
        self.clear.setVisible(bool(self.query))

    def retranslate(self) -> None:
        t, lang = self.tr, self.tr.language
        self.all_chip.setText(t._("All floors"))
        for f in self.building.floors:
            self.chips[f.id].setText(f.names[lang])
        self.clear.setAccessibleName(t._("Clear"))
        self.refresh()


# ---------------------------------------------------------------------- tours
class ToursPage(Page):
    """The tours of this robot: Start again, Continue, go to a chosen stop; admin edits."""

    start = pyqtSignal(str)
    continue_ = pyqtSignal()
    skip = pyqtSignal(str, int)
    new_tour = pyqtSignal()
    edit_tour = pyqtSignal(str)
    delete_tour = pyqtSignal(str)

    def __init__(self, tr: Translator, building: Building) -> None:
        super().__init__(tr, building)
        self.tours: list = []                   # TourInfo
        self.progress: tuple[str, set[int], int] | None = None   # file, done steps, running step
        self.can_continue = False
        self.can_skip: Callable[[int], bool] = lambda _s: False
        self.busy = False
        lay = QVBoxLayout(self)
        lists = QHBoxLayout()
        left, self.tours_title, self.tour_list = self._column(self._show_stops)
        self.no_tours = FitLabel(size="base", color=MUTED, align=int(Qt.AlignCenter), max_lines=3)
        left.addWidget(self.no_tours, 1)
        lists.addLayout(left, 5)
        right, self.stops_title, self.stop_list = self._column(self.update_buttons)
        lists.addLayout(right, 8)
        lay.addLayout(lists, 1)
        buttons = QHBoxLayout()
        self.start_btn = WrapButton(role="primary", key="start", icon=icon("restart", "#FFFFFF"))
        self.start_btn.clicked.connect(self._start)
        self.continue_btn = WrapButton(role="primary", key="continue", icon=icon("play", "#FFFFFF"))
        self.continue_btn.clicked.connect(self.continue_.emit)
        self.skip_btn = WrapButton(key="skip", icon=icon("skip"))
        self.skip_btn.clicked.connect(self._skip)
        for b in (self.start_btn, self.continue_btn, self.skip_btn):
            b.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Fixed)
            buttons.addWidget(b)
        lay.addLayout(buttons)
        self.admin_row = QWidget()
        ar = QHBoxLayout(self.admin_row)
        ar.setContentsMargins(0, 0, 0, 0)
        self.new_btn = WrapButton(key="new_tour", icon=icon("plus"))
        self.new_btn.clicked.connect(self.new_tour.emit)
        self.edit_btn = WrapButton(key="edit_tour", icon=icon("pencil"))
        self.edit_btn.clicked.connect(lambda: self.selected() and self.edit_tour.emit(self.selected().file_name))
        self.delete_btn = WrapButton(key="delete_tour", icon=icon("trash"))
        self.delete_btn.clicked.connect(lambda: self.selected() and self.delete_tour.emit(self.selected().file_name))
        for b in (self.new_btn, self.edit_btn, self.delete_btn):
            b.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Fixed)
            ar.addWidget(b)
        self.admin_row.hide()
        lay.addWidget(self.admin_row)
        self.retranslate()

    def _column(self, on_row: Callable[[], None]) -> tuple[QVBoxLayout, FitLabel, QListWidget]:
        """A column of the page: a title over a list; ``on_row()`` when the list's current row changes."""
        column = QVBoxLayout()
        title = FitLabel(size="base", bold=True, max_lines=1)
        column.addWidget(title)
        lst = make_list(RowDelegate(self))
        lst.currentRowChanged.connect(lambda _r: on_row())
        column.addWidget(lst, 1)
        return column, title, lst

    # ------------------------------------------------------------------ data
    def set_tours(self, tours: list) -> None:
        keep = self.selected().file_name if self.selected() else ""
        self.tours = list(tours)
        self._fill_tours(keep)

    def selected(self):  # -> TourInfo | None
        r = self.tour_list.currentRow()
        return self.tours[r] if 0 <= r < len(self.tours) else None

    def select(self, file_name: str) -> None:
        for i, tour in enumerate(self.tours):
            if tour.file_name == file_name:
                self.tour_list.setCurrentRow(i)
                return

    def selected_stop(self) -> int:
        return self.stop_list.currentRow()

    def select_stop(self, step: int) -> None:
        self.stop_list.setCurrentRow(step)

    def _fill_tours(self, keep: str) -> None:
        t = self.tr
        self.tour_list.blockSignals(True)
        self.tour_list.clear()
        for tour in self.tours:
            n = len(tour.goals)
            self.tour_list.addItem(row(tour.file_name, tour.title,
                                       side=t.n_("{n} stop", "{n} stops", n).format(n=n)))
        self.tour_list.blockSignals(False)
        self.tour_list.setVisible(bool(self.tours))
        self.no_tours.setVisible(not self.tours)
        idx = next((i for i, x in enumerate(self.tours) if x.file_name == keep), 0 if self.tours else -1)
        self.tour_list.setCurrentRow(idx)
        self._show_stops()

    def set_progress(self, progress: tuple[str, set[int], int] | None, can_continue: bool,
                     can_skip: Callable[[int], bool], busy: bool) -> None:
        """Called on every refresh: the stop list is rebuilt only when the tour's progress changed."""
        changed = progress != self.progress
        self.progress = progress
        self.can_continue = can_continue
        self.can_skip = can_skip
        self.busy = busy
        if changed:
            self._show_stops()
        else:
            self.update_buttons()

    def _show_stops(self) -> None:
        tour = self.selected()
        lang = self.tr.language
        keep = self.stop_list.currentRow()
        self.stop_list.blockSignals(True)
        self.stop_list.clear()
        if tour is not None:
            active = self.progress is not None and self.progress[0] == tour.file_name
            for i, (floor, room, desc) in enumerate(tour.goals):
                loc = self.building.find_location(room)
                name = loc.name(lang) if loc is not None else desc
                f = self.building.find_floor(floor)
                state = ""
                if active:
                    assert self.progress is not None
                    state = "current" if i == self.progress[2] else "done" if i in self.progress[1] else ""
                self.stop_list.addItem(row(str(i), f"{name} ({room})", badge=str(i + 1),
                                           side=f.names[lang] if f else "", state=state))
        if 0 <= keep < self.stop_list.count():
            self.stop_list.setCurrentRow(keep)
        self.stop_list.blockSignals(False)
        self.update_buttons()

    def update_buttons(self) -> None:
        t = self.tr
        tour = self.selected()
        running = self.progress is not None and tour is not None and self.progress[0] == tour.file_name
        self.start_btn.setText(t._("Start again") if running else t._("Start the tour"))
        self.start_btn.setEnabled(tour is not None and not self.busy)
        self.continue_btn.setEnabled(self.can_continue)
        step = self.selected_stop()
        self.skip_btn.setEnabled(running and step >= 0 and self.can_skip(step))
        self.edit_btn.setEnabled(tour is not None)
        self.delete_btn.setEnabled(tour is not None)

    def _start(self) -> None:
        tour = self.selected()
        if tour is not None:
            self.start.emit(tour.file_name)

    def _skip(self) -> None:
        tour = self.selected()
        if tour is not None and self.selected_stop() >= 0:
            self.skip.emit(tour.file_name, self.selected_stop())

    def set_admin(self, on: bool) -> None:
        self.admin_row.setVisible(on)

    def retranslate(self) -> None:
        t = self.tr
        self.tours_title.setText(t._("Tours"))
        self.stops_title.setText(t._("Stops of the tour"))
        self.no_tours.setText(t._("There are no tours on this robot yet."))
        self.continue_btn.setText(t._("Continue"))
        self.skip_btn.setText(t._("Go to this stop"))
        self.new_btn.setText(t._("New tour"))
        self.edit_btn.setText(t._("Edit tour"))
        self.delete_btn.setText(t._("Delete tour"))
        self._fill_tours(self.selected().file_name if self.selected() else "")


# ---------------------------------------------------------------------- information
class RobotCard(QFrame):
    """One robot in the Information tab."""

    def __init__(self, name: str) -> None:
        super().__init__()
        self.setObjectName("robotcard")
        self.name = name
        lay = QGridLayout(self)
        lay.setVerticalSpacing(2)
        self.title = FitLabel(size="big", bold=True, max_lines=1)
        self.floor = FitLabel(size="small", color=MUTED, max_lines=1, align=int(Qt.AlignRight | Qt.AlignVCenter))
        self.dot = QLabel("\u25cf")
        self.state = FitLabel(size="base", max_lines=2)
        self.state_text = ""
        self.battery = QProgressBar()
        self.battery.setRange(0, 100)
        self.battery.setMinimumWidth(60)
        self.battery.setSizePolicy(QSizePolicy.Ignored, QSizePolicy.Fixed)
        state_row = QHBoxLayout()
        state_row.setSpacing(6)
        state_row.addWidget(self.dot)
        state_row.addWidget(self.state, 1)
        self.motion = FitLabel(size="small", max_lines=2)
        self.pending = FitLabel(size="small", max_lines=2)
        lay.addWidget(self.title, 0, 0, 1, 2)
        lay.addWidget(self.floor, 0, 2)
        lay.addLayout(state_row, 1, 0, 1, 2)
        lay.addWidget(self.battery, 1, 2)
        lay.addWidget(self.motion, 2, 0, 1, 3)
        lay.addWidget(self.pending, 3, 0, 1, 3)
        lay.setColumnStretch(0, 3)
        lay.setColumnStretch(1, 1)
        lay.setColumnStretch(2, 3)
        self.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Preferred)

    def set_flags(self, here: bool, offline: bool) -> None:
        changed = self.property("here") != here or self.property("offline") != offline
        self.setProperty("here", here)
        self.setProperty("offline", offline)
        if changed:
            self.style().unpolish(self)
            self.style().polish(self)


class InfoPage(Page):
    """Every robot of the building: floor, state, velocities, battery, pending requests, offline."""

    def __init__(self, tr: Translator, building: Building) -> None:
        super().__init__(tr, building)
        lay = QVBoxLayout(self)
        self.scroll = QScrollArea()
        self.scroll.setWidgetResizable(True)
        self.scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarAlwaysOff)
        touch_scroll(self.scroll)
        inner = QWidget()
        self.grid = QGridLayout(inner)
        self.grid.setContentsMargins(0, 0, 0, 0)
        self.cards: dict[str, RobotCard] = {}
        for i, r in enumerate(building.robots):
            card = RobotCard(r.name)
            self.cards[r.name] = card
            self.grid.addWidget(card, i // 2, i % 2)
        self.grid.setColumnStretch(0, 1)
        self.grid.setColumnStretch(1, 1)
        self.scroll.setWidget(inner)
        lay.addWidget(self.scroll)
        self.columns = 2

    def set_columns(self, n: int) -> None:
        if n == self.columns:
            return
        self.columns = n
        for i, r in enumerate(self.building.robots):
            self.grid.addWidget(self.cards[r.name], i // n, i % n)
        for c in range(n):
            self.grid.setColumnStretch(c, 1)

    def set_card(self, name: str, *, title: str, floor: str, state: str, state_color: str, motion: str,
                 battery: float | None, battery_text: str, pending: str, here: bool, offline: bool) -> None:
        c = self.cards[name]
        c.title.setText(title)
        c.title.color = OFFLINE if offline else (ACCENT if here else TEXT)
        c.floor.setText(floor)
        c.state_text = state
        c.state.setText(state)
        if c.dot.property("color") != state_color:
            c.dot.setProperty("color", state_color)
            c.dot.setStyleSheet(f"color: {state_color};")
        c.motion.setText(motion)
        c.battery.setValue(int(round(battery * 100)) if battery is not None else 0)
        low = battery is not None and battery < 0.2
        if c.battery.property("low") != low:
            c.battery.setProperty("low", low)
            c.battery.style().unpolish(c.battery)
            c.battery.style().polish(c.battery)
        c.battery.setFormat(battery_text)
        c.pending.setText(pending)
        c.set_flags(here, offline)

    def retranslate(self) -> None:
        pass     # the window fills the cards in the current language

