"""Tour editing (qt/tour_editing.py) on a fake screen: the editor, what is sent, the tour store's answers."""

from __future__ import annotations

import pytest
from gui_fakes import FakeScreen

from gidabot_gui.core.i18n import Translator
from gidabot_gui.core.model import TourInfo
from gidabot_gui.qt.tour_editing import EDIT_RESULT_TIMEOUT, TourEditController, TourEditScreen
from gidabot_navigation.tours.tour_store import EditResultData

TOUR = TourInfo("real_world.tour", "Real-world tour", "es",
                ((0, "014", "Technicians' Lab"), (1, "101", "Secretary's Office")))


@pytest.fixture
def editing(qapp, faculty, locale_dir) -> tuple[FakeScreen, TourEditController]:
    """(fake screen, controller) of Kbot's screen, admin mode unlocked, TOUR in the catalog."""
    screen = FakeScreen(faculty, "Kbot", Translator("en", locale_dir), tours=(TOUR,))
    screen.admin_unlocked = True
    return screen, TourEditController(screen, faculty, "Kbot", "gui-test")


def test_the_window_and_the_fake_are_tour_edit_screens(make_gui, editing) -> None:
    assert isinstance(editing[0], TourEditScreen)
    assert isinstance(make_gui("Kbot").window, TourEditScreen)


def test_nothing_is_edited_while_admin_mode_is_locked(editing) -> None:
    screen, ctl = editing
    screen.admin_unlocked = False
    ctl.open_editor(None)
    ctl.confirm_delete("real_world.tour")
    assert screen.popup == "" and ctl.editor is None


def test_a_new_tour_is_sent_only_once_valid(editing) -> None:
    screen, ctl = editing
    ctl.open_editor(None)
    card = screen.top.card()
    assert screen.popup == "editor" and card.title == "New tour" and card.full and card.extra is ctl.editor
    editor = ctl.editor
    editor.save.emit()                                         # no name, no stops
    assert not screen.outputs.edits and editor.error.text().startswith("Not saved: ")
    editor.name.setText("Open day")
    editor._name_edited("Open day")
    editor._add("014")
    editor.save.emit()
    (edit,) = screen.outputs.edits
    assert edit.uid.startswith("Kbot/gui-test/tour-edit/")
    assert (edit.file_name, edit.tour_name, edit.language, edit.goal_lines) == (
        "open_day.tour", "Open day", "en", ("0, 014, Computer Technicians 1",))
    assert screen.popup == "edit_pending" and screen.top.card().body == "Open day"


def test_the_store_answer_to_the_edit_sent_is_shown(editing) -> None:
    screen, ctl = editing
    ctl.open_editor("real_world.tour")
    editor = ctl.editor
    assert screen.top.card().title == "Edit tour" and editor.file.isReadOnly()
    assert editor.draft.language == "es" and len(editor.draft.goals) == 2
    editor.save.emit()
    edit = screen.outputs.edits[-1]
    ctl.on_result(EditResultData("someone/else/tour-edit/1", "real_world.tour", False, True))
    assert screen.popup == "edit_pending"                      # not the answer to ours
    ctl.on_result(EditResultData(edit.uid, "real_world.tour", False, True, 7))
    assert screen.popup == "edit_result" and screen.top.card().title == "Tour saved"
    assert screen.top.card().body == "real_world.tour: shared with the other robots."
    ctl.open_editor("real_world.tour")
    ctl.editor.save.emit()
    ctl.on_result(EditResultData(screen.outputs.edits[-1].uid, "real_world.tour", False, False, 0, "in_the_way",
                                 "a directory has that name"))
    card = screen.top.card()
    assert (card.title, card.body, card.tone) == ("The tour store refused it",
                                                  "real_world.tour: a directory has that name", "error")


def test_delete_asks_first(editing) -> None:
    screen, ctl = editing
    ctl.confirm_delete("no_such.tour")
    assert screen.popup == ""
    ctl.confirm_delete("real_world.tour")
    assert screen.popup == "confirm_delete" and screen.top.card().body == "Real-world tour"
    screen.top.press("back")
    assert screen.popup == "" and not screen.outputs.edits
    ctl.confirm_delete("real_world.tour")
    screen.top.press("delete")
    (edit,) = screen.outputs.edits
    assert edit.deleted and (edit.file_name, edit.language) == ("real_world.tour", "es")
    ctl.on_result(EditResultData(edit.uid, "real_world.tour", True, True))
    assert screen.top.card().title == "Tour deleted"


def test_no_answer_from_the_store(editing) -> None:
    screen, ctl = editing
    ctl.confirm_delete("real_world.tour")
    screen.top.press("delete")
    ctl.tick(screen.now + EDIT_RESULT_TIMEOUT - 1)
    assert screen.popup == ""
    ctl.tick(screen.now + EDIT_RESULT_TIMEOUT + 1)
    assert screen.popup == "edit_result" and screen.top.card().title == "No answer"
    ctl.tick(screen.now + 2 * EDIT_RESULT_TIMEOUT)             # said once
    assert len(screen.messages) == 1
