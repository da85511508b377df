"""``--speed max`` (ROS-free): the highest speed ceiling every floor keeps up with, found by the run and held.

Every floor's clock advances in lockstep with its controllers, so at any ceiling they run at their nominal
rate in sim time; what a floor cannot sustain shows as wall time *behind* the ceiling (its timeline slot's
``behind`` counter), and a run whose floors were behind for more than 1 % of the tour is *degraded*
(:mod:`gidabot_sim.report.rates`). The demo passes the floors' clocks to :meth:`SpeedGovernor.look` a few
times per wall second and sets every floor's ceiling to what it returns.

- **Warm-up**: nothing is judged before the tour runs (idle floors keep up with any ceiling), and its first
  ``warmup`` wall seconds are judged as one window, for overload only: the start-up's last processes starve
  the floors then, and a stall of a second must not decide the whole run. The budgets count from its end.
- **Overload** (a window in which the slowest floor achieved less than ``keep_up`` of the ceiling and was
  behind it): the ceiling becomes ``back_off`` times what the slowest floor achieved (never less than
  ``max_drop`` times the ceiling in one window).
- **Over the budget** (the floors kept up, but their time behind since the last change is over ``budget`` of
  the wall time since then, counted over at least ``horizon`` seconds; or the run's time behind since the
  warm-up is over ``run_budget`` of it and grew by a quarter of ``budget`` x ``horizon`` since the last such
  back-off): the ceiling comes down *in proportion* to how far behind the floors were: by ``gain`` times their
  time behind per wall second, at least ``min_cut`` and at most ``1 - max_drop``.
- **Proven**: a ceiling held for ``prove`` wall seconds within half the budget, the floors keeping pace with
  it (the slowest at ``paced`` of it or more), is proven sustainable; a back-off for the budget never goes
  below the highest proven ceiling (at it, the stalls do not depend on the speed, and slower would only be
  slower). An overload may (the machine got busier); after ``calm`` wall seconds within half the budget the
  ceiling goes straight back to it, however many overloads took it down.
- **Probing**: after a back-off no raise goes above ``back_off`` times the ceiling that failed (nor above the
  ceiling the back-off left, if higher: the ``limit``) until the floors have kept half the budget for ``calm``
  wall seconds, a period that doubles with every back-off up to ``max_calm``; then the limit is lifted and the
  ceiling probes upwards again.
- **Raise**: every floor kept up, at most half the budget is spent, the run's time behind leaves room for a
  failed try, and a floor waited for the ceiling for ``patience`` windows in a row: ``raise_by`` times the
  ceiling, up to the limit and ``high``.

Rules and measured runs: docs/demo.md, *Speed*.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from gidabot_sim.world.timeline import Clock

Look = tuple[float, dict[str, Clock]]          # (wall, every floor's clock)


@dataclass
class SpeedGovernor:
    start: float = 50.0          # the first ceiling, sim s per wall s
    low: float = 5.0             # never below
    high: float = 200.0          # never above
    window: float = 1.0          # wall s
    keep_up: float = 0.8         # share of the ceiling the slowest floor achieves over a window when it keeps up
    budget: float = 0.005        # share of the wall time the floors may be behind (degraded above 1 %)
    horizon: float = 15.0        # wall s: the budget is counted over at least this much
    back_off: float = 0.9        # an overload's margin below what the floors achieved; the limit below a failure
    gain: float = 1.5            # a back-off for the budget: this times the floors' time behind per wall second
    min_cut: float = 0.03        # ... but at least this share of the ceiling
    raise_by: float = 1.1
    patience: int = 2            # windows kept up, waiting for the ceiling, before a raise
    warmup: float = 3.0          # wall s of tour judged as one window, for overload only
    calm: float = 5.0            # wall s within the budget after the first back-off before the limit is lifted
    max_calm: float = 40.0       # ... a period that doubles with every back-off up to this
    max_drop: float = 0.5        # a window takes the ceiling down to no less than this share of it
    run_budget: float = 0.007    # share of the tour's wall time the floors may be behind in all (degraded: 1 %)
    paced: float = 0.95          # the floors kept pace with a ceiling: the slowest achieved this share of it
    prove: float = 5.0           # wall s a ceiling is held within half the budget, paced, to be proven
    ceiling: float = field(init=False)
    limit: float = field(init=False)
    proven: float | None = None         # the highest ceiling proven sustainable
    changes: list[tuple[float, float]] = field(default_factory=list)   # (wall, new ceiling)
    back_offs: int = 0
    lifts: int = 0                                                      # limits lifted after a calm period
    _active_since: float | None = None  # wall time the tour started
    _since: Look | None = None          # the window's start
    _epoch: Look | None = None          # the last change (or the warm-up's end)
    _tour: Look | None = None           # the warm-up's end: the run's budget counts from here
    _kept_up: int = 0
    _backed_off: tuple[float, int] | None = None                        # (wall, back-offs so far) while limited
    _excess: float | None = None        # wall s behind over the run's budget at the last back-off for it

    def __post_init__(self) -> None:
        if not (0 < self.low <= self.start <= self.high and math.isfinite(self.high)):
            raise ValueError(f"expected 0 < low {self.low} <= start {self.start} <= high {self.high}")
        if not (self.window > 0 and 0 < self.keep_up < 1 and 0 < self.budget < 1 and self.horizon > 0
                and 0 < self.back_off < 1 < self.raise_by and self.patience >= 1 and self.warmup >= 0
                and self.calm > 0 and self.max_calm > 0 and 0 < self.max_drop <= self.back_off
                and self.budget <= self.run_budget < 1
                and self.gain > 0 and 0 < self.min_cut <= 1 - self.max_drop and 0 < self.paced <= 1
                and self.prove > 0):
            raise ValueError("window > 0, 0 < keep_up < 1, 0 < budget < 1, horizon > 0, 0 < back_off < 1 < raise_by, "
                             "patience >= 1, warmup >= 0, calm > 0, max_calm > 0, 0 < max_drop <= back_off, "
                             "budget <= run_budget < 1, gain > 0, 0 < min_cut <= 1 - max_drop, 0 < paced <= 1, "
                             "prove > 0")
        self.ceiling, self.limit = float(self.start), float(self.high)

    def look(self, clocks: dict[str, Clock], wall: float, active: bool) -> float | None:
        """The floors' clocks at wall time ``wall``; the new ceiling when it changes, else None."""
        if not clocks:
            return None
        if (not active or self._active_since is None or self._since is None
                or set(self._since[1]) != set(clocks)):           # before the tour (or its floors changed)
            self._active_since = wall if active else None
            self._since = self._epoch = (wall, dict(clocks))
            self._tour, self._kept_up = None, 0
            return None
        began, before = self._since
        span = wall - began
        warming = self._tour is None
        if span < (max(self.warmup, self.window) if warming else self.window):
            return None
        self._since = (wall, dict(clocks))
        behind = max(clocks[r].behind - before[r].behind for r in clocks)
        slowest = min((clocks[r].sim - before[r].sim) / span for r in clocks)
        if warming:                                  # the warm-up, judged once: overload only; budgets start now
            self._tour = self._epoch = (wall, dict(clocks))
            if behind > 0 and slowest < self.keep_up * self.ceiling:
                return self._set(max(self.back_off * slowest, self.max_drop * self.ceiling, self.low), wall, clocks)
            return None
        if behind > 0 and slowest < self.keep_up * self.ceiling:          # overload
            return self._back_off(max(self.back_off * slowest, self.max_drop * self.ceiling), wall, clocks)
        epoch_wall, epoch = self._epoch or (began, before)
        held = wall - epoch_wall
        spent = max(clocks[r].behind - epoch[r].behind for r in clocks)
        allowed = self.budget * max(held, self.horizon)
        tour_wall, tour = self._tour
        run_spent = max(clocks[r].behind - tour[r].behind for r in clocks if r in tour)
        run_allowed = self.run_budget * max(wall - tour_wall, self.horizon)
        excess = run_spent - run_allowed
        if excess <= 0:
            self._excess = None
        grew = excess > 0 and (self._excess is None or excess > self._excess + self.budget * self.horizon / 4)
        if spent > allowed or grew:
            if excess > 0:
                self._excess = excess
            rate = max(spent / max(held, self.window), run_spent / max(wall - tour_wall, self.window))
            cut = min(max(self.gain * rate, self.min_cut), 1 - self.max_drop)
            target = self.ceiling * (1 - cut)
            if self.proven is not None and target < self.proven:
                if self.ceiling <= self.proven:      # held at a proven ceiling: the stalls do not depend on the speed
                    self._epoch = (wall, dict(clocks))
                    self._kept_up = 0
                    return None
                target = self.proven
            return self._back_off(target, wall, clocks)
        pace = min(clocks[r].sim - epoch[r].sim for r in clocks if r in epoch) / max(held, 1e-9)
        if held >= self.prove and spent <= allowed / 2 and pace >= self.paced * self.ceiling:
            self.proven = max(self.proven or 0.0, self.ceiling)
        if self._backed_off is not None and spent <= allowed / 2:
            since, count = self._backed_off
            if self.proven is not None and self.ceiling < self.proven and wall - since >= self.calm:
                self._kept_up = 0                   # an overload took it below a proven ceiling: back to it once calm
                return self._set(self.proven, wall, clocks)
            if wall - since >= max(self.calm, min(self.calm * 2 ** (count - 1), self.max_calm)):   # lifted
                self.limit, self._backed_off = float(self.high), None
                self.lifts += 1
        waited = max(clocks[r].wait_ceiling - before[r].wait_ceiling for r in clocks)
        # a raise may fail, and a failure costs up to the budget: only while the run can afford half of it
        room = run_spent + self.budget * self.horizon / 2 <= run_allowed
        self._kept_up = self._kept_up + 1 if waited > 0 and spent <= allowed / 2 and room else 0
        if self._kept_up >= self.patience and self.ceiling < self.limit:
            self._kept_up = 0
            return self._set(min(self.ceiling * self.raise_by, self.limit, self.high), wall, clocks)
        return None

    def _back_off(self, ceiling: float, wall: float, clocks: dict[str, Clock]) -> float | None:
        ceiling = max(self.low, ceiling)
        # no raise above back_off x the ceiling that failed (nor above what was left) until calm
        self.limit = max(self.low, self.proven or 0.0, min(self.limit, max(ceiling, self.back_off * self.ceiling)))
        self.back_offs += 1
        self._backed_off = (wall, self.back_offs)
        self._kept_up = 0
        return self._set(ceiling, wall, clocks)

    def _set(self, ceiling: float, wall: float, clocks: dict[str, Clock]) -> float | None:
        self._epoch = (wall, dict(clocks))           # the budget starts again at every change
        ceiling = round(ceiling, 2)
        if ceiling == self.ceiling:
            return None
        self.ceiling = ceiling
        self.changes.append((wall, ceiling))
        return ceiling

    def summary(self) -> dict:
        """For run.json: the ceiling held at the end, the limit found, the highest proven ceiling, every change."""
        return {"ceiling": self.ceiling, "limit": self.limit, "proven": self.proven, "back_offs": self.back_offs,
                "lifts": self.lifts, "changes": [[round(w, 2), c] for w, c in self.changes]}
