"""The paper's tables from a run's records (ROS-free): Table 3, Table 5, who served each leg, robot contacts.

:func:`analyse` turns the :class:`~gidabot_sim.report.bags.RobotRecord` of every robot into the report's
JSON-able dict (docs/demo.md, *The report*):

* per robot, goal messages received (the goals it validated and kept) and processed (its goal manager accepted
  them and its navigation worked on them): paper Table 3;
* per robot, time, distance and mean velocity while guiding the visitor (paper Table 5): from the robot's
  ``ON_THE_WAY`` event (or, if later, from when its move_base took that leg's goal) to the end of that leg, but
  for the time it waited for or searched for its visitor, the distance integrated over the robot's own
  localisation; and the tour total;
* who served each leg (:func:`leg_audit`), robot-robot contacts (:func:`robot_contacts`) and the run's timing
  (:func:`gidabot_sim.report.rates.timing_report`).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass

from gidabot_navigation.guiding.assignment import LegAudit, LegRecord
from gidabot_navigation.interface import (
    FINAL_PHASES,
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_NONE,
    LEG_START,
    SERVING_PHASES,
    TRIP_DONE_PHASES,
    Phase,
)
from gidabot_sim.report.bags import SIM_STATUS, DiagSample, EventSample, PoseSample, RobotRecord
from gidabot_sim.report.pace import merge, pace_from_diagnostics, pace_from_events, people_at, totals, where_lost
from gidabot_sim.report.rates import timing_report
from gidabot_sim.report.visits import stops_done

LEG_ENDS = FINAL_PHASES - {Phase.REJECTED, Phase.DECLINED}    # a robot ended its part of a trip (a leg it served)
MAX_GOAL_START_LAG = 5.0      # sim s: a move_base goal taken later than this after an ON_THE_WAY is not its leg's


@dataclass
class RobotRow:
    name: str
    floor: float
    received: int
    processed: int
    time_s: float
    distance_m: float
    mean_velocity_mps: float


def guiding_intervals(events: Iterable[EventSample], goal_starts: Sequence[float] = ()) -> list[tuple[float, float]]:
    """[start, end] sim-time intervals while the robot was guiding the visitor: from its ON_THE_WAY, or from
    when its move_base took the goal of that leg (``goal_starts``: the stamps of ``move_base/current_goal``,
    time-ordered) if that was later, within :data:`MAX_GOAL_START_LAG` of it, to the end of the leg. The guiding
    node decides and move_base starts a little later in wall time; at 50x and more, those milliseconds are
    tenths of simulated seconds per leg, which no robot ever spent guiding. The time the robot waited for its
    visitor or searched for them (from a WAITING_FOR_YOU or SEARCHING_VISITOR to the FOLLOW_ME) is left out: the
    paper's Table 5 is the guiding with the visitor behind the robot."""
    intervals: list[tuple[float, float]] = []
    start: float | None = None
    in_leg = first = False
    for ev in sorted(events, key=lambda e: e.t):
        if ev.phase == Phase.ON_THE_WAY and not in_leg:
            start, in_leg, first = ev.t, True, True
        elif ev.phase in (Phase.WAITING_FOR_YOU, Phase.SEARCHING_VISITOR) and start is not None:
            intervals.append((_leg_start(start, first, goal_starts, ev.t), ev.t))
            start = None
        elif ev.phase == Phase.FOLLOW_ME and in_leg and start is None:
            start, first = ev.t, False
        elif ev.phase in LEG_ENDS and in_leg:
            if start is not None:
                intervals.append((_leg_start(start, first, goal_starts, ev.t), ev.t))
            start, in_leg = None, False
    return intervals


def _leg_start(start: float, first: bool, goal_starts: Sequence[float], end: float) -> float:
    """When the leg's guiding began: the first part of a leg from when move_base took its goal, if that was later
    than ``start`` (its ON_THE_WAY) by at most :data:`MAX_GOAL_START_LAG`, and before ``end``."""
    if not first:
        return start
    k = bisect.bisect_left(goal_starts, start)
    if k < len(goal_starts) and goal_starts[k] <= min(end, start + MAX_GOAL_START_LAG):
        return goal_starts[k]
    return start


def path_length(poses: list[PoseSample], intervals: list[tuple[float, float]] | None = None) -> float:
    """Distance in m along the pose samples (only inside ``intervals`` if given)."""
    total = 0.0
    for a, b in zip(poses, poses[1:], strict=False):
        if intervals is not None and not any(s <= a.t and b.t <= e for s, e in intervals):
            continue
        step = math.hypot(b.x - a.x, b.y - a.y)
        if math.isfinite(step):
            total += step
    return total


def robot_row(rec: RobotRecord) -> RobotRow:
    intervals = guiding_intervals(rec.events, rec.goal_starts)
    time_s = sum(e - s for s, e in intervals)
    dist = path_length(rec.track, intervals)
    processed = len(rec.accepted & rec.navigated)
    return RobotRow(rec.name, rec.floor, len(rec.goal_uids), processed, round(time_s, 1), round(dist, 1),
                    round(dist / time_s, 3) if time_s > 0 else 0.0)


def analyse(records: list[RobotRecord], run: dict) -> dict:
    """The report as a JSON-able dict (``robots`` and ``tour``)."""
    rows = [robot_row(r) for r in records]
    done = [e for r in records for e in r.events if e.phase in TRIP_DONE_PHASES and e.goal_uid]
    if run.get("stops_alone") is not None:     # a tour: its stops, those found alone on floors without robot too
        completed = stops_done({e.tour_step for e in done if e.tour_step >= 0}, frozenset(run["stops_alone"]))
    else:
        completed = {e.goal_uid for e in done}
    all_goals = set().union(*(r.goal_uids for r in records)) if records else set()
    time_s = sum(r.time_s for r in rows)
    dist = sum(r.distance_m for r in rows)
    sim_s, wall_s = float(run.get("sim_s", 0.0)), float(run.get("wall_s", 0.0))
    tour = {
        "file": run.get("tour", ""),
        "goals": int(run.get("goals", len(all_goals))),
        "completed": len(completed),
        "time_s": round(time_s, 1),
        "distance_m": round(dist, 1),
        "mean_velocity_mps": round(dist / time_s, 3) if time_s > 0 else 0.0,
        "sim_s": round(sim_s, 1),
        "wall_s": round(wall_s, 1),
        "sim_to_wall": round(sim_s / wall_s, 2) if wall_s > 0 else 0.0,
    }
    unreadable = {f"{r.name}: {topic}": n for r in records for topic, n in sorted(r.bad.items())}
    rejected = {r.name: r.rejected_goals for r in records if r.rejected_goals}
    timing = timing_report(records, run)
    pace = merge(pace_from_events((e.t, e.robot, e.goal_uid, e.phase) for r in records for e in r.events),
                 pace_from_diagnostics((d.name, dict(d.values)) for r in records for d in r.diagnostics))
    lost = where_lost(((e.t, e.robot, e.goal_uid) for r in records for e in r.events
                       if e.phase == Phase.VISITOR_LOST and e.robot == r.name),
                      {r.name: [(p.t, p.x, p.y) for p in r.track] for r in records},
                      {r.name: [(d.t, people_at(d.get("people_at"))) for d in r.diagnostics
                                if d.name.startswith(SIM_STATUS) and "people_at" in dict(d.values)] for r in records})
    return {"robots": [asdict(r) for r in rows], "tour": tour, "unreadable_messages": unreadable,
            "pace": {"legs": pace, "totals": totals(pace), "lost": lost}, "rejected_goals": rejected,
            "legs": leg_audit(records),
            "timing": timing, "degraded": timing["degraded"],
            "contacts": robot_contacts(records)}


def _counter(samples: list[DiagSample], key: str) -> int | None:
    """A counter of the floor simulator's ``/diagnostics`` over the run: its last value, plus the last value before
    each drop (the simulator restarted and counted from 0 again). None: never published."""
    total, last, seen = 0, 0, False
    for d in samples:
        if not d.name.startswith(SIM_STATUS):
            continue
        value = d.number(key)
        if not math.isfinite(value):
            continue
        seen = True
        if value < last:
            total += last
        last = int(value)
    return total + last if seen else None


def robot_contacts(records: list[RobotRecord]) -> dict:
    """Robot-robot collisions and deadlocks counted by every robot's floor simulator (its ``/diagnostics`` in its
    bag: ``robot_collisions``, ``robot_deadlocks``; docs/simulator.md). Robots sharing a floor each run their own
    simulator (world/mates.py): each counts the contacts in which its robot was stopped by another, so a contact in
    which both drove counts twice: an upper bound. ``collisions`` None: some robot's simulator published no count
    (``unmeasured`` names them)."""
    per_robot = {r.name: _counter(r.diagnostics, "robot_collisions") for r in records}
    deadlocks = {r.name: _counter(r.diagnostics, "robot_deadlocks") for r in records}
    unmeasured = sorted(name for name, n in per_robot.items() if n is None)
    return {"collisions": None if unmeasured or not records else sum(n or 0 for n in per_robot.values()),
            "deadlocks": sum(n or 0 for n in deadlocks.values()), "per_robot": per_robot, "unmeasured": unmeasured}


def leg_audit(records: list[RobotRecord]) -> dict:
    """Who served each leg, from every bag (docs/guiding.md, *Who serves a leg*): ``legs`` some robot was
    asked to serve, ``double_served`` (two robots or more had it), ``unserved`` (nobody got it and its trip
    never ended), ``served_by``: legs per robot."""
    legs: dict[tuple[str, str], LegRecord] = {}
    ended = {e.goal_uid for r in records for e in r.events if e.phase in LEG_ENDS and e.goal_uid}
    for r in records:
        for uid, leg, robot, state in r.assignments:
            if state != LEG_NONE:
                rec = legs.setdefault((uid, leg), LegRecord())
                if state == LEG_COMMITTED:
                    rec.committed.add(robot)
        for e in r.events:
            if e.goal_uid and e.leg in (LEG_START, LEG_GOAL):
                rec = legs.setdefault((e.goal_uid, e.leg), LegRecord())
                if e.phase == Phase.ASSIGNED:
                    rec.assigned.add(e.assignee)
                elif e.phase in SERVING_PHASES:
                    rec.served.add(e.robot)
    audit = LegAudit(legs, ended)
    served_by: dict[str, int] = {}
    for uid, leg in legs:
        robot = audit.served_by(uid, leg)
        if robot:
            served_by[robot] = served_by.get(robot, 0) + 1
    return {"legs": len(legs), "double_served": [list(x) for x in audit.double_served],
            "unserved": [list(x) for x in audit.unserved], "served_by": served_by}

