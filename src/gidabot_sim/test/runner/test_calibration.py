"""The benchmarks' calibration workload: fixed work, timed, described."""

from __future__ import annotations

import pytest

from gidabot_sim.runner.calibration import CHECKSUM, WORKLOAD, Calibration, as_json, calibrate, describe, workload


def test_the_workload_is_the_same_work_on_every_run() -> None:
    assert workload() == CHECKSUM
    assert workload(3) == workload(3) != workload(4)


def test_calibrate_keeps_the_fastest_of_its_repeats() -> None:
    timing = calibrate(repeats=2, rounds=5)
    assert timing.repeats == 2 and timing.cpu_s > 0 and timing.wall_s > 0
    with pytest.raises(ValueError, match="repeats 0"):
        calibrate(repeats=0)


def test_a_benchmark_prints_and_saves_its_start_and_end_times() -> None:
    cal = Calibration()
    assert describe(cal) == "calibration: not measured"
    cal.measure(repeats=1)
    cal.measure(repeats=1)
    saved = as_json(cal)
    assert saved["workload"] == WORKLOAD and len(saved["cpu_s"]) == len(saved["wall_s"]) == 2
    line = describe(cal)
    assert line.startswith(f"calibration ({WORKLOAD}, the fastest of 1 runs): ")
    assert "at the start" in line and "at the end" in line and describe(saved) == line
