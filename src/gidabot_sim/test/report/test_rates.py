"""The run's timing from the floors' diagnostics: controllers' and guiding loops' rates, the degraded verdict."""

from __future__ import annotations

import json

from gidabot_sim.report.bags import DiagSample, RobotRecord
from gidabot_sim.report.rates import controller_rates, loop_rates, timing_report
from gidabot_sim.report.text import format_timing


def _diag(t: float, name: str, **values: object) -> DiagSample:
    return DiagSample(t, name, tuple((k, v if isinstance(v, str) else json.dumps(v)) for k, v in values.items()))


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
    controllers = controller_rates(samples, 5.0, 105.0)
    assert controllers["/move_base"] == {"owed": 1000, "answered": 750, "rate_pct": 75.0, "timeouts": 1,
                                         "waited_s": 2.0}
    assert controllers["/amcl"]["rate_pct"] == 100.0          # new since the start: counted from zero
    loops = loop_rates(samples, 5.0, 105.0)
    assert loops["navigation Kbot"] == {"loops": 60, "hz_sim": 0.6, "nominal_hz_sim": 0.5, "rate_pct": 120.0,
                                        "max_gap_wall_s": 2.5}
    rec = RobotRecord("Kbot", 1.0, diagnostics=samples)
    run = {"timing": {"floors": {"Kbot": {"sim_start": 5.0, "sim_end": 105.0, "behind_s": 0.5, "behind_pct": 5.0,
                                          "achieved_factor": 10.0}}, "max_drift_s": 0.4}}
    timing = timing_report([rec], run)
    assert timing["degraded"] is True and timing["max_drift_s"] == 0.4
    assert timing["reasons"] == ["Kbot's clock was behind its speed ceiling for 0.5 s (5.0 % of the tour)",
                                 "Kbot's /move_base ran at 75 % of its nominal rate"]
    assert timing_report([rec], {})["degraded"] is None          # a run without timing: no verdict
    assert "DEGRADED" in "\n".join(format_timing(timing))
