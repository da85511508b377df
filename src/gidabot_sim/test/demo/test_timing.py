"""The run's timing: the floors' clocks at the tour's start and end (demo), rates and the degraded verdict
from the floors' diagnostics (report)."""

from __future__ import annotations

import json

import pytest

from gidabot_sim.demo import report
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


def _diag(t: float, name: str, **values: object) -> report.DiagSample:
    return report.DiagSample(t, name, tuple((k, v if isinstance(v, str) else json.dumps(v)) for k, v in values.items()))


def test_rates_and_the_degraded_verdict() -> None:
    sim = "sim: floor 1"
    samples = [
        _diag(5.0, sim, **{"participant /move_base": {"owed": 10, "answered": 10, "timeouts": 0, "waited_s": 0.1}}),
        _diag(5.0, "guiding: navigation Kbot", loop_count="100", loop_ros="5.0", loop_wall="1000.0",
              loop_nominal_hz="5", loop_max_gap_wall_s="0.2"),
        _diag(105.0, sim, **{"participant /move_base": {"owed": 1010, "answered": 760, "timeouts": 1,
                                                        "waited_s": 2.1},
                             "participant /amcl": {"owed": 500, "answered": 500, "timeouts": 0, "waited_s": 0.5}}),
        _diag(105.0, "guiding: navigation Kbot", loop_count="160", loop_ros="105.0", loop_wall="1010.0",
              loop_nominal_hz="5", loop_max_gap_wall_s="2.5"),
    ]
    controllers = report.controller_rates(samples, 5.0, 105.0)
    assert controllers["/move_base"] == {"owed": 1000, "answered": 750, "rate_pct": 75.0, "timeouts": 1,
                                         "waited_s": 2.0}
    assert controllers["/amcl"]["rate_pct"] == 100.0          # new since the start: counted from zero
    loops = report.loop_rates(samples, 5.0, 105.0)
    assert loops["navigation Kbot"] == {"loops": 60, "hz_sim": 0.6, "nominal_hz_sim": 0.5, "rate_pct": 120.0,
                                        "max_gap_wall_s": 2.5}
    rec = report.RobotRecord("Kbot", 1.0, diagnostics=samples)
    run = {"timing": {"floors": {"Kbot": {"sim_start": 5.0, "sim_end": 105.0, "behind_s": 0.5, "behind_pct": 5.0,
                                          "achieved_factor": 10.0}}, "max_drift_s": 0.4}}
    timing = report.timing_report([rec], run)
    assert timing["degraded"] is True and timing["max_drift_s"] == 0.4
    assert timing["reasons"] == ["Kbot's clock was behind its speed ceiling for 0.5 s (5.0 % of the tour)",
                                 "Kbot's /move_base ran at 75 % of its nominal rate"]
    assert report.timing_report([rec], {})["degraded"] is None          # a run without timing: no verdict
    assert "DEGRADED" in "\n".join(report.format_timing(timing))
