"""A portrait plan (a tall, narrow building: tower.py) uses the floor tab's space at 800x480 and 1280x800: it is
turned a quarter turn, and taps, robots and Set location still land where they should.

Saves docs/screenshots/floor0-portrait-<size>.png.
"""

from __future__ import annotations

import math

import pytest
from PyQt5.QtCore import QPoint, Qt
from PyQt5.QtTest import QTest
from tower import make_tower

from gidabot_gui.qt.floor_view import TURN_GAIN, ViewMapping
from gidabot_navigation.building.model import load_building
from gidabot_navigation.guiding.messages import RobotStatusData


@pytest.fixture(scope="module")
def tower(tmp_path_factory: pytest.TempPathFactory):
    return load_building(make_tower(tmp_path_factory.mktemp("tower")))


@pytest.mark.parametrize("size", [(800, 480), (1280, 800)], ids=["800x480", "1280x800"])
def test_a_portrait_plan_fills_the_floor_tab(make_gui, tower, text_problems, size: tuple[int, int]) -> None:
    gui = make_gui("Tower0", size=size, building=tower)
    gui.feed_all_status(tower)
    w = gui.window
    w.show_page("floor:0")
    gui.process()
    view = w.floor_pages[0.0].view
    iw, ih = view.image.width(), view.image.height()
    assert ih > 2 * iw                                            # the blueprint is a portrait one
    m = view.mapping()
    plan_w, plan_h = m.size(iw, ih)
    upright = min(view.width() / iw, view.height() / ih)
    print(f"\n{size[0]}x{size[1]}: view {view.width()}x{view.height()} px, plan drawn {plan_w:.0f}x{plan_h:.0f} px "
          f"(scale {m.k:.2f}; upright it would be {iw * upright:.0f}x{ih * upright:.0f}, scale {upright:.2f})")
    gui.shot(f"floor0-portrait-{size[0]}x{size[1]}")
    assert m.turned and m.k >= TURN_GAIN * upright
    assert plan_w * plan_h >= 0.5 * view.width() * view.height()   # upright it covered 17% (800x480)
    assert max(plan_w / view.width(), plan_h / view.height()) > 0.99
    assert not text_problems(w)


def test_the_turned_mapping_round_trips_and_turns_headings() -> None:
    m = ViewMapping.fit(272, 688, 513, 217)
    assert m.turned
    for u, v in ((0.0, 0.0), (272.0, 688.0), (100.5, 20.25)):
        assert m.to_blueprint(*m.to_widget(u, v)) == pytest.approx((u, v))
    (x0, y0), (x1, _) = m.to_widget(0.0, 0.0), m.to_widget(272.0, 0.0)
    assert x0 == pytest.approx(x1) and y0 > m.to_widget(272.0, 0.0)[1]   # the top edge is on the left
    assert m.angle(0.0) == pytest.approx(math.pi / 2)                   # east on the plan points up
    assert not ViewMapping.fit(1200, 432, 513, 217).turned              # the faculty stays as it is
    assert not ViewMapping.fit(300, 400, 513, 400).turned               # nearly square: not worth turning


def test_taps_robots_and_set_location_on_a_turned_plan(make_gui, tower) -> None:
    gui = make_gui("Tower0", building=tower, admin_password="x")
    w = gui.window
    gui.feed_all_status(tower)
    w.show_page("floor:0")
    gui.process()
    page = w.floor_pages[0.0]
    view, tf = page.view, tower.floor(0).transform
    m = view.mapping()
    assert m.turned
    loc = tower.location("0E3")
    x, y = m.to_widget(*tf.to_pixel(loc.pose.x + 1.5, loc.pose.y))     # inside room 0E3
    QTest.mouseClick(view, Qt.LeftButton, pos=QPoint(round(x), round(y)))
    gui.process()
    assert w.overlay.name == "confirm" and "0E3" in w.overlay.title.text()
    gui.press("back")
    # the robot, seen heading north (yaw pi/2), is drawn heading left on the turned plan
    w.feed("status", RobotStatusData("Tower0", 0.0, 7.0, 16.0, math.pi / 2, 0.0, 0.0, 0.9, "idle", 0, "", 0.0))
    gui.process()
    assert m.angle(tf.yaw_to_pixel_angle(math.pi / 2)) == pytest.approx(math.pi)
    # Set location: press at (7, 10), drag towards the plan's north (left on the screen): yaw pi/2
    w.admin.unlock()
    gui.click(w.set_location_btn)
    m = view.mapping()
    x0, y0 = m.to_widget(*tf.to_pixel(7.0, 10.0))
    x1, y1 = m.to_widget(*tf.to_pixel(7.0, 12.0))
    assert x1 < x0 and abs(y1 - y0) < 1
    QTest.mousePress(view, Qt.LeftButton, pos=QPoint(round(x0), round(y0)))
    QTest.mouseMove(view, QPoint(round(x1), round(y1)))
    QTest.mouseRelease(view, Qt.LeftButton, pos=QPoint(round(x1), round(y1)))
    gui.process()
    gui.click(page.apply_btn)
    (pose,) = gui.out.poses
    px = 1.0 / (tf.scale * m.k)
    assert (pose.x, pose.y) == (pytest.approx(7.0, abs=px), pytest.approx(10.0, abs=px))
    assert pose.yaw == pytest.approx(math.pi / 2, abs=0.05)
