"""What became of every goal of a chaos run, from the records of the chaos probes (ROS-free).

:class:`Bookkeeping` reads what every master's probe recorded (goals, cancels, events, each with the master
that received it, the publisher and when) and tells, per goal (:class:`GoalFate`) and per thing the visitor
asked for (:class:`StepFate`), definitions as in docs/chaos.md:

* **accepted**: a goal published on ``/gidabot/goals`` by the ``/goal_manager`` of its
  origin robot (seen there by the probe), or one some robot ACCEPTED;
* **completed**: the goal floor's robot reported GOAL_REACHED / TOUR_STEP_DONE /
  TOUR_FINISHED for it (NO_ROBOT_ON_FLOOR from the start robot when the goal floor
  has none);
* **lost**: accepted, not cancelled, and never completed or never ACCEPTED by a robot
  it involves (the robots of its start and goal floors);
* **duplicated**: a goal or cancel uid delivered more than once on one master, or a
  robot that processed a goal twice (two ACCEPTED events, or two final events, with
  different event uids); the same message published again by its own node after a restart is not one
  (:func:`republication`).

It also counts the probes' Table 3 (:meth:`Bookkeeping.table3`) and the partner-offline notices.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from gidabot_navigation.building.model import Building
from gidabot_navigation.interface import (
    FINAL_PHASES,
    GOAL_REACHED_PHASES,
    GUIDING_CALLERIDS,
    LEG_COMMITTED,
    PHASE_NAMES,
    REASON_VISITOR,
    Node,
    Phase,
    global_name,
    is_relay_end,
    phase_name,
)
from gidabot_sim.chaos.table3 import fold_table3

# phases by which the system itself ends a trip (the visitor did not choose it)
SYSTEM_ENDS = frozenset({Phase.UNREACHABLE, Phase.TIMEOUT, Phase.PARTNER_OFFLINE})
VISIBLE_FAILURES = frozenset({Phase.UNREACHABLE, Phase.TIMEOUT, Phase.PARTNER_OFFLINE, Phase.CANCELLED_HERE,
                              Phase.CANCELLED_ELSEWHERE})


@dataclass
class GoalFate:
    uid: str
    origin: str
    initial_floor: float
    goal_floor: float
    goal_id: str
    tour_step: int
    involved: list[str]
    processed_by: list[str] = field(default_factory=list)
    completed: bool = False
    cancelled: bool = False
    cancel_reasons: list[str] = field(default_factory=list)
    visible_failures: list[str] = field(default_factory=list)
    duplicated: list[str] = field(default_factory=list)
    republished: list[str] = field(default_factory=list)     # published again by its own node: see republication
    system_ended: bool = False        # a robot ended it (UNREACHABLE, TIMEOUT, PARTNER_OFFLINE): see StepFate

    @property
    def lost(self) -> bool:
        """Neither ended by anyone nor completed (by every robot it involves): dropped without a word."""
        return not self.cancelled and not self.system_ended and \
            (not self.completed or not set(self.involved) <= set(self.processed_by))


@dataclass
class StepFate:
    """What became of one thing the visitor asked for: a tour step (or the single target, step -1)."""

    step: int
    goals: list[str] = field(default_factory=list)          # the goals made for it, in order
    completed_by: str = ""                                  # the goal that completed it
    system_ends: list[str] = field(default_factory=list)    # goals the system ended: "uid: why"
    visitor_ends: list[str] = field(default_factory=list)   # goals the visitor cancelled
    refusals: int = 0                                       # requests refused with nothing queued (asked again)

    @property
    def passed(self) -> bool:
        """Completed (perhaps by a retry after the system ended a trip), or ended because the visitor chose so."""
        return bool(self.completed_by) or bool(self.visitor_ends)

    def describe(self) -> str:
        label = f"step {self.step + 1}" if self.step >= 0 else "the target"
        if self.completed_by:
            how = f"completed by {self.completed_by}"
        elif self.visitor_ends:
            how = f"ended by the visitor ({'; '.join(self.visitor_ends)})"
        else:
            how = "NOT completed" + ("" if self.goals else " (no goal was ever made for it)")
        ends = f"; ended by the system: {'; '.join(self.system_ends)}" if self.system_ends else ""
        refused = f"; {self.refusals} request(s) refused with nothing queued" if self.refusals else ""
        return f"{label}: {how}{ends}{refused}"


def republication(recs: list[dict[str, Any]]) -> bool:
    """Whether the deliveries ``recs`` of one goal attempt (or cancel) on one master are one guiding node
    publishing the same message again, each time on a new connection to the probe: a restarted goal_manager
    or multirobot_navigation publishes its outbox again (docs/chaos.md, what the faults showed, 2), and a
    publisher replays its recent events to a subscriber that connects again (``ReplayPublisher``); same uid,
    every receiver ignores it. Not one: two copies on one connection (a node that published it twice), a copy
    a relay end delivered (a relay delivers each event exactly once), copies from different publishers, and
    records without their connection number."""
    callers = {str(r.get("c", "")) for r in recs}
    conns = [r.get("n") for r in recs]
    return len(callers) == 1 and callers <= set(GUIDING_CALLERIDS) and \
        all(isinstance(n, int) and not isinstance(n, bool) and n > 0 for n in conns) and len(set(conns)) == len(conns)


class Bookkeeping:
    """Goals and cancels from every master's probe records (dicts, see ``chaos_probe``).

    Record kinds: ``goal`` (uid, origin, floors, goal_id, tour_step), ``cancel`` (uid, goal_uid, origin,
    reason), ``event`` (uid, robot, goal_uid, phase); each with ``m`` (the master's robot), ``c`` (the
    publisher's caller id) and ``w`` (wall time received).
    """

    def __init__(self, building: Building, records: Iterable[dict[str, Any]]) -> None:
        self.building = building
        self.robots = {r.name: r for r in building.robots}
        self.goal_records: dict[str, list[dict[str, Any]]] = defaultdict(list)     # uid -> every delivery
        self.cancel_records: dict[str, list[dict[str, Any]]] = defaultdict(list)
        self.events: dict[str, dict[str, Any]] = {}                                   # event uid -> record
        self.foreign = Counter()                                                      # hostile / unknown records
        for rec in records:
            kind = rec.get("k")
            if kind == "goal":
                self.goal_records[str(rec.get("uid"))].append(rec)
            elif kind == "cancel":
                self.cancel_records[str(rec.get("uid"))].append(rec)
            elif kind == "event":
                if self._legit_event(rec):
                    self.events.setdefault(str(rec.get("uid")), rec)
                else:
                    self.foreign["event"] += 1

    def _legit_event(self, rec: dict[str, Any]) -> bool:
        robot, phase, caller = rec.get("robot"), rec.get("phase"), str(rec.get("c", ""))
        if robot not in self.robots or not isinstance(phase, int) or phase not in PHASE_NAMES:
            return False
        if rec.get("m") == robot:
            return caller in GUIDING_CALLERIDS
        return is_relay_end(caller)

    # -- goals ----------------------------------------------------------------------------
    def accepted(self) -> dict[str, dict[str, Any]]:
        """uid -> the goal's record (its newest assignment attempt, from its origin's master when seen there)."""
        out: dict[str, dict[str, Any]] = {}
        for uid, recs in self.goal_records.items():
            own = [rec for rec in recs if rec.get("c") == global_name(Node.GOAL_MANAGER)
                   and rec.get("m") == rec.get("origin") in self.robots]
            if own:
                out[uid] = max(own, key=lambda rec: int(rec.get("attempt", 0)))
        accepted_events = {e.get("goal_uid") for e in self.events.values() if e.get("phase") == Phase.ACCEPTED}
        for uid in accepted_events:
            if uid and uid not in out and self.goal_records.get(uid):
                out[uid] = self.goal_records[uid][0]
        return out

    def fates(self) -> dict[str, GoalFate]:
        goals = self.accepted()
        by_goal: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for ev in self.events.values():
            by_goal[str(ev.get("goal_uid", ""))].append(ev)
        cancels: dict[str, list[str]] = defaultdict(list)
        for recs in self.cancel_records.values():
            rec = recs[0]
            if rec.get("origin") in self.robots:
                cancels[str(rec.get("goal_uid"))].append(str(rec.get("reason")))
        fates = {}
        for uid, g in goals.items():
            a, b = float(g.get("initial_floor", math.nan)), float(g.get("goal_floor", math.nan))
            # the robots its (newest) assignment committed the legs to
            start_robot = str(g.get("start_robot", "")) if g.get("start_state") == LEG_COMMITTED else ""
            goal_robot = str(g.get("goal_robot", "")) if g.get("goal_state") == LEG_COMMITTED else ""
            involved = [r for r in self.robots if r in (start_robot, goal_robot)]
            fate = GoalFate(uid, str(g.get("origin")), a, b, str(g.get("goal_id", "")), int(g.get("tour_step", -1)),
                            involved)
            completes = goal_robot or (start_robot if math.isclose(a, b) else "")
            accepted_by: dict[str, set[str]] = defaultdict(set)
            # a robot answers each proposal of a leg (attempt) and ends each leg it served once
            answers: dict[tuple[str, str, int], set[str]] = defaultdict(set)
            finals: dict[tuple[str, str], set[str]] = defaultdict(set)
            for ev in by_goal.get(uid, []):
                robot, phase = str(ev.get("robot")), int(ev.get("phase", -1))
                leg = str(ev.get("leg", ""))
                if phase == Phase.ACCEPTED:
                    accepted_by[robot].add(str(ev.get("uid")))
                    answers[(robot, leg, int(ev.get("attempt", 0)))].add(str(ev.get("uid")))
                if phase in FINAL_PHASES:
                    finals[(robot, leg)].add(str(ev.get("uid")))
                if phase in GOAL_REACHED_PHASES and completes and robot == completes:
                    fate.completed = True
                if phase in (Phase.NO_ROBOT_ON_FLOOR, Phase.TOUR_FINISHED) and not goal_robot and start_robot \
                        and robot == start_robot and not math.isclose(a, b):
                    fate.completed = True           # sent to a floor without robot: found alone
                if phase in VISIBLE_FAILURES:
                    fate.visible_failures.append(f"{robot}: phase {phase}")
                if phase in SYSTEM_ENDS:
                    fate.system_ended = True
            fate.processed_by = sorted(set(accepted_by) & set(involved), key=lambda r: list(self.robots).index(r))
            fate.cancel_reasons = cancels.get(uid, [])
            fate.cancelled = bool(fate.cancel_reasons)
            for (robot, leg, attempt), uids in answers.items():
                if len(uids) > 1:
                    fate.duplicated.append(f"{robot} accepted it {len(uids)} times"
                                           + (f" (its {leg} leg, attempt {attempt})" if leg else ""))
            for (robot, leg), uids in finals.items():
                if len(uids) > 1:
                    fate.duplicated.append(f"{robot} ended it {len(uids)} times" + (f" (its {leg} leg)" if leg else ""))
            per_master: dict[tuple[str, Any], list[dict[str, Any]]] = defaultdict(list)
            for r in self.goal_records[uid]:
                per_master[(str(r.get("m")), r.get("attempt", 0))].append(r)
            for (master, attempt), recs in per_master.items():
                if len(recs) < 2:
                    continue
                if republication(recs):
                    fate.republished.append(f"attempt {attempt} published {len(recs)} times on {master}'s master by "
                                            f"{recs[0].get('c')}, each on a new connection")
                else:
                    fate.duplicated.append(f"attempt {attempt} delivered {len(recs)} times on {master}'s master")
            fates[uid] = fate
        return fates

    def visit(self, fates: dict[str, GoalFate], tour_file: str, steps: int) -> list[StepFate]:
        """What became of each of the ``steps`` steps of tour ``tour_file`` (``tour_file`` "": one target) the
        visitor asked for: the goals made for it, which one completed it, the trips the system ended (a
        final phase UNREACHABLE, TIMEOUT or PARTNER_OFFLINE, or a cancel for another reason than the
        visitor's), and the requests refused with nothing queued."""
        out = {k: StepFate(k) for k in (range(steps) if tour_file else [-1])}
        goals = self.accepted()
        by_goal: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for ev in self.events.values():
            by_goal[str(ev.get("goal_uid", ""))].append(ev)
        reasons: dict[str, list[tuple[str, str]]] = defaultdict(list)     # goal uid -> (cancel origin, reason)
        for recs in self.cancel_records.values():
            rec = recs[0]
            if rec.get("origin") in self.robots:
                reasons[str(rec.get("goal_uid"))].append((str(rec.get("origin")), str(rec.get("reason"))))
        order = sorted(goals, key=lambda u: min(float(r.get("w", 0.0)) for r in self.goal_records[u]))
        for uid in order:
            g = goals[uid]
            if str(g.get("tour_file", "")) != tour_file:
                continue
            step = out.get(int(g.get("tour_step", -1)) if tour_file else -1)
            if step is None:
                continue
            step.goals.append(uid)
            if fates.get(uid) is not None and fates[uid].completed and not step.completed_by:
                step.completed_by = uid
            for ev in sorted(by_goal.get(uid, []), key=lambda e: float(e.get("w", 0.0))):
                if int(ev.get("phase", -1)) in SYSTEM_ENDS:
                    step.system_ends.append(f"{uid}: {phase_name(int(ev['phase']))} from {ev.get('robot')}"
                                            f"{' (' + str(ev.get('detail'))[:80] + ')' if ev.get('detail') else ''}")
                    break
            for origin, reason in reasons.get(uid, []):
                if reason == REASON_VISITOR:
                    step.visitor_ends.append(f"{uid}: cancelled at {origin}")
                elif not any(e.startswith(f"{uid}:") for e in step.system_ends):
                    step.system_ends.append(f"{uid}: cancelled by {origin} ({reason})")
        for ev in self.events.values():          # refusals answer a request: no goal was made
            if int(ev.get("phase", -1)) in (Phase.PARTNER_OFFLINE, Phase.REJECTED) and not ev.get("goal_uid") \
                    and str(ev.get("tour_file", "")) == tour_file:
                step = out.get(int(ev.get("tour_step", -1)) if tour_file else -1)
                if step is not None:
                    step.refusals += 1
        return list(out.values())

    def retried_routes(self, steps: list[StepFate]) -> dict[int, tuple[float, float]]:
        """Steps the system ended and a retry completed: step -> (start floor, goal floor) of the goal that
        completed it."""
        goals = self.accepted()
        out = {}
        for st in steps:
            g = goals.get(st.completed_by) if st.completed_by and st.system_ends else None
            if g is not None:
                out[st.step] = (float(g.get("initial_floor", math.nan)), float(g.get("goal_floor", math.nan)))
        return out

    def retried_goals(self, steps: list[StepFate]) -> list[str]:
        """Goals of completed steps that the system ended before a retry completed the step (each is one
        more goal in Table 3 than a run without faults has)."""
        return [uid for st in steps if st.completed_by for uid in st.goals if uid != st.completed_by]

    def table3_with(self, expected: dict[str, tuple[int, int]], fates: dict[str, GoalFate],
                    extra: list[str]) -> dict[str, tuple[int, int]]:
        """``expected`` (the rows of :func:`table3_rows`) plus the goals ``extra`` (trips the system ended and a
        retry replaced): one more received on every master that got each, one more processed by every robot
        that accepted each; a row of several robots counts as :func:`fold_table3` does."""
        more = {name: (sum(any(r.get("m") == name for r in self.goal_records.get(uid, [])) for uid in extra),
                       sum(uid in fates and name in fates[uid].processed_by for uid in extra))
                for name in self.robots}
        added = fold_table3(self.building, more)
        return {row: (rec + added.get(row, (0, 0))[0], proc + added.get(row, (0, 0))[1])
                for row, (rec, proc) in expected.items()}

    def duplicated_cancels(self, republished: bool = False) -> dict[str, list[str]]:
        """Cancel uids (of accepted goals) delivered more than once on one master (``republished``: instead,
        those only published again by their own node, see :func:`republication`)."""
        goals = self.accepted()
        out: dict[str, list[str]] = {}
        for uid, recs in self.cancel_records.items():
            if str(recs[0].get("goal_uid")) not in goals:
                continue
            per_master: dict[str, list[dict[str, Any]]] = defaultdict(list)
            for r in recs:
                per_master[str(r.get("m"))].append(r)
            found = [f"{'published' if republished else 'delivered'} {len(rs)} times on {m}'s master"
                     for m, rs in per_master.items() if len(rs) > 1 and republication(rs) == republished]
            if found:
                out[uid] = found
        return out

    def table3(self, fates: dict[str, GoalFate]) -> dict[str, tuple[int, int]]:
        """robot -> (received, processed), counting the accepted goals that were not cancelled."""
        kept = {uid for uid, f in fates.items() if not f.cancelled}
        out = {}
        for name in self.robots:
            received = sum(1 for uid in kept if any(r.get("m") == name for r in self.goal_records.get(uid, [])))
            processed = sum(1 for uid in kept if name in fates[uid].processed_by)
            out[name] = (received, processed)
        return out

    def partner_notices(self) -> tuple[int, int, list[str]]:
        """(PARTNER_LOST notices, of them followed by PARTNER_BACK or the end of that robot's part, unanswered)."""
        seq: dict[tuple[str, str], list[tuple[float, int]]] = defaultdict(list)
        for ev in self.events.values():
            seq[(str(ev.get("robot")), str(ev.get("goal_uid")))].append((float(ev.get("w", 0.0)), int(ev["phase"])))
        lost = answered = 0
        open_: list[str] = []
        for (robot, goal), items in seq.items():
            items.sort()
            for i, (_, phase) in enumerate(items):
                if phase != Phase.PARTNER_LOST:
                    continue
                lost += 1
                if any(p == Phase.PARTNER_BACK or p in FINAL_PHASES for _, p in items[i + 1:]):
                    answered += 1
                else:
                    open_.append(f"{robot} {goal}")
        return lost, answered, open_

    def tour_finished(self, tour_file: str, last_step: int) -> bool:
        return any(ev.get("phase") == Phase.TOUR_FINISHED and ev.get("tour_file") == tour_file
                   and ev.get("tour_step") == last_step for ev in self.events.values())

