"""Look of the GUI: colours, sizes that follow the screen, the style sheet and drawn icons.

Sizes are in pixels at the reference screen 800x480 and grow with the window
(:meth:`Theme.for_size`), so text stays legible at arm's length and every touch
target is at least ``TOUCH`` pixels high on both 800x480 and 1280x800 screens.
Icons are painted with QPainter (no image files, no SVG module needed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from PyQt5.QtCore import QPointF, QRectF, Qt
from PyQt5.QtGui import QBrush, QColor, QIcon, QPainter, QPainterPath, QPen, QPixmap, QPolygonF

FONT_FAMILY = "DejaVu Sans"
TOUCH = 60          # px, minimum height of a touch target at the reference size
FONT_SIZES = {"small": 15, "base": 18, "big": 22, "title": 27}   # px of text at the reference size

BG = "#F3F0E8"
SURFACE = "#FFFFFF"
HEADER = "#12394A"
HEADER_TEXT = "#FFFFFF"
NAV_TEXT = "#CFE3E8"
PRIMARY = "#0B6E69"
PRIMARY_DARK = "#08524E"
ACCENT = "#E8772E"
DANGER = "#B3261E"
TEXT = "#1B2730"
MUTED = "#56656F"
BORDER = "#D5D0C4"
OTHER_ROBOT = "#1F6FB2"
OFFLINE = "#8A8F93"
TONES = {"info": PRIMARY, "action": PRIMARY, "success": "#2E7D32", "warning": "#A65F00", "error": DANGER}


@dataclass(frozen=True)
class Theme:
    scale: float = 1.0

    @staticmethod
    def for_size(width: int, height: int) -> Theme:
        s = min(width / 800.0, height / 480.0)
        s = max(1.0, min(1.8, s))
        return Theme(round(1.0 + (s - 1.0) * 0.6, 2))

    def px(self, value: float) -> int:
        return int(round(value * self.scale))

    def font(self, size: str) -> int:
        """The pixel size of text of ``size``: one of ``FONT_SIZES`` (small, base, big, title)."""
        return self.px(FONT_SIZES[size])

    @property
    def touch(self) -> int:
        return self.px(TOUCH)

    def style_sheet(self) -> str:
        f, fs, fb, ft = (self.font(size) for size in ("base", "small", "big", "title"))
        r = self.px(10)
        return f"""
QWidget {{ font-family: "{FONT_FAMILY}"; font-size: {f}px; color: {TEXT}; }}
QWidget#root, QStackedWidget#pages, QWidget#page {{ background: {BG}; }}
QFrame#header {{ background: {HEADER}; }}
QFrame#nav {{ background: {HEADER}; }}
QLabel#brand {{ color: {HEADER_TEXT}; font-size: {fb}px; font-weight: bold; }}
QFrame#bottom {{ background: {SURFACE}; border-top: 2px solid {BORDER}; }}
QPushButton {{ background: {SURFACE}; border: 2px solid {BORDER}; border-radius: {r}px; padding: 4px 10px; }}
QPushButton:pressed {{ background: #E6F2F1; border-color: {PRIMARY}; }}
QPushButton:disabled {{ background: #ECE9E2; border-color: #E0DCD2; }}
QPushButton[role="primary"] {{ background: {PRIMARY}; border-color: {PRIMARY}; }}
QPushButton[role="primary"]:pressed {{ background: {PRIMARY_DARK}; }}
QPushButton[role="primary"]:disabled {{ background: #9FBFBD; border-color: #9FBFBD; }}
QPushButton[role="danger"] {{ background: {DANGER}; border-color: {DANGER}; }}
QPushButton[role="danger"]:pressed {{ background: #8C1D17; }}
QPushButton[role="header"] {{ background: #1D4E63; border: 2px solid #2D6A82; }}
QPushButton[role="header"]:pressed {{ background: #2D6A82; }}
QPushButton[role="nav"] {{ background: transparent; border: none; border-radius: 0px;
    border-top-left-radius: {r}px; border-top-right-radius: {r}px; }}
QPushButton[role="nav"]:checked {{ background: {BG}; }}
QPushButton[role="chip"] {{ border-radius: {r}px; }}
QPushButton[role="chip"]:checked {{ background: {PRIMARY}; border-color: {PRIMARY}; }}
QPushButton[role="key"] {{ padding: 0px; border-radius: {self.px(6)}px; }}
QPushButton[role="field"] {{ border-color: #B9B3A6; }}
QFrame#card {{ background: {SURFACE}; border-radius: {self.px(16)}px; }}
QFrame#note {{ background: #FFF4E8; border-left: {self.px(6)}px solid {ACCENT}; border-radius: {self.px(6)}px; }}
QLabel#notetext {{ font-size: {f}px; font-weight: bold; color: #7A3A0C; }}
QFrame#robotcard {{ background: {SURFACE}; border: 2px solid {BORDER}; border-radius: {r}px; }}
QFrame#robotcard[offline="true"] {{ background: #ECEAE5; }}
QFrame#robotcard[here="true"] {{ border-color: {ACCENT}; }}
QFrame#setbar {{ background: #FFF4E8; border: 2px solid {ACCENT}; border-radius: {r}px; }}
QLabel#title {{ font-size: {ft}px; font-weight: bold; }}
QLabel#body {{ font-size: {fb}px; }}
QLabel#muted {{ color: {MUTED}; font-size: {fs}px; }}
QLabel#section {{ font-size: {fb}px; font-weight: bold; }}
QLabel#error {{ color: {DANGER}; font-size: {fs}px; }}
QLineEdit {{ background: {SURFACE}; border: 2px solid #B9B3A6; border-radius: {self.px(8)}px;
    padding: 4px 10px; font-size: {fb}px; min-height: {self.px(46)}px; }}
QLineEdit:focus {{ border-color: {PRIMARY}; }}
QListWidget {{ background: {SURFACE}; border: 2px solid {BORDER}; border-radius: {r}px; outline: none; }}
QScrollArea {{ background: transparent; border: none; }}
QScrollArea > QWidget > QWidget {{ background: transparent; }}
QScrollBar:vertical {{ width: {self.px(14)}px; background: #E9E5DB; border-radius: {self.px(7)}px; }}
QScrollBar::handle:vertical {{ background: #B9B3A6; border-radius: {self.px(7)}px; min-height: 40px; }}
QScrollBar::add-line:vertical, QScrollBar::sub-line:vertical {{ height: 0px; }}
QProgressBar {{ border: 2px solid {BORDER}; border-radius: {self.px(6)}px; background: #ECE9E2;
    text-align: center; font-size: {fs}px; max-height: {self.px(22)}px; }}
QProgressBar::chunk {{ background: #3C9A5F; border-radius: {self.px(4)}px; }}
QProgressBar[low="true"]::chunk {{ background: {DANGER}; }}
"""

    def text_color(self, role: str) -> QColor:
        """Colour of the text of a button with ``role``."""
        if role in ("primary", "danger", "header"):
            return QColor(HEADER_TEXT)
        if role == "nav":
            return QColor(NAV_TEXT)
        return QColor(TEXT)


# ---------------------------------------------------------------------- icons
def _pen(color: str, width: float) -> QPen:
    pen = QPen(QColor(color), width)
    pen.setCapStyle(Qt.RoundCap)
    pen.setJoinStyle(Qt.RoundJoin)
    return pen


def _poly(s: float, *points: tuple[float, float]) -> QPolygonF:
    """The polygon through ``points`` given as fractions of the side ``s`` of an icon."""
    return QPolygonF([QPointF(s * x, s * y) for x, y in points])


def _draw(name: str, p: QPainter, color: str, s: float) -> None:  # noqa: C901 - one drawing per icon
    """Draw icon ``name`` in a square of side ``s``."""
    w = s / 12.0
    p.setPen(_pen(color, w))
    p.setBrush(Qt.NoBrush)
    c = QColor(color)
    if name == "pin":
        path = QPainterPath()
        path.moveTo(s * 0.5, s * 0.94)
        path.cubicTo(s * 0.2, s * 0.6, s * 0.14, s * 0.46, s * 0.14, s * 0.38)
        path.arcTo(QRectF(s * 0.14, s * 0.04, s * 0.72, s * 0.68), 180, -180)
        path.cubicTo(s * 0.86, s * 0.46, s * 0.8, s * 0.6, s * 0.5, s * 0.94)
        p.setBrush(QBrush(c))
        p.setPen(Qt.NoPen)
        p.drawPath(path)
        p.setBrush(QBrush(QColor("#FFFFFF")))
        p.drawEllipse(QPointF(s * 0.5, s * 0.38), s * 0.13, s * 0.13)
    elif name == "route":
        pts = [QPointF(s * 0.18, s * 0.78), QPointF(s * 0.42, s * 0.3), QPointF(s * 0.62, s * 0.66),
               QPointF(s * 0.84, s * 0.2)]
        pen = _pen(color, w * 0.9)
        pen.setStyle(Qt.DashLine)
        p.setPen(pen)
        p.drawPolyline(QPolygonF(pts))
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        for pt in pts:
            p.drawEllipse(pt, s * 0.1, s * 0.1)
    elif name == "globe":
        r = QRectF(s * 0.1, s * 0.1, s * 0.8, s * 0.8)
        p.drawEllipse(r)
        p.drawEllipse(QRectF(s * 0.32, s * 0.1, s * 0.36, s * 0.8))
        p.drawLine(QPointF(s * 0.1, s * 0.5), QPointF(s * 0.9, s * 0.5))
        p.drawLine(QPointF(s * 0.5, s * 0.1), QPointF(s * 0.5, s * 0.9))
    elif name in ("lock", "unlock"):
        p.setBrush(QBrush(c))
        p.setPen(Qt.NoPen)
        p.drawRoundedRect(QRectF(s * 0.18, s * 0.44, s * 0.64, s * 0.48), s * 0.08, s * 0.08)
        p.setBrush(Qt.NoBrush)
        p.setPen(_pen(color, w * 1.1))
        shackle = QRectF(s * 0.3, s * 0.1, s * 0.4, s * 0.5)
        if name == "lock":
            p.drawArc(shackle, 0, 180 * 16)
            p.drawLine(QPointF(s * 0.3, s * 0.35), QPointF(s * 0.3, s * 0.46))
            p.drawLine(QPointF(s * 0.7, s * 0.35), QPointF(s * 0.7, s * 0.46))
        else:
            p.drawArc(shackle.translated(s * 0.16, -s * 0.02), 20 * 16, 160 * 16)
            p.drawLine(QPointF(s * 0.46, s * 0.33), QPointF(s * 0.46, s * 0.46))
    elif name == "stairs":
        p.setPen(_pen(color, w * 1.2))
        p.drawPolyline(_poly(s, (0.08, 0.88), (0.3, 0.88), (0.3, 0.66), (0.52, 0.66), (0.52, 0.44), (0.74, 0.44),
                             (0.74, 0.22), (0.94, 0.22)))
    elif name == "lift":
        p.drawRoundedRect(QRectF(s * 0.16, s * 0.08, s * 0.68, s * 0.84), s * 0.08, s * 0.08)
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawPolygon(_poly(s, (0.5, 0.18), (0.68, 0.42), (0.32, 0.42)))
        p.drawPolygon(_poly(s, (0.5, 0.82), (0.68, 0.58), (0.32, 0.58)))
    elif name == "robot":
        p.setBrush(QBrush(c))
        p.setPen(Qt.NoPen)
        p.drawEllipse(QPointF(s * 0.5, s * 0.5), s * 0.36, s * 0.36)
        p.setBrush(QBrush(QColor("#FFFFFF")))
        p.drawPolygon(_poly(s, (0.74, 0.5), (0.4, 0.3), (0.4, 0.7)))
    elif name == "search":
        p.setPen(_pen(color, w * 1.2))
        p.drawEllipse(QPointF(s * 0.42, s * 0.42), s * 0.26, s * 0.26)
        p.drawLine(QPointF(s * 0.62, s * 0.62), QPointF(s * 0.88, s * 0.88))
    elif name == "close":
        p.setPen(_pen(color, w * 1.3))
        p.drawLine(QPointF(s * 0.24, s * 0.24), QPointF(s * 0.76, s * 0.76))
        p.drawLine(QPointF(s * 0.76, s * 0.24), QPointF(s * 0.24, s * 0.76))
    elif name == "play":
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawPolygon(_poly(s, (0.28, 0.16), (0.84, 0.5), (0.28, 0.84)))
    elif name == "restart":
        p.setPen(_pen(color, w * 1.1))
        p.drawArc(QRectF(s * 0.18, s * 0.18, s * 0.64, s * 0.64), 60 * 16, 280 * 16)
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawPolygon(_poly(s, (0.56, 0.04), (0.8, 0.2), (0.54, 0.32)))
    elif name == "skip":
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawPolygon(_poly(s, (0.14, 0.2), (0.5, 0.5), (0.14, 0.8)))
        p.drawPolygon(_poly(s, (0.46, 0.2), (0.82, 0.5), (0.46, 0.8)))
        p.drawRect(QRectF(s * 0.8, s * 0.2, s * 0.08, s * 0.6))
    elif name == "check":
        p.setPen(_pen(color, w * 1.4))
        p.drawPolyline(_poly(s, (0.16, 0.52), (0.4, 0.76), (0.86, 0.26)))
    elif name == "target":
        p.drawEllipse(QPointF(s * 0.5, s * 0.5), s * 0.3, s * 0.3)
        for a, b in (((0.5, 0.04), (0.5, 0.26)), ((0.5, 0.74), (0.5, 0.96)), ((0.04, 0.5), (0.26, 0.5)),
                     ((0.74, 0.5), (0.96, 0.5))):
            p.drawLine(QPointF(s * a[0], s * a[1]), QPointF(s * b[0], s * b[1]))
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawEllipse(QPointF(s * 0.5, s * 0.5), s * 0.09, s * 0.09)
    elif name == "plus":
        p.setPen(_pen(color, w * 1.3))
        p.drawLine(QPointF(s * 0.5, s * 0.16), QPointF(s * 0.5, s * 0.84))
        p.drawLine(QPointF(s * 0.16, s * 0.5), QPointF(s * 0.84, s * 0.5))
    elif name == "minus":
        p.setPen(_pen(color, w * 1.3))
        p.drawLine(QPointF(s * 0.16, s * 0.5), QPointF(s * 0.84, s * 0.5))
    elif name == "trash":
        p.drawLine(QPointF(s * 0.14, s * 0.22), QPointF(s * 0.86, s * 0.22))
        p.drawLine(QPointF(s * 0.38, s * 0.1), QPointF(s * 0.62, s * 0.1))
        p.drawPolyline(_poly(s, (0.22, 0.3), (0.28, 0.92), (0.72, 0.92), (0.78, 0.3)))
    elif name == "pencil":
        p.setPen(_pen(color, w * 1.1))
        p.drawPolygon(_poly(s, (0.68, 0.1), (0.9, 0.32), (0.34, 0.88), (0.1, 0.9), (0.12, 0.66)))
    elif name in ("up", "down"):
        y0, y1 = (0.8, 0.2) if name == "up" else (0.2, 0.8)
        p.setPen(_pen(color, w * 1.3))
        p.drawLine(QPointF(s * 0.5, s * y0), QPointF(s * 0.5, s * y1))
        p.drawPolyline(QPolygonF([QPointF(s * 0.24, s * (y1 + (y0 - y1) * 0.42)), QPointF(s * 0.5, s * y1),
                                  QPointF(s * 0.76, s * (y1 + (y0 - y1) * 0.42))]))
    elif name == "keyboard":
        p.drawRoundedRect(QRectF(s * 0.06, s * 0.24, s * 0.88, s * 0.52), s * 0.06, s * 0.06)
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        for row, y in enumerate((0.36, 0.5)):
            for i in range(5 - row):
                p.drawRect(QRectF(s * (0.16 + i * 0.15 + row * 0.07), s * y - w / 2, w * 1.2, w * 1.2))
        p.drawRect(QRectF(s * 0.3, s * 0.62, s * 0.4, w))
    elif name == "info":
        p.drawEllipse(QPointF(s * 0.5, s * 0.5), s * 0.4, s * 0.4)
        p.drawLine(QPointF(s * 0.5, s * 0.44), QPointF(s * 0.5, s * 0.72))
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawEllipse(QPointF(s * 0.5, s * 0.3), w * 0.8, w * 0.8)
    elif name == "warning":
        p.drawPolygon(_poly(s, (0.5, 0.08), (0.94, 0.88), (0.06, 0.88)))
        p.drawLine(QPointF(s * 0.5, s * 0.36), QPointF(s * 0.5, s * 0.62))
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawEllipse(QPointF(s * 0.5, s * 0.75), w * 0.8, w * 0.8)
    elif name == "walk":
        # a robot driving right with a person walking behind it (paper section 9)
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawEllipse(QPointF(s * 0.22, s * 0.2), s * 0.08, s * 0.08)
        p.setPen(_pen(color, w * 0.9))
        p.drawLine(QPointF(s * 0.22, s * 0.3), QPointF(s * 0.22, s * 0.58))
        p.drawPolyline(_poly(s, (0.1, 0.86), (0.22, 0.58), (0.32, 0.86)))
        p.drawPolyline(_poly(s, (0.1, 0.5), (0.22, 0.36), (0.34, 0.48)))
        p.setPen(Qt.NoPen)
        p.drawRoundedRect(QRectF(s * 0.5, s * 0.46, s * 0.36, s * 0.34), s * 0.06, s * 0.06)
        p.drawEllipse(QPointF(s * 0.58, s * 0.84), s * 0.05, s * 0.05)
        p.drawEllipse(QPointF(s * 0.78, s * 0.84), s * 0.05, s * 0.05)
        p.drawRect(QRectF(s * 0.64, s * 0.3, s * 0.08, s * 0.16))
        p.setBrush(QBrush(QColor(ACCENT)))
        p.drawPolygon(_poly(s, (0.98, 0.3), (0.86, 0.2), (0.86, 0.4)))
    elif name == "flag":
        p.setPen(_pen(color, w * 1.1))
        p.drawLine(QPointF(s * 0.22, s * 0.1), QPointF(s * 0.22, s * 0.92))
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(c))
        p.drawPolygon(_poly(s, (0.26, 0.12), (0.86, 0.3), (0.26, 0.5)))
    else:
        raise KeyError(f"unknown icon {name!r}")


def icon_pixmap(name: str, color: str = TEXT, size: int = 64) -> QPixmap:
    pm = QPixmap(size, size)
    pm.fill(Qt.transparent)
    p = QPainter(pm)
    try:
        p.setRenderHint(QPainter.Antialiasing)
        _draw(name, p, color, float(size))
    finally:
        p.end()
    return pm


def icon(name: str, color: str = TEXT) -> QIcon:
    return QIcon(icon_pixmap(name, color))


def heading_polygon(cx: float, cy: float, radius: float, angle: float) -> QPolygonF:
    """A triangle pointing along ``angle`` (image angle: counter-clockwise, v up) inside a circle."""
    def pt(a: float, r: float) -> QPointF:
        return QPointF(cx + r * math.cos(a), cy - r * math.sin(a))
    return QPolygonF([pt(angle, radius * 0.95), pt(angle + 2.5, radius * 0.6), pt(angle - 2.5, radius * 0.6)])
