"""Following the tour of a chaos run while it goes (ROS-free), from the records of the chaos probes.

:class:`Tail` reads the new complete lines of every probe's file; :class:`TourWatch` tells from them the goals
of the tour, the steps done, the trip under way and the tour's end (finished, or a trip that failed).
"""

from __future__ import annotations

import contextlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gidabot_navigation.interface import GUIDING_CALLERIDS, LEG_START, TRIP_DONE_PHASES, Node, Phase, global_name


class Tail:
    """New records of every probe's file since the last call (to follow the tour)."""

    def __init__(self, paths: list[Path]) -> None:
        self.offsets = dict.fromkeys(paths, 0)

    def read(self) -> list[dict[str, Any]]:
        recs = []
        for path, off in self.offsets.items():
            try:
                with open(path, encoding="utf-8") as f:
                    f.seek(off)
                    data = f.read()
            except FileNotFoundError:
                continue
            end = data.rfind("\n") + 1
            self.offsets[path] = off + end
            for line in data[:end].splitlines():
                with contextlib.suppress(json.JSONDecodeError):
                    recs.append(json.loads(line))
        return recs


@dataclass
class TourWatch:
    """The tour's progress from the probes' records: goals accepted, steps done, its end."""

    tour_file: str
    last_step: int
    robots: set[str]
    goals: set[str] = field(default_factory=set)
    floors: dict[str, tuple[float, float]] = field(default_factory=dict)   # goal uid -> (start, goal floor)
    done: set[str] = field(default_factory=set)                            # goal uids reached
    finished: bool = False
    failure: str = ""
    last_step_done: int = -1
    latest: str = ""

    def feed(self, recs: list[dict[str, Any]]) -> None:
        for r in recs:
            if r.get("k") == "goal" and r.get("c") == global_name(Node.GOAL_MANAGER) and r.get("m") == r.get("origin") \
                    and r.get("tour_file") == self.tour_file:
                self.goals.add(str(r.get("uid")))
                with contextlib.suppress(TypeError, ValueError):
                    self.floors[str(r.get("uid"))] = (float(r.get("initial_floor")), float(r.get("goal_floor")))
            if r.get("k") != "event" or r.get("robot") not in self.robots or r.get("m") != r.get("robot") \
                    or r.get("c") not in GUIDING_CALLERIDS or r.get("tour_file") != self.tour_file:
                continue
            phase = r.get("phase")
            if phase in TRIP_DONE_PHASES:
                self.done.add(str(r.get("goal_uid")))
                self.last_step_done = max(self.last_step_done, int(r.get("tour_step", -1)))
                self.latest = f"step {int(r.get('tour_step', -1)) + 1} done at {r.get('robot')}"
            if phase == Phase.TOUR_FINISHED and (r.get("tour_step") == self.last_step or r.get("leg") == LEG_START):
                self.finished = True            # (the start leg's: the tour ends on floors without robot)
            elif phase in (Phase.UNREACHABLE, Phase.TIMEOUT):   # the visit ends (PARTNER_OFFLINE: asked again)
                self.failure = f"{r.get('robot')}: phase {phase} ({r.get('detail', '')})"

    def active(self) -> tuple[float, float] | None:
        """(start floor, goal floor) of the tour's goal under way, None between goals."""
        pending = [u for u in self.floors if u not in self.done]
        return self.floors[pending[-1]] if pending else None
