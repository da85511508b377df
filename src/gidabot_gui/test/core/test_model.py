"""The robots' live state as the GUI sees it (core.model.Fleet): offline in wall time, bad input counted."""

from __future__ import annotations

import math

from gidabot_gui.core.model import Fleet
from gidabot_navigation.guiding.messages import PoseData


def test_fleet_offline_after_five_seconds_of_wall_time(faculty, status) -> None:
    fleet = Fleet(faculty, offline_after=5.0)
    assert fleet.is_offline("Kbot", 0.0)          # never seen
    fleet.update_status(status("Kbot", 1), 100.0)
    assert not fleet.is_offline("Kbot", 104.9)
    assert fleet.is_offline("Kbot", 105.1)
    assert fleet.robots["Kbot"].pose == (30.0, 12.0, 0.0)   # last known position kept
    assert fleet.wait_of("Kbot", 105.1) is None


def test_fleet_rejects_unknown_robots_and_nan(faculty, status) -> None:
    fleet = Fleet(faculty)
    assert not fleet.update_status(status("Nobody", 1), 1.0)
    assert not fleet.update_pose(PoseData("Kbot", 1, math.nan, 1.0, 0.0), 1.0)
    assert not fleet.update_status(status("Kbot", 1, x=math.inf), 1.0)
    assert fleet.rejected == 3
    assert fleet.robots["Kbot"].pose is None
