"""The simulated visitor (ROS-free core): follows the robots' instructions unattended.

The building runs one visitor node per floor, each on its robot's master; together
they play one person. A node knows where the person is only from the navigation
events every robot broadcasts (``/gidabot/nav_events``):

* ``GO_TO_FLOOR`` from this floor's robot: the visitor leaves this floor;
* ``GO_TO_FLOOR`` from another robot with ``target_floor`` = this floor: the
  visitor arrives here after walking (stairs: ``stairs_s_per_floor`` per floor;
  lift: ``lift_wait_s`` + ``lift_s_per_floor`` per floor);
* ``WAITING_VISITOR`` from this floor's robot: press Continue once the visitor
  has arrived (plus ``think_s``);
* ``TOUR_STEP_DONE`` from this floor's robot: press Continue (or skip ahead, by
  the skip plan) after ``think_s``;
* ``GOAL_REACHED`` of a single target, ``TOUR_FINISHED``, ``UNREACHABLE``,
  ``TIMEOUT``, cancels: the visit is over (``finished``) -- only events about this
  visit (its tour, its goal), not the answer to somebody else's command at a screen;
* ``PARTNER_OFFLINE`` answering this visitor's own request (no goal was made: the
  robot of the next floor is offline right now): like a person told so, the visitor
  asks again after ``retry_s``, for at most ``retry_for_s``, then gives up.

Time is passed in (sim seconds); :meth:`VisitorCore.step` returns the commands
that are due, so tests need no clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from gidabot_navigation.interface import (
    ACCEPTED,
    CANCELLED_ELSEWHERE,
    CANCELLED_HERE,
    CONTINUE,
    DEFAULT_LANGUAGE,
    GO_TO_FLOOR,
    GOAL_REACHED,
    PARTNER_OFFLINE,
    REJECTED,
    REQUEST,
    SKIP,
    START_TOUR,
    TIMEOUT,
    TOUR_FINISHED,
    TOUR_STEP_DONE,
    UNREACHABLE,
    WAITING_VISITOR,
    WAY_LIFT,
    WAY_STAIRS,
)

ENDS = {UNREACHABLE, CANCELLED_HERE, CANCELLED_ELSEWHERE, TIMEOUT, PARTNER_OFFLINE, REJECTED, TOUR_FINISHED}


@dataclass(frozen=True)
class VisitorConfig:
    robot: str                       # robot of this floor
    floor: float                     # this floor
    start_floor: float = 0.0         # where the visitor starts
    way: str = WAY_STAIRS            # WAY_STAIRS or WAY_LIFT for every floor change
    language: str = DEFAULT_LANGUAGE
    stairs_s_per_floor: float = 20.0 # s of walking per floor by the stairs
    lift_wait_s: float = 25.0        # s waiting for the lift
    lift_s_per_floor: float = 5.0    # s of lift travel per floor
    think_s: float = 3.0             # s before pressing a button
    tour_file: str = ""              # tour to start (on the start floor); "" = single target
    goal_id: str = ""                # single target to request (on the start floor)
    skips: tuple[tuple[int, int], ...] = ()  # (after tour step k is done, go to step m) pairs
    visitor_id: str = "sim-visitor"
    retry_s: float = 30.0            # s before asking again after "the robot on floor N is offline"
    retry_for_s: float = 1800.0      # s of such refusals before giving up

    def walk_time(self, from_floor: float, to_floor: float) -> float:
        floors = abs(to_floor - from_floor)
        if self.way == WAY_LIFT:
            return self.lift_wait_s + self.lift_s_per_floor * floors
        return self.stairs_s_per_floor * floors


@dataclass(frozen=True)
class ButtonPress:
    """A button the visitor presses: the VisitorCommand to publish on this robot's ``visitor/command``
    (the node adds its uid, visitor id and stamp)."""

    command: int
    goal_id: str = ""
    goal_uid: str = ""
    tour_file: str = ""
    tour_step: int = -1
    way: str = ""
    language: str = DEFAULT_LANGUAGE


@dataclass
class _Due:
    at: float
    press: ButtonPress


@dataclass
class VisitorCore:
    cfg: VisitorConfig
    present: bool = False
    started: bool = False
    finished: bool = False
    outcome: str = ""                                 # why the visit ended
    arrivals: dict[str, float] = field(default_factory=dict)   # goal uid -> arrival time here
    waiting: set[str] = field(default_factory=set)             # goals whose robot here waits for us
    _due: list[_Due] = field(default_factory=list)
    _handled: set[str] = field(default_factory=set)            # event uids already seen
    retries: int = 0                                           # requests asked again after a refusal
    _refused_since: float | None = None                        # first refusal of the current request

    def __post_init__(self) -> None:
        self.present = self.on_start_floor

    # -- inputs ------------------------------------------------------------
    @property
    def on_start_floor(self) -> bool:
        """This node plays the visitor's first floor (the only one that starts the visit)."""
        return math.isclose(self.cfg.floor, self.cfg.start_floor)

    def start(self, now: float) -> list[ButtonPress]:
        """Begin the visit: only the start floor's node does something, and only once.

        (The visitor being *present* on a floor is not enough: it arrives on every floor of a
        tour, and a START_TOUR there would restart the tour.)
        """
        if self.started or not self.on_start_floor:
            return []
        self.started = True
        c = self.cfg
        if c.tour_file:
            cmd = ButtonPress(START_TOUR, tour_file=c.tour_file, way=c.way, language=c.language)
        elif c.goal_id:
            cmd = ButtonPress(REQUEST, goal_id=c.goal_id, way=c.way, language=c.language)
        else:
            return []
        return [cmd]

    def concerns_visit(self, goal_uid: str, tour_file: str, location_id: str) -> bool:
        """Whether an event is about this visit (its tour; in single-target mode its goal) rather than
        the answer to another command at a screen (e.g. an invalid request typed there)."""
        if self.cfg.tour_file:
            return tour_file == self.cfg.tour_file
        if goal_uid:
            return True
        return location_id in ("", self.cfg.goal_id)

    def on_event(self, now: float, uid: str, robot: str, phase: int, goal_uid: str,
                 floor: float, target_floor: float, tour_step: int = -1, tour_file: str | None = None,
                 location_id: str = "") -> None:
        """A NavEvent seen on this master (from any robot). ``tour_file`` None: not known (taken as this
        visit's)."""
        if uid and uid in self._handled:
            return
        if uid:
            self._handled.add(uid)
        mine = robot == self.cfg.robot
        ours = self.concerns_visit(goal_uid, self.cfg.tour_file if tour_file is None else tour_file, location_id)
        if phase in ENDS and not ours:
            return
        if phase == PARTNER_OFFLINE and mine and not goal_uid and not self.finished:
            self._refused(now, tour_step)
            return
        if phase == ACCEPTED and ours:
            self._refused_since = None
        if phase == GO_TO_FLOOR:
            if mine:
                self.present = False
            elif math.isclose(target_floor, self.cfg.floor) and math.isfinite(floor):
                self.arrivals[goal_uid] = now + self.cfg.walk_time(floor, self.cfg.floor)
            return
        if not mine:
            if phase in ENDS and phase != TOUR_FINISHED:
                self.finished, self.outcome = True, f"phase {phase} from {robot}"
            return
        if phase == WAITING_VISITOR:
            self.waiting.add(goal_uid)
        elif phase == TOUR_STEP_DONE:
            self.present = True
            nxt = dict(self.cfg.skips).get(tour_step)
            cmd = (ButtonPress(SKIP, goal_uid=goal_uid, tour_file=self.cfg.tour_file, tour_step=nxt, way=self.cfg.way,
                               language=self.cfg.language) if nxt is not None else
                   ButtonPress(CONTINUE, goal_uid=goal_uid, tour_file=self.cfg.tour_file, way=self.cfg.way,
                               language=self.cfg.language))
            self._due.append(_Due(now + self.cfg.think_s, cmd))
        elif phase == GOAL_REACHED and not self.cfg.tour_file:
            self.present, self.finished, self.outcome = True, True, "goal reached"
        elif phase in ENDS:
            self.finished = True
            self.outcome = "tour finished" if phase == TOUR_FINISHED else f"phase {phase}"

    def _refused(self, now: float, step: int) -> None:
        """Our own request was refused (a robot it needs is offline): ask again later, or give up."""
        if self._refused_since is None:
            self._refused_since = now
        if now - self._refused_since >= self.cfg.retry_for_s:
            self.finished, self.outcome = True, f"phase {PARTNER_OFFLINE} (gave up after {self.retries} retries)"
            return
        c = self.cfg
        if c.tour_file:
            cmd = (ButtonPress(START_TOUR, tour_file=c.tour_file, way=c.way, language=c.language) if step <= 0 else
                   ButtonPress(SKIP, tour_file=c.tour_file, tour_step=step, way=c.way, language=c.language))
        elif c.goal_id:
            cmd = ButtonPress(REQUEST, goal_id=c.goal_id, way=c.way, language=c.language)
        else:
            return
        self.retries += 1
        self._due.append(_Due(now + c.retry_s, cmd))

    def step(self, now: float) -> list[ButtonPress]:
        """Commands due at ``now``."""
        for goal_uid in sorted(self.waiting):
            arrival = self.arrivals.get(goal_uid)
            if arrival is not None and now >= arrival:
                self.waiting.discard(goal_uid)
                self.present = True
                self._due.append(_Due(now + self.cfg.think_s, ButtonPress(CONTINUE, goal_uid=goal_uid,
                                                                          way=self.cfg.way,
                                                                          language=self.cfg.language)))
        ready = [d for d in self._due if d.at <= now]
        self._due = [d for d in self._due if d.at > now]
        return [d.press for d in sorted(ready, key=lambda d: d.at)]
