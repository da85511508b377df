"""Pop-ups drawn inside the main window: a dimmed backdrop and a card in the middle.

Pop-ups are not separate windows (a kiosk has no window manager to speak of, and
tests can grab them with the window). A card is built by a function called
again on every language switch, so what is on screen is always in the language
chosen. The backdrop covers the page area only: the header (language button) and
the bottom bar (Cancel while a trip runs) stay reachable; keyboards and editors
(``wide``/``full`` cards) take more of the window.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from PyQt5.QtCore import QRect, Qt, QTimer, pyqtSignal
from PyQt5.QtGui import QColor, QPainter
from PyQt5.QtWidgets import QFrame, QHBoxLayout, QLabel, QSizePolicy, QVBoxLayout, QWidget

from gidabot_gui.qt.theme import ACCENT, TONES, Theme, icon, icon_pixmap
from gidabot_gui.qt.widgets import WrapButton


@dataclass
class Button:
    key: str
    text: str
    role: str = ""             # primary | danger | (plain)
    icon: str = ""


@dataclass
class CardSpec:
    title: str
    body: str = ""
    tone: str = "info"
    icon: str = "info"
    buttons: list[Button] = field(default_factory=list)
    extra: QWidget | None = None      # a widget shown under the body (keyboard, list...)
    wide: bool = False                # the whole window down to the bottom bar (keyboards); else the header
                                      # stays uncovered (language button) and the card sits in between
    full: bool = False                # cover the bottom bar too (admin tour editor)
    note: str = ""                    # a highlighted reminder under the body (walk behind the robot)
    note_icon: str = ""


class Overlay(QWidget):
    """Shows one card at a time; ``on_button(key)`` of the card's builder is called on a tap."""

    changed = pyqtSignal()             # a card was shown or closed
    resized_for_full = pyqtSignal()    # the card needs another part of the window (see wide, full)

    def __init__(self, parent: QWidget) -> None:
        super().__init__(parent)
        self.theme = Theme()
        self.name = ""                 # what the card is, e.g. "event:WAITING_VISITOR", "confirm"
        self.full = False
        self.wide = False
        self._stack: list[tuple] = []
        self._extra_keep = False
        self._builder: Callable[[], CardSpec] | None = None
        self._on_button: Callable[[str], None] | None = None
        self._extra: QWidget | None = None
        self.buttons: dict[str, WrapButton] = {}
        self._timer = QTimer(self)
        self._timer.setSingleShot(True)
        self._timer.timeout.connect(self.close_card)
        self.card = QFrame(self)
        self.card.setObjectName("card")
        lay = QVBoxLayout(self.card)
        head = QHBoxLayout()
        self.icon_label = QLabel()
        self.icon_label.setAlignment(Qt.AlignTop)
        self.title = QLabel()
        self.title.setObjectName("title")
        self.title.setWordWrap(True)
        head.addWidget(self.icon_label, 0, Qt.AlignTop)
        head.addWidget(self.title, 1)
        lay.addLayout(head)
        self.body = QLabel()
        self.body.setObjectName("body")
        self.body.setWordWrap(True)
        self.body.setTextFormat(Qt.PlainText)
        self.body.setAlignment(Qt.AlignLeft | Qt.AlignTop)
        lay.addWidget(self.body)
        self.note = QFrame()
        self.note.setObjectName("note")
        nl = QHBoxLayout(self.note)
        self.note_icon = QLabel()
        self.note_text = QLabel()
        self.note_text.setObjectName("notetext")
        self.note_text.setWordWrap(True)
        self.note_text.setTextFormat(Qt.PlainText)
        nl.addWidget(self.note_icon, 0, Qt.AlignVCenter)
        nl.addWidget(self.note_text, 1)
        lay.addWidget(self.note)
        self.extra_box = QVBoxLayout()
        lay.addLayout(self.extra_box, 1)
        self.button_row = QHBoxLayout()
        lay.addLayout(self.button_row)
        self.hide()

    # ------------------------------------------------------------------ API
    def show_card(self, name: str, builder: Callable[[], CardSpec], on_button: Callable[[str], None],
                  auto_close: float = 0.0) -> None:
        self.name = name
        self._builder = builder
        self._on_button = on_button
        self._timer.stop()
        if auto_close > 0:
            self._timer.start(int(auto_close * 1000))
        self._build()
        self.show()
        self.raise_()
        self.changed.emit()

    def push_card(self, name: str, builder: Callable[[], CardSpec], on_button: Callable[[str], None]) -> None:
        """Show a card over the current one (language menu); :meth:`pop_card` brings the previous back."""
        if self.showing and self._builder is not None and self._on_button is not None:
            self._stack.append((self.name, self._builder, self._on_button, self._extra))
        self._extra_keep = True
        self.show_card(name, builder, on_button)
        self._extra_keep = False

    def pop_card(self) -> None:
        """Close the card on top; the one under it (if any) is shown again, re-translated."""
        if not self._stack:
            self.close_card()
            return
        name, builder, on_button, _extra = self._stack.pop()
        self.show_card(name, builder, on_button)

    def close_card(self) -> None:
        self._stack.clear()
        self._timer.stop()
        self.name = ""
        self._builder = None
        self._on_button = None
        self._set_extra(None)
        if self.full or self.wide:
            self.full = self.wide = False
            self.resized_for_full.emit()
        self.hide()
        self.changed.emit()

    @property
    def showing(self) -> bool:
        return self.isVisible() and bool(self.name)

    def retranslate(self) -> None:
        if self._builder is not None and self.isVisible():
            self._build()

    def set_theme(self, theme: Theme) -> None:
        self.theme = theme
        if self._builder is not None:
            self._build()

    def press(self, key: str) -> None:
        if self._on_button is not None:
            self._on_button(key)

    # ------------------------------------------------------------------ building
    def _set_extra(self, widget: QWidget | None) -> None:
        if self._extra is widget:
            return
        if self._extra is not None:
            self.extra_box.removeWidget(self._extra)
            self._extra.hide()
            if not self._extra_keep:
                self._extra.setParent(None)
        self._extra = widget
        if widget is not None:
            self.extra_box.addWidget(widget)
            widget.show()

    def _build(self) -> None:
        assert self._builder is not None
        spec = self._builder()
        t = self.theme
        color = TONES.get(spec.tone, TONES["info"])
        ic = t.px(44)
        self.icon_label.setPixmap(icon_pixmap(spec.icon, color, ic) if spec.icon else icon_pixmap("info", color, ic))
        self.icon_label.setFixedSize(ic, ic)
        self.icon_label.setVisible(bool(spec.icon))
        self.title.setText(spec.title)
        self.title.setStyleSheet(f"color: {color};")
        self.body.setText(spec.body)
        self.body.setVisible(bool(spec.body))
        self.note_text.setText(spec.note)
        self.note.setVisible(bool(spec.note))
        if spec.note_icon:
            self.note_icon.setPixmap(icon_pixmap(spec.note_icon, ACCENT, t.px(56)))
            self.note_icon.setFixedSize(t.px(56), t.px(56))
        self.note_icon.setVisible(bool(spec.note_icon))
        self._set_extra(spec.extra)
        while self.button_row.count():
            item = self.button_row.takeAt(0)
            w = item.widget()
            if w is not None:
                w.setParent(None)
                w.deleteLater()
        self.buttons = {}
        for b in spec.buttons:
            btn = WrapButton(b.text, role=b.role, key=b.key,
                             icon=icon(b.icon, "#FFFFFF" if b.role in ("primary", "danger") else "#1B2730")
                             if b.icon else None, min_height=t.touch)
            btn.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Fixed)
            btn.clicked.connect(lambda _=False, k=b.key: self.press(k))
            self.button_row.addWidget(btn)
            self.buttons[b.key] = btn
        self.card.layout().setContentsMargins(t.px(22), t.px(14), t.px(22), t.px(14))
        self.card.layout().setSpacing(t.px(10))
        if (self.full, self.wide) != (spec.full, spec.wide):
            self.full, self.wide = spec.full, spec.wide
            self.resized_for_full.emit()
        self._place()
        QTimer.singleShot(0, self._place)      # again once the new widgets are polished

    def _place(self) -> None:
        if self.parentWidget() is None:
            return
        w, h = self.width(), self.height()
        margin = self.theme.px(8)
        if self.wide:
            self.card.setGeometry(QRect(margin, margin, w - 2 * margin, h - 2 * margin))
            return
        lay = self.card.layout()
        for label in (self.title, self.body, self.note_text):
            label.updateGeometry()
        lay.invalidate()
        lay.activate()

        def height_for(width: int) -> int:
            need = lay.totalHeightForWidth(width) if lay.hasHeightForWidth() else lay.totalSizeHint().height()
            return max(need, lay.totalMinimumSize().height())

        cw = min(w - 2 * margin, self.theme.px(640))
        ch = height_for(cw)
        if ch > h - 2 * margin:             # a long text (a language's longer words): the whole width before cutting
            cw = w - 2 * margin
            ch = height_for(cw)
        ch = min(ch, h - 2 * margin)
        self.card.setGeometry(QRect((w - cw) // 2, (h - ch) // 2, cw, ch))

    def resizeEvent(self, _ev: object) -> None:  # noqa: N802 - Qt naming
        self._place()

    def paintEvent(self, _ev: object) -> None:  # noqa: N802 - Qt naming
        p = QPainter(self)
        p.fillRect(self.rect(), QColor(10, 25, 35, 150))
        p.end()

    def mousePressEvent(self, ev: object) -> None:  # noqa: N802 - Qt naming
        ev.accept()     # taps on the backdrop do not reach the page below
