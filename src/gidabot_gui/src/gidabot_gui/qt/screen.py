"""What the parts of the main window share of what they need of it (Protocols; MainWindow satisfies them).

Each part (:mod:`~gidabot_gui.qt.visitor`, :mod:`~gidabot_gui.qt.admin_mode`,
:mod:`~gidabot_gui.qt.tour_editing`) states its own Protocol of the window, built on these: it
never imports the window, and its tests give it a small fake instead.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from gidabot_gui.core.i18n import Translator
from gidabot_gui.core.model import Outputs
from gidabot_gui.qt.overlay import CardSpec
from gidabot_gui.qt.theme import Theme


class Services(Protocol):
    """What every part uses: the language, the look, where messages go, wall time."""

    tr: Translator
    theme: Theme
    outputs: Outputs
    clock: Callable[[], float]


class Popups(Protocol):
    """Showing and closing a pop-up card."""

    def show_popup(self, name: str, build: Callable[[], CardSpec], pressed: Callable[[str], None],
                   auto_close: float = 0.0) -> None:
        """Show the card ``build`` makes (again at each language switch); ``pressed(key)`` on a tap; closed after
        ``auto_close`` s (0: stays)."""

    def close_popup(self) -> None: ...
