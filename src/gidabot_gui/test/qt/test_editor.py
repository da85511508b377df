"""Text entry panels and the tour editor (qt/editor.py): what they emit and how they change the draft."""

from __future__ import annotations

import pytest
from PyQt5.QtWidgets import QLineEdit

from gidabot_gui.core.admin import TourDraft
from gidabot_gui.core.i18n import Translator
from gidabot_gui.qt.editor import PasswordPanel, SearchPanel, TourEditor
from gidabot_gui.qt.pages import BADGE, KEY, MAIN
from gidabot_gui.qt.theme import Theme


@pytest.fixture
def tr(qapp, locale_dir) -> Translator:
    return Translator("en", locale_dir)


def emitted(signal) -> list:
    got: list = []
    signal.connect(lambda *a: got.append(a[0] if a else None))
    return got


def test_the_password_is_hidden_and_sent_by_unlock_or_done(tr) -> None:
    panel = PasswordPanel(tr, Theme())
    sent, back = emitted(panel.submitted), emitted(panel.back)
    assert panel.field.echoMode() == QLineEdit.Password and panel.keyboard.target is panel.field
    for ch in "robot42":
        panel.keyboard.keys[ch].click()
    panel.unlock.click()
    panel.keyboard.done_key.click()
    panel.back_btn.click()
    assert sent == ["robot42", "robot42"] and back == [None]
    tr.set_language("eu")
    panel.retranslate()
    assert panel.unlock.text() != "Unlock"


def test_search_lists_what_matches_as_it_is_typed(tr, faculty) -> None:
    panel = SearchPanel(tr, faculty, Theme(), "larrea")
    chosen, closed = emitted(panel.chosen), emitted(panel.closed)
    assert panel.results.count() == 1 and panel.results.item(0).data(KEY) == "223"
    panel.field.clear()
    for ch in "lab":
        panel.keyboard.keys[ch].click()
    labs = [panel.results.item(i).data(KEY) for i in range(panel.results.count())]
    assert len(labs) > 1 and "113" in labs
    panel.results.itemClicked.emit(panel.results.item(0))
    assert chosen == [labs[0]]
    panel.field.setText("qqqq")
    assert panel.results.count() == 0 and panel.empty.text() == "No place matches “qqqq”."
    panel.keyboard.done_key.click()
    panel.close_btn.click()
    assert closed == [None, None]


def stops(editor: TourEditor) -> list[tuple[str, str]]:
    """(badge, text) of each stop row."""
    return [(editor.stops.item(i).data(BADGE), editor.stops.item(i).data(MAIN)) for i in range(editor.stops.count())]


def test_a_new_tour_takes_its_file_name_from_its_name(tr, faculty) -> None:
    editor = TourEditor(tr, faculty, Theme(), TourDraft("", "", "en", []))
    assert not editor.file.isReadOnly() and not editor.desc.isEnabled()
    editor.name.setFocus()
    editor._focus(editor.name)
    assert editor.stack.currentIndex() == 2 and editor.keyboard.target is editor.name      # the keyboard
    editor._name_edited("Jornada de puertas abiertas")
    assert editor.file.text() == "jornada_de_puertas_abiertas.tour"
    editor.keyboard.done_key.click()
    assert editor.stack.currentIndex() == 0
    editor.lang_buttons["es"].click()
    assert editor.collect().language == "es" and editor.collect().name == ""   # the field was not typed into


def test_stops_are_added_from_the_building_moved_removed_and_described(tr, faculty) -> None:
    draft = TourDraft("visit.tour", "Visit", "en", [(1, "101", "Secretary")], existing=True)
    editor = TourEditor(tr, faculty, Theme(), draft)
    assert editor.file.isReadOnly() and stops(editor) == [("1", "Secretary (101)")]
    editor.add_btn.click()
    assert editor.stack.currentIndex() == 1
    editor.floor_chips[2].click()
    row = next(i for i in range(editor.picker.count()) if editor.picker.item(i).data(KEY) == "223")
    editor.picker.itemClicked.emit(editor.picker.item(row))
    assert editor.stack.currentIndex() == 0 and draft.goals[-1] == (2, "223", "M. Larrea's Office")
    assert editor.stops.currentRow() == 1
    editor.up_btn.click()
    assert [g[1] for g in draft.goals] == ["223", "101"] and editor.stops.currentRow() == 0
    editor.up_btn.click()                                           # the first stays first
    assert [g[1] for g in draft.goals] == ["223", "101"]
    editor.desc.setText("Larrea")
    editor._desc_edited("Larrea")
    assert draft.goals[0][2] == "Larrea" and stops(editor)[0] == ("1", "Larrea (223)")
    editor.remove_btn.click()
    assert stops(editor) == [("1", "Secretary (101)")]
    editor.show_error("Not saved: bad")
    assert editor.error.text() == "Not saved: bad" and not editor.error.isHidden()
    editor.show_error("")
    assert editor.error.isHidden()


def test_save_and_close_are_told(tr, faculty) -> None:
    editor = TourEditor(tr, faculty, Theme(), TourDraft("", "", "en", []))
    saved, closed = emitted(editor.save), emitted(editor.closed)
    editor.save_btn.click()
    editor.close_btn.click()
    assert saved == [None] and closed == [None]
