"""Who arrives at the meeting point (ROS-free): the goal-floor robot asks them to press Continue.

While the goal-floor robot of a cross-floor trip waits at the connector's meeting point, it watches the people
its laser tracks (:class:`~gidabot_navigation.perception.people.Track`). Someone who *arrives* — a confirmed
track first seen farther than ``approach_from`` m that comes within ``arrive_within`` m of the robot — is asked
to press Continue; someone who stays there (within ``arrive_within``) without pressing it is asked again every
``ask_again_after`` s, at most ``max_asks`` times in all. A person who was already standing by the robot when
it arrived is not taken for the visitor (a bystander); nobody arriving changes nothing (the Continue timeout
runs as without it).

Inputs: :meth:`ArrivalWatch.on_people` with the robot's pose, the tracks and the time (s); it returns a short
description of the arrival when the robot should ask, else None.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.errors import GuidingError
from gidabot_navigation.perception.people import Track


@dataclass(frozen=True)
class ArrivalConfig:
    """Distances in m, times in s."""

    arrive_within: float = 1.5
    approach_from: float = 2.5
    ask_again_after: float = 20.0
    max_asks: int = 3

    def __post_init__(self) -> None:
        problems = [f"{name}: {getattr(self, name)!r} must be a positive number"
                    for name in ("arrive_within", "approach_from", "ask_again_after")
                    if not (isinstance(getattr(self, name), (int, float)) and math.isfinite(getattr(self, name))
                            and getattr(self, name) > 0)]
        if not problems and self.approach_from <= self.arrive_within:
            problems.append(f"approach_from {self.approach_from:g} must be more than arrive_within "
                            f"{self.arrive_within:g}")
        if not isinstance(self.max_asks, int) or self.max_asks < 1:
            problems.append(f"max_asks: {self.max_asks!r} must be a whole number >= 1")
        if problems:
            raise GuidingError("meeting point: " + "; ".join(problems))


@dataclass
class ArrivalWatch:
    """The people around the robot waiting at a meeting point (see the module's docstring)."""

    cfg: ArrivalConfig = field(default_factory=ArrivalConfig)
    asks: int = 0
    _came_from_afar: set[int] = field(default_factory=set)   # track ids first seen beyond approach_from
    _known: set[int] = field(default_factory=set)            # every track id seen
    _asked_at: float | None = None

    def on_people(self, robot: Pose2D, tracks: Sequence[Track], t: float) -> str | None:
        cfg = self.cfg
        here: list[tuple[float, int]] = []
        for tr in tracks:
            if not tr.confirmed or not (math.isfinite(tr.x) and math.isfinite(tr.y)):
                continue
            d = math.hypot(tr.x - robot.x, tr.y - robot.y)
            if tr.id not in self._known:
                self._known.add(tr.id)
                if d > cfg.approach_from:
                    self._came_from_afar.add(tr.id)
            if d <= cfg.arrive_within and tr.id in self._came_from_afar:
                here.append((d, tr.id))
        if not here or self.asks >= cfg.max_asks:
            return None
        if self._asked_at is not None and t - self._asked_at < cfg.ask_again_after:
            return None
        self.asks += 1
        self._asked_at = t
        d, tid = min(here)
        return f"person {tid} at {d:.1f} m" + ("" if self.asks == 1 else f", asked again ({self.asks})")
