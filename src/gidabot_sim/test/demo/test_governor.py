"""--speed max: the governor raises the ceiling while every floor keeps up with it, backs off when one falls
behind, and never goes back above what failed."""

from __future__ import annotations

import pytest

from gidabot_sim.demo.governor import SpeedGovernor
from gidabot_sim.world.timeline import Clock


class Floors:
    """Two floors' clocks: ``run`` advances them by one wall second at a given pace."""

    def __init__(self) -> None:
        self.wall = 0.0
        self.clocks = {"A": Clock(0.0, 0.0), "B": Clock(0.0, 0.0)}

    def run(self, factor: dict[str, float], behind: dict[str, float] | None = None,
            waited: dict[str, float] | None = None) -> dict[str, Clock]:
        self.wall += 1.0
        self.clocks = {r: Clock(c.sim + factor[r], self.wall, behind=c.behind + (behind or {}).get(r, 0.0),
                                wait_ceiling=c.wait_ceiling + (waited or {}).get(r, 0.0))
                       for r, c in self.clocks.items()}
        return self.clocks


def test_the_ceiling_rises_while_the_floors_keep_up_and_wait_for_it_only_once_the_tour_runs() -> None:
    gov, floors = SpeedGovernor(start=50.0, patience=2), Floors()
    assert gov.look(floors.clocks, floors.wall, active=False) is None
    for _ in range(4):                                       # before the tour: held
        assert gov.look(floors.run({"A": 50, "B": 50}, waited={"A": 0.3}), floors.wall, active=False) is None
    assert gov.look(floors.run({"A": 50, "B": 50}, waited={"A": 0.3}), floors.wall, active=True) is None
    assert gov.look(floors.run({"A": 50, "B": 50}, waited={"A": 0.3}), floors.wall, active=True) == 55.0
    # kept up without waiting for the ceiling (not limited by it): held
    for _ in range(3):
        assert gov.look(floors.run({"A": 55, "B": 55}), floors.wall, active=True) is None


def test_a_floor_behind_brings_the_ceiling_down_below_what_it_achieved_and_caps_later_raises() -> None:
    gov, floors = SpeedGovernor(start=100.0, patience=1), Floors()
    gov.look(floors.clocks, floors.wall, active=True)
    new = gov.look(floors.run({"A": 100, "B": 70}, behind={"B": 0.3}), floors.wall, active=True)
    assert new == 63.0 and gov.limit == 90.0                # 0.9 x B's 70x; never again above 0.9 x 100
    for _ in range(10):
        gov.look(floors.run({"A": gov.ceiling, "B": gov.ceiling}, waited={"B": 0.1}), floors.wall, active=True)
    assert gov.ceiling == 90.0
    assert [c for _, c in gov.changes] == [63.0, 69.3, 76.23, 83.85, 90.0]
    # a little lateness (within the budget) is not a failure
    assert gov.look(floors.run({"A": 90, "B": 90}, behind={"A": 0.01}), floors.wall, active=True) is None
    assert gov.summary()["ceiling"] == 90.0


def test_short_stalls_cost_the_budget_and_only_their_rate_brings_the_ceiling_down() -> None:
    gov, floors = SpeedGovernor(start=50.0, patience=1, budget=0.005, horizon=15.0), Floors()
    gov.look(floors.clocks, floors.wall, active=True)
    # a 50 ms stall every 20 s (0.25 % of the time) keeping up otherwise: held, never raised (no ceiling waits)
    for k in range(60):
        stall = {"A": 0.05} if k % 20 == 19 else {}
        assert gov.look(floors.run({"A": 49, "B": 50}, behind=stall), floors.wall, active=True) is None, k
    assert gov.ceiling == 50.0 and gov.limit == 200.0
    # a 60 ms stall every 4 s (1.5 %, a degraded run): backed off by 10 %, and never again above 45x
    changes = [gov.look(floors.run({"A": 49, "B": 50}, behind={"A": 0.06} if k % 4 == 3 else {}), floors.wall,
                        active=True) for k in range(16)]
    assert [c for c in changes if c is not None] == [45.0] and gov.limit == 45.0
    # budget spent more than half: no raise even though a floor waited for the ceiling
    gov2, floors2 = SpeedGovernor(start=50.0, patience=1, budget=0.005, horizon=15.0), Floors()
    gov2.look(floors2.clocks, floors2.wall, active=True)
    assert gov2.look(floors2.run({"A": 50, "B": 50}, behind={"A": 0.05}, waited={"B": 0.2}), floors2.wall,
                     active=True) is None
    assert gov2.look(floors2.run({"A": 50, "B": 50}, waited={"B": 0.2}), floors2.wall, active=True) is None


def test_the_start_up_is_not_judged_a_floor_behind_before_the_tour_changes_nothing() -> None:
    gov, floors = SpeedGovernor(start=50.0, patience=1), Floors()
    gov.look(floors.clocks, floors.wall, active=False)
    for _ in range(3):                  # every robot's nodes starting: the floors starved, far behind the ceiling
        assert gov.look(floors.run({"A": 2, "B": 30}, behind={"A": 0.9, "B": 0.4}), floors.wall, active=False) is None
    assert (gov.ceiling, gov.limit) == (50.0, 200.0)
    # the tour starts: its first window, from the last look at the start-up, is judged on its own
    assert gov.look(floors.run({"A": 50, "B": 50}, waited={"A": 0.2}), floors.wall, active=True) == 55.0


def test_a_frozen_floor_brings_it_down_to_the_lowest_ceiling_and_bad_settings_are_refused() -> None:
    gov, floors = SpeedGovernor(start=50.0, low=5.0), Floors()
    gov.look(floors.clocks, floors.wall, active=True)
    assert gov.look(floors.run({"A": 0, "B": 50}, behind={"A": 1.0}), floors.wall, active=True) == 5.0
    with pytest.raises(ValueError):
        SpeedGovernor(start=1.0, low=5.0)
    with pytest.raises(ValueError):
        SpeedGovernor(back_off=1.5)
