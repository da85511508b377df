"""One floor's blueprint with the robots on it (and, in admin mode, Set location and the floor's keep-out zones).

Map metres -> blueprint pixels by the building's
:class:`~gidabot_navigation.building.geometry.BlueprintTransform`; blueprint pixels ->
widget pixels by :class:`ViewMapping` (the blueprint is scaled to fit, centred, and turned
a quarter turn when that shows it much larger: a tall, narrow building on a wide screen).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from PyQt5.QtCore import QPointF, QRectF, QSize, Qt, pyqtSignal
from PyQt5.QtGui import (
    QBrush,
    QColor,
    QFont,
    QFontMetrics,
    QPainter,
    QPainterPath,
    QPen,
    QPixmap,
    QPolygonF,
    QTransform,
)
from PyQt5.QtWidgets import QSizePolicy, QWidget

from gidabot_gui.qt.theme import ACCENT, DANGER, FONT_FAMILY, OFFLINE, OTHER_ROBOT, PRIMARY, Theme, heading_polygon
from gidabot_navigation.building.model import Floor

TURN_GAIN = 1.5    # a blueprint is turned when that shows it at least this much larger


@dataclass(frozen=True)
class ViewMapping:
    """Blueprint pixels <-> widget pixels: the image scaled by ``k`` and offset by (ox, oy); ``turned``:
    drawn a quarter turn counter-clockwise first (its top edge on the left, its text reading upwards),
    ``image_w`` being its width in pixels."""

    k: float
    ox: float
    oy: float
    turned: bool = False
    image_w: int = 0

    @staticmethod
    def fit(image_w: int, image_h: int, widget_w: int, widget_h: int) -> ViewMapping:
        """The largest fit, upright or turned (turned only when it is ``TURN_GAIN`` times larger)."""
        iw, ih = max(1, image_w), max(1, image_h)
        k = min(widget_w / iw, widget_h / ih)
        k_turned = min(widget_w / ih, widget_h / iw)
        if k_turned >= TURN_GAIN * k:
            return ViewMapping(k_turned, (widget_w - ih * k_turned) / 2.0, (widget_h - iw * k_turned) / 2.0, True, iw)
        return ViewMapping(k, (widget_w - iw * k) / 2.0, (widget_h - ih * k) / 2.0)

    def to_widget(self, u: float, v: float) -> tuple[float, float]:
        if self.turned:
            u, v = v, self.image_w - u
        return self.ox + u * self.k, self.oy + v * self.k

    def to_blueprint(self, x: float, y: float) -> tuple[float, float]:
        u, v = (x - self.ox) / self.k, (y - self.oy) / self.k
        return (self.image_w - v, u) if self.turned else (u, v)

    def angle(self, blueprint_angle: float) -> float:
        """An angle on the blueprint (rad, counter-clockwise from +u, v up) as drawn in the widget."""
        return blueprint_angle + (math.pi / 2 if self.turned else 0.0)

    def size(self, image_w: int, image_h: int) -> tuple[float, float]:
        """Width and height (widget px) the blueprint is drawn at."""
        w, h = (image_h, image_w) if self.turned else (image_w, image_h)
        return w * self.k, h * self.k


@dataclass(frozen=True)
class RobotMark:
    name: str
    x: float            # m, map frame
    y: float
    yaw: float
    radius: float       # m
    here: bool          # this screen's robot
    offline: bool
    label: str          # text shown next to it


class FloorView(QWidget):
    """Paints a floor's blueprint, its robots, the goal, and the pose being set; with ``show_keep_out`` (admin mode
    only: visitors need not see them) the floor's keep-out zones, hatched in red."""

    location_tapped = pyqtSignal(float, float)          # map x, y of a tap (visitor mode)
    pose_dragged = pyqtSignal(float, float, float, float)  # blueprint px: press u, v, release u, v

    def __init__(self, floor: Floor, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.floor = floor
        self.image = QPixmap(str(floor.blueprint_file))
        self._scaled: QPixmap | None = None
        self.robots: list[RobotMark] = []
        self.goal: tuple[float, float] | None = None     # map x, y of the current goal on this floor
        self.featured: list[tuple[float, float]] = []
        self.setting_pose = False
        self.show_keep_out = False
        self.press_px: tuple[float, float] | None = None  # blueprint px
        self.drag_px: tuple[float, float] | None = None
        self.theme = Theme()
        self.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Expanding)
        self.setMinimumSize(200, 80)

    # ------------------------------------------------------------------ geometry
    def mapping(self) -> ViewMapping:
        return ViewMapping.fit(self.image.width(), self.image.height(), self.width(), self.height())

    def map_to_widget(self, x: float, y: float) -> tuple[float, float]:
        u, v = self.floor.transform.to_pixel(x, y)
        return self.mapping().to_widget(u, v)

    def widget_to_blueprint(self, x: float, y: float) -> tuple[float, float]:
        return self.mapping().to_blueprint(x, y)

    def _aspect(self) -> float:
        """Height per width the blueprint wants: lying (turned when needed) on a wide screen."""
        w, h = max(1, self.image.width()), max(1, self.image.height())
        return min(w, h) / max(w, h)

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt naming
        return QSize(600, int(600 * self._aspect()))

    def hasHeightForWidth(self) -> bool:  # noqa: N802 - Qt naming
        return True

    def heightForWidth(self, w: int) -> int:  # noqa: N802 - Qt naming
        return int(w * self._aspect())

    # ------------------------------------------------------------------ state
    def set_robots(self, robots: list[RobotMark]) -> None:
        if robots != self.robots:
            self.robots = robots
            self.update()

    def set_goal(self, goal: tuple[float, float] | None) -> None:
        if goal != self.goal:
            self.goal = goal
            self.update()

    def set_show_keep_out(self, on: bool) -> None:
        if on != self.show_keep_out:
            self.show_keep_out = on
            self.update()

    def set_setting_pose(self, on: bool) -> None:
        self.setting_pose = on
        self.press_px = self.drag_px = None
        self.setCursor(Qt.CrossCursor if on else Qt.ArrowCursor)
        self.update()

    # ------------------------------------------------------------------ input
    def mousePressEvent(self, ev: object) -> None:  # noqa: N802 - Qt naming
        pos = ev.pos()
        if self.setting_pose:
            self.press_px = self.widget_to_blueprint(pos.x(), pos.y())
            self.drag_px = self.press_px
            self.update()

    def mouseMoveEvent(self, ev: object) -> None:  # noqa: N802 - Qt naming
        if self.setting_pose and self.press_px is not None:
            pos = ev.pos()
            self.drag_px = self.widget_to_blueprint(pos.x(), pos.y())
            self.update()

    def mouseReleaseEvent(self, ev: object) -> None:  # noqa: N802 - Qt naming
        pos = ev.pos()
        if self.setting_pose:
            if self.press_px is None:
                return
            self.drag_px = self.widget_to_blueprint(pos.x(), pos.y())
            self.update()
            self.pose_dragged.emit(self.press_px[0], self.press_px[1], self.drag_px[0], self.drag_px[1])
            return
        u, v = self.widget_to_blueprint(pos.x(), pos.y())
        x, y = self.floor.transform.to_map(u, v)
        self.location_tapped.emit(x, y)

    # ------------------------------------------------------------------ painting
    def resizeEvent(self, _ev: object) -> None:  # noqa: N802 - Qt naming
        self._scaled = None

    def paintEvent(self, _ev: object) -> None:  # noqa: N802 - Qt naming
        p = QPainter(self)
        p.setRenderHint(QPainter.Antialiasing)
        m = self.mapping()
        if self._scaled is None and not self.image.isNull():
            image = self.image.transformed(QTransform().rotate(-90)) if m.turned else self.image
            w, h = m.size(self.image.width(), self.image.height())
            self._scaled = image.scaled(max(1, int(w)), max(1, int(h)), Qt.KeepAspectRatio, Qt.SmoothTransformation)
        if self._scaled is not None:
            p.drawPixmap(int(m.ox), int(m.oy), self._scaled)
        scale_px = self.floor.transform.scale * m.k                   # widget px per metre
        if self.show_keep_out:
            self._paint_keep_out(p)
        for x, y in self.featured:
            wx, wy = self.map_to_widget(x, y)
            p.setPen(Qt.NoPen)
            p.setBrush(QBrush(QColor(PRIMARY)))
            p.drawEllipse(QPointF(wx, wy), 4.0 * self.theme.scale, 4.0 * self.theme.scale)
        if self.goal is not None:
            self._paint_goal(p, *self.map_to_widget(*self.goal))
        for r in sorted(self.robots, key=lambda r: r.here):           # this robot on top
            self._paint_robot(p, r, scale_px, m)
        if self.setting_pose and self.press_px is not None:
            self._paint_pose(p, m)
        p.end()

    def _paint_keep_out(self, p: QPainter) -> None:
        edge, fill = QColor(DANGER), QColor(DANGER)
        fill.setAlpha(60)
        for zone in self.floor.keep_out:
            outline = QPolygonF([QPointF(*self.map_to_widget(x, y)) for x, y in zone.polygon.points])
            p.setPen(QPen(edge, 2))
            p.setBrush(QBrush(fill))
            p.drawPolygon(outline)
            p.setBrush(QBrush(edge, Qt.BDiagPattern))
            p.drawPolygon(outline)

    def _paint_goal(self, p: QPainter, wx: float, wy: float) -> None:
        s = 16.0 * self.theme.scale
        path = QPainterPath()
        path.moveTo(wx, wy)
        path.cubicTo(wx - s * 0.6, wy - s * 0.9, wx - s * 0.7, wy - s * 1.2, wx - s * 0.7, wy - s * 1.5)
        path.arcTo(QRectF(wx - s * 0.7, wy - s * 2.2, s * 1.4, s * 1.4), 180, -180)
        path.cubicTo(wx + s * 0.7, wy - s * 1.2, wx + s * 0.6, wy - s * 0.9, wx, wy)
        p.setPen(QPen(QColor("#FFFFFF"), 2))
        p.setBrush(QBrush(QColor("#C0392B")))
        p.drawPath(path)
        p.setBrush(QBrush(QColor("#FFFFFF")))
        p.setPen(Qt.NoPen)
        p.drawEllipse(QPointF(wx, wy - s * 1.5), s * 0.28, s * 0.28)

    def _paint_robot(self, p: QPainter, r: RobotMark, scale_px: float, m: ViewMapping) -> None:
        wx, wy = self.map_to_widget(r.x, r.y)
        radius = max(11.0 * self.theme.scale, r.radius * scale_px)
        color = QColor(OFFLINE if r.offline else ACCENT if r.here else OTHER_ROBOT)
        if r.here and not r.offline:
            halo = QColor(color)
            halo.setAlpha(70)
            p.setPen(Qt.NoPen)
            p.setBrush(QBrush(halo))
            p.drawEllipse(QPointF(wx, wy), radius * 1.9, radius * 1.9)
        p.setPen(QPen(QColor("#FFFFFF"), 2.5))
        p.setBrush(QBrush(color))
        p.drawEllipse(QPointF(wx, wy), radius, radius)
        angle = m.angle(self.floor.transform.yaw_to_pixel_angle(r.yaw))
        p.setPen(Qt.NoPen)
        p.setBrush(QBrush(QColor("#FFFFFF")))
        p.drawPolygon(heading_polygon(wx, wy, radius, angle))
        # name tag above (below when too close to the top)
        f = QFont(FONT_FAMILY)
        f.setPixelSize(self.theme.font("small"))
        f.setBold(True)
        fm = QFontMetrics(f)
        tw, th = fm.horizontalAdvance(r.label) + 14, fm.height() + 6
        tx = min(max(2.0, wx - tw / 2), self.width() - tw - 2)
        ty = wy - radius - th - 4
        if ty < 2:
            ty = wy + radius + 4
        p.setBrush(QBrush(color))
        p.setPen(Qt.NoPen)
        p.drawRoundedRect(QRectF(tx, ty, tw, th), th / 2, th / 2)
        p.setFont(f)
        p.setPen(QColor("#FFFFFF"))
        p.drawText(QRectF(tx, ty, tw, th), int(Qt.AlignCenter), r.label)

    def _paint_pose(self, p: QPainter, m: ViewMapping) -> None:
        assert self.press_px is not None
        x0, y0 = m.to_widget(*self.press_px)
        x1, y1 = m.to_widget(*(self.drag_px or self.press_px))
        p.setPen(QPen(QColor(ACCENT), 4))
        p.setBrush(QBrush(QColor(255, 255, 255, 200)))
        p.drawEllipse(QPointF(x0, y0), 12 * self.theme.scale, 12 * self.theme.scale)
        if math.hypot(x1 - x0, y1 - y0) > 3:
            p.drawLine(QPointF(x0, y0), QPointF(x1, y1))
            a = math.atan2(-(y1 - y0), x1 - x0)
            p.setBrush(QBrush(QColor(ACCENT)))
            p.drawPolygon(heading_polygon(x1, y1, 16 * self.theme.scale, a))
