"""Admin mode on the touch screen (Qt thread): the part of the window that unlocks it and sets the location.

Admin mode exists only when the node was given a password hash (``GuiConfig.admin``).
The Admin button asks for the password (wrong ones refused, repeated ones locked out by
:class:`~gidabot_gui.core.admin.PasswordCheck`); Lock leaves admin mode. Set location:
press the robot's position on this floor's blueprint, drag towards where it faces, Apply
publishes ``initialpose`` (:func:`~gidabot_gui.core.admin.pose_from_drag`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from gidabot_gui.core.admin import pose_from_drag
from gidabot_gui.core.i18n import format_number
from gidabot_gui.core.model import InitialPose
from gidabot_gui.qt.editor import PasswordPanel
from gidabot_gui.qt.overlay import CardSpec

if TYPE_CHECKING:
    from gidabot_gui.qt.window import MainWindow


class AdminController:
    """Admin password, Lock and Set location (see the module docstring)."""

    def __init__(self, screen: MainWindow) -> None:
        self.screen = screen
        self.check = screen.config.admin           # None: no admin mode at all
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
                s.overlay.pop_card()
                self.unlock()
            else:
                s.log("gui: wrong administrator password")
                state["wrong"] = True
                panel.field.clear()
                s.overlay.retranslate()

        panel.submitted.connect(submitted)
        panel.back.connect(s.overlay.pop_card)
        s.overlay.push_card("password", build, lambda _k: s.overlay.pop_card())
        self.password_panel = panel

    def unlock(self) -> None:
        if self.check is None:
            return
        self.unlocked = True
        self.screen.update_header()

    def lock(self) -> None:
        self.unlocked = False
        self._stop_set_location()
        self.screen.update_header()

    # ------------------------------------------------------------------ Set location
    def start_set_location(self) -> None:
        if not self.unlocked:
            return
        s = self.screen
        s.show_home()
        self.pending_pose = None
        s.floor_pages[s.robot.floor].start_set_location()

    def pose_dragged(self, u0: float, v0: float, u1: float, v1: float) -> None:
        if not self.unlocked:
            return
        s = self.screen
        floor = s.building.floor(s.robot.floor)
        live = s.fleet.robots[s.robot.name]
        default_yaw = live.pose[2] if live.pose is not None else 0.0
        self.pending_pose = pose_from_drag(floor.transform, floor.id, (u0, v0), (u1, v1),
                                           default_yaw=default_yaw)

    def set_location_done(self, apply: bool) -> None:
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
        s = self.screen
        self.pending_pose = None
        s.floor_pages[s.robot.floor].stop_set_location()
