"""Lockstep (ROS-free): a floor's clock advances by computed steps, in step with its controllers.

The simulator stops every ``step`` sim seconds (a *stop*; 0.1 s, the move_base stand-in's control
period). Before it steps past a stop it waits for:

1. its **participants** (:class:`Lockstep`): a controller registers by answering once (a
   ``gidabot_msgs/StepDone``). While not idle it owes an answer for every stop, and the simulator
   publishes its inputs at every stop (the move_base stand-in driving: its odometry, whose stamp is
   the stop); idle, it owes only the stops that published one of its inputs (the amcl stand-in: each
   ground truth). It also owes the cmd_vel messages it says it sent (they travel on another
   connection than its answer). One that does not answer within ``timeout`` wall seconds (frozen,
   dead) is counted *absent*: the world goes on without it until it answers again;
2. the **other floors** (drift bound): it stays at most ``max_drift`` sim seconds ahead of the
   slowest live floor;
3. its **speed ceiling** (:class:`~gidabot_sim.world.clock.Pacer`).

:class:`Stepper` decides from explicit events, and the wall time passed in, whether to step now or
what it waits for, and counts what the reports need: the wall time spent behind the ceiling and
waiting (per cause), and per participant the stops it owed, answered and missed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from gidabot_sim.errors import SimConfigError, StepDoneRejected
from gidabot_sim.world.clock import MAX_SPEED, Pacer

EPS = 1e-6                 # s: stamps closer than this are the same time
MAX_PARTICIPANTS = 16
MAX_NAME = 256
CONTROLLERS, FLOORS, CEILING = "controllers", "floors", "ceiling"     # what a stop waits for


@dataclass(frozen=True)
class Answer:
    """A participant's answer (the fields of a ``gidabot_msgs/StepDone``)."""

    node: str
    session: int
    done: float                          # sim s through which its work is done
    idle: bool = False
    inputs: tuple[str, ...] = ()         # topics of the simulator it acts on
    commands: int = 0                    # cmd_vel messages it published since it started

    def check(self) -> None:
        """:class:`StepDoneRejected` naming the bad field."""
        if not isinstance(self.node, str) or not 1 <= len(self.node) <= 128 or not self.node.isprintable():
            raise StepDoneRejected(f"StepDone node {str(self.node)[:80]!r}: expected 1..128 printable characters")
        if not (math.isfinite(self.done) and self.done >= 0):
            raise StepDoneRejected(f"StepDone from {self.node}: done {self.done!r} must be a sim time >= 0")
        if len(self.inputs) > MAX_PARTICIPANTS or not all(
                isinstance(t, str) and 1 <= len(t) <= MAX_NAME and t.isprintable() for t in self.inputs):
            raise StepDoneRejected(f"StepDone from {self.node}: inputs {list(self.inputs)[:4]!r}...: expected at most "
                                   f"{MAX_PARTICIPANTS} topic names of 1..{MAX_NAME} printable characters")
        if not (isinstance(self.commands, int) and self.commands >= 0):
            raise StepDoneRejected(f"StepDone from {self.node}: commands {self.commands!r} must be an integer >= 0")


@dataclass
class Participant:
    """What the simulator knows of one participant, and its counts (kept across its restarts)."""

    node: str
    session: int
    done: float = 0.0
    idle: bool = False
    inputs: tuple[str, ...] = ()
    commands: int = 0                    # cmd_vel messages it says it sent (this session)
    command_base: int = 0                # commands received from this node before this session
    absent: bool = False
    heard: float = -math.inf             # wall time of its latest answer
    since: float | None = None           # wall time it started owing the current stop
    owed: int = 0                        # stops it owed an answer for
    answered: int = 0                    # ... and answered before the world went on
    timeouts: int = 0                    # times the world stopped waiting for it
    waited: float = 0.0                  # wall s the world waited for it
    sessions: int = 1

    @property
    def missed(self) -> int:
        return self.owed - self.answered


class Lockstep:
    """The participants of one floor and what each owes (see the module docstring)."""

    def __init__(self, timeout: float = 2.0) -> None:
        if not (math.isfinite(timeout) and timeout > 0):
            raise SimConfigError(f"participant timeout: {timeout!r} must be > 0 wall seconds")
        self.timeout = float(timeout)
        self.participants: dict[str, Participant] = {}
        self.stamps: dict[str, float] = {}        # topic -> stamp of the simulator's newest message on it
        self._received: dict[str, int] = {}       # node -> cmd_vel messages received from it
        self._owing: set[str] = set()             # participants that owed the current stop
        self._waited_for: set[str] = set()        # ... and that the world waited for
        self._stop_wall = -math.inf               # wall time the world reached the current stop
        self.rejoined: list[str] = []             # absent participants that answered again (for the log)
        self.timed_out: list[str] = []            # participants the world stopped waiting for (for the log)

    # -- events --------------------------------------------------------------------------------
    def answer(self, a: Answer, wall: float) -> None:
        """A StepDone received at ``wall``; :class:`StepDoneRejected` when malformed or from one participant
        too many."""
        a.check()
        p = self.participants.get(a.node)
        if p is None:
            if len(self.participants) >= MAX_PARTICIPANTS:
                raise StepDoneRejected(f"StepDone from {a.node}: already {MAX_PARTICIPANTS} participants")
            p = self.participants[a.node] = Participant(a.node, a.session, a.done)
        elif a.session != p.session:          # restarted: a new process under the same name
            # what the old process said it sent belongs to it; a command it sent unannounced, before it
            # died, is taken for one of the new process's (it then waits one command less, once)
            p.command_base += p.commands
            p.session, p.sessions, p.done = a.session, p.sessions + 1, a.done
        p.done = max(p.done, a.done)
        p.heard = wall
        p.idle, p.inputs, p.commands = a.idle, tuple(a.inputs), a.commands
        p.since = None
        if p.absent:
            p.absent = False
            self.rejoined.append(p.node)

    def command(self, node: str) -> None:
        """A cmd_vel message from ``node`` arrived."""
        self._received[node] = self._received.get(node, 0) + 1

    def published(self, topic: str, stamp: float) -> None:
        """The simulator published a message stamped ``stamp`` on ``topic``."""
        self.stamps[topic] = stamp

    # -- decisions -----------------------------------------------------------------------------
    def inputs_due(self) -> set[str]:
        """Topics the simulator publishes at every stop: the inputs of the participants that owe every stop."""
        return {topic for p in self.participants.values() if not p.idle and not p.absent for topic in p.inputs}

    def missing_inputs(self, t: float) -> set[str]:
        """Inputs due at the stop at ``t`` but not published for it (a participant stopped being idle during it)."""
        return {topic for topic in self.inputs_due() if self.stamps.get(topic, -math.inf) < t - EPS}

    def owes(self, p: Participant, t: float) -> bool:
        """Whether ``p`` owes an answer (or commands) for the stop at sim time ``t``."""
        if self._received.get(p.node, 0) - p.command_base < p.commands:
            return True
        if not p.idle and p.done < t - EPS:
            return True
        return any(p.done + EPS < self.stamps.get(topic, -math.inf) <= t + EPS for topic in p.inputs)

    def waiting(self, t: float, wall: float) -> list[str]:
        """Participants the stop at ``t`` still waits for (at wall time ``wall``); one that has owed it for
        longer than the timeout is counted absent and no longer waited for."""
        pending = []
        for p in self.participants.values():
            if not self.owes(p, t):
                continue
            self._owing.add(p.node)
            if p.absent:
                continue
            self._waited_for.add(p.node)
            if p.since is None:
                p.since = max(self._stop_wall, p.heard)
            if wall - p.since > self.timeout:
                p.absent = True
                p.timeouts += 1
                # commands it announced and never delivered (a dead connection) are not waited for again
                p.command_base = min(p.command_base, self._received.get(p.node, 0) - p.commands)
                self.timed_out.append(p.node)
                continue
            pending.append(p.node)
        return pending

    def deadline(self) -> float:
        """Wall time at which the first participant waited for times out (inf: none is waited for)."""
        return min((p.since + self.timeout for p in self.participants.values()
                    if p.since is not None and not p.absent), default=math.inf)

    def leave(self, t: float, waited: float, wall: float) -> None:
        """The world steps on from the stop at ``t`` at ``wall``, after waiting ``waited`` wall s for its
        participants."""
        for node in self._owing:
            p = self.participants[node]
            p.owed += 1
            if not self.owes(p, t):
                p.answered += 1
            if node in self._waited_for:
                p.waited += waited
            p.since = None
        self._owing.clear()
        self._waited_for.clear()
        self._stop_wall = wall

    def stats(self) -> dict[str, dict[str, float]]:
        """Per participant: stops owed, answered, missed; timeouts, waited_s, sessions, absent, idle."""
        return {p.node: {"owed": p.owed, "answered": p.answered, "missed": p.missed, "timeouts": p.timeouts,
                         "waited_s": round(p.waited, 3), "sessions": p.sessions, "absent": int(p.absent),
                         "idle": int(p.idle)} for p in self.participants.values()}


@dataclass(frozen=True)
class Wait:
    """The stop cannot be left yet: look again at ``until`` (wall time) or at the next event."""

    reason: str                     # CONTROLLERS, FLOORS or CEILING
    until: float
    who: tuple[str, ...] = ()       # the participants waited for


@dataclass
class Stepper:
    """The clock of one floor: stops every ``step`` sim seconds from ``start`` (see the module docstring).

    The node calls :meth:`check` (with the wall time and the slowest live peer floor's sim time) until
    it returns None, then :meth:`advance` and computes the step.
    """

    step: float
    pacer: Pacer
    lockstep: Lockstep = field(default_factory=Lockstep)
    max_drift: float | None = None        # sim s ahead of the slowest live floor at most (None: no bound)
    start: float = 0.0
    peer_poll: tuple[float, float] = (0.001, 0.02)    # wall s between two looks at the other floors: min, max
    steps: int = 0
    waited: dict[str, float] = field(default_factory=lambda: {CONTROLLERS: 0.0, FLOORS: 0.0, CEILING: 0.0})
    max_lead: float = 0.0                 # sim s this floor was ahead of the slowest peer at most
    _last: tuple[str, float] | None = None    # (reason, wall) of the last check that waited
    _stop_wait: float = 0.0                   # wall s waited for participants at this stop

    def __post_init__(self) -> None:
        if not (math.isfinite(self.step) and self.step > 0):
            raise SimConfigError(f"step: {self.step!r} must be > 0 sim seconds")
        if self.max_drift is not None and not (math.isfinite(self.max_drift) and self.max_drift >= self.step):
            raise SimConfigError(f"max_drift: {self.max_drift!r} must be at least one step ({self.step:g} s)")

    @property
    def t(self) -> float:
        """Sim time of the current stop."""
        return self.start + self.steps * self.step

    @property
    def next_t(self) -> float:
        return self.start + (self.steps + 1) * self.step

    def _account(self, wall: float) -> None:
        if self._last is not None:
            reason, since = self._last
            spent = max(0.0, wall - since)
            self.waited[reason] += spent
            if reason == CONTROLLERS:
                self._stop_wait += spent
            self._last = None

    def check(self, wall: float, peers: float | None = None) -> Wait | None:
        """None: step now. Else what the stop waits for (``peers``: the slowest live peer floor's sim time)."""
        self._account(wall)
        wait = self._decide(wall, peers)
        if wait is not None:
            self._last = (wait.reason, wall)
        return wait

    def _decide(self, wall: float, peers: float | None) -> Wait | None:
        pending = self.lockstep.waiting(self.t, wall)
        if pending:
            return Wait(CONTROLLERS, self.lockstep.deadline(), tuple(pending))
        if peers is not None:
            self.max_lead = max(self.max_lead, self.t - peers)
            if self.max_drift is not None and self.next_t > peers + self.max_drift + EPS:
                # look again when the slowest floor may have caught up, at this floor's ceiling
                need = (self.next_t - peers - self.max_drift) / (self.pacer.speed or MAX_SPEED)
                return Wait(FLOORS, wall + min(max(need, self.peer_poll[0]), self.peer_poll[1]))
        due = self.pacer.due(self.next_t)
        if wall < due:
            return Wait(CEILING, due)
        return None

    def advance(self, wall: float) -> float:
        """Leave the current stop (after :meth:`check` returned None); returns the sim time of the next one."""
        self._account(wall)
        self.lockstep.leave(self.t, self._stop_wait, wall)
        self._stop_wait = 0.0
        self.steps += 1
        self.pacer.reached(self.t, wall)
        return self.t

    def behind(self, wall: float) -> float:
        """Wall s this floor's clock has been behind its speed ceiling."""
        return self.pacer.behind_at(self.t, wall)
