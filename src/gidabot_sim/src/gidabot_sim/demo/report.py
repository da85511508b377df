"""``gidabot report <run folder>``: the paper's tables from a run's rosbags (no ROS needed).

A run folder (written by ``gidabot demo``/``chaos``) holds ``run.json`` and one
rosbag per robot (``<robot>.bag``, recorded on that robot's master; after a restart
of its master the recording goes on in further parts, ``run.json`` lists them as
``bags``, and every part is read: a message in two parts counts once). Bags are
read with the ``rosbags`` library, which takes the message definitions from the
bags themselves. Printed (``--json``: the same as one JSON object):

* per robot, goal messages received and processed (paper Table 3), hostile input left
  out (docs/demo.md, *The report*):

  - *received*: the goals the robot validated and kept: distinct goals on
    ``/gidabot/goals`` of its master that pass the goal manager's own check
    (``guiding.messages.validate_trip`` against the run's building) and were published
    by their origin robot's goal manager (the bag's connection header: ``callerid``
    ``/goal_manager`` for the robot's own goals, the relay end from the origin robot
    for the others'). Other messages are counted apart (``rejected_goals``);
  - *processed*: the trips the robot ran: its goal manager accepted them (an
    ``ACCEPTED`` event published by its own ``/goal_manager``) and its navigation
    worked on them (an event of its own ``/multirobot_navigation``).

  A robot's events (Table 5, completions) are the ones its own guiding nodes published
  (bags without publisher information: every event naming the robot);
* per robot, time, distance and mean velocity while guiding the visitor (paper
  Table 5): from the robot's ``ON_THE_WAY`` event (or, if later, from when its move_base took
  that leg's goal: ``move_base/current_goal``) to the end of that leg, with the
  distance integrated over the robot's own localisation (``/amcl_pose`` of its bag:
  a sample every 0.1 m, whatever the sim speed; bags without it: the robot's
  ``/gidabot/poses``); and the tour total;
* a run with many visitors (``gidabot demo --visitors``: ``population`` in ``run.json``): per
  robot legs served, busy fraction and queue length, per visitor wait and trip time, the mean
  and 95th percentile wait, visits completed, cancelled and timed out (:mod:`gidabot_sim.demo.crowd`
  over the run's ``monitor.jsonl``), and a verdict: FAILED (exit 1) on a visit that did not end as
  its visitor chose, a lost or duplicated goal, a leg served by two robots or by none;
* one PNG per floor with the path each robot followed over the blueprint (Fig. 7):
  thick while guiding the visitor, thin dashed while driving alone (to a meeting
  point, back to the visitor), the tour's goals numbered by step;
* the run's timing (:func:`timing_report`): per floor over the tour, the achieved factor and
  the wall time its clock was behind its speed ceiling (``run.json``, from the floors' timeline),
  each lockstep controller's answers against the steps it owed (move_base, amcl: its rate in
  sim time against nominal) and each guiding node's loop rate against nominal (the floor's
  ``/diagnostics`` in its bag), the largest drift between floors; the run is *degraded* when a
  floor was behind for more than 1 % of the tour or a rate fell below 80 % of nominal.
"""

from __future__ import annotations

import argparse
import bisect
import json
import math
import re
import sys
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from gidabot_navigation.building.geometry import quaternion_to_yaw
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.guiding.assignment import LegAudit, LegRecord
from gidabot_navigation.guiding.messages import Trip, validate_trip
from gidabot_navigation.interface import (
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_NONE,
    LEG_START,
    SERVING_PHASES,
    Phase,
    Topic,
    global_name,
    relay_end_name,
)
from gidabot_sim.demo.crowd import Crowd
from gidabot_sim.demo.progress import COMPLETIONS, GUIDING_CALLERIDS, stops_done
from gidabot_sim.errors import ReportError, SimConfigError
from gidabot_sim.visitor.population import VisitorPlan, plans_from_list

LEG_ENDS = {Phase.GOAL_REACHED, Phase.GO_TO_FLOOR, Phase.NO_ROBOT_ON_FLOOR, Phase.UNREACHABLE, Phase.CANCELLED_HERE,
            Phase.CANCELLED_ELSEWHERE, Phase.TIMEOUT, Phase.PARTNER_OFFLINE, Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED}
TIMING_STATUSES = ("sim: floor ", "guiding: ")      # the /diagnostics statuses the timing report reads
MAX_BEHIND_PCT = 1.0          # a floor behind its ceiling for more of the tour's wall time: degraded
MAX_GOAL_START_LAG = 5.0      # sim s: a move_base goal taken later than this after an ON_THE_WAY is not its leg's
MIN_RATE_PCT = 80.0           # a controller or guiding loop below this share of its nominal rate: degraded


@dataclass(frozen=True)
class EventSample:
    t: float            # s, header stamp (sim time)
    robot: str
    goal_uid: str
    phase: int
    tour_step: int = -1
    leg: str = ""          # the leg of the trip the robot acted on (docs/guiding.md, who serves a leg)
    assignee: str = ""     # ASSIGNED: the robot that serves ``leg``


@dataclass(frozen=True)
class PoseSample:
    t: float
    x: float
    y: float


@dataclass(frozen=True)
class GoalInfo:
    """Where a goal ends (for the plots)."""

    goal_id: str
    floor: float
    x: float
    y: float
    tour_step: int
    yaw: float = 0.0    # rad: the robot stops facing the door, so the room is that way


@dataclass(frozen=True)
class DiagSample:
    """One status of the floor's ``/diagnostics`` (the simulator's, a guiding node's)."""

    t: float                 # s, header stamp (the floor's sim time)
    name: str
    values: tuple[tuple[str, str], ...]

    def get(self, key: str, default: str = "") -> str:
        return dict(self.values).get(key, default)


@dataclass
class RobotRecord:
    """What one robot's bag says."""

    name: str
    floor: float
    goal_uids: set[str] = field(default_factory=set)      # goals it validated and kept (received)
    events: list[EventSample] = field(default_factory=list)      # events emitted by this robot's guiding nodes
    accepted: set[str] = field(default_factory=set)        # goals its goal manager accepted
    navigated: set[str] = field(default_factory=set)       # goals its navigation worked on
    poses: list[PoseSample] = field(default_factory=list)  # this robot's /gidabot/poses, time-ordered
    local_poses: list[PoseSample] = field(default_factory=list)  # its /amcl_pose (local), time-ordered
    goals: dict[str, GoalInfo] = field(default_factory=dict)     # goal uid -> where it ends
    bad: dict[str, int] = field(default_factory=dict)            # topic -> messages that cannot be read
    rejected_goals: int = 0                                      # messages on /gidabot/goals that are no goal
    diagnostics: list[DiagSample] = field(default_factory=list)  # its floor's timing statuses, time-ordered
    assignments: set[tuple[str, str, str, int]] = field(default_factory=set)  # (goal uid, leg, robot, state)
    goal_starts: list[float] = field(default_factory=list)  # when its move_base took each goal (current_goal)

    @property
    def track(self) -> list[PoseSample]:
        """The robot's path: its own localisation if recorded, else its shared poses."""
        return self.local_poses or self.poses


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
    tenths of simulated seconds per leg, which no robot ever spent guiding."""
    intervals: list[tuple[float, float]] = []
    start: float | None = None
    for ev in sorted(events, key=lambda e: e.t):
        if ev.phase == Phase.ON_THE_WAY and start is None:
            start = ev.t
        elif ev.phase in LEG_ENDS and start is not None:
            k = bisect.bisect_left(goal_starts, start)
            if k < len(goal_starts) and goal_starts[k] <= min(ev.t, start + MAX_GOAL_START_LAG):
                start = goal_starts[k]
            intervals.append((start, ev.t))
            start = None
    return intervals


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
    done = [e for r in records for e in r.events if e.phase in COMPLETIONS and e.goal_uid]
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
    return {"robots": [asdict(r) for r in rows], "tour": tour, "unreadable_messages": unreadable,
            "rejected_goals": rejected, "legs": leg_audit(records), "timing": timing, "degraded": timing["degraded"],
            "contacts": robot_contacts(records)}


def _counter(samples: list[DiagSample], key: str) -> int | None:
    """A counter of the floor simulator's ``/diagnostics`` over the run: its last value, plus the last value before
    each drop (the simulator restarted and counted from 0 again). None: never published."""
    total, last, seen = 0, 0, False
    for d in samples:
        if not d.name.startswith("sim: floor "):
            continue
        value = _number(d, key)
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


# ---------------------------------------------------------------------------
# Timing: can the run's sim time be trusted?
# ---------------------------------------------------------------------------

def _bracket(samples: list[DiagSample], start: float, end: float) -> tuple[DiagSample, DiagSample] | None:
    """The samples around [start, end] (sim time): the last at or before ``start`` (else the first), the first at
    or after ``end`` (else the last)."""
    if len(samples) < 2:
        return None
    a = next((d for d in reversed(samples) if d.t <= start), samples[0])
    b = next((d for d in samples if d.t >= end), samples[-1])
    return (a, b) if b.t > a.t else None


def _number(sample: DiagSample, key: str) -> float:
    try:
        value = float(sample.get(key, "nan"))
    except ValueError:
        return math.nan
    return value


def controller_rates(samples: list[DiagSample], start: float, end: float) -> dict[str, dict]:
    """Each lockstep participant of the floor's simulator over [start, end]: the steps it owed and answered in time
    (its achieved rate against its nominal one), the times the world stopped waiting for it."""
    pair = _bracket([d for d in samples if d.name.startswith("sim: floor ")], start, end)
    if pair is None:
        return {}
    out = {}
    for key, text in pair[1].values:
        if not key.startswith("participant "):
            continue
        try:
            after, before = json.loads(text), json.loads(pair[0].get(key, "{}"))
        except json.JSONDecodeError:
            continue
        delta = {k: after.get(k, 0) - before.get(k, 0) for k in ("owed", "answered", "timeouts", "waited_s")}
        owed = delta["owed"]
        out[key[len("participant "):]] = {"owed": owed, "answered": delta["answered"],
                                          "rate_pct": round(100.0 * delta["answered"] / owed, 1) if owed else 100.0,
                                          "timeouts": delta["timeouts"], "waited_s": round(delta["waited_s"], 3)}
    return out


def loop_rates(samples: list[DiagSample], start: float, end: float) -> dict[str, dict]:
    """Each guiding node's main loop over [start, end]: iterations per sim second, against its nominal rate (it
    wakes at least ``loop_nominal_hz`` times per wall second: at the floor's achieved factor, that many per sim
    second divided by it), and the longest wall gap between two iterations so far."""
    names = sorted({d.name for d in samples if d.name.startswith("guiding: ")})
    out = {}
    for name in names:
        pair = _bracket([d for d in samples if d.name == name], start, end)
        if pair is None:
            continue
        a, b = pair
        count = _number(b, "loop_count") - _number(a, "loop_count")
        ros = _number(b, "loop_ros") - _number(a, "loop_ros")
        wall = _number(b, "loop_wall") - _number(a, "loop_wall")
        nominal = _number(b, "loop_nominal_hz")
        if not all(math.isfinite(v) for v in (count, ros, wall, nominal)) or ros <= 0 or wall <= 0:
            continue
        out[name[len("guiding: "):]] = {
            "loops": int(count), "hz_sim": round(count / ros, 3), "nominal_hz_sim": round(nominal * wall / ros, 3),
            "rate_pct": round(100.0 * count / (nominal * wall), 1),
            "max_gap_wall_s": round(_number(b, "loop_max_gap_wall_s"), 3)}
    return out


def timing_report(records: list[RobotRecord], run: dict) -> dict:
    """Per floor over the tour (``run.json``'s ``timing``, from the timeline): achieved factor, wall time behind
    the speed ceiling and waiting; from the bags: its controllers' and guiding loops' rates. ``degraded``: a floor
    behind for more than ``MAX_BEHIND_PCT`` % of the tour, or a rate below ``MIN_RATE_PCT`` % of nominal (None:
    the run has no timing)."""
    timing = run.get("timing") or {}
    floors: dict[str, dict] = {}
    reasons = []
    for rec in records:
        floor = dict((timing.get("floors") or {}).get(rec.name) or {})
        if not floor:
            continue
        start, end = float(floor.get("sim_start", 0.0)), float(floor.get("sim_end", math.inf))
        floor["controllers"] = controller_rates(rec.diagnostics, start, end)
        floor["guiding"] = loop_rates(rec.diagnostics, start, end)
        floors[rec.name] = floor
        if floor.get("behind_pct", 0.0) > MAX_BEHIND_PCT:
            reasons.append(f"{rec.name}'s clock was behind its speed ceiling for {floor['behind_s']:.1f} s "
                           f"({floor['behind_pct']:.1f} % of the tour)")
        for kind in ("controllers", "guiding"):
            for node, rate in floor[kind].items():
                if rate["rate_pct"] < MIN_RATE_PCT:
                    reasons.append(f"{rec.name}'s {node} ran at {rate['rate_pct']:.0f} % of its nominal rate")
    return {"floors": floors, "max_drift_s": timing.get("max_drift_s"), "degraded": bool(reasons) if floors else None,
            "reasons": reasons}


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


PASSED_VERDICT, FAILED_VERDICT = "PASSED", "FAILED"
COLLISIONS_NOTE = ("robot-robot contacts counted by each robot's floor simulator (a contact in which both robots "
                   "drove counts for each)")


def crowd_report(folder: Path, run: dict, report: dict) -> dict:
    """The many-visitors part of a run's report (``gidabot demo --visitors``; docs/demo.md): per visitor and per
    robot from the monitor's records (:mod:`gidabot_sim.demo.crowd`), the legs' audit from the bags, a verdict."""
    building = _run_building(folder, run)
    try:
        plans = plans_from_list(run["population"], building) if building is not None else \
            tuple(VisitorPlan.from_dict(p) for p in run["population"])
    except SimConfigError as err:
        raise ReportError(f"{folder / 'run.json'}: population: {err}") from err
    crowd = Crowd(plans)
    monitor = folder / "monitor.jsonl"
    try:
        with open(monitor, encoding="utf-8") as lines:
            for line in lines:
                crowd.feed_line(line)
    except OSError as err:
        raise ReportError(f"{monitor}: cannot read ({err.strerror})") from err
    summary = crowd.summary([r["name"] for r in run.get("robots", [])])
    legs = report["legs"]
    problems = list(summary["problems"])
    problems += [f"leg {leg} of {uid} served by {', '.join(robots)}" for uid, leg, robots in legs["double_served"]]
    problems += [f"leg {leg} of {uid} served by nobody" for uid, leg in legs["unserved"]]
    contacts = report.get("contacts") or {"collisions": None, "deadlocks": 0, "per_robot": {}, "unmeasured": []}
    if contacts["collisions"] is None:
        problems.append("robot-robot collisions not measured (no count from the simulator of "
                        f"{', '.join(contacts['unmeasured']) or 'any robot'})")
    elif contacts["collisions"]:
        problems.append(f"{contacts['collisions']} robot-robot collision(s): "
                        + ", ".join(f"{r} {n}" for r, n in contacts["per_robot"].items() if n))
    if run.get("outcome") not in (None, "completed"):
        problems.append(f"the run did not finish: {run.get('outcome')}")
    return {"visitors": summary["visitors"], "completed": summary["completed"], "cancelled": summary["cancelled"],
            "timed_out": summary["timed_out"], "left": summary["left"], "failed": summary["failed"],
            "refused": summary["refused"], "unfinished": summary["unfinished"], "asked_again": summary["asked_again"],
            "collisions": contacts["collisions"], "collisions_note": COLLISIONS_NOTE,
            "deadlocks": contacts["deadlocks"],
            "legs_double_served": len(legs["double_served"]), "legs_unserved": len(legs["unserved"]),
            "wait_mean_s": summary["wait_mean_s"], "wait_p95_s": summary["wait_p95_s"], "seed": run.get("seed"),
            "population": summary, "problems": problems,
            "verdict": FAILED_VERDICT if problems else PASSED_VERDICT}


def format_crowd(report: dict) -> list[str]:
    """The many-visitors tables: per robot, per visitor, overall, the verdict."""
    pop = report["population"]
    chosen = ", ".join(f"{k} {n}" for k, n in pop["intents"].items())
    lines = ["", f"Visitors: {report['visitors']} (seed {report.get('seed')}): {report['completed']} completed, "
                 f"{report['cancelled']} cancelled, {report['timed_out']} timed out, {report.get('left', 0)} left "
                 f"at the screen, {report['failed']} failed, {report['refused']} refused, {report['unfinished']} "
                 f"unfinished; chosen: {chosen}"]
    wait = "-" if report["wait_mean_s"] is None else f"{report['wait_mean_s']:.1f} s"
    p95 = "-" if report["wait_p95_s"] is None else f"{report['wait_p95_s']:.1f} s"
    lines.append(f"Wait before the first robot moved: mean {wait}, 95th percentile {p95}")
    head = f"{'Robot':<12} {'Legs':>5} {'Busy':>6} {'Queue max':>10} {'Queue mean':>11}"
    lines += ["", head, "-" * len(head)]
    lines += [f"{r['robot']:<12} {r['legs_served']:>5} {100 * r['busy_fraction']:>5.0f}% {r['queue_max']:>10} "
              f"{r['queue_mean']:>11.2f}" for r in pop["per_robot"]]
    head = f"{'Visitor':<11} {'At':<12} {'Target':<18} {'Way':<7} {'Chose':<9} {'Arrive':>7} {'Shown':>6} " \
           f"{'Patience':>8} {'Wait':>7} {'Trip':>7}  Outcome"
    lines += ["", head, "-" * len(head)]

    def s(value: float | None) -> str:
        return "-" if value is None else f"{value:.0f}"

    for v in pop["per_visitor"]:
        again = f" (asked again {v['asked_again']}x)" if v.get("asked_again") else ""
        lines.append(f"{v['visitor']:<11} {v['robot']:<12} {v['target']:<18} {v['way']:<7} {v['intent']:<9} "
                     f"{v['arrive_s']:>7.0f} {s(v.get('shown_wait_s')):>6} {s(v.get('patience_s')):>8} "
                     f"{s(v['wait_s']):>7} {s(v['trip_s']):>7}  {v['outcome']}{again}"
                     + ("" if v["as_chosen"] else "  <- not as chosen"))
    lines += ["", "Collisions (robot-robot): not measured" if report["collisions"] is None else
              f"Collisions (robot-robot): {report['collisions']} ({report['collisions_note']}); deadlocks "
              f"reported: {report.get('deadlocks', 0)}"]
    lines.append(f"Verdict: {report['verdict']}" + "".join(f"\n  {p}" for p in report["problems"]))
    return lines


def format_tables(report: dict) -> str:
    lines = ["Goal messages per robot (paper Table 3) and guiding data (paper Table 5)", ""]
    head = f"{'Robot':<12} {'Floor':>5} {'Received':>9} {'Processed':>10} {'Time (s)':>9} {'Dist. (m)':>10} " \
           f"{'Mean vel. (m/s)':>16}"
    lines += [head, "-" * len(head)]
    for r in report["robots"]:
        lines.append(f"{r['name']:<12} {r['floor']:>5g} {r['received']:>9} {r['processed']:>10} {r['time_s']:>9.1f} "
                     f"{r['distance_m']:>10.1f} {r['mean_velocity_mps']:>16.2f}")
    t = report["tour"]
    lines.append(f"{'Tour':<12} {'':>5} {'':>9} {'':>10} {t['time_s']:>9.1f} {t['distance_m']:>10.1f} "
                 f"{t['mean_velocity_mps']:>16.2f}")
    lines += ["", f"Goals completed: {t['completed']} of {t['goals']}"
                  f"   sim time {t['sim_s']:.0f} s, wall time {t['wall_s']:.0f} s "
                  f"(sim/wall {t['sim_to_wall']:.1f}x)"]
    lines += format_timing(report.get("timing") or {})
    legs = report.get("legs")
    if legs:
        verdict = "each served by exactly one robot" if not legs["double_served"] and not legs["unserved"] else \
            f"{len(legs['double_served'])} served by two robots or more, {len(legs['unserved'])} by none"
        lines.append(f"Legs: {legs['legs']}, {verdict} ("
                     + ", ".join(f"{r} {n}" for r, n in sorted(legs["served_by"].items())) + ")")
        lines += [f"  two robots on {uid} {leg}: {', '.join(robots)}" for uid, leg, robots in legs["double_served"]]
        lines += [f"  nobody on {uid} {leg}" for uid, leg in legs["unserved"]]
    contacts = report.get("contacts")
    if contacts and "population" not in report:
        lines.append("Robot-robot collisions: " + ("not measured" if contacts["collisions"] is None else
                                                   f"{contacts['collisions']}, deadlocks {contacts['deadlocks']}"))
    for robot, n in report.get("rejected_goals", {}).items():
        lines.append(f"note: {robot}: {n} message(s) on {Topic.GOALS} were not goals (hostile input), not counted")
    for where, n in report.get("unreadable_messages", {}).items():
        lines.append(f"warning: {where}: {n} message(s) in the bag could not be deserialised (skipped)")
    if "population" in report:
        lines += format_crowd(report)
    return "\n".join(lines)


def format_timing(timing: dict) -> list[str]:
    floors = timing.get("floors") or {}
    if not floors:
        return []
    def short(name: str) -> str:
        return name.rsplit("/", 1)[-1].split(" ")[0]

    nodes = sorted({short(n) for f in floors.values() for n in (*f["controllers"], *f["guiding"])})
    lines = ["", "Timing over the tour, per floor (docs/simulator.md): achieved sim/wall factor, wall time behind the "
                 "speed ceiling, rates against nominal (%)", ""]
    head = f"{'Robot':<12} {'sim/wall':>8} {'behind (s)':>10} {'behind %':>8} " + " ".join(
        f"{n[:12]:>12}" for n in nodes)
    lines += [head, "-" * len(head)]
    for robot, f in floors.items():
        rates = {short(n): r["rate_pct"] for kind in ("controllers", "guiding") for n, r in f[kind].items()}
        lines.append(f"{robot:<12} {f['achieved_factor']:>8.1f} {f['behind_s']:>10.2f} {f['behind_pct']:>8.2f} "
                     + " ".join(f"{rates[n]:>12.0f}" if n in rates else f"{'-':>12}" for n in nodes))
    drift = timing.get("max_drift_s")
    lines.append("")
    lines.append(("largest drift between floors: " + (f"{drift:.1f} s sim" if drift is not None else "not measured"))
                 + ("; DEGRADED: " + "; ".join(timing["reasons"]) if timing.get("degraded") else "; not degraded"))
    return lines


def format_markdown(report: dict, run: dict, folder: Path) -> str:
    """Tables 3 and 5, the timing per floor and (with ``cpu.json``) the CPU per kind of process, in Markdown."""
    t = report["tour"]
    speed = run.get("speed")
    lines = [f"`gidabot demo --tour {t['file']} --speed {speed}"
             + (f" --seed {run['seed']}`" if run.get("seed") is not None else "`")
             + f": {t['completed']} of {t['goals']} goals, tour sim {t['sim_s']:.0f} s, wall {t['wall_s']:.1f} s "
             f"(sim/wall {t['sim_to_wall']:.1f}x)", "",
             "| Robot | Floor | Received | Processed | Time (s) | Dist. (m) | Mean vel. (m/s) |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in report["robots"]:
        lines.append(f"| {r['name']} | {r['floor']:g} | {r['received']} | {r['processed']} | {r['time_s']:.1f} | "
                     f"{r['distance_m']:.1f} | {r['mean_velocity_mps']:.2f} |")
    lines.append(f"| Tour | | | | {t['time_s']:.1f} | {t['distance_m']:.1f} | {t['mean_velocity_mps']:.2f} |")
    timing = report.get("timing") or {}
    floors = timing.get("floors") or {}
    if floors:
        lines += ["", "| Floor's robot | sim/wall | behind (s) | waiting for controllers (s) | for floors (s) | "
                      "controllers (% of nominal) | guiding loops (% of nominal) |",
                  "|---|---:|---:|---:|---:|---|---|"]
        for robot, f in floors.items():
            ctl = ", ".join(f"{n.rsplit('/', 1)[-1]} {v['rate_pct']:.0f}" for n, v in f["controllers"].items())
            gui = ", ".join(f"{n.split(' ')[0]} {v['rate_pct']:.0f}" for n, v in f["guiding"].items())
            lines.append(f"| {robot} | {f['achieved_factor']:.1f} | {f['behind_s']:.2f} | "
                         f"{f['wait_controllers_s']:.2f} | {f['wait_floors_s']:.2f} | {ctl} | {gui} |")
        lines += ["", f"Largest drift between floors: {timing.get('max_drift_s')} s of sim time; "
                      + ("**degraded**: " + "; ".join(timing["reasons"]) if timing.get("degraded") else "not degraded")
                      + "."]
    cpu_file = folder / "cpu.json"
    if cpu_file.exists():
        cpu = json.loads(cpu_file.read_text(encoding="utf-8")).get("tour") or {}
        sim_s = float(t.get("sim_s") or 0.0)
        if cpu and sim_s > 0:
            lines += ["", f"CPU during the tour: {cpu['cpu_s']:.0f} s in {cpu['wall_s']:.0f} s of wall time "
                          f"({cpu['cores']:.2f} cores), {1000.0 * cpu['cpu_s'] / sim_s:.1f} ms per simulated second:",
                      "", "| process (all robots) | CPU s | ms per sim s | cores |", "|---|---:|---:|---:|"]
            for kind, sec in cpu["per_kind_cpu_s"].items():
                lines.append(f"| {kind} | {sec:.1f} | {1000.0 * sec / sim_s:.2f} | {sec / cpu['wall_s']:.3f} |")
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# Reading bags (rosbags, no ROS)
# ---------------------------------------------------------------------------

def _stamp(msg: object, fallback_ns: int) -> float:
    header = getattr(msg, "header", None)
    if header is not None:
        t = header.stamp.sec + header.stamp.nanosec * 1e-9
        if t > 0:
            return t
    return fallback_ns * 1e-9


_UID = re.compile(r"^[A-Za-z0-9_.:/@+-]{1,160}\Z")
GOAL_MANAGER, NAVIGATION = GUIDING_CALLERIDS


def plausible_goal(msg: Any, building: Any | None) -> bool:
    """A goal message as a robot could have sent it. With the building: exactly the goal manager's check
    (``validate_trip``); without: a valid uid, finite numbers, short printable text."""
    if building is not None:
        try:
            validate_trip(building, _trip(msg))
        except (GidaBotError, AttributeError, TypeError, ValueError):
            return False
        return True
    try:
        texts = (msg.origin_robot, msg.visitor_id, msg.way, msg.connector, msg.start_id, msg.goal_id,
                 msg.language, msg.tour_file)
        numbers = (msg.initial_floor, msg.goal_floor, msg.initial_pose.x, msg.initial_pose.y,
                   msg.goal_pose.position.x, msg.goal_pose.position.y, msg.goal_pose.orientation.z,
                   msg.goal_pose.orientation.w)
        if not _UID.match(msg.uid):
            return False
    except (AttributeError, TypeError):
        return False
    if not all(isinstance(t, str) and len(t) <= 64 and t.isprintable() for t in texts):
        return False
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in numbers)


def _trip(msg: Any) -> Trip:
    """A Goal read from a bag (rosbags) as the goal manager sees it."""
    q = msg.goal_pose.orientation
    return Trip(uid=msg.uid, origin_robot=msg.origin_robot, visitor_id=msg.visitor_id,
                initial_floor=msg.initial_floor, initial_x=msg.initial_pose.x, initial_y=msg.initial_pose.y,
                goal_floor=msg.goal_floor, goal_x=msg.goal_pose.position.x, goal_y=msg.goal_pose.position.y,
                goal_yaw=quaternion_to_yaw(q.x, q.y, q.z, q.w), way=msg.way, connector=msg.connector,
                start_id=msg.start_id, goal_id=msg.goal_id, language=msg.language, tour_file=msg.tour_file,
                tour_step=msg.tour_step, start_robot=msg.start_robot, start_state=msg.start_state,
                goal_robot=msg.goal_robot, goal_state=msg.goal_state, attempt=msg.attempt)


def _callerid(conn: Any) -> str | None:
    """The node that published a bag connection's messages (None: the bag does not say)."""
    return getattr(getattr(conn, "ext", None), "callerid", None) or None


def _from_robot(callerid: str | None, robot: str, recorder: str, building: Any | None) -> bool:
    """Whether a message published on ``recorder``'s master by ``callerid`` can come from ``robot``'s guiding
    nodes: their own node names on its own master, the relay end of the pair on another."""
    if callerid is None:
        return True
    if robot == recorder:
        return callerid in GUIDING_CALLERIDS
    if building is None or building.find_robot(robot) is None or building.find_robot(recorder) is None:
        return False
    names = [r.name for r in building.robots]
    return callerid == relay_end_name(*sorted((robot, recorder), key=names.index))


def read_robot_bag(path: Path, name: str, floor: float, rec: RobotRecord | None = None,
                   building: Any | None = None) -> RobotRecord:
    """Extract goals, this robot's events and poses from one robot's bag (added to ``rec``: bag parts)."""
    from rosbags.highlevel import AnyReader

    rec = rec or RobotRecord(name, floor)
    try:
        with AnyReader([path]) as reader:
            wanted = [c for c in reader.connections
                      if c.topic in (Topic.GOALS, Topic.NAV_EVENTS, Topic.POSES, global_name(Topic.AMCL_POSE),
                                     Topic.DIAGNOSTICS, global_name(Topic.MOVE_BASE_CURRENT_GOAL))]
            for conn, t_ns, raw in reader.messages(connections=wanted):
                try:
                    msg = reader.deserialize(raw, conn.msgtype)
                except Exception:  # noqa: BLE001 - rosbags raises several types; one bad message is skipped
                    rec.bad[conn.topic] = rec.bad.get(conn.topic, 0) + 1
                    continue
                caller = _callerid(conn)
                if conn.topic == Topic.GOALS:
                    if not (plausible_goal(msg, building) and _from_robot(caller, msg.origin_robot, name, building)):
                        rec.rejected_goals += 1
                        continue
                    rec.goal_uids.add(msg.uid)
                    rec.assignments.update({(msg.uid, LEG_START, msg.start_robot, int(msg.start_state)),
                                            (msg.uid, LEG_GOAL, msg.goal_robot, int(msg.goal_state))})
                    gp, q = msg.goal_pose.position, msg.goal_pose.orientation
                    rec.goals[msg.uid] = GoalInfo(msg.goal_id, float(msg.goal_floor), gp.x, gp.y,
                                                  int(msg.tour_step), 2.0 * math.atan2(q.z, q.w))
                elif conn.topic == Topic.DIAGNOSTICS:
                    t = _stamp(msg, t_ns)
                    rec.diagnostics.extend(DiagSample(t, st.name, tuple((kv.key, kv.value) for kv in st.values))
                                           for st in msg.status if st.name.startswith(TIMING_STATUSES))
                elif conn.topic == global_name(Topic.MOVE_BASE_CURRENT_GOAL):
                    rec.goal_starts.append(_stamp(msg, t_ns))
                elif conn.topic == global_name(Topic.AMCL_POSE):
                    p = msg.pose.pose.position
                    rec.local_poses.append(PoseSample(_stamp(msg, t_ns), p.x, p.y))
                elif conn.topic == Topic.NAV_EVENTS:
                    if msg.robot == name and _from_robot(caller, name, name, building):
                        rec.events.append(EventSample(_stamp(msg, t_ns), msg.robot, msg.goal_uid, int(msg.phase),
                                                      int(msg.tour_step), msg.leg, msg.assignee))
                        if msg.phase == Phase.ACCEPTED and caller in (None, GOAL_MANAGER):
                            rec.accepted.add(msg.goal_uid)
                        elif caller in (None, NAVIGATION) and msg.goal_uid:
                            rec.navigated.add(msg.goal_uid)
                elif msg.robot == name:
                    p = msg.nav_pose.position
                    rec.poses.append(PoseSample(_stamp(msg, t_ns), p.x, p.y))
    except Exception as err:  # rosbags raises several unrelated types for damaged bags
        raise ReportError(f"{path}: cannot read bag: {err}") from err
    # parts overlap (two recorders ran for a while): keep each event and sample once
    rec.events = sorted(dict.fromkeys(rec.events), key=lambda e: e.t)
    rec.poses = sorted(set(rec.poses), key=lambda p: p.t)
    rec.local_poses = sorted(set(rec.local_poses), key=lambda p: p.t)
    rec.diagnostics = sorted(set(rec.diagnostics), key=lambda d: d.t)
    rec.goal_starts = sorted(set(rec.goal_starts))
    return rec


def load_run(folder: Path) -> tuple[dict, list[RobotRecord]]:
    run_file = folder / "run.json"
    try:
        run = json.loads(run_file.read_text(encoding="utf-8"))
    except OSError as err:
        raise ReportError(f"{run_file}: cannot read ({err.strerror}); is {folder} a run folder?") from err
    except json.JSONDecodeError as err:
        raise ReportError(f"{run_file}: not valid JSON: {err}") from err
    building = _run_building(folder, run)
    records = []
    for robot in run.get("robots", []):
        parts = robot.get("bags") or [robot.get("bag", f"{robot['name']}.bag")]
        rec = RobotRecord(robot["name"], float(robot.get("floor", 0)))
        for part in parts:
            bag = folder / part
            if not bag.exists():
                raise ReportError(f"{bag}: missing bag of robot {robot['name']}")
            read_robot_bag(bag, rec.name, rec.floor, rec, building)
        records.append(rec)
    return run, records


def _run_building(folder: Path, run: dict) -> Any | None:
    """The run's building, to tell goals from hostile messages (None when it cannot be loaded)."""
    from gidabot_navigation.building.model import load_building
    from gidabot_navigation.errors import GidaBotError

    path = Path(run.get("building", "building/building.yaml"))
    path = path if path.is_absolute() else folder / path
    try:
        return load_building(path)
    except (GidaBotError, OSError):
        return None


def plot_paths(folder: Path, run: dict, records: list[RobotRecord]) -> list[Path]:
    """One PNG per floor: the path each robot followed over the floor's blueprint (paper Fig. 7)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    from gidabot_navigation.building.model import load_building
    from gidabot_navigation.errors import GidaBotError

    building_file = Path(run.get("building", "building/building.yaml"))
    if not building_file.is_absolute():   # relative to the run folder (folders can be moved)
        building_file = folder / building_file
    try:
        building = load_building(building_file)
    except GidaBotError as err:
        raise ReportError(f"{building_file}: cannot load the run's building: {err}") from err
    goals: dict[str, GoalInfo] = {}
    for rec in records:
        goals.update(rec.goals)
    written = []
    colours = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"]
    for floor in building.floors:
        img = Image.open(floor.blueprint_file)
        fig, ax = plt.subplots(figsize=(img.width / 100, img.height / 100 + 0.8), dpi=100)
        ax.imshow(img)
        ax.set_xlim(-0.5, img.width - 0.5)
        ax.set_ylim(img.height - 0.5, -0.5)
        for i, rec in enumerate(records):
            track = rec.track
            if rec.floor != floor.id or not track:
                continue
            colour = colours[i % len(colours)]
            intervals = guiding_intervals(rec.events, rec.goal_starts)
            for guiding, part in _split(track, intervals):
                uv = [floor.transform.to_pixel(p.x, p.y) for p in part]
                ax.plot([u for u, _ in uv], [v for _, v in uv], "-" if guiding else "--", color=colour,
                        linewidth=2.5 if guiding else 1.0, alpha=1.0 if guiding else 0.7)
            start, end = floor.transform.to_pixel(track[0].x, track[0].y), \
                floor.transform.to_pixel(track[-1].x, track[-1].y)
            ax.plot(*start, "o", color=colour, markersize=8)
            ax.plot(*end, "s", color=colour, markersize=8)
            ax.plot([], [], "-", color=colour, linewidth=2.5,
                    label=f"{rec.name}: guiding (thick), alone (dashed); o start, \u25a0 end")
        marks: dict[tuple[float, float], list[str]] = {}   # label 1 m from the goal towards its door
        for g in goals.values():
            if g.floor == floor.id:
                label = str(g.tour_step + 1) if g.tour_step >= 0 else g.goal_id
                key = (round(g.x + math.cos(g.yaw), 1), round(g.y + math.sin(g.yaw), 1))
                if label not in marks.setdefault(key, []):
                    marks[key].append(label)
        for (x, y), labels in marks.items():
            u, v = floor.transform.to_pixel(x, y)
            ax.annotate(",".join(sorted(labels, key=lambda t: (len(t), t))), (u, v), ha="center", va="center",
                        fontsize=9, fontweight="bold", color="white",
                        bbox={"boxstyle": "round,pad=0.25", "fc": "#333333", "ec": "none"})
        tour = run.get("tour", "")
        ax.set_title(f"{floor.names['en']} (floor {floor.label}): paths followed"
                     + (f" during {tour}; numbers: tour steps" if tour else ""), fontsize=12)
        ax.set_axis_off()
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.0), frameon=False, fontsize=10)
        out = folder / f"paths_floor{floor.label}.png"
        fig.savefig(out, bbox_inches="tight")
        plt.close(fig)
        written.append(out)
    return written


def _split(track: list[PoseSample], intervals: list[tuple[float, float]]) -> list[tuple[bool, list[PoseSample]]]:
    """The track cut into consecutive parts inside / outside the guiding intervals (parts share ends)."""
    def inside(t: float) -> bool:
        return any(s <= t <= e for s, e in intervals)

    parts: list[tuple[bool, list[PoseSample]]] = []
    for sample in track:
        state = inside(sample.t)
        if parts and parts[-1][0] == state:
            parts[-1][1].append(sample)
        else:
            prev = parts[-1][1][-1:] if parts else []
            parts.append((state, prev + [sample]))
    return parts


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="gidabot report", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", type=Path, help="run folder written by gidabot demo / chaos")
    parser.add_argument("--json", action="store_true", help="print the tables as one JSON object")
    parser.add_argument("--markdown", action="store_true",
                        help="print the tables (and the run's timing and CPU) as Markdown, as the docs show them")
    parser.add_argument("--no-plots", action="store_true", help="do not write the per-floor path PNGs")
    args = parser.parse_args(argv)
    try:
        run, records = load_run(args.run)
        report = analyse(records, run)
        if run.get("population") is not None:
            report.update(crowd_report(args.run, run, report))
        report["run_folder"] = str(args.run.resolve())
        if not args.no_plots:
            report["plots"] = [str(p) for p in plot_paths(args.run, run, records)]
    except ReportError as err:
        print(f"gidabot report: {err}", file=sys.stderr)
        return 1
    (args.run / "report.json").write_text(json.dumps(report, indent=2), encoding="utf-8")
    if args.json:
        print(json.dumps(report))
    elif args.markdown:
        print(format_markdown(report, run, args.run))
    else:
        print(format_tables(report))
        for p in report.get("plots", []):
            print(f"wrote {p}")
    return 1 if report.get("verdict") == FAILED_VERDICT else 0
