"""Admin tour editor and the text-entry panels (password, search), all for the touch screen."""

from __future__ import annotations

from collections.abc import Callable

from PyQt5.QtCore import QEvent, QObject, Qt, pyqtSignal
from PyQt5.QtWidgets import (
    QButtonGroup,
    QGridLayout,
    QHBoxLayout,
    QLineEdit,
    QStackedWidget,
    QVBoxLayout,
    QWidget,
)

from gidabot_gui.core.admin import TourDraft, floor_text, slug_file_name
from gidabot_gui.core.i18n import LANGUAGE_NAMES, Translator
from gidabot_gui.core.places import find_locations
from gidabot_gui.qt.pages import KEY, MAIN, RowDelegate, make_list, row
from gidabot_gui.qt.theme import DANGER, MUTED, Theme, icon
from gidabot_gui.qt.widgets import FitLabel, Keyboard, WrapButton
from gidabot_navigation.building.model import Building, Location
from gidabot_navigation.interface import LANGUAGES


class _FocusWatch(QObject):
    """Calls ``on_focus(line_edit)`` when one of the watched line edits gets the focus (or a tap)."""

    def __init__(self, on_focus: Callable[[QLineEdit], None]) -> None:
        super().__init__()
        self.on_focus = on_focus

    def eventFilter(self, obj: QObject, ev: QEvent) -> bool:  # noqa: N802 - Qt naming
        if ev.type() in (QEvent.FocusIn, QEvent.MouseButtonPress) and isinstance(obj, QLineEdit):
            self.on_focus(obj)
        return False


class PasswordPanel(QWidget):
    """Password field, Unlock / Back, and a keyboard."""

    submitted = pyqtSignal(str)
    back = pyqtSignal()

    def __init__(self, tr: Translator, theme: Theme) -> None:
        super().__init__()
        self.tr = tr
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        top = QHBoxLayout()
        self.field = QLineEdit()
        self.field.setEchoMode(QLineEdit.Password)
        self.field.returnPressed.connect(lambda: self.submitted.emit(self.field.text()))
        self.unlock = WrapButton(role="primary", key="unlock", icon=icon("unlock", "#FFFFFF"), min_height=theme.touch)
        self.unlock.clicked.connect(lambda: self.submitted.emit(self.field.text()))
        self.back_btn = WrapButton(key="back", min_height=theme.touch)
        self.back_btn.clicked.connect(self.back.emit)
        top.addWidget(self.field, 1)
        top.addWidget(self.unlock)
        top.addWidget(self.back_btn)
        lay.addLayout(top)
        self.keyboard = Keyboard(tr._)
        self.keyboard.target = self.field
        self.keyboard.done.connect(lambda: self.submitted.emit(self.field.text()))
        self.keyboard.set_key_height(theme.px(40))
        lay.addWidget(self.keyboard)
        self.retranslate()

    def retranslate(self) -> None:
        self.field.setPlaceholderText(self.tr._("Password"))
        self.unlock.setText(self.tr._("Unlock"))
        self.back_btn.setText(self.tr._("Back"))
        self.keyboard.retranslate()


class SearchPanel(QWidget):
    """Search field with live results on the left and a keyboard on the right."""

    chosen = pyqtSignal(str)
    closed = pyqtSignal()

    def __init__(self, tr: Translator, building: Building, theme: Theme, query: str = "") -> None:
        super().__init__()
        self.tr = tr
        self.building = building
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        top = QHBoxLayout()
        self.field = QLineEdit(query)
        self.field.textChanged.connect(self.refresh)
        self.close_btn = WrapButton(key="close_search", icon=icon("close"), min_height=theme.touch)
        self.close_btn.clicked.connect(self.closed.emit)
        top.addWidget(self.field, 1)
        top.addWidget(self.close_btn)
        lay.addLayout(top)
        body = QHBoxLayout()
        self.delegate = RowDelegate(self)
        self.delegate.theme = theme
        self.results = make_list(self.delegate)
        self.results.itemClicked.connect(lambda it: self.chosen.emit(it.data(KEY)))
        self.empty = FitLabel(size="base", color=MUTED, align=int(Qt.AlignCenter), max_lines=3)
        self.empty.set_theme(theme)
        left = QVBoxLayout()
        left.addWidget(self.results, 1)
        left.addWidget(self.empty, 1)
        body.addLayout(left, 9)
        self.keyboard = Keyboard(tr._)
        self.keyboard.target = self.field
        self.keyboard.done.connect(self.closed.emit)
        self.keyboard.set_key_height(theme.px(40))
        body.addWidget(self.keyboard, 11)
        lay.addLayout(body, 1)
        self.retranslate()

    def matches(self) -> list[Location]:
        return find_locations(self.building, self.field.text(), self.tr.language)

    def refresh(self) -> None:
        lang = self.tr.language
        self.results.clear()
        found = self.matches()
        for loc in found:
            self.results.addItem(row(loc.id, loc.name(lang), badge=loc.id))
        self.results.setVisible(bool(found))
        self.empty.setVisible(not found)
        self.empty.setText(self.tr._("No place matches “{text}”.").format(text=self.field.text()))

    def retranslate(self) -> None:
        self.field.setPlaceholderText(self.tr._("Room number or name"))
        self.close_btn.setText(self.tr._("Close"))
        self.keyboard.retranslate()
        self.refresh()


class TourEditor(QWidget):
    """Create or edit a tour: name, file name, language, stops (from the building), descriptions."""

    save = pyqtSignal()
    closed = pyqtSignal()

    def __init__(self, tr: Translator, building: Building, theme: Theme, draft: TourDraft) -> None:
        super().__init__()
        self.tr = tr
        self.building = building
        self.theme = theme
        self.draft = draft
        touch = theme.touch
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.setSpacing(theme.px(6))
        r1 = QHBoxLayout()
        self.name = QLineEdit(draft.name)
        self.name.textEdited.connect(self._name_edited)
        r1.addWidget(self.name, 1)
        self.lang_group = QButtonGroup(self)
        self.lang_buttons: dict[str, WrapButton] = {}
        for lang in LANGUAGES:
            b = WrapButton(LANGUAGE_NAMES[lang], role="chip", key=f"lang:{lang}", min_height=touch)
            b.setCheckable(True)
            b.setChecked(lang == draft.language)
            b.clicked.connect(lambda _=False, code=lang: self._set_language(code))
            self.lang_group.addButton(b)
            self.lang_buttons[lang] = b
            r1.addWidget(b)
        lay.addLayout(r1)
        r2 = QHBoxLayout()
        self.file = QLineEdit(draft.file_name)
        self.file.setReadOnly(draft.existing)
        r2.addWidget(self.file, 1)
        self.save_btn = WrapButton(role="primary", key="save", icon=icon("check", "#FFFFFF"), min_height=touch)
        self.save_btn.clicked.connect(self.save.emit)
        self.close_btn = WrapButton(key="close_editor", icon=icon("close"), min_height=touch)
        self.close_btn.clicked.connect(self.closed.emit)
        r2.addWidget(self.save_btn)
        r2.addWidget(self.close_btn)
        lay.addLayout(r2)
        self.stack = QStackedWidget()
        # page 0: stops and their buttons
        stops = QWidget()
        sl = QHBoxLayout(stops)
        sl.setContentsMargins(0, 0, 0, 0)
        self.delegate = RowDelegate(self)
        self.delegate.theme = theme
        self.stops = make_list(self.delegate)
        self.stops.currentRowChanged.connect(self._stop_selected)
        sl.addWidget(self.stops, 3)
        grid = QGridLayout()
        self.add_btn = WrapButton(key="add_stop", icon=icon("plus"), min_height=touch)
        self.add_btn.clicked.connect(lambda: self.stack.setCurrentIndex(1))
        self.remove_btn = WrapButton(key="remove_stop", icon=icon("minus"), min_height=touch)
        self.remove_btn.clicked.connect(self._remove)
        self.up_btn = WrapButton(key="up", icon=icon("up"), min_height=touch)
        self.up_btn.clicked.connect(lambda: self._move(-1))
        self.down_btn = WrapButton(key="down", icon=icon("down"), min_height=touch)
        self.down_btn.clicked.connect(lambda: self._move(1))
        for i, b in enumerate((self.add_btn, self.remove_btn, self.up_btn, self.down_btn)):
            grid.addWidget(b, i // 2, i % 2)
        grid.setRowStretch(2, 1)
        sl.addLayout(grid, 2)
        self.stack.addWidget(stops)
        # page 1: pick a location to add
        picker = QWidget()
        pl = QVBoxLayout(picker)
        pl.setContentsMargins(0, 0, 0, 0)
        chips = QHBoxLayout()
        self.floor_group = QButtonGroup(self)
        self.floor_chips: dict[float, WrapButton] = {}
        for f in building.floors:
            c = WrapButton(role="chip", key=f"pick_floor:{f.label}", min_height=touch)
            c.setCheckable(True)
            c.clicked.connect(lambda _=False, fid=f.id: self._fill_picker(fid))
            self.floor_group.addButton(c)
            self.floor_chips[f.id] = c
            chips.addWidget(c)
        self.pick_back = WrapButton(key="pick_back", min_height=touch)
        self.pick_back.clicked.connect(lambda: self.stack.setCurrentIndex(0))
        chips.addWidget(self.pick_back)
        pl.addLayout(chips)
        self.pick_delegate = RowDelegate(self)
        self.pick_delegate.theme = theme
        self.picker = make_list(self.pick_delegate)
        self.picker.itemClicked.connect(lambda it: self._add(it.data(KEY)))
        pl.addWidget(self.picker, 1)
        self.stack.addWidget(picker)
        # page 2: keyboard
        self.keyboard = Keyboard(tr._)
        self.keyboard.set_key_height(theme.px(32))
        self.keyboard.done.connect(self._keyboard_done)
        self.stack.addWidget(self.keyboard)
        lay.addWidget(self.stack, 1)
        self.desc = QLineEdit()
        self.desc.textEdited.connect(self._desc_edited)
        lay.addWidget(self.desc)
        self.error = FitLabel(size="small", color=DANGER, max_lines=2)
        self.error.set_theme(theme)
        self.error.hide()
        lay.addWidget(self.error)
        self._watch = _FocusWatch(self._focus)
        for field in (self.name, self.file, self.desc):
            field.installEventFilter(self._watch)
        self._name_follows_file = not draft.existing
        self._fill_picker(building.floors[0].id)
        self.retranslate()
        self._fill_stops(0)

    # ------------------------------------------------------------------ editing
    def _focus(self, field: QLineEdit) -> None:
        if field.isReadOnly():
            return
        self.keyboard.target = field
        self.stack.setCurrentIndex(2)

    def _keyboard_done(self) -> None:
        self.stack.setCurrentIndex(0)

    def _name_edited(self, text: str) -> None:
        self.draft.name = text
        if self._name_follows_file:
            self.file.setText(slug_file_name(text))

    def _set_language(self, lang: str) -> None:
        self.draft.language = lang

    def _stop_selected(self, r: int) -> None:
        if 0 <= r < len(self.draft.goals):
            self.desc.setText(self.draft.goals[r][2])
            self.desc.setEnabled(True)
        else:
            self.desc.clear()
            self.desc.setEnabled(False)

    def _desc_edited(self, text: str) -> None:
        r = self.stops.currentRow()
        if 0 <= r < len(self.draft.goals):
            f, room, _ = self.draft.goals[r]
            self.draft.goals[r] = (f, room, text)
            self.stops.item(r).setData(MAIN, f"{text} ({room})")

    def _fill_stops(self, select: int) -> None:
        lang = self.tr.language
        self.stops.blockSignals(True)
        self.stops.clear()
        for i, (floor, room, desc) in enumerate(self.draft.goals):
            f = self.building.find_floor(floor)
            self.stops.addItem(row(str(i), f"{desc} ({room})", badge=str(i + 1),
                                   side=f.names[lang] if f else floor_text(floor)))
        self.stops.blockSignals(False)
        if self.draft.goals:
            self.stops.setCurrentRow(max(0, min(select, len(self.draft.goals) - 1)))
        self._stop_selected(self.stops.currentRow())

    def _fill_picker(self, floor: float) -> None:
        self.floor_chips[floor].setChecked(True)
        lang = self.tr.language
        self.picker.clear()
        for loc in self.building.locations:
            if loc.floor == floor:
                self.picker.addItem(row(loc.id, loc.name(lang), badge=loc.id))

    def _add(self, room: str) -> None:
        loc = self.building.location(room)
        self.draft.goals.append((loc.floor, loc.id, loc.name(self.draft.language)))
        self.stack.setCurrentIndex(0)
        self._fill_stops(len(self.draft.goals) - 1)

    def _remove(self) -> None:
        r = self.stops.currentRow()
        if 0 <= r < len(self.draft.goals):
            del self.draft.goals[r]
            self._fill_stops(r)

    def _move(self, d: int) -> None:
        r = self.stops.currentRow()
        j = r + d
        if 0 <= r < len(self.draft.goals) and 0 <= j < len(self.draft.goals):
            g = self.draft.goals
            g[r], g[j] = g[j], g[r]
            self._fill_stops(j)

    def collect(self) -> TourDraft:
        self.draft.name = self.name.text()
        self.draft.file_name = self.file.text().strip()
        return self.draft

    def show_error(self, text: str) -> None:
        self.error.setText(text)
        self.error.setVisible(bool(text))

    def retranslate(self) -> None:
        t = self.tr
        self.name.setPlaceholderText(t._("Name of the tour"))
        self.file.setPlaceholderText(t._("File name, e.g. open_day.tour"))
        self.desc.setPlaceholderText(t._("Description of the selected stop"))
        self.save_btn.setText(t._("Save"))
        self.close_btn.setText(t._("Close"))
        self.add_btn.setText(t._("Add stop"))
        self.remove_btn.setText(t._("Remove"))
        self.up_btn.setText(t._("Up"))
        self.down_btn.setText(t._("Down"))
        self.pick_back.setText(t._("Back"))
        for f in self.building.floors:
            self.floor_chips[f.id].setText(f.names[t.language])
        self.keyboard.retranslate()
