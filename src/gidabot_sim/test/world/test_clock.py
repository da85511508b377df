"""The speed ceiling of a floor's clock (no catch-up, behind time counted) and aligned sim-time schedules."""

from __future__ import annotations

import math

import pytest

from gidabot_sim.errors import SimConfigError
from gidabot_sim.world.clock import Pacer, Periodic, check_speed


def test_the_ceiling_schedules_every_stop_from_its_anchor() -> None:
    pacer = Pacer(10.0, start_wall=1000.0)
    assert pacer.due(0.0) == 1000.0 and pacer.due(5.0) == pytest.approx(1000.5)
    pacer.reached(5.0, 1000.4)                                 # early: nothing to count
    assert pacer.behind == 0.0 and pacer.behind_at(5.0, 1000.4) == 0.0
    assert Pacer(None, 1000.0).due(1e9) == -math.inf           # no ceiling: always due


def test_a_late_stop_is_never_caught_up_by_running_faster_than_the_ceiling() -> None:
    pacer = Pacer(10.0, start_wall=1000.0, slack=0.05)
    pacer.reached(1.0, 1000.13)            # 30 ms late: within the slack, made up by the next steps
    assert pacer.behind == 0.0 and pacer.due(2.0) == pytest.approx(1000.2)
    pacer.reached(2.0, 1002.2)             # 2 s late (a stopped process): counted, schedule re-anchored there
    assert pacer.behind == pytest.approx(2.0)
    assert pacer.due(3.0) == pytest.approx(1002.3)          # the next step waits a full step: no burst
    assert pacer.behind_at(3.0, 1002.5) == pytest.approx(2.2)


def test_a_new_ceiling_counts_the_lateness_so_far_and_starts_from_there() -> None:
    pacer = Pacer(10.0, start_wall=0.0)
    pacer.set_speed(50.0, t=10.0, wall=1.5)                  # 0.5 s late at 10x when it changed
    assert pacer.behind == pytest.approx(0.5) and pacer.due(60.0) == pytest.approx(2.5)
    pacer.set_speed(None, t=60.0, wall=2.5)
    assert pacer.due(1e6) == -math.inf and pacer.behind_at(1e6, 3.0) == pytest.approx(0.5)


@pytest.mark.parametrize("speed", [0.0, -1.0, math.nan, math.inf, 1001.0, True, "10"])
def test_bad_speeds_are_refused_with_the_value(speed: object) -> None:
    with pytest.raises(SimConfigError, match="speed"):
        check_speed(speed)  # type: ignore[arg-type]
    with pytest.raises(SimConfigError, match="slack"):
        Pacer(10.0, 0.0, slack=-1.0)


def test_periodic_fires_on_period_boundaries_and_skips_missed_ones() -> None:
    p = Periodic(10.0)
    fired = [t / 100 for t in range(100) if p.due(t / 100)]
    assert fired == pytest.approx([k / 10 for k in range(10)])
    assert p.due(5.0) and not p.due(5.05) and p.due(5.1)    # a jump: fires once, then aligned again
    p.reset()
    assert p.due(5.12)
    with pytest.raises(SimConfigError):
        Periodic(0.0)
