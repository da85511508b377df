"""The simulated visitor (ROS-free core): follows the robots' instructions unattended.

The building runs one visitor node per robot, each on that robot's master (its touch
screen); together they play one person. A node knows where the person is only from the
navigation events every robot broadcasts (``/gidabot/nav_events``):

* the visit starts at one robot (``start_robot``: the first robot of the start floor);
* ``GO_TO_FLOOR`` from this robot: the visitor leaves this floor;
* ``GO_TO_FLOOR`` from another robot with ``target_floor`` = this floor: the
  visitor arrives here after walking (stairs: ``stairs_s_per_floor`` per floor;
  lift: ``lift_wait_s`` + ``lift_s_per_floor`` per floor);
* ``NO_ROBOT_ON_FLOOR`` of this visit's tour: the visitor walks to that floor, spends
  ``visit_s`` at each stop of the tour on floors without robot (walking between their
  floors), then walks to the floor of the tour's next stop with a robot: that is when
  it arrives for that step there; of a single target: the visit is over (found alone);
* ``WAITING_VISITOR`` from this robot: press Continue once the visitor has arrived
  (plus ``think_s``);
* ``TOUR_STEP_DONE`` from this robot: press Continue (or skip ahead, by
  the skip plan) after ``think_s``;
* ``GOAL_REACHED`` of a single target, ``TOUR_FINISHED``, ``UNREACHABLE``,
  ``TIMEOUT``, ``VISITOR_LOST`` (the guiding robot lost the visitor), cancels: the visit is over
  (``finished``) -- only events about this visit (its tour, its goal), not the answer to somebody else's
  command at a screen;
* ``PARTNER_OFFLINE`` answering this visitor's own request (no goal was made: the
  robot of the next floor is offline right now): like a person told so, the visitor
  asks again after ``retry_s``, for at most ``retry_for_s``, then gives up;
* ``PARTNER_OFFLINE`` about a trip of this visit (a robot gave it up: its partner was
  offline longer than ``partner_timeout``): the person asks again for the same tour step
  (or target) ``retry_s`` after being on a floor with a robot: the node of the floor the
  person is on, or arrives at (when the ``GO_TO_FLOOR`` of that trip comes), asks.

The visitor's body (:mod:`gidabot_sim.world.people`) walks as its behaviour says
(:mod:`gidabot_sim.visitor.behaviour`: given, else from ``behaviour_seed``; -1: the tidy default): one that wanders off
for good does nothing more from then on (:meth:`VisitorCore.wandered`): it presses no button, turns up nowhere.

One visitor of a population (``gidabot demo --visitors K``; each node then runs one core per
visitor, fed only the events of that visitor's trips) may also choose to cancel: at its start
robot's screen, ``cancel_after_s`` after asking, it presses Cancel for its latest trip unless the
visit is over; or never to turn up (``no_show``): it ignores ``WAITING_VISITOR`` away from its
start floor, so the robot waiting at the meeting point gives up. Before it confirms, the screen
shows how long until the robots of each leg are there (``start(now, shown)``); one with a
``patience_s`` does not confirm when a wait shown is longer: it leaves (``left``), by its choice.

Time is passed in (sim seconds); :meth:`VisitorCore.step` returns the commands
that are due, so tests need no clock.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import GoalRejected
from gidabot_navigation.guiding.assignment import AssignConfig
from gidabot_navigation.guiding.messages import Trip, validate_trip
from gidabot_navigation.guiding.trips import RobotView, TripPlanner, WaitModel, preview_trip
from gidabot_navigation.interface import DEFAULT_LANGUAGE, WAY_LIFT, WAY_STAIRS, Cmd, Phase
from gidabot_sim.visitor.behaviour import Behaviour, draw_behaviour

ENDS = {Phase.UNREACHABLE, Phase.CANCELLED_HERE, Phase.CANCELLED_ELSEWHERE, Phase.TIMEOUT, Phase.PARTNER_OFFLINE,
        Phase.REJECTED, Phase.TOUR_FINISHED, Phase.VISITOR_LOST}


@dataclass(frozen=True)
class VisitorConfig:
    robot: str                       # this node's robot
    floor: float                     # its floor
    start_floor: float = 0.0         # where the visitor starts
    start_robot: str = ""            # the robot where the visit starts ("" = any robot of the start floor)
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
    visit_s: float = 60.0            # s spent at a stop on a floor without robot (found alone)
    robot_floors: tuple[float, ...] = ()   # the floors with a robot
    # one visitor of a population (gidabot_sim.visitor.population): when it asks, and what it chooses
    arrive_s: float = 0.0            # s after every robot is up (the node starts the visit then)
    cancel_after_s: float = -1.0     # >= 0: presses Cancel this long after asking, if the visit is not over
    no_show: bool = False            # never turns up at a meeting point on another floor (that robot times out)
    patience_s: float = -1.0         # >= 0: does not confirm when a wait shown before confirming is longer
    behaviour_seed: int = -1         # how its body walks (gidabot_sim.visitor.behaviour; -1: tidy)
    behaviour: Behaviour | None = None   # how its body walks, given (gidabot demo --walk): behaviour_seed unused

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
    given_up: dict[str, int] = field(default_factory=dict)     # trips a robot gave up -> their tour step
    _refused_since: float | None = None                        # first refusal of the current request
    tour_floors: tuple[float, ...] = ()                        # the floor of each step of the tour
    step_arrivals: dict[int, float] = field(default_factory=dict)  # tour step -> arrival on its floor after
    #                                                                the stops found alone before it
    asked_at: float | None = None                              # when the visit started (the button pressed)
    goal_uids: list[str] = field(default_factory=list)         # this visitor's trips, oldest first
    cancel_sent: bool = False
    left: bool = False                                         # did not confirm: a wait shown was too long
    shown: tuple[float | None, ...] = ()                       # the waits shown before confirming (s, None unknown)
    first_seen: float | None = None                            # the first event of this visit seen here
    behaviour: Behaviour = field(init=False)

    def __post_init__(self) -> None:
        self.present = self.on_start_floor
        given = self.cfg.behaviour
        self.behaviour = given if given is not None else draw_behaviour(self.cfg.behaviour_seed)

    @property
    def visit_start(self) -> float | None:
        """When the visit started (the button pressed at its start robot; on another floor: its first event seen
        here): its behaviour's times count from there."""
        return self.asked_at if self.asked_at is not None else self.first_seen

    def wandered(self, now: float) -> bool:
        """It wandered off for good by ``now``: it does nothing more."""
        start = self.visit_start
        return start is not None and self.behaviour.wandered(now - start)

    # -- inputs ------------------------------------------------------------
    @property
    def on_start_floor(self) -> bool:
        """This node's robot is where the visitor starts (the only one that starts the visit)."""
        return math.isclose(self.cfg.floor, self.cfg.start_floor) and self.cfg.start_robot in ("", self.cfg.robot)

    def start(self, now: float, shown: tuple[float | None, ...] = ()) -> list[ButtonPress]:
        """Begin the visit: only the start floor's node does something, and only once. ``shown``: the waits (s)
        the screen shows before the visitor confirms, one per leg (None: not known); with a ``patience_s``, a
        longer one and the visitor does not confirm (:attr:`left`).

        (The visitor being *present* on a floor is not enough: it arrives on every floor of a
        tour, and a START_TOUR there would restart the tour.)
        """
        if self.started or not self.on_start_floor:
            return []
        self.started, self.asked_at, self.shown = True, now, tuple(shown)
        c = self.cfg
        longest = max((w for w in shown if w is not None and math.isfinite(w)), default=0.0)
        if c.patience_s >= 0 and longest > c.patience_s:
            self.left, self.finished = True, True
            self.outcome = f"left: shown a wait of {longest:.0f} s, more than the {c.patience_s:.0f} s it accepts"
            return []
        if c.tour_file:
            cmd = ButtonPress(Cmd.START_TOUR, tour_file=c.tour_file, way=c.way, language=c.language)
        elif c.goal_id:
            cmd = ButtonPress(Cmd.REQUEST, goal_id=c.goal_id, way=c.way, language=c.language)
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
        if ours and self.first_seen is None:
            self.first_seen = now
        if self.wandered(now):
            return
        if phase in ENDS and not ours:
            return
        if phase == Phase.PARTNER_OFFLINE and mine and not goal_uid and not self.finished:
            self._refused(now, tour_step)
            return
        if phase == Phase.PARTNER_OFFLINE and goal_uid and ours and not self.finished:
            self._trip_given_up(now, goal_uid, tour_step)
            return
        if phase == Phase.ACCEPTED and ours:
            self._refused_since = None
        if phase == Phase.GO_TO_FLOOR:
            if mine:
                self.present = False
            elif math.isclose(target_floor, self.cfg.floor) and math.isfinite(floor):
                arrival = now + self.cfg.walk_time(floor, self.cfg.floor)
                if goal_uid in self.given_up:        # sent here for a trip that was given up meanwhile
                    self.present = True
                    self._refused(arrival, self.given_up.pop(goal_uid))
                else:
                    self.arrivals[goal_uid] = arrival
            return
        if phase == Phase.NO_ROBOT_ON_FLOOR and ours:
            if mine:
                self.present = False
            if not self.cfg.tour_file:
                self.finished, self.outcome = True, "found the goal alone on a floor without robot"
            elif math.isfinite(floor):
                self._walk_alone(now, floor, tour_step)
            return
        if not mine:
            # a refusal elsewhere (PARTNER_OFFLINE without a trip) is asked again there: the visit goes on
            if phase in ENDS and phase not in (Phase.TOUR_FINISHED, Phase.PARTNER_OFFLINE):
                self.finished, self.outcome = True, f"phase {phase} from {robot}"
            return
        if phase == Phase.WAITING_VISITOR:
            if self.cfg.no_show and not self.on_start_floor:
                return                       # it never comes: the robot waiting here gives up (TIMEOUT)
            self.waiting.add(goal_uid)
            if goal_uid not in self.arrivals and tour_step in self.step_arrivals:
                self.arrivals[goal_uid] = self.step_arrivals.pop(tour_step)
        elif phase == Phase.TOUR_STEP_DONE:
            self.present = True
            nxt = dict(self.cfg.skips).get(tour_step)
            cmd = (ButtonPress(Cmd.SKIP, goal_uid=goal_uid, tour_file=self.cfg.tour_file, tour_step=nxt,
                               way=self.cfg.way, language=self.cfg.language) if nxt is not None else
                   ButtonPress(Cmd.CONTINUE, goal_uid=goal_uid, tour_file=self.cfg.tour_file, way=self.cfg.way,
                               language=self.cfg.language))
            self._due.append(_Due(now + self.cfg.think_s, cmd))
        elif phase == Phase.GOAL_REACHED and not self.cfg.tour_file:
            self.present, self.finished, self.outcome = True, True, "goal reached"
        elif phase in ENDS:
            self.finished = True
            self.outcome = "tour finished" if phase == Phase.TOUR_FINISHED else f"phase {phase}"

    def _trip_given_up(self, now: float, goal_uid: str, step: int) -> None:
        """A robot gave up a trip of this visit: whoever has the person (here now, or arriving here for that
        trip) asks again for the same step; other nodes remember it in case the person is sent here later."""
        self.waiting.discard(goal_uid)
        arrival = self.arrivals.pop(goal_uid, None)
        if self.present:
            self._refused(now, step)
        elif arrival is not None:
            self.present = True
            self._refused(max(now, arrival), step)
        else:
            self.given_up[goal_uid] = step

    def on_goal(self, goal_uid: str) -> None:
        """A trip made for this visitor (its Goal names the visitor)."""
        if goal_uid not in self.goal_uids:
            self.goal_uids.append(goal_uid)

    def on_tour(self, floors: tuple[float, ...]) -> None:
        """The floor of each step of this visit's tour (from the tour store's catalog)."""
        self.tour_floors = tuple(floors)

    def _walk_alone(self, now: float, floor: float, step: int) -> None:
        """Sent from ``floor`` to tour step ``step`` on a floor without robot: find it and the following such
        stops alone, then walk to the next stop with a robot (its robot waits at the meeting point)."""
        t, here = now, floor
        for k in range(max(step, 0), len(self.tour_floors)):
            there = self.tour_floors[k]
            t += self.cfg.walk_time(here, there)
            here = there
            if any(math.isclose(there, f) for f in self.cfg.robot_floors):
                self.step_arrivals[k] = t
                return
            t += self.cfg.visit_s

    def _refused(self, now: float, step: int) -> None:
        """Our own request was refused (a robot it needs is offline): ask again later, or give up."""
        if self._refused_since is None:
            self._refused_since = now
        if now - self._refused_since >= self.cfg.retry_for_s:
            self.finished, self.outcome = True, f"phase {Phase.PARTNER_OFFLINE} (gave up after {self.retries} retries)"
            return
        c = self.cfg
        if c.tour_file:
            cmd = (ButtonPress(Cmd.START_TOUR, tour_file=c.tour_file, way=c.way, language=c.language) if step <= 0 else
                   ButtonPress(Cmd.SKIP, tour_file=c.tour_file, tour_step=step, way=c.way, language=c.language))
        elif c.goal_id:
            cmd = ButtonPress(Cmd.REQUEST, goal_id=c.goal_id, way=c.way, language=c.language)
        else:
            return
        self.retries += 1
        self._due.append(_Due(now + c.retry_s, cmd))

    def step(self, now: float) -> list[ButtonPress]:
        """Commands due at ``now``."""
        if self.wandered(now):
            self._due.clear()
            if not self.outcome:
                self.outcome = "wandered off for good"
            return []
        for goal_uid in sorted(self.waiting):
            arrival = self.arrivals.get(goal_uid)
            if arrival is not None and now >= arrival:
                self.waiting.discard(goal_uid)
                self.present = True
                self._due.append(_Due(now + self.cfg.think_s, ButtonPress(Cmd.CONTINUE, goal_uid=goal_uid,
                                                                          way=self.cfg.way,
                                                                          language=self.cfg.language)))
        c = self.cfg
        if (c.cancel_after_s >= 0 and self.asked_at is not None and now >= self.asked_at + c.cancel_after_s
                and self.goal_uids and not self.finished and not self.cancel_sent):
            self.cancel_sent = True          # at the screen where it asked, about its latest trip
            self._due.append(_Due(now, ButtonPress(Cmd.CANCEL, goal_uid=self.goal_uids[-1], tour_file=c.tour_file,
                                                   way=c.way, language=c.language)))
        ready = [d for d in self._due if d.at <= now]
        self._due = [d for d in self._due if d.at > now]
        return [d.press for d in sorted(ready, key=lambda d: d.at)]


class Screen:
    """What a robot's screen shows a visitor before it confirms (as the GUI does, ``gidabot_gui.core.plans``):
    the robot of each leg and how long until it is there, from every robot's broadcast queue and pose
    (``/gidabot/pending``, ``/gidabot/status``), ranked as the robot will rank them
    (:func:`~gidabot_navigation.guiding.trips.preview_trip`). Times: wall s (when each message was received)."""

    def __init__(self, building: Building, offline_after: float = 5.0, planner: TripPlanner | None = None) -> None:
        self.building = building
        self.offline_after = offline_after
        self.planner = planner or TripPlanner(building)
        self.views: dict[str, RobotView] = {}
        self.heard: dict[str, float] = {}
        self.poses: dict[str, tuple[float, float]] = {}

    def on_status(self, robot: str, now_wall: float, pose: tuple[float, float] | None) -> None:
        found = self.building.find_robot(robot)
        if found is None:
            return
        self.heard[robot] = now_wall
        if pose is not None and all(math.isfinite(v) for v in pose):
            self.poses[robot] = (float(pose[0]), float(pose[1]))
            view = self.views.get(robot) or RobotView(found)
            self.views[robot] = RobotView(found, view.queue, view.wait_new, self.poses[robot], view.heard)

    def on_pending(self, robot: str, goals: Iterable[Trip], wait_new: float, now_wall: float) -> None:
        found = self.building.find_robot(robot)
        if found is None:
            return
        queue = []
        for trip in goals:
            try:
                queue.append(validate_trip(self.building, trip))
            except GoalRejected:
                continue
        wait = float(wait_new) if math.isfinite(wait_new) else 0.0
        self.views[robot] = RobotView(found, tuple(queue), max(0.0, wait), self.poses.get(robot), now_wall)

    def waits(self, robot: str, goal_id: str, way: str, now_wall: float) -> tuple[float | None, ...]:
        """The waits (s) shown at ``robot``'s screen for a trip to ``goal_id`` by ``way``, one per leg (None: no
        robot of that leg's floor is online)."""
        origin, goal = self.building.find_robot(robot), self.building.find_location(goal_id)
        if origin is None or goal is None:
            return ()
        pose = self.poses.get(robot, (origin.home.x, origin.home.y))
        online = lambda r: now_wall - self.heard.get(r, -math.inf) <= self.offline_after  # noqa: E731
        return tuple(p.wait_s for p in preview_trip(self.planner, WaitModel(), origin, pose, goal, way, self.views,
                                                     online, now_wall, AssignConfig.helper_gain))
