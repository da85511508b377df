"""Sim time: one formula on every floor, the /clock tick rate, aligned sim-time schedules."""

from __future__ import annotations

import math

import pytest

from gidabot_sim.errors import SimConfigError
from gidabot_sim.world.clock import Periodic, SimClock, next_cycle, tick_period


def test_floors_with_the_same_start_and_speed_agree() -> None:
    a = SimClock.create(10.0, 1000.0, wall_now=1003.0)
    b = SimClock.create(10.0, 1000.0, wall_now=1500.0)     # started much later: same timeline
    for wall in (1000.0, 1001.25, 2000.0):
        assert a.sim_time(wall) == b.sim_time(wall) == pytest.approx((wall - 1000.0) * 10.0)
    assert a.sim_time(999.0) < 0                             # before start_wall: not started
    assert a.wall_time(50.0) == pytest.approx(1005.0)
    now = SimClock.create(4.0, 0.0, wall_now=123.5)          # start_wall 0 = now
    assert now.start_wall == 123.5 and now.sim_time(124.0) == pytest.approx(2.0)


@pytest.mark.parametrize("speed, start", [(0.0, 1.0), (-1.0, 1.0), (math.nan, 1.0), (5000.0, 1.0),
                                          (1.0, -5.0), (1.0, math.inf)])
def test_bad_speed_or_start(speed, start) -> None:
    with pytest.raises(SimConfigError):
        SimClock(speed, start)


def test_tick_period_gives_control_loops_resolution_without_flooding() -> None:
    assert tick_period(1.0) == pytest.approx(0.05)           # 20 Hz wall, 0.05 s sim per tick
    assert tick_period(10.0) == pytest.approx(0.01)          # 100 Hz wall, 0.1 s sim per tick
    assert tick_period(50.0) == pytest.approx(0.01)          # capped at 100 messages per wall second
    assert tick_period(2.0) == pytest.approx(0.025)
    with pytest.raises(SimConfigError):
        tick_period(10.0, clock_step=0.0)


def test_periodic_fires_on_period_boundaries_and_skips_missed_ones() -> None:
    p = Periodic(10.0)
    fired = [t / 100 for t in range(100) if p.due(t / 100)]
    assert fired == pytest.approx([k / 10 for k in range(10)])
    assert p.due(5.0) and not p.due(5.05) and p.due(5.1)    # a jump: fires once, then aligned again
    p.reset()
    assert p.due(5.12)
    with pytest.raises(SimConfigError):
        Periodic(0.0)


def test_next_cycle_keeps_the_period_and_skips_what_a_stall_missed() -> None:
    assert next_cycle(10.0, 0.1, 10.03) == pytest.approx(10.1)       # on time: one period later
    assert next_cycle(10.0, 0.1, 10.15) == pytest.approx(10.1)       # a little late: catch up at once
    assert next_cycle(10.0, 0.1, 12.0) == pytest.approx(12.1)        # stalled: missed cycles skipped
    assert next_cycle(10.0, 0.1, 3.0) == pytest.approx(3.1)          # time jumped back: re-anchored
