"""A floor's blueprint (qt/floor_view.py): fitting and turning it, taps and drags in map terms, what is drawn."""

from __future__ import annotations

import math

import pytest
from PyQt5.QtCore import QPoint, Qt
from PyQt5.QtGui import QColor
from PyQt5.QtTest import QTest

from gidabot_gui.qt.floor_view import FloorView, RobotMark, ViewMapping
from gidabot_gui.qt.theme import ACCENT, OFFLINE, OTHER_ROBOT


def test_a_wide_plan_is_fitted_upright_and_centred() -> None:
    m = ViewMapping.fit(400, 200, 800, 200)
    assert (m.k, m.ox, m.oy, m.turned) == (1.0, 200.0, 0.0, False)
    assert m.to_widget(0, 0) == (200.0, 0.0) and m.size(400, 200) == (400.0, 200.0)
    assert m.angle(0.3) == 0.3


def test_a_tall_plan_on_a_wide_screen_is_turned_its_top_edge_on_the_left() -> None:
    m = ViewMapping.fit(100, 400, 800, 200)                       # upright it would be drawn at scale 0.5
    assert m.turned and m.k == 2.0 and (m.ox, m.oy) == (0.0, 0.0)
    assert m.to_widget(0, 0) == (0.0, 200.0)                      # the plan's top-left: the widget's bottom-left
    assert m.to_widget(100, 0) == (0.0, 0.0)
    assert m.size(100, 400) == (800.0, 200.0)
    assert m.angle(0.0) == pytest.approx(math.pi / 2)             # the plan's +u points up
    for u, v in ((0, 0), (13.5, 250.0), (100, 400)):
        assert m.to_blueprint(*m.to_widget(u, v)) == pytest.approx((u, v))


def test_a_plan_a_little_taller_stays_upright() -> None:
    assert not ViewMapping.fit(200, 300, 400, 300).turned          # turning would gain less than TURN_GAIN


@pytest.fixture
def view(qapp, faculty):
    v = FloorView(faculty.floor(1))
    v.resize(700, 320)
    v.show()
    qapp.processEvents()
    yield v
    v.close()
    v.deleteLater()


def click_at(view: FloorView, x: float, y: float) -> None:
    wx, wy = view.map_to_widget(x, y)
    QTest.mouseClick(view, Qt.LeftButton, pos=QPoint(round(wx), round(wy)))


def test_a_tap_is_told_in_map_metres(view) -> None:
    taps: list[tuple[float, float]] = []
    view.location_tapped.connect(lambda x, y: taps.append((x, y)))
    click_at(view, 20.0, 12.0)
    px = 1.0 / (view.floor.transform.scale * view.mapping().k)    # one widget pixel in metres
    assert taps == [(pytest.approx(20.0, abs=px), pytest.approx(12.0, abs=px))]


def test_setting_the_pose_a_drag_is_told_in_blueprint_pixels_and_no_tap(view) -> None:
    taps: list = []
    drags: list[tuple[float, ...]] = []
    view.location_tapped.connect(lambda *a: taps.append(a))
    view.pose_dragged.connect(lambda *a: drags.append(a))
    view.set_setting_pose(True)
    tf = view.floor.transform
    a = view.map_to_widget(20.0, 12.0)
    b = view.map_to_widget(23.0, 12.0)
    QTest.mousePress(view, Qt.LeftButton, pos=QPoint(round(a[0]), round(a[1])))
    QTest.mouseMove(view, QPoint(round(b[0]), round(b[1])))
    QTest.mouseRelease(view, Qt.LeftButton, pos=QPoint(round(b[0]), round(b[1])))
    (drag,) = drags
    one_px = 1.0 / view.mapping().k                               # one widget pixel in blueprint pixels
    assert drag == pytest.approx((*tf.to_pixel(20.0, 12.0), *tf.to_pixel(23.0, 12.0)), abs=one_px)
    assert not taps
    view.set_setting_pose(False)
    click_at(view, 20.0, 12.0)
    assert len(taps) == 1 and len(drags) == 1


def pixel(view: FloorView, x: float, y: float) -> str:
    image = view.grab().toImage()
    return QColor(image.pixel(round(x), round(y))).name().upper()


def test_robots_are_drawn_where_they_are_in_their_colours(view) -> None:
    view.set_robots([RobotMark("Kbot", 15.0, 10.0, 0.0, 0.3, True, False, "Kbot · You are here"),
                     RobotMark("Basajaun", 40.0, 10.0, 0.0, 0.3, False, False, "Basajaun"),
                     RobotMark("Lamia", 65.0, 10.0, 0.0, 0.3, False, True, "Lamia · offline")])
    radius = max(11.0 * view.theme.scale, 0.3 * view.floor.transform.scale * view.mapping().k)
    for x, colour in ((15.0, ACCENT), (40.0, OTHER_ROBOT), (65.0, OFFLINE)):
        wx, wy = view.map_to_widget(x, 10.0)
        assert pixel(view, wx, wy + 0.75 * radius) == colour       # the disc, beside its heading mark
    view.set_robots([])
    wx, wy = view.map_to_widget(40.0, 10.0)
    assert pixel(view, wx, wy + 0.75 * radius) != OTHER_ROBOT


def test_the_goal_is_a_red_pin_standing_on_it(view) -> None:
    view.set_goal((40.0, 10.0))
    wx, wy = view.map_to_widget(40.0, 10.0)
    s = 16.0 * view.theme.scale
    assert pixel(view, wx, wy - 1.0 * s) == "#C0392B"
    view.set_goal(None)
    assert pixel(view, wx, wy - 1.0 * s) != "#C0392B"


def test_keep_out_zones_are_drawn_for_admins_only(qapp, faculty) -> None:
    """A floor's keep-out zones (building file key keep_out) are hatched in red in admin mode, not shown to
    visitors."""
    from dataclasses import replace

    from gidabot_gui.qt.theme import DANGER
    from gidabot_navigation.building.geometry import Polygon
    from gidabot_navigation.building.model import KeepOut

    zone = KeepOut("stairs_top", Polygon(((50.0, 14.0), (56.0, 14.0), (56.0, 20.0), (50.0, 20.0))))
    v = FloorView(replace(faculty.floor(1), keep_out=(zone,)))
    v.resize(700, 320)
    v.show()
    qapp.processEvents()
    try:
        points = [v.map_to_widget(x / 4, y / 4) for x in range(201, 224, 2) for y in range(58, 78, 2)]
        outside = [v.map_to_widget(x, 17.0) for x in (45.0, 58.0)]

        def redness() -> list[int]:
            image = v.grab().toImage()
            return [QColor(image.pixel(round(x), round(y))).red() - QColor(image.pixel(round(x), round(y))).green()
                    for x, y in points + outside]

        before = redness()
        v.set_show_keep_out(True)
        after = redness()
        n = len(points)
        assert all(a > b + 15 for a, b in zip(after[:n], before[:n], strict=True))   # tinted red inside
        assert after[n:] == before[n:]                                                 # nothing outside
        assert any(pixel(v, *xy) == DANGER for xy in points)                           # the hatching
        v.set_show_keep_out(False)
        assert redness() == before
    finally:
        v.close()
        v.deleteLater()
