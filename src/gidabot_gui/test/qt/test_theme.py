"""The look (qt/theme.py): sizes that follow the screen, the style sheet, text colours, painted icons."""

from __future__ import annotations

import math

import pytest
from PyQt5.QtGui import QColor

from gidabot_gui.qt.theme import (
    FONT_SIZES,
    HEADER_TEXT,
    NAV_TEXT,
    TEXT,
    TOUCH,
    Theme,
    heading_polygon,
    icon,
    icon_pixmap,
)
from gidabot_gui.qt.visitor import NOTICE_ICONS

ICONS = ("pin", "route", "globe", "lock", "unlock", "stairs", "lift", "robot", "search", "close", "play", "restart",
         "skip", "check", "target", "plus", "minus", "trash", "pencil", "up", "down", "keyboard", "info",
         "warning", "walk", "flag")


@pytest.mark.parametrize(("size", "scale"), [((800, 480), 1.0), ((640, 400), 1.0), ((1280, 800), 1.36),
                                             ((1920, 1080), 1.48), ((4000, 4000), 1.48)])
def test_sizes_grow_with_the_screen_up_to_a_ceiling(size: tuple[int, int], scale: float) -> None:
    assert Theme.for_size(*size).scale == scale


def test_text_and_touch_targets_scale_together() -> None:
    small, big = Theme(), Theme.for_size(1280, 800)
    assert {s: small.font(s) for s in FONT_SIZES} == FONT_SIZES
    assert big.font("base") == round(18 * 1.36) and big.touch == round(TOUCH * 1.36) > small.touch == TOUCH
    with pytest.raises(KeyError):
        small.font("huge")


def test_the_style_sheet_uses_the_sizes_of_its_scale() -> None:
    sheet = Theme.for_size(1280, 800).style_sheet()
    assert "font-size: 24px" in sheet and "QLabel#title { font-size: 37px; font-weight: bold; }" in sheet
    assert "font-size: 18px" in Theme().style_sheet()


def test_button_texts_are_readable_on_their_background() -> None:
    t = Theme()
    assert t.text_color("primary") == t.text_color("danger") == QColor(HEADER_TEXT)
    assert t.text_color("nav") == QColor(NAV_TEXT) and t.text_color("") == QColor(TEXT)


@pytest.mark.parametrize("name", ICONS)
def test_every_icon_is_drawn_in_its_colour(qapp, name: str) -> None:
    image = icon_pixmap(name, "#B3261E", 48).toImage()
    painted = [QColor(image.pixel(x, y)) for x in range(48) for y in range(48) if QColor(image.pixel(x, y)).alpha()]
    assert len(painted) > 48, f"{name} is (almost) empty"
    assert any(c.name().upper() == "#B3261E" for c in painted)
    assert not icon(name).isNull()


def test_the_icons_the_screen_uses_exist(qapp) -> None:
    assert set(NOTICE_ICONS.values()) <= set(ICONS)
    with pytest.raises(KeyError):
        icon_pixmap("teapot")


def test_a_heading_mark_points_along_its_angle() -> None:
    tip = heading_polygon(100.0, 50.0, 20.0, math.pi / 2)[0]       # up: y decreases on screen
    assert (tip.x(), tip.y()) == (pytest.approx(100.0), pytest.approx(50.0 - 19.0))
    tip = heading_polygon(100.0, 50.0, 20.0, 0.0)[0]
    assert (tip.x(), tip.y()) == (pytest.approx(119.0), pytest.approx(50.0))
