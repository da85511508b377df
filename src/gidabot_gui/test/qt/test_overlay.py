"""Pop-up cards (qt/overlay.py): what a card shows, its buttons, closing by itself, cards over cards."""

from __future__ import annotations

import pytest
from gui_fakes import wait_until
from PyQt5.QtCore import Qt
from PyQt5.QtTest import QTest
from PyQt5.QtWidgets import QLineEdit, QWidget

from gidabot_gui.qt.overlay import Button, CardSpec, Overlay
from gidabot_gui.qt.theme import TONES


@pytest.fixture
def overlay(qapp):
    parent = QWidget()
    parent.resize(800, 400)
    ov = Overlay(parent)
    ov.setGeometry(parent.rect())
    parent.show()
    qapp.processEvents()
    yield ov
    parent.close()
    parent.deleteLater()


def card(title: str, *keys: str, **kw) -> CardSpec:
    return CardSpec(title, kw.pop("body", "the body"), buttons=[Button(k, k.upper()) for k in keys], **kw)


def test_a_card_shows_its_texts_and_buttons_and_taps_reach_its_handler(overlay, qapp) -> None:
    pressed: list[str] = []
    changed: list[bool] = []
    overlay.changed.connect(lambda: changed.append(True))
    overlay.show_card("confirm", lambda: card("Where to", "go", "back", tone="error", note="walk behind"),
                      pressed.append)
    qapp.processEvents()
    assert overlay.showing and overlay.name == "confirm" and changed
    assert (overlay.title.text(), overlay.body.text(), overlay.note_text.text()) == ("Where to", "the body",
                                                                                     "walk behind")
    assert overlay.note.isVisible() and TONES["error"] in overlay.title.styleSheet()
    assert list(overlay.buttons) == ["go", "back"] and overlay.buttons["go"].text() == "GO"
    QTest.mouseClick(overlay.buttons["back"], Qt.LeftButton)
    assert pressed == ["back"]
    assert overlay.showing                                     # the handler decides what closes
    overlay.close_card()
    assert not overlay.showing and overlay.name == "" and not overlay.isVisible()


def test_a_card_without_body_or_note_hides_them(overlay) -> None:
    overlay.show_card("plain", lambda: card("Only a title", body=""), lambda _k: None)
    assert not overlay.body.isVisibleTo(overlay) and not overlay.note.isVisibleTo(overlay)


def test_a_card_closes_by_itself_after_auto_close(overlay, qapp) -> None:
    overlay.show_card("info", lambda: card("Soon gone", "ok"), lambda _k: None, auto_close=0.05)
    assert overlay.showing
    assert wait_until(qapp, lambda: not overlay.showing, 5.0)


def test_a_card_is_built_again_in_the_new_language(overlay) -> None:
    words = {"lang": "en"}
    overlay.show_card("greeting", lambda: card("Hello" if words["lang"] == "en" else "Kaixo", "ok"),
                      lambda _k: None)
    words["lang"] = "eu"
    overlay.retranslate()
    assert overlay.title.text() == "Kaixo"


def test_a_card_pushed_over_another_brings_it_back_with_its_widget(overlay) -> None:
    field = QLineEdit("typed")
    overlay.show_card("search", lambda: card("Search", extra=field, wide=True), lambda _k: None)
    overlay.push_card("language", lambda: card("Language", "en", "eu"), lambda _k: None)
    assert overlay.name == "language" and not field.isVisible()
    overlay.pop_card()
    assert overlay.name == "search" and field.isVisible() and field.text() == "typed"
    overlay.pop_card()                                         # nothing under it: closed
    assert not overlay.showing


def test_closing_forgets_the_cards_under(overlay) -> None:
    overlay.show_card("a", lambda: card("A"), lambda _k: None)
    overlay.push_card("b", lambda: card("B"), lambda _k: None)
    overlay.close_card()
    overlay.pop_card()
    assert not overlay.showing


def test_wide_and_full_cards_ask_for_more_of_the_window(overlay) -> None:
    asked: list[tuple[bool, bool]] = []
    overlay.resized_for_full.connect(lambda: asked.append((overlay.wide, overlay.full)))
    overlay.show_card("editor", lambda: card("Editor", wide=True, full=True), lambda _k: None)
    assert asked == [(True, True)]
    geometry = overlay.card.geometry()
    assert geometry.width() == overlay.width() - 2 * overlay.theme.px(8)      # the whole width
    overlay.close_card()
    assert asked[-1] == (False, False)
    overlay.show_card("small", lambda: card("Small", "ok"), lambda _k: None)
    assert overlay.card.width() < overlay.width() and len(asked) == 2          # centred, no change asked
