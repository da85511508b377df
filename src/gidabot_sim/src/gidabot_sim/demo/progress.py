"""Progress of a run, from the monitor's JSON lines (ROS-free)."""

from __future__ import annotations

import contextlib
import json
from dataclasses import dataclass, field

from gidabot_navigation.interface import (
    ACCEPTED,
    GOAL_REACHED,
    PARTNER_OFFLINE,
    PHASE_NAMES,
    REJECTED,
    TIMEOUT,
    TOUR_FINISHED,
    TOUR_STEP_DONE,
    UNREACHABLE,
)

# phases that end the visit. Cancels do not: a skip cancels the step being run, and a cancel that
# gives a trip up comes with its own phase (UNREACHABLE, TIMEOUT, PARTNER_OFFLINE) first.
FAILURES = {p: PHASE_NAMES[p] for p in (UNREACHABLE, TIMEOUT, PARTNER_OFFLINE, REJECTED)}


@dataclass
class Progress:
    """What happened so far: goals issued and completed, the latest phase, the end."""

    total_goals: int
    tour_mode: bool = True
    robots_total: int = 0
    robots_up: list[str] = field(default_factory=list)          # robots heard once, in order
    goals: dict[str, dict] = field(default_factory=dict)        # goal uid -> monitor record
    completed: set[str] = field(default_factory=set)
    robot: str = ""
    phase: str = "starting"
    finished: bool = False
    outcome: str = ""
    first_sim: float | None = None     # sim time of the first goal
    last_sim: float | None = None      # sim time of the end
    first_wall: float | None = None
    last_wall: float | None = None
    events: int = 0
    latest_sim: float | None = None    # the newest record (an unfinished run is measured up to it)
    latest_wall: float | None = None
    states: dict[str, str] = field(default_factory=dict)

    def feed_line(self, line: str) -> bool:
        """Take one JSON line; return True when the visible progress changed."""
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            return False
        return self.feed(rec) if isinstance(rec, dict) else False

    def feed(self, rec: dict) -> bool:
        kind = rec.get("kind")
        if kind in ("goal", "event", "cancel"):
            with contextlib.suppress(TypeError, ValueError):
                self.latest_sim, self.latest_wall = float(rec.get("sim", 0.0)), float(rec.get("wall", 0.0))
        if kind == "up":
            robot = str(rec.get("robot", ""))
            if robot in self.robots_up:
                return False
            self.robots_up.append(robot)
            return True
        if kind == "status":
            self.states[str(rec.get("robot"))] = str(rec.get("state"))
            return False
        if kind == "goal":
            uid = str(rec.get("uid"))
            if uid in self.goals:
                return False
            self.goals[uid] = rec
            self.robot, self.phase = str(rec.get("origin", "")), "new goal"
            if self.first_sim is None:
                self.first_sim, self.first_wall = float(rec.get("sim", 0.0)), float(rec.get("wall", 0.0))
            return True
        if kind != "event":
            return False
        self.events += 1
        phase = int(rec.get("phase", -1))
        if phase != ACCEPTED:   # every robot involved accepts: not worth a line
            self.robot, self.phase = str(rec.get("robot", "")), PHASE_NAMES.get(phase, f"phase {phase}")
        uid = str(rec.get("goal_uid", ""))
        if phase in (GOAL_REACHED, TOUR_STEP_DONE, TOUR_FINISHED) and uid:
            self.completed.add(uid)
        if not self.finished:
            if phase == TOUR_FINISHED or (phase == GOAL_REACHED and not self.tour_mode):
                self._finish("completed", rec)
            elif phase in FAILURES:
                self._finish(f"{FAILURES[phase]} ({rec.get('robot')}: {rec.get('detail', '')})", rec)
        return True

    def _finish(self, outcome: str, rec: dict) -> None:
        self.finished, self.outcome = True, outcome
        self.last_sim, self.last_wall = float(rec.get("sim", 0.0)), float(rec.get("wall", 0.0))

    @property
    def goal_index(self) -> int:
        """1-based number of the goal being run: its tour step + 1 in a tour, else goals seen."""
        if not self.goals:
            return 0
        step = list(self.goals.values())[-1].get("tour_step", -1)
        return int(step) + 1 if self.tour_mode and isinstance(step, int) and step >= 0 else len(self.goals)

    def current_goal(self) -> str:
        if not self.goals:
            return ""
        last = list(self.goals.values())[-1]
        floors = ""
        if "initial_floor" in last and "goal_floor" in last:
            floors = f" {float(last['initial_floor']):g}->{float(last['goal_floor']):g}"
        return f"{last.get('goal_id', '')}{floors}"

    def line(self) -> str:
        if not self.goals and self.robots_total and not self.events:
            up = len(self.robots_up)
            return (f"starting: {up} of {self.robots_total} robots up" + (f" ({', '.join(self.robots_up)})"
                                                                           if up else ""))
        return (f"goal {self.goal_index} of {self.total_goals} ({self.current_goal() or '-'}), "
                f"{len(self.completed)} done | {self.robot or '-'}: {self.phase}")

    def sim_seconds(self) -> float:
        """Sim time from the first goal to the end (unfinished: to the newest record)."""
        last = self.last_sim if self.last_sim is not None else self.latest_sim
        if self.first_sim is None or last is None:
            return 0.0
        return max(0.0, last - self.first_sim)

    def wall_seconds(self) -> float:
        last = self.last_wall if self.last_wall is not None else self.latest_wall
        if self.first_wall is None or last is None:
            return 0.0
        return max(0.0, last - self.first_wall)
