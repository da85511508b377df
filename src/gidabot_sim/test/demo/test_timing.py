"""The run's timing: the floors' clocks at the tour's start and end, the largest drift between them."""

from __future__ import annotations

import pytest

from gidabot_sim.demo.timing import RunTiming
from gidabot_sim.world.timeline import Clock


def test_the_tour_is_measured_between_its_first_goal_and_its_end_and_the_largest_drift_kept() -> None:
    timing = RunTiming(["A", "B"])
    timing.look({"A": Clock(5.0, 100.0), "B": Clock(5.5, 100.0)}, 100.0, tour_started=False)
    assert timing.summary() == {"floors": {}, "max_drift_s": 0.0}          # nothing before the tour
    timing.look({"A": Clock(10.0, 101.0, behind=0.1), "B": Clock(10.4, 101.0)}, 101.0, tour_started=True)
    timing.look({"A": Clock(30.0, 102.0, behind=0.1), "B": Clock(30.9, 102.0)}, 102.0, tour_started=True)
    timing.look({"A": Clock(40.0, 102.5, behind=0.6, wait_controllers=0.2), "B": Clock(99.0, 97.0)}, 102.5, True)
    summary = timing.summary()
    a = summary["floors"]["A"]
    assert (a["sim_start"], a["sim_end"], a["sim_s"], a["wall_s"]) == (10.0, 40.0, 30.0, 1.5)
    assert a["achieved_factor"] == 20.0 and a["behind_s"] == 0.5 and a["behind_pct"] == pytest.approx(33.33)
    assert a["wait_controllers_s"] == 0.2
    assert summary["max_drift_s"] == 0.9      # B's last clock is 5.5 s old: not running, not counted
    assert timing.factors({"A": Clock(50.0, 103.0), "B": Clock(99.0, 97.0)}, 103.0) == {"A": 20.0, "B": 0.0}


def test_lateness_pending_at_the_tours_start_and_made_up_later_is_no_time_behind() -> None:
    timing = RunTiming(["A"])
    timing.look({"A": Clock(10.0, 100.0, behind=0.004)}, 100.0, tour_started=True)   # 4 ms late, within the slack
    timing.look({"A": Clock(40.0, 101.5, behind=0.002)}, 101.5, tour_started=True)   # made up, 2 ms late now
    a = timing.summary()["floors"]["A"]
    assert a["behind_s"] == 0.0 and a["behind_pct"] == 0.0
