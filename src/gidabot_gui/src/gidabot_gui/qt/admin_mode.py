"""Admin mode on the touch screen (Qt thread): the part of the window that unlocks it and sets the location.

Admin mode exists only when the node was given a password hash (``GuiConfig.admin``).
The Admin button asks for the password (wrong ones refused, repeated ones locked out by
:class:`~gidabot_gui.core.admin.PasswordCheck`); Lock leaves admin mode. Set location:
press the robot's position on this floor's blueprint, drag towards where it faces, Apply
publishes ``initialpose`` (:func:`~gidabot_gui.core.admin.pose_from_drag`). What it needs of
the window is :class:`AdminScreen`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol, runtime_checkable

from gidabot_gui.core.admin import PasswordCheck, pose_from_drag
from gidabot_gui.core.i18n import format_number
from gidabot_gui.core.model import Fleet, InitialPose
from gidabot_gui.qt.editor import PasswordPanel
from gidabot_gui.qt.overlay import CardSpec
from gidabot_gui.qt.screen import Services
from gidabot_navigation.building.model import Floor


@runtime_checkable
class AdminScreen(Services, Protocol):
    """What admin mode needs of the screen (:class:`~gidabot_gui.qt.window.MainWindow` is one)."""

    fleet: Fleet
    log: Callable[[str], None]

    def push_popup(self, name: str, build: Callable[[], CardSpec], pressed: Callable[[str], None]) -> None:
        """Show a card over the one on screen (:meth:`pop_popup` brings that back)."""

    def pop_popup(self) -> None: ...

    def rebuild_popup(self) -> None:
        """Build the card on screen again (its builder's answer changed)."""

    def show_message(self, name: str, title: Callable[[], str], body: Callable[[], str], tone: str) -> None:
        """A pop-up with OK that closes by itself."""

    def set_location_mode(self, on: bool) -> None:
        """This robot's floor page (shown first) taking a pose dragged on its blueprint, or back to normal."""

    def changed(self) -> None:
        """Admin mode was entered or left: bring what is shown up to date."""


class AdminController:
    """Admin password, Lock and Set location of robot ``robot`` on its ``floor`` (see the module docstring).

    ``check`` is None when there is no admin mode at all.
    """

    def __init__(self, screen: AdminScreen, check: PasswordCheck | None, robot: str, floor: Floor) -> None:
        self.screen = screen
        self.check = check
        self.robot = robot
        self.floor = floor
        self.unlocked = False
        self.pending_pose: InitialPose | None = None
        self.password_panel: PasswordPanel | None = None

    def pressed(self) -> None:
        """The Admin / Lock button."""
        check = self.check
        if check is None:
            return
        if self.unlocked:
            self.lock()
            return
        s = self.screen
        panel = PasswordPanel(s.tr, s.theme)
        state = {"wrong": False}

        def build() -> CardSpec:
            t = s.tr
            panel.retranslate()
            if state["wrong"]:
                locked = check.locked_for(s.clock())
                title = (t._("Too many attempts: wait {s} s").format(s=int(math.ceil(locked))) if locked > 0
                         else t._("Wrong password"))
                return CardSpec(title, "", "error", "lock", [], extra=panel, wide=True)
            return CardSpec(t._("Administrator password"), "", "action", "lock", [], extra=panel, wide=True)

        def submitted(password: str) -> None:
            if check.check(password, s.clock()):
                s.pop_popup()
                self.unlock()
            else:
                s.log("gui: wrong administrator password")
                state["wrong"] = True
                panel.field.clear()
                s.rebuild_popup()

        panel.submitted.connect(submitted)
        panel.back.connect(s.pop_popup)
        s.push_popup("password", build, lambda _k: s.pop_popup())
        self.password_panel = panel

    def unlock(self) -> None:
        if self.check is None:
            return
        self.unlocked = True
        self.screen.changed()

    def lock(self) -> None:
        self.unlocked = False
        self._stop_set_location()
        self.screen.changed()

    # ------------------------------------------------------------------ Set location
    def start_set_location(self) -> None:
        if not self.unlocked:
            return
        self.pending_pose = None
        self.screen.set_location_mode(True)

    def pose_dragged(self, u0: float, v0: float, u1: float, v1: float) -> None:
        """A press at (u0, v0) dragged to (u1, v1), blueprint pixels: the pose Apply will send."""
        if not self.unlocked:
            return
        live = self.screen.fleet.robots[self.robot]
        default_yaw = live.pose[2] if live.pose is not None else 0.0
        self.pending_pose = pose_from_drag(self.floor.transform, self.floor.id, (u0, v0), (u1, v1),
                                           default_yaw=default_yaw)

    def set_location_done(self, apply: bool) -> None:
        """Apply (``apply``) or Cancel of Set location."""
        s = self.screen
        pose = self.pending_pose
        self._stop_set_location()
        if apply and pose is not None and self.unlocked:
            s.outputs.send_initial_pose(pose)
            lang = s.tr.language
            s.show_message("location_sent", lambda: s.tr._("Location sent"),
                           lambda: s.tr._("x = {x} m, y = {y} m, heading {deg}°").format(
                               x=format_number(pose.x, 2, lang), y=format_number(pose.y, 2, lang),
                               deg=int(round(math.degrees(pose.yaw)))), "success")

    def _stop_set_location(self) -> None:
        self.pending_pose = None
        self.screen.set_location_mode(False)
