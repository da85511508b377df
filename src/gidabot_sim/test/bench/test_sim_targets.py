"""`gidabot bench sim` judges: a missed target (planner, real-time factor, the whole stack) exits 1."""

from __future__ import annotations

import json

import pytest

from gidabot_sim.bench import sim

PLANNER = [{"floor": "1", "plans": 10, "median_ms": 2.0, "max_ms": 6.0, "longest_path_m": 60.0,
            "longest_path_ms": 6.0, "resolution_m": 0.05}]
RTF = {"floor": "1", "robot": "Kbot", "sim_s": 200.0, "wall_s": 2.0, "cpu_s": 2.0, "real_time_factor": 100.0,
       "laser_beams": 360, "laser_scans": 2000, "laser_hz": 10.0, "driven_m": 130.0, "goals": ["succeeded"]}


@pytest.fixture
def fast(monkeypatch):
    monkeypatch.setattr(sim, "bench_planner", lambda building: [dict(r) for r in PLANNER])
    monkeypatch.setattr(sim, "bench_rtf", lambda building, floor: dict(RTF))


def test_every_target_met_exits_0(fast, capsys) -> None:
    assert sim.main(["--no-ros"]) == 0
    assert capsys.readouterr().out.strip().endswith("PASS")
    assert sim.main(["--no-ros", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["pass"] is True


def test_a_missed_target_exits_1_and_names_it(fast, monkeypatch, capsys) -> None:
    monkeypatch.setattr(sim, "bench_rtf", lambda building, floor: {**RTF, "real_time_factor": 5.0})
    assert sim.main(["--no-ros"]) == 1
    out = capsys.readouterr().out
    assert "missed: real-time factor 5.0x" in out and out.strip().endswith("FAIL")
    monkeypatch.setattr(sim, "bench_rtf", lambda building, floor: dict(RTF))
    monkeypatch.setattr(sim, "bench_planner", lambda building: [{**PLANNER[0], "max_ms": 500.0}])
    assert sim.main(["--no-ros", "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["pass"] is False and "planner on floor 1" in report["missed"][0]


def test_the_whole_stack_below_its_factor_or_a_slow_controller_exits_1(fast, monkeypatch, capsys) -> None:
    stack = {"robot": "Kbot", "goals": ["reached"] * 3, "places": ["110", "111", "104"], "sim_s": 500.0,
             "wall_s": 10.0, "achieved_factor": 50.0, "guiding_sim_s": 300.0, "guiding_wall_s": 6.0,
             "guiding_factor": 50.0, "cpu_ms_per_sim_s": {}, "cpu_cores": 1.0,
             "rates_pct": {"/move_base": 100.0, "/amcl": 70.0}}
    monkeypatch.setattr(sim, "bench_ros", lambda building, speed: {"speed": speed, "robot": "Kbot",
                                                                    "one_core_capacity_factor_estimate": None})
    monkeypatch.setattr(sim, "bench_stack", lambda building: dict(stack))
    assert sim.main(["--json"]) == 1
    missed = json.loads(capsys.readouterr().out)["missed"]
    assert any("whole stack: 50.0x" in m for m in missed) and any("/amcl" in m for m in missed), missed
