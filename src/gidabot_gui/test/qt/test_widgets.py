"""Touch widgets (qt/widgets.py): texts that wrap and shrink instead of being cut, one font per row of tabs,
buttons in as many columns as fit, the on-screen keyboard."""

from __future__ import annotations

import pytest
from PyQt5.QtCore import QRect
from PyQt5.QtGui import QFont
from PyQt5.QtWidgets import QLineEdit, QWidget

from gidabot_gui.qt.widgets import (
    MIN_FONT_RATIO,
    WRAP,
    ButtonGrid,
    FitLabel,
    Keyboard,
    WrapButton,
    equalize_fonts,
    fit_font,
)

LONG = "Laboratorio de Robótica y Sistemas Autónomos Inteligentes"


def font(px: int) -> QFont:
    f = QFont("DejaVu Sans")
    f.setPixelSize(px)
    return f


def test_fit_font_keeps_the_size_that_fits_and_shrinks_what_does_not(qapp) -> None:
    f, ok = fit_font(font(18), QRect(0, 0, 400, 60), "Dean's Office", WRAP, 2)
    assert ok and f.pixelSize() == 18
    f, ok = fit_font(font(18), QRect(0, 0, 260, 40), LONG, WRAP, 2)
    assert ok and int(18 * MIN_FONT_RATIO) <= f.pixelSize() < 18
    f, ok = fit_font(font(18), QRect(0, 0, 60, 20), LONG, WRAP, 2)
    assert not ok and f.pixelSize() == max(9, int(18 * MIN_FONT_RATIO))     # the smallest tried


def shown(*widgets: QWidget) -> QWidget:
    parent = QWidget()
    for w in widgets:
        w.setParent(parent)
    parent.show()
    return parent


def test_a_button_wraps_its_label_and_says_when_even_that_is_cut(qapp) -> None:
    ok = WrapButton(LONG, role="primary", key="ok")
    cut = WrapButton(LONG * 3, key="cut")
    parent = shown(ok, cut)
    ok.setGeometry(0, 0, 300, 60)
    cut.setGeometry(0, 70, 120, 40)
    parent.grab()                                              # paint: the fit is decided while painting
    assert not ok.clipped and cut.clipped
    ok.setText("Go")
    parent.grab()
    assert ok.text() == "Go" and ok.accessibleName() == "Go" and not ok.clipped
    assert ok.sizeHint().height() >= ok.min_height == 60


def test_tabs_share_the_font_the_longest_needs(qapp) -> None:
    short, long_ = WrapButton("Offices", role="nav"), WrapButton("Informazioa eta laguntza", role="nav")
    parent = shown(short, long_)
    for i, b in enumerate((short, long_)):
        b.setGeometry(i * 130, 0, 120, 60)
        b.max_lines = 1
    alone = (short.fitted_pixel_size(), long_.fitted_pixel_size())
    assert alone[1] < alone[0]
    equalize_fonts([short, long_])
    assert short.font_cap == long_.font_cap == alone[1]
    equalize_fonts([short, long_], floor=alone[1] + 2)       # never below the floor: the long one shrinks alone
    assert short.font_cap == alone[1] + 2
    parent.close()


def test_a_label_shrinks_to_its_lines_and_says_when_cut(qapp) -> None:
    fits, cut = FitLabel(LONG, size="base", max_lines=2), FitLabel(LONG * 4, size="big", max_lines=1)
    parent = shown(fits, cut)
    fits.setGeometry(0, 0, 300, 60)
    cut.setGeometry(0, 70, 150, 30)
    parent.grab()
    assert not fits.clipped and cut.clipped
    fits.setText("Ready")
    assert fits.text() == "Ready" and fits.accessibleName() == "Ready"


@pytest.mark.parametrize(("height", "columns"), [(400, 1), (140, 2), (60, 2)])      # 60: too low even so, scrolls
def test_a_grid_uses_as_many_columns_as_it_needs_to_fit(qapp, height: int, columns: int) -> None:
    grid = ButtonGrid(max_columns=2, min_width=110)
    grid.available_height = height
    grid.set_buttons([WrapButton(f"Room {i}", key=str(i)) for i in range(4)])
    grid.resize(300, height)
    assert grid._columns(300) == columns
    rows = -(-4 // columns)
    assert grid.needed_height(300) == rows * grid.row_height + (rows - 1) * grid.spacing
    boxes = [b.geometry() for b in grid.buttons]
    assert not any(a.intersects(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    assert len({b.x() for b in boxes}) == columns


def test_a_narrow_grid_stays_in_one_column(qapp) -> None:
    grid = ButtonGrid(max_columns=3, min_width=110)
    grid.set_buttons([WrapButton(str(i)) for i in range(9)])
    assert grid._columns(200) == 1                               # two columns would be under 110 px each


def test_the_keyboard_types_shifts_once_erases_and_is_done(qapp) -> None:
    field = QLineEdit()
    kb = Keyboard(lambda text: f"<{text}>")
    kb.target = field
    done: list[bool] = []
    kb.done.connect(lambda: done.append(True))
    kb.shift_key.click()
    for ch in "kbot":
        kb.keys[ch].click()
    kb.space_key.click()
    kb.keys["1"].click()
    assert field.text() == "Kbot 1" and not kb.shift and kb.keys["a"].text() == "a"
    kb.back_key.click()
    assert field.text() == "Kbot "
    kb.done_key.click()
    assert done == [True]
    assert kb.space_key.text() == "<Space>" and kb.done_key.text() == "<Done>"    # through the translator
    kb.set_key_height(40)
    assert all(b.is_key and b.minimumHeight() == 40 for b in kb.all_keys())
