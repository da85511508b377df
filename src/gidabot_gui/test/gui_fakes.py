"""Stand-ins for the GUI tests: recorded outputs and speech, a fake screen for one controller, NavEvents,
waiting on Qt.

:class:`FakeScreen` offers what the window's parts need of the window (the Protocols
``VisitorScreen``, ``AdminScreen``, ``TourEditScreen``) with the real ROS-free services
(translator, texts, fleet) and records every screen operation, so a controller is
tested without a MainWindow.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any


@dataclass
class RecordingOutputs:
    """Records what the GUI would publish."""

    commands: list = field(default_factory=list)
    poses: list = field(default_factory=list)
    edits: list = field(default_factory=list)

    def send_command(self, cmd: Any) -> None:
        self.commands.append(cmd)

    def send_initial_pose(self, pose: Any) -> None:
        self.poses.append(pose)

    def send_tour_edit(self, edit: Any) -> None:
        self.edits.append(edit)


@dataclass
class RecordingSpeaker:
    """Records what would be said, and how often speech was stopped."""

    said: list[tuple[str, str]] = field(default_factory=list)
    stops: int = 0

    def say(self, text: str, language: str) -> None:
        self.said.append((text, language))

    def stop(self) -> None:
        self.stops += 1


@dataclass
class Popup:
    """A pop-up the fake screen shows: its builder and button handler, as a controller gave them."""

    name: str
    build: Callable[[], Any]
    pressed: Callable[[str], None]
    auto_close: float = 0.0

    def card(self) -> Any:
        """The card as it would be drawn now (in the current language)."""
        return self.build()

    def buttons(self) -> list[str]:
        return [b.key for b in self.card().buttons]

    def press(self, key: str) -> None:
        assert key in self.buttons(), f"pop-up {self.name!r} has no button {key!r} (has {self.buttons()})"
        self.pressed(key)


class FakeScreen:
    """The screen as the window's parts see it, for robot ``robot`` of ``building``: real services, and every
    pop-up and screen operation recorded (``ops``, ``changes``)."""

    def __init__(self, building: Any, robot: str, tr: Any, tours: tuple = ()) -> None:
        from gidabot_gui.core.model import Fleet
        from gidabot_gui.core.texts import Texts
        from gidabot_gui.qt.theme import Theme

        self.building = building
        self.tr = tr
        self.theme = Theme()
        self.outputs = RecordingOutputs()
        self.speaker = RecordingSpeaker()
        self.now = 1000.0
        self.logs: list[str] = []
        self.fleet = Fleet(building)
        self.texts = Texts(tr, building, robot)
        self.tours = list(tours)
        self.texts.tours = {t.file_name: t for t in self.tours}
        self.admin_unlocked = False
        self.stack: list[Popup] = []       # the pop-up on screen is the last
        self.messages: list[Popup] = []    # every show_message
        self.ops: list[tuple] = []         # page and mode operations, in order
        self.changes = 0

    # ------------------------------------------------------------------ services
    def clock(self) -> float:
        return self.now

    def log(self, message: str) -> None:
        self.logs.append(message)

    def tour(self, file_name: str) -> Any:
        return next((t for t in self.tours if t.file_name == file_name), None)

    def feed_all_status(self, state: str = "idle") -> None:
        """Every robot online at home (this fake's clock)."""
        from gidabot_navigation.guiding.messages import RobotStatusData

        for r in self.building.robots:
            self.fleet.update_status(RobotStatusData(r.name, r.floor, r.home.x, r.home.y, r.home.yaw, 0.0, 0.0,
                                                     0.9, state, 0), self.now)

    # ------------------------------------------------------------------ pop-ups
    @property
    def popup(self) -> str:
        return self.stack[-1].name if self.stack else ""

    @property
    def top(self) -> Popup:
        assert self.stack, "no pop-up is shown"
        return self.stack[-1]

    def show_popup(self, name: str, build: Callable[[], Any], pressed: Callable[[str], None],
                   auto_close: float = 0.0) -> None:
        self.stack = [Popup(name, build, pressed, auto_close)]

    def push_popup(self, name: str, build: Callable[[], Any], pressed: Callable[[str], None]) -> None:
        self.stack.append(Popup(name, build, pressed))

    def pop_popup(self) -> None:
        if self.stack:
            self.stack.pop()

    def close_popup(self) -> None:
        self.stack = []

    def rebuild_popup(self) -> None:
        self.ops.append(("rebuild_popup",))

    def show_message(self, name: str, title: Callable[[], str], body: Callable[[], str], tone: str) -> None:
        from gidabot_gui.qt.overlay import Button, CardSpec

        popup = Popup(name, lambda: CardSpec(title(), body(), tone, buttons=[Button("ok", "OK")]),
                      lambda _k: self.close_popup())
        self.stack = [popup]
        self.messages.append(popup)

    # ------------------------------------------------------------------ pages
    def show_home(self) -> None:
        self.ops.append(("show_home",))

    def show_tours(self) -> None:
        self.ops.append(("show_tours",))

    def select_tour_stop(self, file_name: str, step: int) -> None:
        self.ops.append(("select_tour_stop", file_name, step))

    def set_search_query(self, text: str) -> None:
        self.ops.append(("set_search_query", text))

    def set_location_mode(self, on: bool) -> None:
        self.ops.append(("set_location_mode", on))

    def changed(self) -> None:
        self.changes += 1


def nav_event(phase: Any, uid: str, goal_uid: str = "", robot: str = "Kbot", **kw: Any) -> Any:
    """A NavEvent of ``robot`` as the adapter hands it over; the fields left out are unknown (NaN floors, no
    language)."""
    from gidabot_navigation.guiding.messages import NavEventData

    fields = {"floor": math.nan, "language": "", "target_floor": math.nan, **kw}
    return NavEventData(uid=uid, robot=robot, phase=int(phase), goal_uid=goal_uid, **fields)


def wait_until(app: Any, cond: Callable[[], bool], timeout: float) -> bool:
    """Run the Qt event loop until ``cond()`` holds or ``timeout`` s (wall) passed; ``cond()`` at the end."""
    from PyQt5.QtCore import QEventLoop, QTimer

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not cond():
        loop = QEventLoop()
        QTimer.singleShot(10, loop.quit)
        loop.exec_()
    return cond()
