"""LoopMeter: a loop's iterations with their ROS and wall times, for diagnostics."""

from __future__ import annotations

import pytest

from gidabot_navigation.loop_meter import LoopMeter


def test_counts_iterations_and_the_longest_wall_gap() -> None:
    meter = LoopMeter(5.0)
    assert meter.values()["loop_count"] == "0"
    for k, wall in enumerate((10.0, 10.2, 10.4, 12.9, 13.0)):
        meter.tick(100.0 + 20.0 * k, wall)
    values = meter.values()
    assert values == {"loop_count": "5", "loop_ros": "180.000", "loop_wall": "13.000", "loop_nominal_hz": "5",
                      "loop_max_gap_wall_s": "2.500"}
    with pytest.raises(ValueError, match="nominal_hz"):
        LoopMeter(0.0)
