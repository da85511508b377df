"""Tour editing in admin mode (Qt thread): the part of the window that creates, edits and deletes tours.

New / Edit open the :class:`~gidabot_gui.qt.editor.TourEditor` on a
:class:`~gidabot_gui.core.admin.TourDraft`; Save validates it like a tour file and sends it on
``tour_store/edit`` (nothing is sent while it is invalid); Delete asks first. The tour store's
``edit_result`` with the uid sent is shown, or "No answer" after ``EDIT_RESULT_TIMEOUT`` s.
What it needs of the window is :class:`TourEditScreen`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol, runtime_checkable

from gidabot_gui.core.admin import TourDraft, delete_edit
from gidabot_gui.core.model import TourEdit, TourInfo
from gidabot_gui.errors import TourEditError
from gidabot_gui.qt.editor import TourEditor
from gidabot_gui.qt.overlay import Button, CardSpec
from gidabot_gui.qt.screen import Popups, Services
from gidabot_navigation.building.model import Building
from gidabot_navigation.tours.tour_store import EditResultData

EDIT_RESULT_TIMEOUT = 8.0   # s (wall) to wait for tour_store/edit_result


@runtime_checkable
class TourEditScreen(Services, Popups, Protocol):
    """What tour editing needs of the screen (:class:`~gidabot_gui.qt.window.MainWindow` is one)."""

    @property
    def admin_unlocked(self) -> bool:
        """Admin mode is unlocked: tours may be edited."""

    def tour(self, file_name: str) -> TourInfo | None:
        """The tour of the catalog with this file name."""

    def show_message(self, name: str, title: Callable[[], str], body: Callable[[], str], tone: str) -> None:
        """A pop-up with OK that closes by itself."""


class TourEditController:
    """The admin's tour editor and the tour store's answers (see the module docstring).

    Edits are sent with uid ``<robot>/<visitor_id>/tour-edit/<n>``.
    """

    def __init__(self, screen: TourEditScreen, building: Building, robot: str, visitor_id: str) -> None:
        self.screen = screen
        self.building = building
        self.uid_prefix = f"{robot}/{visitor_id}/tour-edit/"
        self.pending: tuple[str, float, TourEdit] | None = None    # uid, sent at, edit
        self.editor: TourEditor | None = None
        self._seq = 0

    def _next_uid(self) -> str:
        self._seq += 1
        return f"{self.uid_prefix}{self._seq}"

    def _send(self, edit: TourEdit) -> None:
        self.screen.outputs.send_tour_edit(edit)
        self.pending = (edit.uid, self.screen.clock(), edit)

    def open_editor(self, file_name: str | None) -> None:
        """The editor on the catalog's tour ``file_name``, or on a new tour (None)."""
        s = self.screen
        if not s.admin_unlocked:
            return
        tour = s.tour(file_name) if file_name else None
        if tour is not None:
            draft = TourDraft(tour.file_name, tour.name, tour.language or s.tr.language, list(tour.goals),
                              existing=True)
        else:
            draft = TourDraft("", "", s.tr.language, [])
        editor = TourEditor(s.tr, self.building, s.theme, draft)
        self.editor = editor

        def build() -> CardSpec:
            editor.retranslate()
            t = s.tr
            return CardSpec(t._("Edit tour") if draft.existing else t._("New tour"), "", "action", "pencil", [],
                            extra=editor, wide=True, full=True)

        def save() -> None:
            d = editor.collect()
            try:
                edit = d.to_edit(self.building, self._next_uid())
            except TourEditError as err:
                editor.show_error(s.tr._("Not saved: {error}").format(error=str(err)))
                return
            self._send(edit)
            s.close_popup()
            s.show_message("edit_pending", lambda: s.tr._("Saving…"), lambda: d.name or d.file_name, "info")

        editor.save.connect(save)
        editor.closed.connect(s.close_popup)
        s.show_popup("editor", build, lambda _k: s.close_popup())

    def confirm_delete(self, file_name: str) -> None:
        """Ask before deleting the catalog's tour ``file_name``; Delete sends it."""
        s = self.screen
        if not s.admin_unlocked:
            return
        tour = s.tour(file_name)
        if tour is None:
            return

        def build() -> CardSpec:
            t = s.tr
            return CardSpec(t._("Delete this tour?"), tour.title, "warning", "trash",
                            [Button("delete", t._("Delete"), "danger", "trash"), Button("back", t._("Keep it"))])

        def pressed(key: str) -> None:
            s.close_popup()
            if key == "delete":
                self._send(delete_edit(file_name, tour.language or s.tr.language, self._next_uid()))

        s.show_popup("confirm_delete", build, pressed)

    def on_result(self, res: EditResultData) -> None:
        """``tour_store/edit_result``: shown if it answers the edit sent last."""
        if self.pending is None or res.uid != self.pending[0]:
            return
        self.pending = None
        s = self.screen
        name = res.file_name
        if res.ok:
            s.show_message("edit_result", lambda: s.tr._("Tour deleted") if res.deleted else s.tr._("Tour saved"),
                           lambda: s.tr._("{tour}: shared with the other robots.").format(tour=name), "success")
        else:
            s.show_message("edit_result", lambda: s.tr._("The tour store refused it"),
                           lambda: f"{name}: {res.error or res.reason}", "error")

    def tick(self, now: float) -> None:
        """No answer from the tour store in time: say so."""
        if self.pending is not None and now - self.pending[1] > EDIT_RESULT_TIMEOUT:
            self.pending = None
            s = self.screen
            s.show_message("edit_result", lambda: s.tr._("No answer"),
                           lambda: s.tr._("The tour store did not answer. Is it running?"), "error")
