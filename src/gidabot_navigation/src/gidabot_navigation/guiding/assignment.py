"""Who serves each leg of a visitor's trip, with no central computer (ROS-free core).

A trip has up to two legs: the *start* leg (from where the visitor asked; on one floor the
whole trip, across floors to the connector) and the *goal* leg (on the goal floor: meet the
visitor at the connector, guide to the goal). A floor may have several robots, so each leg
needs exactly one of them, whatever the network does. The protocol (``docs/guiding.md``,
*Who serves a leg*, with every failure case):

1. The robot where the visitor confirmed (the trip's origin: the *requester*) is the only
   writer of the trip's assignment (:class:`Assigner`). For each leg it ranks the online
   robots of that floor (:func:`~gidabot_navigation.guiding.trips.rank_candidates`) and
   proposes the leg to the first: it broadcasts the Goal with the leg ``LEG_PROPOSED`` to
   that robot, as assignment ``attempt`` n (every change is a new, higher attempt).
2. A robot that finds a leg newly proposed to it answers once per proposal (attempt), ACCEPTED
   (leg, attempt, its own eta; it queues the trip but does not run it) or DECLINED (its queue is
   full; or, only where ``max_wait`` is configured, it could not be there in time). A long queue
   is no reason to decline: the visitor was shown the wait before confirming, and chose.
3. The requester commits on an ACCEPTED of the robot the leg is proposed to *now*: it
   broadcasts the Goal with the leg ``LEG_COMMITTED`` (attempt n+1) and an ASSIGNED event.
   A leg is committed once, to one robot, and never changes afterwards.
4. DECLINED, no answer within ``answer_timeout`` or the robot offline: the leg is proposed
   to the next robot (a new attempt); an answer to an older proposal is ignored. No robot
   left: if one of them declined (it is there, its queue is full), the leg *waits*: after
   ``requeue_after`` a new round proposes it again, best robot first, until one accepts; if
   none declined (every one offline or silent), the requester gives the trip up
   (:class:`GaveUp`), visibly, for every robot.
5. A robot runs a leg only while the newest Goal it has of the trip (highest attempt)
   commits that leg to it; it drops a trip the newest Goal no longer names it in, ignores
   a Goal older than the newest it has, and forgets an unconfirmed proposal after
   ``proposal_ttl`` (:class:`LegBook`).

6. A robot taken out of service (a staff command) hands back the committed legs it has not started:
   a DECLINED of the committed robot for its committed leg. The requester then proposes the leg to
   the other robots of its floor as in 4 (a new attempt; the robot that handed it back is not asked
   again in that round). A commit that reaches the robot after it handed the leg back is handed back
   again. A goal leg whose floor has no robot in service left (``alone``) is given to nobody
   (``LEG_NONE``): the visitor finds the goal alone, as on a floor without robot.

Safety (never two robots on a leg) rests only on 3, 5 and 6: one writer commits a leg, it moves
only when its robot handed it back (and stopped holding it), and nobody acts without a commit,
so late, lost, duplicated or reordered messages can delay a leg but never give it twice.
:func:`audit_legs` checks it from what the robots published.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from gidabot_navigation.building.model import format_floor
from gidabot_navigation.errors import GuidingError
from gidabot_navigation.guiding.messages import NavEventData, SeenSet, Trip
from gidabot_navigation.guiding.state import GuidingStateError, number, str_list, trip_from_dict, trip_to_dict
from gidabot_navigation.guiding.trips import Candidate, leg_floor
from gidabot_navigation.interface import (
    FINAL_PHASES,
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_NONE,
    LEG_PROPOSED,
    LEGS,
    SERVING_PHASES,
    Phase,
)


@dataclass(frozen=True)
class AssignConfig:
    """``answer_timeout`` (wall s): how long a proposed robot has to answer; ``proposal_ttl`` (wall s): how
    long a robot keeps a proposal that is never confirmed; ``max_wait`` (s, 0 = off, the default): a robot
    declines a leg it could not be at before this (the paper's design has no such limit: the visitor is shown
    the wait and decides; a site may configure one); ``helper_gain`` (s): another robot of the start floor comes
    to the visitor only if it is there at least this much sooner than the robot the visitor stands at;
    ``requeue_after`` (wall s): a leg every robot of its floor declined (queues full) waits this long before it
    is proposed again."""

    answer_timeout: float = 3.0
    proposal_ttl: float = 60.0
    max_wait: float = 0.0
    helper_gain: float = 20.0
    requeue_after: float = 10.0

    def __post_init__(self) -> None:
        for name in ("answer_timeout", "proposal_ttl", "max_wait", "helper_gain", "requeue_after"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or value < 0 or (value == 0 and name not in ("helper_gain", "max_wait")):
                raise GuidingError(f"{name}: {value!r} must be a positive number of seconds"
                                   + (" (0: no limit)" if name == "max_wait" else ""))

    def too_long(self, eta: float) -> bool:
        """True when a robot that could be at a leg's meeting point in ``eta`` s declines it (``max_wait`` set)."""
        return self.max_wait > 0 and eta > self.max_wait


# -- what the requester asks its goal manager to do ---------------------------------------

@dataclass(frozen=True)
class Publish:
    """Broadcast this snapshot of the trip (a new attempt) on /gidabot/goals, and apply it here."""

    trip: Trip


@dataclass(frozen=True)
class Assigned:
    """``robot`` serves ``leg`` (committed): tell it with an ASSIGNED event (``eta`` s until it is there)."""

    trip: Trip
    leg: str
    robot: str
    eta: float


@dataclass(frozen=True)
class GaveUp:
    """No robot can serve ``leg``: the trip cannot be made (``detail``: who was asked and why not)."""

    trip: Trip
    leg: str
    detail: str


Output = Publish | Assigned | GaveUp
MAX_PASSED = 20           # reasons kept per leg (the detail of a trip given up)
# (trip, leg, robots to leave out, wall s) -> the online robots that could serve the leg, best first
Ranker = Callable[[Trip, str, Sequence[str], float], list[Candidate]]
# (trip, leg) -> True when no robot of the leg's floor is in service: the visitor goes there alone
Alone = Callable[[Trip, str], bool]


@dataclass
class LegTry:
    """The requester's record of one leg: proposed to (or committed to) ``robot``."""

    robot: str
    state: int               # LEG_PROPOSED or LEG_COMMITTED
    since: float             # wall s, when it was proposed to ``robot``
    attempt: int             # the attempt that proposed it to ``robot``
    eta: float = 0.0         # s, the estimate for ``robot``
    tried: list[str] = field(default_factory=list)     # every robot proposed so far, in order
    passed: list[str] = field(default_factory=list)    # why the earlier ones do not serve it
    done: bool = False       # the committed robot has finished its part
    declined: list[str] = field(default_factory=list)  # robots that declined it in this round
    waiting: bool = False    # every robot of the floor passed, one at least declined: asked again after
    #                          ``requeue_after`` (since ``since``); ``robot`` is then the last one asked
    rounds: int = 1          # rounds of proposals so far


class Assigner:
    """The requester's side: the assignment of every open trip this robot originated (their single writer)."""

    def __init__(self, me: str, cfg: AssignConfig, rank: Ranker, alone: Alone | None = None) -> None:
        self.me = me
        self.cfg = cfg
        self.rank = rank
        self.alone: Alone = alone or (lambda trip, leg: False)
        self.trips: dict[str, Trip] = {}                 # uid -> the latest snapshot published
        self.legs: dict[str, dict[str, LegTry]] = {}     # uid -> leg -> record

    def __contains__(self, uid: object) -> bool:
        return uid in self.trips

    def __len__(self) -> int:
        return len(self.trips)

    def open(self, trip: Trip, legs: Sequence[str], now_wall: float) -> list[Output]:
        """Propose each of ``legs`` to its best candidate (attempt 1). A leg without any candidate:
        ``[GaveUp]`` and nothing is kept."""
        records: dict[str, LegTry] = {}
        snapshot = trip
        for leg in legs:
            candidates = self.rank(trip, leg, (), now_wall)
            if not candidates:
                floor = format_floor(leg_floor(trip, leg))
                return [GaveUp(trip, leg, f"no robot of floor {floor} is online")]
            best = candidates[0]
            snapshot = snapshot.with_leg(leg, best.robot, LEG_PROPOSED, 1)
            records[leg] = LegTry(best.robot, LEG_PROPOSED, now_wall, 1, best.eta, [best.robot])
        snapshot = replace(snapshot, attempt=1)
        self.trips[trip.uid] = snapshot
        self.legs[trip.uid] = records
        return [Publish(snapshot)]

    def on_answer(self, goal_uid: str, leg: str, robot: str, attempt: int, accepted: bool, eta: float,
                  detail: str, now_wall: float) -> list[Output]:
        """ACCEPTED / DECLINED of ``robot`` for ``leg``: commit, or ask the next robot. An answer to an
        older proposal, or from a robot the leg is not proposed to now, changes nothing."""
        rec = self.legs.get(goal_uid, {}).get(leg)
        if rec is not None and rec.state == LEG_COMMITTED and rec.robot == robot and not accepted and not rec.done \
                and attempt > rec.attempt:       # (an answer to the proposal itself, or an older one, is no hand-back)
            return self._handed_back(goal_uid, leg, robot, detail, now_wall)
        if rec is None or rec.state != LEG_PROPOSED or rec.robot != robot or attempt < rec.attempt:
            return []
        if not accepted:
            if rec.waiting:
                return []               # the leg already waits for its next round
            rec.declined.append(robot)
            return self._next(goal_uid, leg, f"{robot} declined" + (f" ({detail})" if detail else ""), now_wall)
        # (a late ACCEPTED of the last robot asked, while the leg waits: the newest attempt still proposes it there)
        rec.state, rec.eta, rec.waiting = LEG_COMMITTED, eta, False
        trip = self._bump(goal_uid, leg, robot, LEG_COMMITTED)
        return [Publish(trip), Assigned(trip, leg, robot, eta)]

    def tick(self, now_wall: float, online: Callable[[str], bool]) -> list[Output]:
        """Proposals nobody answered in time: the next robot. A robot proposed a leg (online then) that goes
        offline has the same ``answer_timeout`` to answer: it was heard at most ``offline_after`` ago, its status
        and its answer may come together when a short cut heals (a 4.7 s cut ended trips it did not need to).
        A leg that waits (its floor's robots declined it) is proposed again after ``requeue_after``."""
        out: list[Output] = []
        for uid in list(self.legs):
            for leg, rec in list(self.legs.get(uid, {}).items()):
                if rec.state != LEG_PROPOSED or uid not in self.legs:      # (given up by its other leg)
                    continue
                rec.since = min(rec.since, now_wall)         # the monotonic clock restarted (host reboot)
                if rec.waiting:
                    if now_wall - rec.since >= self.cfg.requeue_after:
                        out += self._round(uid, leg, now_wall)
                elif now_wall - rec.since >= self.cfg.answer_timeout:
                    why = (f"{rec.robot} is offline" if not online(rec.robot) else
                           f"{rec.robot} did not answer within {self.cfg.answer_timeout:g} s")
                    out += self._next(uid, leg, why, now_wall)
        return out

    def on_done(self, goal_uid: str, leg: str, robot: str) -> None:
        """``robot`` ended its part of the trip (a final phase): once every leg is done, the trip is closed."""
        rec = self.legs.get(goal_uid, {}).get(leg)
        if rec is None or rec.robot != robot:
            return
        if rec.state == LEG_PROPOSED:
            return                      # a final phase of a robot that never served it (e.g. DECLINED): on_answer
        rec.done = True
        if all(r.done for r in self.legs[goal_uid].values()):
            self.close(goal_uid)

    def _handed_back(self, uid: str, leg: str, robot: str, detail: str, now_wall: float) -> list[Output]:
        """The robot a leg is committed to handed it back (out of service, before starting it): the other robots
        of the floor are asked, as after a DECLINED."""
        rec = self.legs[uid][leg]
        rec.state, rec.tried, rec.declined, rec.waiting = LEG_PROPOSED, [robot], [], False
        return self._next(uid, leg, f"{robot} handed it back" + (f" ({detail})" if detail else ""), now_wall)

    def close(self, goal_uid: str) -> None:
        """The trip is over (cancelled, given up, finished): nothing more to assign."""
        self.trips.pop(goal_uid, None)
        self.legs.pop(goal_uid, None)

    def _next(self, uid: str, leg: str, why: str, now_wall: float) -> list[Output]:
        rec = self.legs[uid][leg]
        rec.passed.append(why)
        del rec.passed[:-MAX_PASSED]
        trip = self.trips[uid]
        candidates = self.rank(trip, leg, tuple(rec.tried), now_wall)
        if not candidates and leg == LEG_GOAL and self.alone(trip, leg):
            return self._to_nobody(uid, leg)
        if not candidates and rec.declined:
            # every robot of the floor passed and one at least is there but declined (queue full): the leg waits
            # and is asked again in a new round; it is never left without a robot while one could take it
            rec.waiting, rec.since = True, now_wall
            return []
        if not candidates:
            self.close(uid)
            floor = format_floor(leg_floor(trip, leg))
            return [GaveUp(trip, leg, f"no robot of floor {floor} can serve it: {'; '.join(rec.passed)}")]
        return self._propose(uid, leg, candidates[0], now_wall)

    def _to_nobody(self, uid: str, leg: str) -> list[Output]:
        """No robot of the leg's floor is in service: nobody serves it (the visitor goes there alone)."""
        trip = self._bump(uid, leg, "", LEG_NONE)
        del self.legs[uid][leg]
        if not self.legs[uid] or all(r.done for r in self.legs[uid].values()):
            self.close(uid)
        return [Publish(trip)]

    def _round(self, uid: str, leg: str, now_wall: float) -> list[Output]:
        """A new round for a leg that waited: every online robot of its floor again, best first."""
        rec = self.legs[uid][leg]
        rec.tried, rec.declined, rec.waiting = [], [], False
        rec.rounds += 1
        return self._next(uid, leg, f"round {rec.rounds}", now_wall)

    def _propose(self, uid: str, leg: str, best: Candidate, now_wall: float) -> list[Output]:
        rec = self.legs[uid][leg]
        rec.robot, rec.since, rec.eta = best.robot, now_wall, best.eta
        rec.tried.append(best.robot)
        trip = self._bump(uid, leg, best.robot, LEG_PROPOSED)
        rec.attempt = trip.attempt
        return [Publish(trip)]

    def _bump(self, uid: str, leg: str, robot: str, state: int) -> Trip:
        trip = self.trips[uid]
        trip = trip.with_leg(leg, robot, state, trip.attempt + 1)
        self.trips[uid] = trip
        return trip

    # -- restarts --------------------------------------------------------------------------
    def state(self) -> list[dict[str, Any]]:
        return [{"trip": trip_to_dict(self.trips[uid]), "legs": {leg: asdict(r) for leg, r in legs.items()}}
                for uid, legs in self.legs.items()]

    def load_state(self, records: object) -> None:
        if not isinstance(records, list):
            raise GuidingStateError("assignments: expected a list")
        trips: dict[str, Trip] = {}
        legs: dict[str, dict[str, LegTry]] = {}
        for rec in records:
            trip = trip_from_dict(rec["trip"])
            parsed = {}
            for leg, r in rec["legs"].items():
                if leg not in LEGS or r["state"] not in (LEG_PROPOSED, LEG_COMMITTED):
                    raise GuidingStateError(f"assignment of {trip.uid}: bad leg {leg!r} or state")
                parsed[leg] = LegTry(str(r["robot"]), int(r["state"]), number(r["since"], "since"),
                                     int(number(r["attempt"], "attempt")), number(r.get("eta", 0.0), "eta"),
                                     str_list(r.get("tried", []), "tried"), str_list(r.get("passed", []), "passed"),
                                     bool(r.get("done", False)), str_list(r.get("declined", []), "declined"),
                                     bool(r.get("waiting", False)), int(number(r.get("rounds", 1), "rounds")))
            trips[trip.uid], legs[trip.uid] = trip, parsed
        self.trips, self.legs = trips, legs


class LegBook:
    """A serving robot's side: the newest assignment attempt seen of each trip, the proposals it answered,
    and since when it holds proposals that are not confirmed yet."""

    def __init__(self, me: str, limit: int = 20000) -> None:
        self.me = me
        self.limit = limit
        self._newest: OrderedDict[str, int] = OrderedDict()   # goal uid -> highest attempt seen
        self._answered = SeenSet(limit)                       # "<goal uid>#<leg>" answered
        self._proposed: dict[str, float] = {}                 # goal uid -> wall s, held and not committed

    def newer(self, trip: Trip) -> bool:
        """True (and remembered) if ``trip`` is a newer attempt than any seen of that trip."""
        seen = self._newest.get(trip.uid)
        if seen is not None and trip.attempt <= seen:
            return False
        self._newest[trip.uid] = trip.attempt
        self._newest.move_to_end(trip.uid)
        while len(self._newest) > self.limit:
            self._newest.popitem(last=False)
        return True

    def first_answer(self, goal_uid: str, leg: str, attempt: int | None = None) -> bool:
        """True the first time this robot answers the proposal of ``leg`` made in ``attempt`` (a leg that waited
        may be proposed to it again in a later round: a new proposal, a new answer); ``attempt`` None: the first
        time it accepts ``leg`` at all (an ACCEPTED for a commit that came without a proposal seen here)."""
        return self._answered.add(f"{goal_uid}#{leg}" if attempt is None else f"{goal_uid}#{leg}@{attempt}")

    def answered(self, goal_uid: str, leg: str, attempt: int | None = None) -> bool:
        return (f"{goal_uid}#{leg}" if attempt is None else f"{goal_uid}#{leg}@{attempt}") in self._answered

    def holding(self, goal_uid: str, now_wall: float) -> None:
        """This robot holds a proposal of the trip that is not confirmed yet (kept at most ``proposal_ttl``)."""
        self._proposed.setdefault(goal_uid, now_wall)

    def settled(self, goal_uid: str) -> None:
        """The proposal was confirmed, or the trip dropped."""
        self._proposed.pop(goal_uid, None)

    def expired(self, now_wall: float, ttl: float) -> list[str]:
        """The trips held unconfirmed for ``ttl`` s or more (forgotten here)."""
        out = []
        for uid, since in list(self._proposed.items()):
            since = min(since, now_wall)           # the monotonic clock restarted (host reboot)
            self._proposed[uid] = since
            if now_wall - since >= ttl:
                out.append(uid)
                del self._proposed[uid]
        return out

    def state(self, remember: int) -> dict[str, Any]:
        return {"newest": [[uid, n] for uid, n in self._newest.items()][-remember:],
                "answered": self._answered.recent(remember),
                "proposed": [[uid, t] for uid, t in self._proposed.items()]}

    def load_state(self, state: object) -> None:
        if not isinstance(state, dict):
            raise GuidingStateError("legs: expected an object")
        newest = [(str(uid), int(number(n, "attempt"))) for uid, n in state.get("newest", [])]
        proposed = [(str(uid), number(t, "proposed since")) for uid, t in state.get("proposed", [])]
        answered = str_list(state.get("answered", []), "answered")
        for uid, n in newest:
            self._newest[uid] = n
        self._answered.update(answered)
        self._proposed.update(proposed)


# ---------------------------------------------------------------------------
# Checking the invariant from what the robots published
# ---------------------------------------------------------------------------

@dataclass
class LegRecord:
    """What the published goals and events say about one leg of one trip."""

    committed: set[str] = field(default_factory=set)    # robots a Goal snapshot committed it to
    assigned: set[str] = field(default_factory=set)     # assignees of ASSIGNED events
    served: set[str] = field(default_factory=set)       # robots that sent a serving phase for it
    accepted: set[str] = field(default_factory=set)     # robots that answered ACCEPTED
    declined: set[str] = field(default_factory=set)
    committed_at: dict[str, int] = field(default_factory=dict)   # robot -> the first attempt committing it there
    proposed_at: dict[str, set[int]] = field(default_factory=dict)   # robot -> the attempts proposing it there
    declined_at: dict[str, int] = field(default_factory=dict)    # robot -> the newest attempt it declined

    @property
    def handed_back(self) -> set[str]:
        """Robots that had the leg committed and handed it back before serving it: a DECLINED of the proposal that
        led to the commit, or of a later attempt."""
        out = set()
        for robot, at in self.committed_at.items():
            proposal = max((a for a in self.proposed_at.get(robot, ()) if a < at), default=at)
            if self.declined_at.get(robot, -1) >= proposal:
                out.add(robot)
        return out - self.served

    @property
    def robots(self) -> set[str]:
        """Every robot that had the leg (committed, assigned or serving) and did not hand it back: one at most."""
        return (self.committed | self.assigned | self.served) - self.handed_back


@dataclass
class LegAudit:
    """:func:`audit_legs`: per (goal uid, leg) what happened, and the legs that break the invariant."""

    legs: dict[tuple[str, str], LegRecord]
    ended: set[str]                                       # goal uids with a final phase from some robot

    @property
    def double_served(self) -> list[tuple[str, str, list[str]]]:
        """Legs that two or more robots had."""
        return [(uid, leg, sorted(r.robots)) for (uid, leg), r in sorted(self.legs.items()) if len(r.robots) > 1]

    @property
    def unserved(self) -> list[tuple[str, str]]:
        """Legs some robot was asked to serve that nobody got, of trips that never ended."""
        return [(uid, leg) for (uid, leg), r in sorted(self.legs.items())
                if not r.robots and uid not in self.ended]

    def served_by(self, goal_uid: str, leg: str) -> str:
        """The robot that had the leg ("" none, or several: see :attr:`double_served`)."""
        robots = self.legs.get((goal_uid, leg), LegRecord()).robots
        return next(iter(robots)) if len(robots) == 1 else ""


def audit_legs(goals: Iterable[Trip], events: Iterable[NavEventData]) -> LegAudit:
    """Who had each leg, from every Goal snapshot and NavEvent published (e.g. read from the bags; duplicates
    and any order are fine). The invariant: every leg has at most one robot; a leg needed by a trip that
    did not end has one."""
    legs: dict[tuple[str, str], LegRecord] = {}
    ended: set[str] = set()
    for trip in goals:
        for leg in LEGS:
            state = trip.leg_state(leg)
            if state == LEG_NONE:
                continue
            rec = legs.setdefault((trip.uid, leg), LegRecord())
            if state == LEG_PROPOSED:
                rec.proposed_at.setdefault(trip.leg_robot(leg), set()).add(trip.attempt)
            if state == LEG_COMMITTED:
                robot = trip.leg_robot(leg)
                rec.committed.add(robot)
                rec.committed_at[robot] = min(rec.committed_at.get(robot, trip.attempt), trip.attempt)
    for ev in events:
        if not ev.goal_uid:
            continue
        if ev.phase in FINAL_PHASES and ev.phase != Phase.DECLINED:
            ended.add(ev.goal_uid)
        if ev.leg not in LEGS:
            continue
        rec = legs.setdefault((ev.goal_uid, ev.leg), LegRecord())
        if ev.phase == Phase.ASSIGNED:
            rec.assigned.add(ev.assignee)
        elif ev.phase == Phase.ACCEPTED:
            rec.accepted.add(ev.robot)
        elif ev.phase == Phase.DECLINED:
            rec.declined.add(ev.robot)
            rec.declined_at[ev.robot] = max(rec.declined_at.get(ev.robot, ev.attempt), ev.attempt)
        elif ev.phase in SERVING_PHASES:
            rec.served.add(ev.robot)
    return LegAudit(legs, ended)
