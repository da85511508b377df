"""Records the core tests share: a tour of the faculty, and statuses and NavEvents as the adapter hands them over."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from gui_fakes import nav_event

from gidabot_gui.core.model import TourInfo
from gidabot_navigation.guiding.messages import NavEventData, RobotStatusData
from gidabot_navigation.interface import RobotState


@pytest.fixture
def tour() -> TourInfo:
    return TourInfo("real_world.tour", "Real-world tour", "en",
                    ((0, "014", "Technicians' Lab"), (0, "008", "Caretakers' Office"),
                     (1, "101", "Secretary's Office"), (2, "223", "M. Larrea's Office")))


@pytest.fixture
def status() -> Callable[..., RobotStatusData]:
    """An idle robot's status at (x, y) unless told otherwise."""
    def make(robot: str, floor: float, x: float = 30.0, y: float = 12.0, **kw: object) -> RobotStatusData:
        base = dict(yaw=0.0, linear=0.0, angular=0.0, battery=0.9, state=RobotState.IDLE, pending=0)
        base.update(kw)
        return RobotStatusData(robot, floor, x, y, **base)  # type: ignore[arg-type]

    return make


@pytest.fixture
def ev() -> Callable[..., NavEventData]:
    """A NavEvent of ``robot``; the fields a test leaves out are unknown (NaN floors, no language)."""
    return nav_event
