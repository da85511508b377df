"""Statistics of a run with many visitors, from the monitor's JSON lines (ROS-free).

Input: the visitors' plans (:mod:`gidabot_sim.visitor.population`) and the monitor's records
(``monitor.jsonl``: every Goal and NavEvent seen on one master; the relays bring every
robot's). A visitor's trips are the goals whose ``visitor_id`` is the visitor's (a goal comes
again for every new assignment attempt: the newest attempt counts). Measured:

* per visitor: *wait* = sim s from its first goal to the first robot moving for it (the first
  ``ON_THE_WAY`` or ``GOING_TO_MEETING`` of its trips), *trip* = sim s from its first goal to the
  end of its visit, and how the visit ended: ``completed`` (``GOAL_REACHED``; a target on a floor
  without robot: ``NO_ROBOT_ON_FLOOR``; a tour: ``TOUR_FINISHED``), ``cancelled``, ``timed out``,
  ``failed`` (unreachable, a partner offline, rejected), ``refused`` (the request made no goal: a
  ``REJECTED`` or ``UNREACHABLE`` answer from the robot it asked, about its target), ``left`` (shown
  the waits before confirming, the visitor did not confirm: one was longer than its patience; the
  visitor's own record, kind ``visitor``, written by the simulated visitor into the same file) or
  ``unfinished``. A visitor whose trip was given up (``PARTNER_OFFLINE``: a robot it needed was
  offline) asks again (:mod:`gidabot_sim.visitor.visitor`): its visit goes on with the new trip;
* per robot: legs served (the legs its trips' newest assignment committed to it), busy fraction
  (the share of the run during which it had a committed leg not yet ended) and queue length over
  time (committed legs not yet ended: max and time-weighted mean);
* overall: mean and 95th percentile wait (nearest rank), visits completed, cancelled, timed out.

The verdict fails (``problems``) on a visit that neither completed nor ended as the visitor chose
(cancel: cancelled or completed first; no-show: timed out; any visitor: left at the screen), a
visitor whose request made no goal (lost), or two goals for one request (duplicated: two goals of
the same visitor and tour step open at the same time; a request asked again after its trip ended,
e.g. given up, is a new request).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from gidabot_navigation.interface import FINAL_PHASES, LEG_COMMITTED, LEG_GOAL, LEG_START, PHASE_NAMES, Phase
from gidabot_sim.report.visits import MonitorFeed, visit_completed
from gidabot_sim.visitor.population import INTENT_CANCEL, INTENT_COMPLETE, INTENT_NO_SHOW, VisitorPlan

COMPLETED, CANCELLED, TIMED_OUT, FAILED, UNFINISHED = "completed", "cancelled", "timed out", "failed", "unfinished"
REFUSED = "refused"              # the request made no goal: the robot refused it (REJECTED, UNREACHABLE)
LEFT = "left"                    # shown the waits, the visitor did not confirm (its patience): its choice
MOVING = (Phase.ON_THE_WAY, Phase.GOING_TO_MEETING)
TRIP_ENDS = FINAL_PHASES - {Phase.GO_TO_FLOOR, Phase.DECLINED}    # a trip is over (not only one robot's part of it)
FAILURE_PHASES = (Phase.UNREACHABLE, Phase.PARTNER_OFFLINE, Phase.REJECTED)
REFUSALS = (Phase.REJECTED, Phase.UNREACHABLE)   # answers to a request that end the visit without a goal


@dataclass
class _Goal:
    uid: str
    visitor: str
    first_s: float                      # sim s the goal was first seen
    tour_step: int
    tour: bool
    attempt: int = -1
    committed: dict[str, str] = field(default_factory=dict)    # leg -> robot, newest attempt
    committed_s: dict[str, float] = field(default_factory=dict)  # leg -> sim s its robot was first committed
    ended_s: float = math.inf           # sim s of the first event that ended the trip (any robot's)


def percentile(values: Sequence[float], q: float) -> float:
    """Nearest-rank percentile ``q`` (0..100) of ``values`` (NaN when empty)."""
    if not values:
        return math.nan
    ordered = sorted(values)
    rank = max(1, math.ceil(q / 100.0 * len(ordered)))
    return ordered[rank - 1]


def _number(value: object, default: float = math.nan) -> float:
    try:
        out = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return default
    return out if math.isfinite(out) else default


class Crowd(MonitorFeed):
    """Feed monitor records (:meth:`feed`) in order; :meth:`visit_end` and :meth:`summary` read the result."""

    def __init__(self, plans: Iterable[VisitorPlan]) -> None:
        self.plans = {p.visitor_id: p for p in plans}
        self.goals: dict[str, _Goal] = {}
        self.events: dict[str, dict] = {}                         # event uid -> record (each once)
        self.first_s: float | None = None
        self.last_s: float | None = None
        self.first_wall: float | None = None
        self.last_wall: float | None = None
        self.robots_up: list[str] = []
        self.latest = ""                                           # the newest event, for the progress line
        self._ends: dict[str, tuple[str, float]] = {}              # visitor -> how and when its visit ended
        self._end_phase: dict[str, object] = {}                    # visitor -> the phase that ended it
        self.asked_again: dict[str, int] = {}                      # visitor -> trips asked again after a give-up
        self.shown: dict[str, list] = {}                           # visitor -> the waits shown before confirming
        self.patience: dict[str, float] = {}
        self._early: dict[str, list[dict]] = {}                    # goal uid -> its events that came before it

    # -- input -----------------------------------------------------------------------------------
    def feed(self, rec: dict) -> bool:
        """One monitor record; True when it concerns a visitor of the population (or a robot came up)."""
        if rec.get("kind") == "up" and str(rec.get("robot")) not in self.robots_up:
            self.robots_up.append(str(rec.get("robot")))
            return True
        if rec.get("kind") == "goal":
            return self._goal(rec, self._clock(rec))
        if rec.get("kind") == "visitor":
            return self._visitor(rec)
        if rec.get("kind") == "event":
            uid, goal_uid = str(rec.get("uid", "")), str(rec.get("goal_uid", ""))
            if not goal_uid and rec.get("phase") in REFUSALS:
                return self._refusal(rec)
            if not uid or uid in self.events:
                return False
            if goal_uid not in self.goals:
                # an event may overtake its goal (other topic, other relay): kept until the goal comes
                if len(self._early) < 10000 and len(self._early.get(goal_uid, [])) < 1000:
                    self._early.setdefault(goal_uid, []).append(rec)
                return False
            return self._event(rec)
        return False

    def _event(self, rec: dict) -> bool:
        """An event of a population visitor's trip (its goal known)."""
        uid, goal_uid = str(rec.get("uid", "")), str(rec.get("goal_uid", ""))
        if uid in self.events:
            return False
        self._clock(rec)
        t = _when(rec)
        self.events[uid] = rec
        phase, visitor = rec.get("phase"), self.goals[goal_uid].visitor
        if phase in TRIP_ENDS:
            g = self.goals[goal_uid]
            g.ended_s = min(g.ended_s, t if math.isfinite(t) else g.first_s)
        end = _ending(phase, bool(self.plans[visitor].tour_file))
        if end and visitor not in self._ends:
            self._ends[visitor] = (end, t)
            self._end_phase[visitor] = phase
        self.latest = f"{rec.get('robot')}: {PHASE_NAMES.get(phase, phase)} ({self.goals[goal_uid].visitor})"
        return True

    def _refusal(self, rec: dict) -> bool:
        """A request refused before any goal (``REJECTED``: e.g. no robot could be there within its max wait;
        ``UNREACHABLE``): it ends the visit of the first visitor still without a trip who asked that robot for
        that place or tour."""
        robot, place, tour = str(rec.get("robot", "")), str(rec.get("location_id", "")), str(rec.get("tour_file", ""))
        asked = {g.visitor for g in self.goals.values()}
        for p in sorted(self.plans.values(), key=lambda p: p.arrive_s):
            if (p.robot == robot and p.visitor_id not in asked and p.visitor_id not in self._ends
                    and ((p.tour_file and p.tour_file == tour) or (p.goal_id and p.goal_id == place))):
                self._ends[p.visitor_id] = (REFUSED, self._clock(rec))
                self.latest = f"{robot}: {PHASE_NAMES.get(rec.get('phase'), '')} ({p.visitor_id}: {rec.get('detail')})"
                return True
        return False

    def _visitor(self, rec: dict) -> bool:
        """What a visitor chose at the screen (the simulated visitor's record): asked, or left."""
        vid = str(rec.get("visitor", ""))
        if vid not in self.plans:
            return False
        t = self._clock(rec)
        shown = rec.get("shown")
        self.shown[vid] = [w if isinstance(w, (int, float)) else None for w in shown] if isinstance(shown, list) \
            else []
        self.patience[vid] = _number(rec.get("patience_s"))
        if rec.get("event") == "left" and vid not in self._ends:
            self._ends[vid] = (LEFT, t)
            self._end_phase[vid] = None
            self.latest = f"{vid} left {rec.get('robot')}'s screen ({rec.get('detail')})"
        return True

    def _clock(self, rec: dict) -> float:
        t, wall = _number(rec.get("sim")), _number(rec.get("wall"))
        if math.isfinite(t):
            self.first_s = t if self.first_s is None else min(self.first_s, t)
            self.last_s = t if self.last_s is None else max(self.last_s, t)
        if math.isfinite(wall):
            self.first_wall = wall if self.first_wall is None else self.first_wall
            self.last_wall = wall
        return t

    def _goal(self, rec: dict, t: float) -> bool:
        visitor, uid = str(rec.get("visitor_id", "")), str(rec.get("uid", ""))
        if visitor not in self.plans or not uid:
            return False
        g = self.goals.get(uid)
        if g is None:
            if self._end_phase.get(visitor) == Phase.PARTNER_OFFLINE and t >= self._ends[visitor][1]:
                # its trip was given up (a robot it needed was offline) and the visitor asked again: the visit goes on
                del self._ends[visitor], self._end_phase[visitor]
                self.asked_again[visitor] = self.asked_again.get(visitor, 0) + 1
            step = rec.get("tour_step", -1)
            g = self.goals[uid] = _Goal(uid, visitor, _when(rec, "stamp") if math.isfinite(t) else t,
                                        step if isinstance(step, int) else -1, bool(rec.get("tour_file")))
        attempt = int(_number(rec.get("attempt"), 0))
        for early in self._early.pop(uid, []):
            self._event(early)
        if attempt > g.attempt:
            g.attempt = attempt
            g.committed = {leg: str(rec.get(f"{leg}_robot", "")) for leg in (LEG_START, LEG_GOAL)
                           if rec.get(f"{leg}_state") == LEG_COMMITTED and rec.get(f"{leg}_robot")}
            for leg in g.committed:
                g.committed_s.setdefault(leg, t if math.isfinite(t) else g.first_s)
        return True

    # -- results ---------------------------------------------------------------------------------
    def _events_of(self, uids: set[str]) -> list[dict]:
        return sorted((e for e in self.events.values() if e.get("goal_uid") in uids),
                      key=lambda e: _when(e, default=0.0))

    def visit_end(self, visitor: str) -> tuple[str, float | None]:
        """(how the visit ended, sim s of the end or None): the first event of its trips that ends it."""
        return self._ends.get(visitor, (UNFINISHED, None))

    @property
    def finished(self) -> bool:
        """Every visitor's visit has ended."""
        return all(self.visit_end(v)[0] != UNFINISHED for v in self.plans)

    def line(self) -> str:
        """The progress line of ``gidabot demo --visitors``."""
        ends = [self.visit_end(v)[0] for v in self.plans]
        asked = len({g.visitor for g in self.goals.values()})
        return (f"visitors: {asked} of {len(self.plans)} with a trip, {ends.count(COMPLETED)} completed, "
                f"{ends.count(CANCELLED)} cancelled, {ends.count(TIMED_OUT)} timed out, {ends.count(LEFT)} left, "
                f"{ends.count(FAILED)} failed, {ends.count(REFUSED)} refused | {self.latest or '-'}")

    def sim_seconds(self) -> float:
        return (self.last_s - self.first_s) if self.first_s is not None and self.last_s is not None else 0.0

    def wall_seconds(self) -> float:
        return (self.last_wall - self.first_wall) if self.first_wall is not None and self.last_wall is not None \
            else 0.0

    def visitor_rows(self) -> list[dict]:
        rows = []
        for vid, plan in self.plans.items():
            goals = sorted((g for g in self.goals.values() if g.visitor == vid), key=lambda g: g.first_s)
            end, end_s = self.visit_end(vid)
            start = goals[0].first_s if goals else None
            moves = [_when(e) for e in self._events_of({g.uid for g in goals}) if e.get("phase") in MOVING]
            wait = round(max(0.0, moves[0] - start), 1) if moves and start is not None else None
            trip = round(end_s - start, 1) if end_s is not None and start is not None else None
            as_chosen = end in (COMPLETED, LEFT) or (plan.intent == INTENT_CANCEL and end == CANCELLED) or \
                (plan.intent == INTENT_NO_SHOW and end == TIMED_OUT)
            shown = [w for w in self.shown.get(vid, []) if w is not None]
            rows.append({"visitor": vid, "robot": plan.robot, "target": plan.goal_id or plan.tour_file,
                         "way": plan.way, "intent": plan.intent, "arrive_s": plan.arrive_s, "goals": len(goals),
                         "outcome": end, "as_chosen": as_chosen, "wait_s": wait, "trip_s": trip,
                         "shown_wait_s": round(max(shown), 1) if shown else None,
                         "patience_s": plan.patience_s if plan.patience_s >= 0 else None,
                         "asked_again": self.asked_again.get(vid, 0), "duplicated": _duplicated(goals)})
        return rows

    def robot_rows(self, robots: Sequence[str], end_s: float | None = None) -> list[dict]:
        """Per robot: legs served, busy fraction, queue length (max, time-weighted mean) over the run."""
        t0 = self.first_s if self.first_s is not None else 0.0
        t1 = end_s if end_s is not None else (self.last_s if self.last_s is not None else t0)
        span = max(t1 - t0, 1e-9)
        ended: dict[tuple[str, str], float] = {}               # (goal uid, robot) -> its first final phase
        for e in self.events.values():
            key = (str(e.get("goal_uid")), str(e.get("robot")))
            if e.get("phase") in FINAL_PHASES and key not in ended:
                ended[key] = _number(e.get("sim"), t1)
        ends = {g.uid: s for g in self.goals.values() for s in [self.visit_end(g.visitor)[1]] if s is not None}
        rows = []
        for robot in robots:
            changes: list[tuple[float, int]] = []
            legs = 0
            for g in self.goals.values():
                for leg, who in g.committed.items():
                    if who != robot:
                        continue
                    legs += 1
                    begin = g.committed_s.get(leg, g.first_s)
                    stop = min(ended.get((g.uid, robot), math.inf), ends.get(g.uid, math.inf), t1)
                    if stop > begin:
                        changes += [(begin, 1), (stop, -1)]
            rows.append({"robot": robot, "legs_served": legs, **_queue_stats(changes, t0, t1, span)})
        return rows

    def summary(self, robots: Sequence[str], end_s: float | None = None) -> dict:
        visitors = self.visitor_rows()
        waits = [v["wait_s"] for v in visitors if v["wait_s"] is not None]
        count = {k: sum(v["outcome"] == k for v in visitors) for k in (COMPLETED, CANCELLED, TIMED_OUT, LEFT, FAILED,
                                                                      REFUSED, UNFINISHED)}
        problems = [f"{v['visitor']} ({v['intent']}, {v['target']} from {v['robot']}): {v['outcome']}"
                    for v in visitors if not v["as_chosen"]]
        problems += [f"{v['visitor']}: its request made no goal (lost)" for v in visitors
                     if v["goals"] == 0 and v["outcome"] == UNFINISHED]
        problems += [f"{v['visitor']}: {v['duplicated']} duplicated goal(s)" for v in visitors if v["duplicated"]]
        return {
            "visitors": len(visitors), "completed": count[COMPLETED], "cancelled": count[CANCELLED],
            "timed_out": count[TIMED_OUT], "left": count[LEFT], "failed": count[FAILED], "refused": count[REFUSED],
            "unfinished": count[UNFINISHED], "asked_again": sum(v["asked_again"] for v in visitors),
            "intents": {k: sum(v["intent"] == k for v in visitors)
                        for k in (INTENT_COMPLETE, INTENT_CANCEL, INTENT_NO_SHOW)},
            "wait_mean_s": round(sum(waits) / len(waits), 1) if waits else None,
            "wait_p95_s": round(percentile(waits, 95), 1) if waits else None,
            "per_visitor": visitors, "per_robot": self.robot_rows(robots, end_s), "problems": problems,
        }


def _when(rec: dict, key: str = "stamp", default: float = math.nan) -> float:
    """When a goal or an event happened (sim s): its stamp (the visitor confirming, the robot acting: that robot's
    clock), else when the monitor saw it (later by the relays' latency, times the speed)."""
    stamp = _number(rec.get(key))
    if math.isfinite(stamp) and stamp > 0:
        return stamp
    return _number(rec.get("sim"), default)


def _duplicated(goals: Sequence[_Goal]) -> int:
    """Goals made for a request that already had an open one: two goals of the same tour step (-1: a single
    target) open at the same time. A trip asked again once the earlier one ended (given up) is a new request."""
    extra = 0
    for i, g in enumerate(goals):
        if any(h.tour_step == g.tour_step and h.first_s <= g.first_s < h.ended_s for h in goals[:i]):
            extra += 1
    return extra


def _ending(phase: object, tour: bool) -> str:
    """How an event of a visitor's trip ends the visit ("" = it does not)."""
    if visit_completed(phase, tour):
        return COMPLETED
    if phase in (Phase.CANCELLED_HERE, Phase.CANCELLED_ELSEWHERE):
        return CANCELLED
    if phase == Phase.TIMEOUT:
        return TIMED_OUT
    return FAILED if phase in FAILURE_PHASES else ""


def _queue_stats(changes: list[tuple[float, int]], t0: float, t1: float, span: float) -> dict:
    """Busy fraction and queue length (max, time-weighted mean) of a step function given by +1/-1 changes."""
    level, peak, area, busy, last = 0, 0, 0.0, 0.0, t0
    for t, d in sorted(changes, key=lambda c: (c[0], c[1])):
        t = min(max(t, t0), t1)
        area += level * (t - last)
        busy += (t - last) if level > 0 else 0.0
        last, level = t, level + d
        peak = max(peak, level)
    area += level * (t1 - last)
    busy += (t1 - last) if level > 0 else 0.0
    return {"busy_fraction": round(busy / span, 3), "queue_max": peak, "queue_mean": round(area / span, 2)}
