"""The run's timing from the floors' clocks (ROS-free): achieved factor, time behind the ceiling, drift.

The demo looks at every floor's clock (:class:`gidabot_sim.world.timeline.Clock`) at the tour's first goal,
while the tour runs and at its end; :meth:`RunTiming.summary` is what ``run.json`` keeps under
``timing`` (the report adds the controllers' rates from the bags and gives the verdict).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from gidabot_sim.world.timeline import Clock


@dataclass
class RunTiming:
    """``peer_timeout``: wall s after which a floor whose clock was not updated counts as not running."""

    robots: list[str]
    peer_timeout: float = 5.0
    first: dict[str, Clock] = field(default_factory=dict)     # clocks at the tour's first goal
    latest: dict[str, Clock] = field(default_factory=dict)
    first_wall: float | None = None
    latest_wall: float | None = None
    max_drift: float = 0.0            # sim s between the fastest and the slowest running floor, at most
    _previous: tuple[float, dict[str, Clock]] | None = None

    def look(self, clocks: dict[str, Clock], wall: float, tour_started: bool) -> None:
        """The floors' clocks at wall time ``wall``; ``tour_started``: the tour's first goal has been seen."""
        if not clocks:
            return
        if tour_started and not self.first:
            self.first, self.first_wall = dict(clocks), wall
        if self.first:
            self.latest, self.latest_wall = dict(clocks), wall
            running = [c.sim for c in clocks.values() if wall - c.wall < self.peer_timeout]
            if len(running) > 1:
                self.max_drift = max(self.max_drift, max(running) - min(running))
        self._previous = (wall, dict(clocks))

    def factors(self, clocks: dict[str, Clock], wall: float) -> dict[str, float]:
        """Achieved sim s per wall s of each floor since the previous look (the progress line)."""
        if self._previous is None or wall <= self._previous[0]:
            return {}
        span = wall - self._previous[0]
        return {r: (c.sim - self._previous[1][r].sim) / span for r, c in clocks.items() if r in self._previous[1]}

    def summary(self) -> dict:
        """Per floor over the tour: sim and wall seconds, achieved factor, wall s behind the ceiling and waiting
        (for controllers, other floors, the ceiling), participants given up on; the largest drift."""
        floors = {}
        if self.first and self.latest and self.first_wall is not None and self.latest_wall is not None:
            wall = self.latest_wall - self.first_wall
            for robot in self.robots:
                a, b = self.first.get(robot), self.latest.get(robot)
                if a is None or b is None:
                    continue
                sim = b.sim - a.sim
                # the clocks' behind includes lateness not yet re-anchored, which the floor may still make up:
                # lateness pending at the tour's start and made up later is no time behind (never below 0)
                behind = max(0.0, b.behind - a.behind)
                floors[robot] = {
                    "sim_start": round(a.sim, 2), "sim_end": round(b.sim, 2), "sim_s": round(sim, 2),
                    "wall_s": round(wall, 2),
                    "achieved_factor": round(sim / wall, 2) if wall > 0 else 0.0,
                    "behind_s": round(behind, 3),
                    "behind_pct": round(100.0 * behind / wall, 2) if wall > 0 else 0.0,
                    "wait_controllers_s": round(b.wait_controllers - a.wait_controllers, 3),
                    "wait_floors_s": round(b.wait_floors - a.wait_floors, 3),
                    "wait_ceiling_s": round(b.wait_ceiling - a.wait_ceiling, 3),
                    "steps": int(b.steps - a.steps), "timeouts": int(b.timeouts - a.timeouts),
                    "max_lead_s": round(b.max_lead, 2),
                }
        return {"floors": floors, "max_drift_s": round(self.max_drift, 2)}
