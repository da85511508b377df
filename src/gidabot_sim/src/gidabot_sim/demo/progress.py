"""Progress of a run, from the monitor's JSON lines (ROS-free).

The visit ends only on events about *its own* trips from the robots those trips involve
(docs/demo.md), never on whatever else is on the bus (another visitor, a hostile publisher):

- a goal is one of the visit's trips if it is the visit's (its tour file; in single-target
  mode its goal and no tour), valid (``guiding.messages.validate_trip`` against the
  building, as every goal manager checks it) and published by its origin robot's goal
  manager;
- an event counts if it is about one of those trips, its robot is involved in the trip
  (the trip's origin, or a robot one of its assignments named for a leg: docs/guiding.md,
  *Who serves a leg*) and it was published by that robot's guiding nodes.

"Published by" is the publisher's node (``callerid``, recorded by the monitor): on the
monitor's master a robot's own goal manager or navigation, for any other robot the relay
end of the monitor's robot and that robot (a relay carries a robot's events only from its
master). Only a REJECTED answer to the visitor's own request (no trip yet: a robot of the
start floor, about the visit's tour or goal) ends a visit without a trip.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, field

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.guiding.messages import Trip, validate_trip
from gidabot_navigation.guiding.state import trip_from_dict
from gidabot_navigation.interface import GUIDING_CALLERIDS, PHASE_NAMES, TRIP_DONE_PHASES, Phase, relay_end_name
from gidabot_sim.report.visits import MonitorFeed, stops_done, visit_completed

# phases that end the visit. Cancels do not: a skip cancels the step being run, and a cancel that
# gives a trip up comes with its own phase (UNREACHABLE, TIMEOUT, PARTNER_OFFLINE, VISITOR_LOST) first.
FAILURES = {p: PHASE_NAMES[p] for p in (Phase.UNREACHABLE, Phase.TIMEOUT, Phase.PARTNER_OFFLINE, Phase.REJECTED,
                                        Phase.VISITOR_LOST)}


@dataclass(frozen=True)
class Visit:
    """What the visit is and where the monitor listens: who may steer its progress."""

    building: Building
    monitor_robot: str            # the robot whose master the monitor runs on
    tour_file: str = ""           # the visit's tour ("" = one target)
    goal_id: str = ""             # the target of a single-target visit
    start_floor: float = math.nan

    def publisher_of(self, robot: str) -> str:
        """The node that publishes ``robot``'s messages on the monitor's master ("" = one of its own guiding nodes)."""
        if robot == self.monitor_robot:
            return ""
        names = [r.name for r in self.building.robots]
        a, b = sorted((robot, self.monitor_robot), key=names.index)
        return relay_end_name(a, b)

    def sent_by(self, robot: str, callerid: object) -> bool:
        """Whether a message published by ``callerid`` can be ``robot``'s."""
        if self.building.find_robot(robot) is None:
            return False
        relay = self.publisher_of(robot)
        return callerid in GUIDING_CALLERIDS if not relay else callerid == relay

    def trip(self, rec: dict) -> Trip | None:
        """The visit's trip a monitor goal record describes, or None (another visit's, invalid, forged)."""
        fields = {k: v for k, v in rec.items() if k in Trip.__dataclass_fields__}
        try:
            trip = validate_trip(self.building, trip_from_dict(fields))
        except (GidaBotError, TypeError, ValueError):
            return None
        ours = trip.tour_file == self.tour_file if self.tour_file else \
            (trip.goal_id == self.goal_id and not trip.tour_file)
        return trip if ours and self.sent_by(trip.origin_robot, rec.get("callerid")) else None

    def answers_request(self, rec: dict) -> bool:
        """A REJECTED answer to the visitor's own request (no trip yet) from a robot of the start floor."""
        robot = str(rec.get("robot", ""))
        starters = {r.name for r in self.building.robots_on(self.start_floor)} if math.isfinite(self.start_floor) \
            else set()
        about = rec.get("tour_file") == self.tour_file if self.tour_file else rec.get("location_id") == self.goal_id
        return (robot in starters and about and not rec.get("goal_uid")
                and self.sent_by(robot, rec.get("callerid")))


@dataclass
class Progress(MonitorFeed):
    """What happened so far: goals issued and completed, the latest phase, the end."""

    total_goals: int
    visit: Visit
    robots_total: int = 0
    alone: frozenset[int] = frozenset()                          # tour steps on floors without robot
    robots_up: list[str] = field(default_factory=list)          # robots heard once, in order
    goals: dict[str, dict] = field(default_factory=dict)        # goal uid -> monitor record
    completed: set[str] = field(default_factory=set)            # goal uids completed
    steps: set[int] = field(default_factory=set)                # their tour steps
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
    trips: dict[str, Trip] = field(default_factory=dict)          # goal uid -> the visit's trip
    named: dict[str, set[str]] = field(default_factory=dict)      # goal uid -> its origin and every robot any
                                                                  # of its assignments named for a leg
    ignored: int = 0                   # goals and events that are not the visit's (other visits, hostile input)

    @property
    def tour_mode(self) -> bool:
        return bool(self.visit.tour_file)

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
            trip = self.visit.trip(rec)
            if trip is None:
                self.ignored += 1
                return False
            self.named.setdefault(uid, {trip.origin_robot}).update(r for r in (trip.start_robot, trip.goal_robot) if r)
            if uid in self.goals:          # the same trip again with a newer assignment (docs/guiding.md)
                return False
            self.goals[uid], self.trips[uid] = rec, trip
            self.robot, self.phase = trip.origin_robot, "new goal"
            if self.first_sim is None:
                self.first_sim, self.first_wall = float(rec.get("sim", 0.0)), float(rec.get("wall", 0.0))
            return True
        if kind != "event":
            return False
        phase = rec.get("phase")
        robot = str(rec.get("robot", ""))
        trip = self.trips.get(str(rec.get("goal_uid", "")))
        known = isinstance(phase, int) and not isinstance(phase, bool) and phase in PHASE_NAMES
        ours = (known and trip is not None and self.visit.sent_by(robot, rec.get("callerid"))
                and robot in self.named.get(trip.uid, ()))
        if not ours and not (known and phase == Phase.REJECTED and self.visit.answers_request(rec)):
            self.ignored += 1
            return False
        self.events += 1
        if phase not in (Phase.ACCEPTED, Phase.ASSIGNED, Phase.DECLINED):   # who serves which leg: not worth a line
            self.robot, self.phase = robot, PHASE_NAMES.get(phase, f"phase {phase}")
        if phase in TRIP_DONE_PHASES and trip is not None:
            self.completed.add(trip.uid)
            if trip.tour_step >= 0:
                self.steps.add(trip.tour_step)
        if not self.finished:
            if visit_completed(phase, self.tour_mode):
                self._finish("completed", rec)
            elif phase in FAILURES:
                self._finish(f"{FAILURES[phase]} ({robot}: {rec.get('detail', '')})", rec)
        return True

    def _finish(self, outcome: str, rec: dict) -> None:
        self.finished, self.outcome = True, outcome
        self.last_sim, self.last_wall = float(rec.get("sim", 0.0)), float(rec.get("wall", 0.0))

    @property
    def done(self) -> int:
        """Goals done: the tour's stops (those found alone included), else the targets completed."""
        return len(stops_done(self.steps, self.alone)) if self.tour_mode else len(self.completed)

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
                f"{self.done} done | {self.robot or '-'}: {self.phase}")

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
