"""Touch-friendly building blocks: buttons and labels whose text wraps and shrinks to fit.

:class:`WrapButton` and :class:`FitLabel` never clip: the text wraps at word
boundaries and, if it still does not fit, the font shrinks down to
``MIN_FONT_RATIO`` of its size; if even that does not fit, ``clipped`` is set
(the GUI tests assert it never is, in every language and screen size).
"""

from __future__ import annotations

from collections.abc import Callable

from PyQt5.QtCore import QRect, QSize, Qt, pyqtSignal
from PyQt5.QtGui import QColor, QFont, QFontMetrics, QIcon, QPainter
from PyQt5.QtWidgets import (
    QAbstractItemView,
    QGridLayout,
    QHBoxLayout,
    QLineEdit,
    QPushButton,
    QScroller,
    QSizePolicy,
    QStyle,
    QStyleOptionButton,
    QStylePainter,
    QVBoxLayout,
    QWidget,
)

from gidabot_gui.core.i18n import N_
from gidabot_gui.qt.theme import TOUCH, Theme

MIN_FONT_RATIO = 0.66
WRAP = int(Qt.TextWordWrap)


def fit_font(font: QFont, rect: QRect, text: str, flags: int, max_lines: int = 3) -> tuple[QFont, bool]:
    """The largest font (down to MIN_FONT_RATIO of ``font``) with which ``text`` fits in ``rect``."""
    size = font.pixelSize() if font.pixelSize() > 0 else int(font.pointSizeF() * 96 / 72)
    min_size = max(9, int(size * MIN_FONT_RATIO))
    f = QFont(font)
    while True:
        f.setPixelSize(size)
        fm = QFontMetrics(f)
        br = fm.boundingRect(rect, flags, text)
        lines = max(1, round(br.height() / max(1, fm.lineSpacing())))
        words_fit = all(fm.horizontalAdvance(w) <= rect.width() for w in text.split())
        if br.width() <= rect.width() and br.height() <= rect.height() and lines <= max_lines and words_fit:
            return f, True
        if size <= min_size:
            return f, False
        size -= 1


class PaintedText:
    """The text of a widget that paints it itself (the style draws no label): a new text lays the widget out
    again, repaints it and is its accessible name."""

    _text: str

    def setText(self, text: str) -> None:  # noqa: N802 - Qt naming
        if text != self._text:
            self._text = text
            self.setAccessibleName(text)    # type: ignore[attr-defined]
            self.updateGeometry()           # type: ignore[attr-defined]
            self.update()                   # type: ignore[attr-defined]

    def text(self) -> str:
        return self._text


class WrapButton(PaintedText, QPushButton):
    """A push button whose label wraps onto several lines and shrinks to fit.

    ``role`` selects the style (``primary``, ``danger``, ``nav``, ``chip``, ``header``,
    ``key``, ``field`` or plain); ``key`` names the button for tests and callers.
    """

    def __init__(self, text: str = "", role: str = "", key: str = "", icon: QIcon | None = None,
                 parent: QWidget | None = None, min_height: int = TOUCH) -> None:
        super().__init__(parent)
        self._text = text
        self.role = role
        self.key = key
        self.clipped = False
        self.max_lines = 2
        self.align = int(Qt.AlignCenter)
        self.bold = role in ("primary", "danger", "nav")
        self.min_height = min_height
        self.text_color: QColor | None = None
        self.font_cap = 0                 # px; 0 = the style's font size
        self.marker = ""                  # colour of a dot in the top-right corner ("" = none)
        self.is_key = role == "key"       # a key of the on-screen keyboard (smaller touch target)
        self._fit_cache: dict[tuple, tuple[QFont, bool]] = {}
        if role:
            self.setProperty("role", role)
        if icon is not None:
            self.setIcon(icon)
        self.setFocusPolicy(Qt.NoFocus)
        self.setSizePolicy(QSizePolicy.Preferred, QSizePolicy.Fixed)
        self.setMinimumHeight(min_height)
        self.setAccessibleName(text)

    def set_min_height(self, h: int) -> None:
        self.min_height = h
        self.setMinimumHeight(h)

    def _icon_size(self) -> int:
        return int(self.fontMetrics().height() * 1.5) if not self.icon().isNull() else 0

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt naming
        fm = self.fontMetrics()
        icon_w = self._icon_size()
        words = self._text.split()
        longest = max((fm.horizontalAdvance(w) for w in words), default=0)
        full = fm.horizontalAdvance(self._text)
        width = max(longest, min(full, int(full / 1.6) + fm.averageCharWidth() * 2))
        return QSize(width + icon_w + (12 if icon_w else 0) + 28, max(self.min_height, fm.lineSpacing() + 16))

    def minimumSizeHint(self) -> QSize:  # noqa: N802 - Qt naming
        return QSize(self._icon_size() + 40, self.min_height)

    def _text_layout(self, capped: bool = True) -> tuple[QFont, bool, QRect, int, int]:
        """(font, fits, text rect, flags, icon size) of the label in the current geometry."""
        pad_x, pad_y = 10, 4
        rect = self.rect().adjusted(pad_x, pad_y, -pad_x, -pad_y)
        ic = self._icon_size()
        font = QFont(self.font())
        font.setBold(self.bold)
        if self.font_cap and capped:
            font.setPixelSize(min(font.pixelSize() if font.pixelSize() > 0 else self.font_cap, self.font_cap))
        text_rect = QRect(rect)
        if ic:
            text_rect.setLeft(rect.left() + ic + 10)
        flags = WRAP | self.align
        key = (self._text, text_rect.width(), text_rect.height(), font.key(), flags, self.max_lines)
        hit = self._fit_cache.get(key)
        if hit is None:
            if len(self._fit_cache) > 8:
                self._fit_cache.clear()
            hit = self._fit_cache[key] = fit_font(font, text_rect, self._text, flags, self.max_lines)
        f, ok = hit
        return f, ok, text_rect, flags, ic

    def fitted_pixel_size(self) -> int:
        """The font size the label would use on its own (without ``font_cap``)."""
        return self._text_layout(capped=False)[0].pixelSize()

    def paintEvent(self, _event: object) -> None:  # noqa: N802 - Qt naming
        p = QStylePainter(self)
        opt = QStyleOptionButton()
        self.initStyleOption(opt)
        opt.text = ""
        opt.icon = QIcon()
        p.drawControl(QStyle.CE_PushButton, opt)
        color = self.text_color or Theme().text_color(self.role)
        if self.role == "nav" and self.isChecked():
            color = QColor("#1B2730")
        if self.role == "chip" and self.isChecked():
            color = QColor("#FFFFFF")
        if not self.isEnabled():
            color = QColor("#8B948F") if self.role not in ("primary", "danger") else QColor("#F2F2F2")
        f, ok, text_rect, flags, ic = self._text_layout()
        self.clipped = not ok
        if ic:
            # keep icon and text together, centred (or left-aligned)
            rect = self.rect().adjusted(10, 4, -10, -4)
            used = QFontMetrics(f).boundingRect(text_rect, flags, self._text)
            total = ic + 10 + used.width()
            left = rect.left() if self.align & Qt.AlignLeft else rect.left() + max(0, (rect.width() - total) // 2)
            icon_rect = QRect(left, rect.center().y() - ic // 2, ic, ic)
            mode = QIcon.Normal if self.isEnabled() else QIcon.Disabled
            self.icon().paint(p, icon_rect, Qt.AlignCenter, mode)
            text_rect = QRect(left + ic + 10, rect.top(), rect.right() - (left + ic + 10) + 1, rect.height())
            flags = WRAP | int(Qt.AlignVCenter | Qt.AlignLeft)
        p.setFont(f)
        p.setPen(color)
        p.drawText(text_rect, flags, self._text)
        if self.marker:               # a short bar under the label ("this robot's floor")
            h = max(4, self.height() // 14)
            w = max(24, self.width() // 3)
            p.setRenderHint(QPainter.Antialiasing)
            p.setPen(Qt.NoPen)
            p.setBrush(QColor(self.marker))
            p.drawRoundedRect((self.width() - w) // 2, self.height() - h - 3, w, h, h / 2, h / 2)


def equalize_fonts(buttons: list[WrapButton], floor: int = 0) -> None:
    """Give ``buttons`` one font size: the smallest any of them needs to fit (a tidy tab bar).

    With ``floor`` (px) the common size never goes below it; a button that needs less shrinks alone.
    """
    sizes = [b.fitted_pixel_size() for b in buttons if b.isVisible() and b.width() > 0]
    if sizes:
        cap = max(min(sizes), floor)
        for b in buttons:
            if b.font_cap != cap:
                b.font_cap = cap
                b.update()


class FitLabel(PaintedText, QWidget):
    """A label that wraps and shrinks its text to fit its rectangle (``clipped`` if it cannot)."""

    def __init__(self, text: str = "", size: str = "base", bold: bool = False, color: str = "",
                 align: int = int(Qt.AlignLeft | Qt.AlignVCenter), max_lines: int = 2,
                 parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._text = text
        self.size_role = size
        self.bold = bold
        self.color = color
        self.align = align
        self.max_lines = max_lines
        self.clipped = False
        self.theme = Theme()
        self._fit_key: tuple | None = None
        self._fit: tuple[QFont, bool] = (QFont(), True)
        self.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Preferred)

    def set_theme(self, theme: Theme) -> None:
        self.theme = theme
        self.updateGeometry()
        self.update()

    def _font(self) -> QFont:
        f = QFont(self.font())
        f.setPixelSize(self.theme.font(self.size_role))
        f.setBold(self.bold)
        return f

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt naming
        fm = QFontMetrics(self._font())
        return QSize(min(fm.horizontalAdvance(self._text) + 4, 600), fm.lineSpacing() + 4)

    def minimumSizeHint(self) -> QSize:  # noqa: N802 - Qt naming
        fm = QFontMetrics(self._font())
        return QSize(40, fm.lineSpacing() + 2)

    def paintEvent(self, _event: object) -> None:  # noqa: N802 - Qt naming
        p = QPainter(self)
        p.setRenderHint(QPainter.TextAntialiasing)
        flags = WRAP | self.align
        font = self._font()
        key = (self._text, self.width(), self.height(), font.key(), flags, self.max_lines)
        if self._fit_key != key:
            self._fit_key, self._fit = key, fit_font(font, self.rect(), self._text, flags, self.max_lines)
        f, ok = self._fit
        self.clipped = not ok
        p.setFont(f)
        p.setPen(QColor(self.color) if self.color else self.palette().windowText().color())
        p.drawText(self.rect(), flags, self._text)


def touch_scroll(view: QWidget) -> None:
    """Kinetic scrolling by dragging with a finger (touch events; mouse clicks stay clicks)."""
    target = view.viewport() if hasattr(view, "viewport") else view
    QScroller.grabGesture(target, QScroller.TouchGesture)
    if isinstance(view, QAbstractItemView):
        view.setVerticalScrollMode(QAbstractItemView.ScrollPerPixel)


class ButtonGrid(QWidget):
    """Buttons in as many columns as needed so that they fit the height given (scrolls otherwise)."""

    def __init__(self, parent: QWidget | None = None, max_columns: int = 3, min_width: int = 120) -> None:
        super().__init__(parent)
        self.buttons: list[WrapButton] = []
        self.max_columns = max_columns
        self.min_width = min_width
        self.row_height = TOUCH
        self.spacing = 8
        self.available_height = 0
        self.font_floor = 15
        self.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Preferred)

    def set_buttons(self, buttons: list[WrapButton]) -> None:
        for b in self.buttons:
            b.setParent(None)
            b.deleteLater()
        self.buttons = list(buttons)
        for b in self.buttons:
            b.setParent(self)
            b.show()
        self._relayout()

    def _columns(self, width: int) -> int:
        n = len(self.buttons)
        if not n:
            return 1
        best = 1
        for cols in range(1, self.max_columns + 1):
            if cols > 1 and (width - (cols - 1) * self.spacing) / cols < self.min_width:
                break
            best = cols
            rows = -(-n // cols)
            if rows * self.row_height + (rows - 1) * self.spacing <= max(self.available_height, self.row_height):
                return cols
        return best

    def needed_height(self, width: int) -> int:
        cols = self._columns(width)
        rows = -(-len(self.buttons) // cols) if self.buttons else 0
        return rows * self.row_height + max(0, rows - 1) * self.spacing

    def hasHeightForWidth(self) -> bool:  # noqa: N802 - Qt naming
        return True

    def heightForWidth(self, width: int) -> int:  # noqa: N802 - Qt naming
        return self.needed_height(width)

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt naming
        return QSize(self.min_width * 2, self.needed_height(max(self.width(), self.min_width * 2)))

    def resizeEvent(self, _event: object) -> None:  # noqa: N802 - Qt naming
        self._relayout()

    def paintEvent(self, _event: object) -> None:  # noqa: N802 - Qt naming
        equalize_fonts(self.buttons, floor=self.font_floor)     # children are painted after their parent

    def _relayout(self) -> None:
        if not self.buttons:
            return
        width = self.width()
        cols = self._columns(width)
        rows = -(-len(self.buttons) // cols)
        h = self.row_height
        if self.available_height > 0:
            free = (self.available_height - (rows - 1) * self.spacing) / rows
            h = int(max(self.row_height, min(self.row_height * 1.5, free)))
        w = (width - (cols - 1) * self.spacing) / cols
        for i, b in enumerate(self.buttons):
            r, c = divmod(i, cols)
            b.setGeometry(int(c * (w + self.spacing)), int(r * (h + self.spacing)), int(w), h)
        self.setMinimumHeight(rows * h + (rows - 1) * self.spacing)


class Keyboard(QWidget):
    """An on-screen keyboard for the touch screen (letters, digits, a few symbols).

    Types into ``target`` (a QLineEdit); ``done`` is emitted by its Done key.
    """

    done = pyqtSignal()
    ROWS = ("1234567890", "qwertyuiop", "asdfghjklñ", "zxcvbnm-_.")

    def __init__(self, tr_text: Callable[[str], str], parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._tr = tr_text
        self.target: QLineEdit | None = None
        self.shift = False
        self.keys: dict[str, WrapButton] = {}
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.setSpacing(4)
        for row in self.ROWS:
            hl = QHBoxLayout()
            hl.setSpacing(4)
            for ch in row:
                b = WrapButton(ch, role="key", key=ch, min_height=44)
                b.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Fixed)
                b.clicked.connect(lambda _=False, c=ch: self._type(c))
                self.keys[ch] = b
                hl.addWidget(b)
            lay.addLayout(hl)
        grid = QGridLayout()
        grid.setSpacing(4)
        self.shift_key = WrapButton("⇧", role="key", key="shift", min_height=44)
        self.shift_key.setCheckable(True)
        self.shift_key.clicked.connect(self._toggle_shift)
        self.space_key = WrapButton("", role="key", key="space", min_height=44)
        self.space_key.clicked.connect(lambda: self._type(" "))
        self.back_key = WrapButton("⌫", role="key", key="backspace", min_height=44)
        self.back_key.clicked.connect(self._backspace)
        self.done_key = WrapButton("", role="primary", key="done", min_height=44)
        self.done_key.clicked.connect(self.done.emit)
        for col, (w, span) in enumerate(((self.shift_key, 2), (self.space_key, 5), (self.back_key, 2),
                                         (self.done_key, 3))):
            w.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Fixed)
            grid.addWidget(w, 0, sum((2, 5, 2, 3)[:col]), 1, span)
        lay.addLayout(grid)
        self.retranslate()

    def retranslate(self) -> None:
        self.space_key.setText(self._tr(N_("Space")))
        self.done_key.setText(self._tr(N_("Done")))

    def all_keys(self) -> list[WrapButton]:
        return [*self.keys.values(), self.shift_key, self.space_key, self.back_key, self.done_key]

    def set_key_height(self, h: int) -> None:
        """Keys are at least ``h`` px high and grow with the space the keyboard is given."""
        for b in self.all_keys():
            b.set_min_height(h)
            b.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Expanding)
            b.is_key = True

    def _type(self, ch: str) -> None:
        if self.target is None:
            return
        self.target.insert(ch.upper() if self.shift else ch)
        if self.shift:
            self._toggle_shift()

    def _toggle_shift(self) -> None:
        self.shift = not self.shift
        self.shift_key.setChecked(self.shift)
        for ch, b in self.keys.items():
            b.setText(ch.upper() if self.shift else ch)

    def _backspace(self) -> None:
        if self.target is not None:
            self.target.backspace()
