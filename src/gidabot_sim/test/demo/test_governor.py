"""--speed max, on synthetic series of the floors' lag: the governor raises the ceiling while every floor keeps up
with it, backs off in proportion to how far behind the floors fell, never below a ceiling it proved sustainable
(unless the floors cannot keep up at all), probes upwards again after calm periods, and leaves the tour's first
seconds (the start-up's stalls) out of its budgets."""

from __future__ import annotations

import random

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


def started(**settings: float) -> tuple[SpeedGovernor, Floors]:
    """A governor whose tour has begun (and, with ``warmup`` 0, whose warm-up window is the next second)."""
    gov, floors = SpeedGovernor(**{"warmup": 0.0, **settings}), Floors()
    gov.look(floors.clocks, floors.wall, active=True)
    return gov, floors


def keep_up(gov: SpeedGovernor, floors: Floors, seconds: int, behind: float = 0.0) -> list[float]:
    """``seconds`` windows in which both floors keep up with the ceiling and wait for it (``behind``: a stall of
    that many wall s in every window); the ceilings set."""
    got = []
    for _ in range(seconds):
        new = gov.look(floors.run({"A": gov.ceiling, "B": gov.ceiling}, behind={"A": behind}, waited={"B": 0.2}),
                       floors.wall, active=True)
        if new is not None:
            got.append(new)
    return got


def machine(gov: SpeedGovernor, floors: Floors, capacity: float, seconds: int, stalls: float = 0.0,
            seed: int = 1) -> None:
    """A machine whose floors compute ``capacity`` sim s per wall s at most: below it they wait for the ceiling,
    above it they are behind by the share they miss; ``stalls``: each second, a 20-60 ms stall with this
    probability, whatever the speed."""
    rng = random.Random(seed)
    for _ in range(seconds):
        achieved = min(gov.ceiling, capacity)
        behind = 1.0 - achieved / gov.ceiling + (rng.uniform(0.02, 0.06) if rng.random() < stalls else 0.0)
        waited = 0.2 if gov.ceiling < capacity else 0.0
        gov.look(floors.run({"A": achieved, "B": achieved}, behind={"A": behind}, waited={"B": waited}),
                 floors.wall, active=True)


def test_the_ceiling_rises_while_the_floors_keep_up_and_wait_for_it_only_once_the_tour_runs() -> None:
    gov, floors = SpeedGovernor(start=50.0, patience=2, warmup=1.0), Floors()
    assert gov.look(floors.clocks, floors.wall, active=False) is None
    for _ in range(4):                                       # before the tour: held
        assert gov.look(floors.run({"A": 50, "B": 50}, waited={"A": 0.3}), floors.wall, active=False) is None
    assert gov.look(floors.clocks, floors.wall, active=True) is None                 # the tour starts
    assert gov.look(floors.run({"A": 50, "B": 50}, waited={"A": 0.3}), floors.wall, active=True) is None  # warm-up
    assert gov.look(floors.run({"A": 50, "B": 50}, waited={"A": 0.3}), floors.wall, active=True) is None
    assert gov.look(floors.run({"A": 50, "B": 50}, waited={"A": 0.3}), floors.wall, active=True) == 55.0
    # kept up without waiting for the ceiling (not limited by it): held
    for _ in range(3):
        assert gov.look(floors.run({"A": 55, "B": 55}), floors.wall, active=True) is None


def test_the_start_up_stalls_of_the_warm_up_decide_nothing_beyond_an_overload() -> None:
    gov, floors = SpeedGovernor(start=50.0, patience=1, warmup=3.0), Floors()
    gov.look(floors.clocks, floors.wall, active=False)
    for _ in range(3):                  # every robot's nodes starting: the floors starved, before the tour
        assert gov.look(floors.run({"A": 2, "B": 30}, behind={"A": 0.9}), floors.wall, active=False) is None
    gov.look(floors.clocks, floors.wall, active=True)
    # the tour's first three seconds: one second far behind (0.4 s), the floors at 45x on average: no back-off,
    # and the stall is not charged to the budgets (it would be over the run's 0.7 % for a minute)
    assert gov.look(floors.run({"A": 35, "B": 50}, behind={"A": 0.4}), floors.wall, active=True) is None
    assert gov.look(floors.run({"A": 50, "B": 50}), floors.wall, active=True) is None
    assert gov.look(floors.run({"A": 50, "B": 50}), floors.wall, active=True) is None
    assert (gov.ceiling, gov.limit, gov.back_offs) == (50.0, 200.0, 0)
    assert keep_up(gov, floors, 1) == [55.0]
    # a warm-up the floors could not keep up with at all: the ceiling goes to what they achieved, no limit set
    gov2, floors2 = SpeedGovernor(start=100.0, warmup=2.0), Floors()
    gov2.look(floors2.clocks, floors2.wall, active=True)
    gov2.look(floors2.run({"A": 40, "B": 100}, behind={"A": 0.6}), floors2.wall, active=True)
    assert gov2.look(floors2.run({"A": 40, "B": 100}, behind={"A": 0.6}), floors2.wall, active=True) == 50.0
    assert (gov2.limit, gov2.back_offs) == (200.0, 0)       # (0.9 x 40x is below half of 100x)


def test_an_overload_brings_the_ceiling_below_what_the_floors_achieved_and_caps_later_raises() -> None:
    gov, floors = started(start=100.0, patience=1, calm=1000.0, run_budget=0.5)
    assert keep_up(gov, floors, 1) == []                     # the warm-up window
    new = gov.look(floors.run({"A": 100, "B": 70}, behind={"B": 0.3}), floors.wall, active=True)
    assert new == 63.0 and gov.limit == 90.0                # 0.9 x B's 70x; never again above 0.9 x 100
    assert keep_up(gov, floors, 10) == [69.3, 76.23, 83.85, 90.0] and gov.ceiling == 90.0
    # a little lateness (within the budget) is not a failure
    assert gov.look(floors.run({"A": 90, "B": 90}, behind={"A": 0.01}), floors.wall, active=True) is None


def test_a_back_off_for_the_budget_is_in_proportion_to_how_far_behind_the_floors_were() -> None:
    cuts = []
    for stall in (0.08, 0.2, 0.4):                           # wall s behind in one second (the budget: 75 ms)
        gov, floors = started(start=50.0, patience=1, calm=1000.0, gain=4.0, min_cut=0.03)
        keep_up(gov, floors, 1)
        assert keep_up(gov, floors, 1, behind=stall) == [gov.ceiling]
        cuts.append(gov.ceiling)
    # 8 % behind: 32 % off; 20 %: 80 %, at most halved; a little over the budget: at least 3 % off
    assert cuts == [34.0, 25.0, 25.0]
    gov, floors = started(start=50.0, patience=1, calm=1000.0, horizon=1.0, budget=0.005)
    keep_up(gov, floors, 1)
    assert keep_up(gov, floors, 1, behind=0.006) == [48.5]


def test_a_proven_ceiling_is_never_left_for_the_budget_only_for_an_overload_and_then_only_until_calm() -> None:
    gov, floors = started(start=50.0, patience=1, calm=5.0, prove=5.0, run_budget=0.5, raise_by=1.1)
    keep_up(gov, floors, 1)                                  # warm-up
    for _ in range(5):                                       # 50x held, paced, without waiting: proven
        gov.look(floors.run({"A": 50, "B": 50}), floors.wall, active=True)
    assert gov.proven == 50.0
    assert keep_up(gov, floors, 1) == [55.0]
    # stalls at 55x over the budget: the proportional cut (12 %) would go to 48.4x; it stops at the proven 50x
    assert keep_up(gov, floors, 1, behind=0.08) == [50.0] and gov.limit == 50.0
    # the same stalls at 50x: the stalls do not depend on the speed there; held, however long
    assert keep_up(gov, floors, 30, behind=0.08) == [] and gov.ceiling == 50.0
    # the machine gets busier: the floors make 30x of 50x; an overload may go below the proven ceiling...
    assert gov.look(floors.run({"A": 30, "B": 30}, behind={"A": 0.4}), floors.wall, active=True) == 27.0
    # ... and once calm again (5 s) it goes straight back to it; the limit is lifted after 10 s (a second back-off)
    assert keep_up(gov, floors, 4) == [29.7, 32.67, 35.94, 39.53]
    assert keep_up(gov, floors, 1) == [50.0] and gov.lifts == 0
    assert keep_up(gov, floors, 5) == [55.0] and gov.lifts == 1


def test_a_long_overload_does_not_keep_the_ceiling_below_a_proven_one_for_the_rest_of_the_run() -> None:
    """The machine swamped by other processes for ten seconds: every second an overload back-off, down to the
    lowest ceiling; five calm seconds later the ceiling is the proven one again (a bench on a loaded machine held
    5x for two minutes after such a burst, the calm period having doubled with each of its 14 back-offs)."""
    gov, floors = started(start=40.0, patience=1, calm=5.0, prove=5.0, run_budget=0.5)
    keep_up(gov, floors, 1)
    for _ in range(5):
        gov.look(floors.run({"A": 40, "B": 40}), floors.wall, active=True)
    assert gov.proven == 40.0
    for _ in range(10):
        gov.look(floors.run({"A": gov.ceiling * 0.3, "B": gov.ceiling * 0.3}, behind={"A": 0.7}), floors.wall,
                 active=True)
    assert gov.ceiling == 5.0 and gov.back_offs == 10
    assert 40.0 in keep_up(gov, floors, 6) and gov.ceiling == 40.0


def test_after_a_back_off_the_ceiling_probes_upwards_again_once_calm_ever_more_rarely() -> None:
    gov, floors = started(start=50.0, patience=1, calm=5.0, raise_by=1.1, back_off=0.9, run_budget=0.5,
                          min_cut=0.1, gain=1.0, prove=1000.0)
    keep_up(gov, floors, 1)
    # a 100 ms stall (the budget is 75 ms over 15 s): backed off to 45x, the limit
    assert keep_up(gov, floors, 1, behind=0.1) == [45.0] and gov.limit == 45.0
    # calm: held at the limit for 5 s, then the limit is lifted and the ceiling rises past 50x
    assert keep_up(gov, floors, 4) == []
    assert keep_up(gov, floors, 2) == [49.5, 54.45] and gov.lifts == 1 and gov.limit == 200.0
    # 60x really is too fast: the second back-off needs 10 s of calm, the third 20 s
    assert keep_up(gov, floors, 1) == [59.9]
    assert keep_up(gov, floors, 1, behind=0.1) == [53.91] and gov.limit == 53.91
    assert keep_up(gov, floors, 9) == [] and gov.limit == 53.91
    assert keep_up(gov, floors, 1) == [59.3] and gov.lifts == 2
    assert keep_up(gov, floors, 1, behind=0.1) == [53.37] and gov.back_offs == 3
    assert keep_up(gov, floors, 19) == [] and gov.limit == 53.37
    assert gov.summary()["back_offs"] == 3 and gov.summary()["lifts"] == 2


def test_the_whole_run_keeps_its_time_behind_below_the_degraded_mark() -> None:
    gov, floors = started(start=50.0, patience=1, budget=0.005, horizon=15.0, run_budget=0.007, calm=1000.0,
                          min_cut=0.1, gain=1.0, prove=1000.0)
    keep_up(gov, floors, 1)
    assert keep_up(gov, floors, 1) == [55.0]
    # 30 ms stalls, each within the budget since the last raise (half of 75 ms): raised while the tour's time
    # behind leaves room for a failed raise (37.5 ms) within 0.7 % of at least 15 s (105 ms)
    assert keep_up(gov, floors, 2, behind=0.03) == [60.5, 66.55]
    assert keep_up(gov, floors, 1, behind=0.03) == []          # 90 ms + 37.5 > 105: held
    assert keep_up(gov, floors, 14) == [] and gov.ceiling == 66.55
    assert keep_up(gov, floors, 1) == [73.2]
    # 60 ms more: within the budget since the raise (75 ms), but over 0.7 % of the run: backed off
    assert keep_up(gov, floors, 1, behind=0.06) == [65.88]
    assert keep_up(gov, floors, 1, behind=0.01) == [] and gov.back_offs == 1       # the excess did not grow enough
    assert keep_up(gov, floors, 1, behind=0.03) == [59.29] and gov.back_offs == 2
    assert keep_up(gov, floors, 5) == [] and gov.ceiling == 59.29


def test_a_frozen_floor_halves_the_ceiling_each_window_down_to_the_lowest_and_bad_settings_are_refused() -> None:
    gov, floors = started(start=50.0, low=5.0)
    got = [gov.look(floors.run({"A": 0, "B": gov.ceiling}, behind={"A": 1.0}), floors.wall, active=True)
           for _ in range(5)]
    assert got == [25.0, 12.5, 6.25, 5.0, None]
    for bad in ({"start": 1.0, "low": 5.0}, {"back_off": 1.5}, {"warmup": -1.0}, {"calm": 0.0}, {"max_calm": 0.0},
                {"max_drop": 0.95}, {"budget": 0.005, "run_budget": 0.004}, {"gain": 0.0}, {"min_cut": 0.6},
                {"prove": 0.0}):
        with pytest.raises(ValueError):
            SpeedGovernor(**bad)


@pytest.mark.parametrize("capacity", [25.0, 42.0, 60.0, 90.0])
def test_on_a_machine_of_any_capacity_the_run_ends_near_it_and_never_far_below(capacity: float) -> None:
    """The whole loop: a machine whose floors compute ``capacity`` x, with speed-independent stalls now and then and
    the start-up's stall in the warm-up; after two minutes the ceiling is within [0.8, 1.1] x the capacity."""
    gov, floors = SpeedGovernor(start=50.0), Floors()
    gov.look(floors.clocks, floors.wall, active=False)
    gov.look(floors.clocks, floors.wall, active=True)
    gov.look(floors.run({"A": 20, "B": 20}, behind={"A": 0.5}), floors.wall, active=True)   # start-up's stall
    machine(gov, floors, capacity, 120, stalls=0.1)
    assert 0.8 * capacity <= gov.ceiling <= 1.1 * capacity, gov.summary()
    assert gov.proven is not None and gov.proven >= 0.8 * min(capacity, 50.0), gov.summary()
