"""``--speed max`` (ROS-free): the highest speed ceiling every floor keeps up with, found by the run and held.

Every floor's clock advances in lockstep with its controllers, so at any ceiling they run at their nominal
rate in sim time; what a floor cannot sustain shows as wall time *behind* the ceiling (its timeline slot's
``behind`` counter), and a run whose floors were behind for more than 1 % of the tour is *degraded*
(:mod:`gidabot_sim.report.rates`). The demo passes the floors' clocks to :meth:`SpeedGovernor.look` a few
times per wall second and sets every floor's ceiling to what it returns. Over each window of ``window`` wall
seconds:

- a floor could not keep up at all (the slowest floor achieved less than ``keep_up`` of the ceiling and was
  behind it): the ceiling becomes ``back_off`` times the slowest floor's achieved factor;
- the floors kept up but their time behind since the last change is over ``budget`` of the wall time since
  then (counted over at least ``horizon`` seconds), or their time behind since judging started is over
  ``run_budget`` of that time and has grown by a quarter of ``budget`` x ``horizon`` since the last back-off
  for it: the ceiling becomes ``back_off`` times what it was;
- after a back-off, no raise goes above ``back_off`` times the ceiling that failed (the ``limit``) until the
  floors have kept half the budget for ``calm`` wall seconds, a period that doubles with every back-off;
- a back-off for the budget that did not make the floors' time behind per second fall below ``helps`` times
  what it was, where the floors had otherwise kept pace with the ceiling it left (the slowest achieved at
  least ``paced`` of it), is undone and that ceiling held for the rest of the run (``flat_at``): the stalls
  do not depend on the speed there. Where the floors fell short of the ceiling itself, slower does help;
- a window never takes the ceiling below ``max_drop`` times what it was;
- every floor kept up, at most half the budget is spent, the run's time behind leaves room for a failed
  try, and a floor waited for the ceiling for ``patience`` windows in a row: the ceiling is raised by
  ``raise_by``, up to the limit and ``high``;
- otherwise it is held.

Judging starts once the tour runs (``active``) and has run for ``settle`` wall seconds: idle floors keep up
with any ceiling, and the start-up starves the floors for a while; neither says anything about the floors
while their robots drive. Rules and measured runs: docs/demo.md, *Speed*.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from gidabot_sim.world.timeline import Clock


@dataclass
class SpeedGovernor:
    start: float = 50.0          # the first ceiling, sim s per wall s
    low: float = 5.0             # never below
    high: float = 200.0          # never above
    window: float = 1.0          # wall s
    keep_up: float = 0.8         # share of the ceiling the slowest floor achieves over a window when it keeps up
    budget: float = 0.005        # share of the wall time the floors may be behind (degraded above 1 %)
    horizon: float = 15.0        # wall s: the budget is counted over at least this much
    back_off: float = 0.9
    raise_by: float = 1.1
    patience: int = 2            # windows kept up, waiting for the ceiling, before a raise
    settle: float = 2.0          # wall s of tour before the first window
    calm: float = 5.0            # wall s within the budget after the first back-off before the limit is lifted
    max_drop: float = 0.5        # a window takes the ceiling down to no less than this share of it
    run_budget: float = 0.007    # share of the tour's wall time the floors may be behind in all (degraded: 1 %)
    helps: float = 0.75          # a back-off helped when the floors' time behind per second fell below this share
    paced: float = 0.95          # the floors kept pace with a ceiling: the slowest achieved this share of it
    ceiling: float = field(init=False)
    limit: float = field(init=False)
    changes: list[tuple[float, float]] = field(default_factory=list)   # (wall, new ceiling)
    back_offs: int = 0
    lifts: int = 0                                                      # limits lifted after a calm period
    flat_at: float | None = None        # the ceiling held because backing off did not make the stalls rarer
    _since: tuple[float, dict[str, Clock]] | None = None                # the window's start
    _epoch: tuple[float, dict[str, Clock]] | None = None                # the last change (or the tour's start)
    _kept_up: int = 0
    _active_since: float | None = None                                  # wall time the tour started
    _backed_off: tuple[float, int] | None = None                        # (wall, back-offs so far) while limited
    _tour: tuple[float, dict[str, Clock]] | None = None                 # the first judged window's start
    _excess: float | None = None        # wall s behind over the tour's budget at the last back-off for it
    _left: tuple[float, float, bool] | None = None  # the last back-off: the ceiling left, its rate of time behind,
                                                    # whether the floors kept pace with it (``paced``) meanwhile

    def __post_init__(self) -> None:
        if not (0 < self.low <= self.start <= self.high and math.isfinite(self.high)):
            raise ValueError(f"expected 0 < low {self.low} <= start {self.start} <= high {self.high}")
        if not (self.window > 0 and 0 < self.keep_up < 1 and 0 < self.budget < 1 and self.horizon > 0
                and 0 < self.back_off < 1 < self.raise_by and self.patience >= 1 and self.settle >= 0
                and self.calm > 0 and 0 < self.max_drop <= self.back_off and self.budget <= self.run_budget < 1
                and 0 < self.helps <= 1 and 0 < self.paced <= 1):
            raise ValueError("window > 0, 0 < keep_up < 1, 0 < budget < 1, horizon > 0, 0 < back_off < 1 < raise_by, "
                             "patience >= 1, settle >= 0, calm > 0, 0 < max_drop <= back_off, "
                             "budget <= run_budget < 1, 0 < helps <= 1, 0 < paced <= 1")
        self.ceiling, self.limit = float(self.start), float(self.high)

    def look(self, clocks: dict[str, Clock], wall: float, active: bool) -> float | None:
        """The floors' clocks at wall time ``wall``; the new ceiling when it changes, else None."""
        if not clocks:
            return None
        if not active:
            self._active_since = self._tour = None
        elif self._active_since is None:
            self._active_since = wall
        if (self._since is None or set(self._since[1]) != set(clocks) or self._active_since is None
                or wall - self._active_since < self.settle):
            self._since = self._epoch = self._tour = (wall, dict(clocks))   # start-up: not judged (module docstring)
            self._kept_up = 0
            return None
        began, before = self._since
        span = wall - began
        if span < self.window:
            return None
        self._since = (wall, dict(clocks))
        behind = max(clocks[r].behind - before[r].behind for r in clocks)
        slowest = min((clocks[r].sim - before[r].sim) / span for r in clocks)
        if behind > 0 and slowest < self.keep_up * self.ceiling:
            self._left = self.flat_at = None                          # overloaded: slower does help
            return self._back_off(max(self.back_off * slowest, self.max_drop * self.ceiling), wall, clocks)
        epoch_wall, epoch = self._epoch or (began, before)
        spent = max(clocks[r].behind - epoch[r].behind for r in clocks)
        allowed = self.budget * max(wall - epoch_wall, self.horizon)
        tour_wall, tour = self._tour or (epoch_wall, epoch)
        run_spent = max(clocks[r].behind - tour[r].behind for r in clocks if r in tour)
        run_allowed = self.run_budget * max(wall - tour_wall, self.horizon)
        excess = run_spent - run_allowed
        if excess <= 0:
            self._excess = None
        grew = excess > 0 and (self._excess is None or excess > self._excess + self.budget * self.horizon / 4)
        if (spent > allowed or grew) and self.flat_at is None:
            if excess > 0:
                self._excess = excess
            rate = spent / (wall - epoch_wall)                       # wall s behind per wall s at this ceiling
            left = self._left
            if left is not None and left[2] and wall - epoch_wall >= self.window and rate >= self.helps * left[1]:
                # the last back-off did not make the stalls rarer, and the floors kept pace with the ceiling it
                # left between them: here the stalls do not depend on the speed
                self.flat_at, self._backed_off, self.limit = left[0], None, left[0]
                return self._set(left[0], wall, clocks)
            pace = min((clocks[r].sim - epoch[r].sim) for r in clocks if r in epoch) / (wall - epoch_wall)
            self._left = (self.ceiling, rate, pace >= self.paced * self.ceiling)
            return self._back_off(self.back_off * self.ceiling, wall, clocks)
        if self._backed_off is not None and spent <= allowed / 2 and self.flat_at is None:
            since, count = self._backed_off
            if wall - since >= self.calm * 2 ** (count - 1):        # calm long enough: the limit is lifted
                self.limit, self._backed_off = float(self.high), None
                self.lifts += 1
        waited = max(clocks[r].wait_ceiling - before[r].wait_ceiling for r in clocks)
        # a raise may fail, and a failure costs up to the budget: only while the run can afford half of it
        room = run_spent + self.budget * self.horizon / 2 <= run_allowed
        self._kept_up = self._kept_up + 1 if waited > 0 and spent <= allowed / 2 and room else 0
        if self._kept_up >= self.patience and self.ceiling < self.limit:
            self._kept_up, self._left = 0, None
            return self._set(min(self.ceiling * self.raise_by, self.limit, self.high), wall, clocks)
        return None

    def _back_off(self, ceiling: float, wall: float, clocks: dict[str, Clock]) -> float | None:
        self.limit = max(self.low, min(self.limit, self.back_off * self.ceiling))
        self.back_offs += 1
        self._backed_off = (wall, self.back_offs)
        self._kept_up = 0
        return self._set(max(self.low, min(ceiling, self.limit)), wall, clocks)

    def _set(self, ceiling: float, wall: float, clocks: dict[str, Clock]) -> float | None:
        self._epoch = (wall, dict(clocks))           # the budget starts again at every change
        ceiling = round(ceiling, 2)
        if ceiling == self.ceiling:
            return None
        self.ceiling = ceiling
        self.changes.append((wall, ceiling))
        return ceiling

    def summary(self) -> dict:
        """For run.json: the ceiling held at the end, the limit found, and every change."""
        return {"ceiling": self.ceiling, "limit": self.limit, "back_offs": self.back_offs, "lifts": self.lifts,
                "flat_at": self.flat_at,
                "changes": [[round(w, 2), c] for w, c in self.changes]}
