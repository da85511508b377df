"""The visitor flow at one robot's screen (ROS-free state machine).

Inputs: the visitor's choices (request a destination, start a tour, Continue,
skip to a stop, Cancel) and the NavEvents of this robot. Outputs: the
:class:`~gidabot_navigation.guiding.messages.CommandData` forms to publish on
``visitor/command`` and :class:`Notice` records the window turns into pop-ups and speech.
Time is wall time in seconds, passed in.

Trips. Every trip this screen knows is kept by its goal uid. A request sent from
here is a *local pending* trip (uid ``""``) until the first event of this robot
that belongs to it arrives: an event whose goal uid starts with
``<robot>/<visitor_id>/`` (Goal.uid convention), or, for tours, an event of the
same tour file. A trip of another robot's visitor reaches this screen with
``GOING_TO_MEETING`` / ``WAITING_VISITOR`` (cross-floor trips) or
``TOUR_STEP_DONE``. The *current* trip is the one whose visitor stands at this
screen: the latest that had a visitor-facing event or was requested here.

Several robots on a floor: when another robot of this floor is assigned the start leg of a
trip requested here (this robot is busy, ``ASSIGNED``), the visitor is told who comes and
when, and waits at this screen (and may cancel here) until that robot starts guiding them;
that robot's events about the trip are followed only for that. A tour sent to a floor
without robot (``NO_ROBOT_ON_FLOOR``) is told again once the robot that will wait for the
visitor at the next stop is known (its ``ASSIGNED``, from this robot).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace
from enum import Enum

from gidabot_gui.core.model import TourInfo, clip
from gidabot_gui.errors import GuiError
from gidabot_navigation.building.model import Building
from gidabot_navigation.guiding.messages import CommandData, NavEventData
from gidabot_navigation.interface import FINAL_PHASES, LEG_GOAL, LEG_START, Cmd, Phase

REQUEST_TIMEOUT = 20.0   # s (wall) without any event for a request before "no answer"
SEEN_UIDS = 2000         # event uids remembered for de-duplication


class Activity(Enum):
    PENDING = "pending"      # sent from here, no event yet
    QUEUED = "queued"        # ACCEPTED: in the robot's queue
    GUIDING = "guiding"      # ON_THE_WAY
    COMING = "coming"        # GOING_TO_MEETING: the robot drives alone to meet a visitor
    WAITING = "waiting"      # WAITING_VISITOR: press Continue when here
    STEP_DONE = "step_done"  # TOUR_STEP_DONE: Continue or choose the next stop
    HANDED = "handed"        # ASSIGNED to another robot of this floor: it comes here for the visitor


FACING = {Activity.PENDING, Activity.QUEUED, Activity.GUIDING, Activity.WAITING, Activity.STEP_DONE,
          Activity.HANDED}


class Mode(Enum):
    SINGLE = "single"
    TOUR = "tour"


class LocalNotice(Enum):
    """What this screen tells the visitor on its own, with no NavEvent behind it."""

    NO_ANSWER = "no_answer"      # no event answered a request within the request timeout
    BUSY = "busy"                # a trip runs at this screen: finish or cancel it first


NoticeKind = Phase | LocalNotice   # what a pop-up is about: a NavEvent's phase, or the screen's own notice


@dataclass
class ScreenTrip:
    """A trip as this screen follows it (not the guiding nodes' Trip: what the visitor here does in it)."""

    uid: str
    activity: Activity
    local: bool                  # requested at this screen
    goal_id: str = ""
    goal_floor: float = math.nan
    start_id: str = ""           # location or connector id where the trip started here ("" = unknown)
    way: str = ""
    tour_file: str = ""
    tour_step: int = -1
    since: float = 0.0           # wall time of the last change
    focus: int = 0               # order in which trips came to the visitor at this screen
    step_notice_shown: bool = False
    helper: str = ""             # HANDED: the robot that comes for the visitor


@dataclass
class TourProgress:
    file_name: str
    done: set[int] = field(default_factory=set)
    running: int = -1            # step being guided to (-1 = none)
    last_done: int = -1


@dataclass(frozen=True)
class Notice:
    """Something to tell the visitor: a NavEvent of this robot, or a local outcome.

    ``kind``: the :class:`Phase` of the event, or a :class:`LocalNotice`.
    ``modal``: a pop-up (with speech); otherwise a banner line only.
    ``actions``: buttons of the pop-up: ``ok``, ``continue``, ``cancel``, ``choose_stop``.
    ``adopt_language``: the trip's visitor arrives from another robot; show their language.
    """

    kind: NoticeKind
    event: NavEventData | None = None
    modal: bool = True
    actions: tuple[str, ...] = ("ok",)
    goal_id: str = ""
    tour_file: str = ""
    tour_step: int = -1
    adopt_language: str = ""
    final: bool = False          # the trip is over at this screen


class VisitorFlow:
    """State of the visitor side of one robot's screen."""

    def __init__(self, building: Building, robot: str, visitor_id: str,
                 request_timeout: float = REQUEST_TIMEOUT) -> None:
        if building.find_robot(robot) is None:
            raise GuiError(f"robot {robot!r} is not in building {building.id} "
                           f"({', '.join(r.name for r in building.robots)})")
        self.building = building
        self.robot = robot
        self.floor = building.robot(robot).floor
        self.visitor_id = visitor_id
        self.request_timeout = request_timeout
        self.trips: dict[str, ScreenTrip] = {}
        self.tour: TourProgress | None = None
        self.mode = Mode.SINGLE
        self.rejected = 0
        self.last_rejection = ""
        self._seq = 0
        self._focus = 0
        self._seen: set[str] = set()
        self._seen_order: deque[str] = deque()
        self._alone: dict[str, NavEventData] = {}   # tour file -> its NO_ROBOT_ON_FLOOR sent here

    # ------------------------------------------------------------------ views
    @property
    def current(self) -> ScreenTrip | None:
        """The trip whose visitor is at this screen (None when idle)."""
        facing = [t for t in self.trips.values() if t.activity in FACING]
        return max(facing, key=lambda t: t.focus) if facing else None

    @property
    def busy(self) -> bool:
        return self.current is not None

    @property
    def coming(self) -> ScreenTrip | None:
        """A trip whose robot (this one) drives alone to meet its visitor."""
        return next((t for t in self.trips.values() if t.activity is Activity.COMING), None)

    @property
    def can_cancel(self) -> bool:
        return self.current is not None

    @property
    def can_continue(self) -> bool:
        cur = self.current
        return cur is not None and cur.activity in (Activity.WAITING, Activity.STEP_DONE)

    def can_skip_to(self, step: int) -> bool:
        cur = self.current
        return (cur is not None and cur.activity is Activity.STEP_DONE and self.tour is not None
                and cur.tour_file == self.tour.file_name and step > self.tour.last_done)

    # ------------------------------------------------------------------ visitor actions
    def _command(self, command: Cmd, language: str, **fields: object) -> CommandData:
        self._seq += 1
        uid = f"{self.robot}/{self.visitor_id}/cmd/{self._seq}"
        return CommandData(uid=uid, visitor_id=self.visitor_id, command=int(command), language=language,
                       **fields)  # type: ignore[arg-type]

    def _new_local(self, now: float, **fields: object) -> ScreenTrip:
        self.trips.pop("", None)
        self._focus += 1
        trip = ScreenTrip(uid="", activity=Activity.PENDING, local=True, since=now, focus=self._focus,
                    **fields)  # type: ignore[arg-type]
        self.trips[""] = trip
        return trip

    def request(self, goal_id: str, way: str, language: str, now: float, start_id: str = "") -> CommandData:
        """The visitor confirmed ``goal_id`` (``way`` when floors change)."""
        goal = self.building.find_location(goal_id)
        if goal is None:
            raise GuiError(f"unknown destination {goal_id!r}")
        if self.busy:
            raise GuiError("a trip is already running at this robot; cancel it first")
        changes_floor = goal.floor != self.floor
        self.mode = Mode.SINGLE
        self.tour = None
        self._new_local(now, goal_id=goal_id, goal_floor=goal.floor, start_id=start_id,
                        way=way if changes_floor else "")
        return self._command(Cmd.REQUEST, language, goal_id=goal_id, way=way if changes_floor else "")

    def can_start_tour(self) -> bool:
        """Idle, or a tour waits at a stop here (Start again restarts it)."""
        cur = self.current
        return cur is None or cur.activity is Activity.STEP_DONE

    def start_tour(self, tour: TourInfo, way: str, language: str, now: float, start_id: str = "") -> CommandData:
        """Start (again) ``tour`` from its first stop."""
        if not self.can_start_tour():
            raise GuiError("a trip is already running at this robot; cancel it first")
        cur = self.current
        if cur is not None:                 # the tour waiting here is replaced (the goal manager restarts it)
            self.trips.pop(cur.uid, None)
        if not tour.goals:
            raise GuiError(f"tour {tour.file_name} has no stops")
        self.mode = Mode.TOUR
        self.tour = TourProgress(tour.file_name, running=0)
        floor, room, _ = tour.goals[0]
        self._new_local(now, goal_id=room, goal_floor=floor, start_id=start_id, way=way,
                        tour_file=tour.file_name, tour_step=0)
        return self._command(Cmd.START_TOUR, language, tour_file=tour.file_name, way=way)

    def continue_(self, language: str, now: float, goal_uid: str | None = None) -> CommandData | None:
        """The visitor pressed Continue (at the meeting point, or after a tour stop)."""
        trip = self.trips.get(goal_uid) if goal_uid else self.current
        if trip is None or trip.activity not in (Activity.WAITING, Activity.STEP_DONE):
            return None
        cmd = self._command(Cmd.CONTINUE, language, goal_uid=trip.uid, tour_file=trip.tour_file, way=trip.way)
        if trip.activity is Activity.WAITING:
            trip.activity, trip.since = Activity.GUIDING, now
            self._focus += 1
            trip.focus = self._focus
        else:
            self._next_step(trip, trip.tour_step + 1, now)
        return cmd

    def skip(self, step: int, goals: tuple[tuple[float, str, str], ...], language: str,
             now: float) -> CommandData | None:
        """The visitor chose stop ``step`` (0-based) of the current tour as the next one."""
        if not self.can_skip_to(step) or not 0 <= step < len(goals):
            return None
        trip = self.current
        assert trip is not None
        cmd = self._command(Cmd.SKIP, language, goal_id=goals[step][1], goal_uid=trip.uid,
                            tour_file=trip.tour_file, tour_step=step, way=trip.way)
        self._next_step(trip, step, now)
        return cmd

    def _next_step(self, trip: ScreenTrip, step: int, now: float) -> None:
        self.trips.pop(trip.uid, None)
        if self.tour is not None:
            self.tour.running = step
        self._new_local(now, tour_file=trip.tour_file, tour_step=step, way=trip.way,
                        start_id=trip.goal_id)

    def cancel(self, language: str, now: float) -> CommandData | None:
        """The visitor pressed Cancel: drop the current trip (and the tour) here at once."""
        trip = self.current
        if trip is None:
            return None
        cmd = self._command(Cmd.CANCEL, language, goal_uid=trip.uid, tour_file=trip.tour_file)
        self.trips.pop(trip.uid, None)
        self.tour = None
        return cmd

    def set_mode(self, mode: Mode) -> None:
        self.mode = mode

    # ------------------------------------------------------------------ events
    def _remember(self, uid: str) -> bool:
        """False if ``uid`` was handled already."""
        if not uid:
            return True
        if uid in self._seen:
            return False
        self._seen.add(uid)
        self._seen_order.append(uid)
        while len(self._seen_order) > SEEN_UIDS:
            self._seen.discard(self._seen_order.popleft())
        return True

    def _reject(self, why: str) -> None:
        self.rejected += 1
        self.last_rejection = why

    def _belongs_to_pending(self, ev: NavEventData) -> bool:
        pend = self.trips.get("")
        if pend is None:
            return False
        if ev.goal_uid.startswith(f"{self.robot}/{self.visitor_id}/"):
            return True
        if pend.tour_file and ev.tour_file == pend.tour_file:
            return True
        # the answer to a request that made no goal (invalid, partner offline, no path) carries no goal uid
        return not ev.goal_uid and ev.phase in (Phase.REJECTED, Phase.PARTNER_OFFLINE, Phase.UNREACHABLE)

    def on_event(self, ev: NavEventData, now: float) -> Notice | None:
        """A NavEvent seen on this master; returns what to tell the visitor (or None)."""
        if ev.robot != self.robot:
            return self._helper_event(ev)
        if not self._remember(ev.uid):
            return None
        try:
            phase = Phase(ev.phase)
        except ValueError:
            self._reject(f"NavEvent {clip(ev.uid, 60)!r} has unknown phase {ev.phase!r}")
            return None
        if phase is Phase.DECLINED:
            return None          # the legs' assignment between robots: another robot is asked
        trip = self.trips.get(ev.goal_uid) if ev.goal_uid else None
        if trip is None and self._belongs_to_pending(ev):
            trip = self.trips.pop("")
            trip.uid = ev.goal_uid
            if ev.goal_uid:
                self.trips[ev.goal_uid] = trip
        if trip is None and ev.goal_uid and phase in (Phase.ACCEPTED, Phase.ON_THE_WAY, Phase.GOING_TO_MEETING,
                                                      Phase.WAITING_VISITOR, Phase.TOUR_STEP_DONE):
            trip = ScreenTrip(uid=ev.goal_uid, activity=Activity.QUEUED, local=False, since=now)
            self.trips[ev.goal_uid] = trip
        if phase is Phase.ASSIGNED:
            return self._assigned(ev, trip, now)
        if trip is not None:
            self._update_trip(trip, ev, now)
        return self._handle(phase, ev, trip)

    def _assigned(self, ev: NavEventData, trip: ScreenTrip | None, now: float) -> Notice | None:
        """This robot assigned a leg of a trip made here: another robot of the floor comes for the visitor,
        or (a tour sent to a floor without robot) the robot that waits at the next stop is known."""
        if ev.leg == LEG_START and ev.assignee != self.robot and trip is not None and trip.activity in (
                Activity.PENDING, Activity.QUEUED):
            trip.activity, trip.helper, trip.since = Activity.HANDED, ev.assignee, now
            self._focus_on(trip)
            return Notice(Phase.ASSIGNED, ev, actions=("ok", "cancel"), goal_id=trip.goal_id,
                          tour_file=trip.tour_file, tour_step=trip.tour_step)
        alone = self._alone.get(ev.tour_file) if ev.tour_file else None
        if ev.leg == LEG_GOAL and alone is not None and alone.tour_step < ev.tour_step:
            del self._alone[ev.tour_file]
            told = replace(alone, assignee=ev.assignee)
            return Notice(Phase.NO_ROBOT_ON_FLOOR, told, goal_id=alone.location_id, tour_file=alone.tour_file,
                          tour_step=alone.tour_step, modal=not self.busy, final=True)
        return None

    def _helper_event(self, ev: NavEventData) -> Notice | None:
        """Another robot's event: only about a trip handed to it from here (its visitor waits at this screen)."""
        trip = self.trips.get(ev.goal_uid) if ev.goal_uid else None
        if trip is None or trip.activity is not Activity.HANDED or ev.robot != trip.helper \
                or not self._remember(ev.uid):
            return None
        if ev.phase == Phase.ON_THE_WAY:
            del self.trips[trip.uid]             # the visitor left with it
            return None
        if ev.phase in FINAL_PHASES:
            was_current = trip is self.current
            del self.trips[trip.uid]
            return Notice(Phase(ev.phase), ev, goal_id=trip.goal_id, tour_file=trip.tour_file,
                          tour_step=trip.tour_step, modal=was_current or not self.busy, final=True)
        return None

    def _update_trip(self, trip: ScreenTrip, ev: NavEventData, now: float) -> None:
        trip.since = now
        loc = self.building.find_location(ev.location_id) if ev.location_id else None
        if loc is not None and ev.phase not in (Phase.GO_TO_FLOOR, Phase.NO_ROBOT_ON_FLOOR):
            trip.goal_id, trip.goal_floor = loc.id, loc.floor
        if ev.connector and ev.phase in (Phase.WAITING_VISITOR, Phase.GOING_TO_MEETING) and not trip.start_id:
            trip.start_id = ev.connector
        if ev.way:
            trip.way = ev.way
        if ev.tour_file:
            trip.tour_file = ev.tour_file
            if ev.tour_step >= 0:
                trip.tour_step = ev.tour_step

    def _focus_on(self, trip: ScreenTrip) -> None:
        self._focus += 1
        trip.focus = self._focus

    def _tour_of(self, trip: ScreenTrip) -> TourProgress:
        if self.tour is None or self.tour.file_name != trip.tour_file:
            self.tour = TourProgress(trip.tour_file)
        self.mode = Mode.TOUR
        return self.tour

    def _handle(self, phase: Phase, ev: NavEventData, trip: ScreenTrip | None) -> Notice | None:
        def notice(kind: Phase, **kw: object) -> Notice:
            return Notice(kind, ev, goal_id=trip.goal_id if trip else ev.location_id,
                          tour_file=trip.tour_file if trip else ev.tour_file,
                          tour_step=trip.tour_step if trip else ev.tour_step, **kw)  # type: ignore[arg-type]

        adopt = ev.language if (trip is not None and not trip.local and ev.language) else ""
        if phase is Phase.ACCEPTED:
            if trip is not None and trip.activity is Activity.PENDING:
                trip.activity = Activity.QUEUED
            return None
        if phase in (Phase.PARTNER_LOST, Phase.PARTNER_BACK):
            # not final: the trip waits for (or goes on with) a robot that was offline
            facing = trip is not None and trip.activity in FACING
            return notice(phase, modal=facing or not self.busy, actions=("ok",))
        if phase is Phase.GOING_TO_MEETING:
            if trip is not None and trip.activity in (Activity.QUEUED, Activity.PENDING) and not trip.local:
                trip.activity = Activity.COMING
            return notice(phase, modal=False)
        if trip is not None and phase is Phase.ON_THE_WAY:
            first = trip.activity not in (Activity.GUIDING,)
            trip.activity = Activity.GUIDING
            if trip.tour_file and self.tour is not None and trip.tour_file == self.tour.file_name:
                self.tour.running = trip.tour_step
            self._focus_on(trip)
            return notice(phase, actions=("ok", "cancel"), adopt_language=adopt if first else "")
        if phase in (Phase.WAITING_FOR_YOU, Phase.FOLLOW_ME, Phase.SEARCHING_VISITOR):
            # not final: the robot guiding keeps its visitor's pace (waits, goes on, looks for them)
            facing = trip is not None and trip.activity in FACING
            return notice(phase, modal=facing or not self.busy, actions=("ok", "cancel"))
        if trip is not None and phase is Phase.PRESS_CONTINUE and trip.activity is Activity.WAITING:
            self._focus_on(trip)           # someone arrived at the meeting point: asked to press Continue
            return notice(phase, actions=("continue", "cancel"))
        if phase is Phase.PRESS_CONTINUE:
            return None
        if trip is not None and phase is Phase.WAITING_VISITOR:
            trip.activity = Activity.WAITING
            self._focus_on(trip)
            return notice(phase, actions=("continue", "cancel"), adopt_language=adopt)
        step_done = phase is Phase.TOUR_STEP_DONE or (phase is Phase.GOAL_REACHED and trip is not None
                                                      and bool(trip.tour_file) and trip.tour_step >= 0)
        if trip is not None and step_done:
            tour = self._tour_of(trip)
            tour.done.add(trip.tour_step)
            tour.last_done = max(tour.last_done, trip.tour_step)
            tour.running = -1
            trip.activity = Activity.STEP_DONE
            self._focus_on(trip)
            if trip.step_notice_shown:
                return None
            trip.step_notice_shown = True
            return notice(Phase.TOUR_STEP_DONE, actions=("continue", "choose_stop", "cancel"),
                          adopt_language=adopt)
        # terminal phases (or facing phases of a trip we could not identify)
        if phase is Phase.NO_ROBOT_ON_FLOOR and ev.tour_file:
            self._alone[ev.tour_file] = ev       # told again with the robot of the next stop (ASSIGNED)
        was_current = trip is not None and trip is self.current
        if trip is not None:
            self.trips.pop(trip.uid, None)
        if phase is Phase.TOUR_FINISHED or (self.tour is not None and trip is not None
                                            and trip.tour_file == self.tour.file_name):
            if phase is Phase.TOUR_FINISHED and self.tour is not None:
                self.tour.done.add(trip.tour_step if trip else ev.tour_step)
            self.tour = None
        if phase in (Phase.ON_THE_WAY, Phase.WAITING_VISITOR, Phase.TOUR_STEP_DONE):
            self._reject(f"NavEvent {clip(ev.uid, 60)!r} ({phase.name}) names no trip (goal_uid "
                         f"{clip(ev.goal_uid, 60)!r})")
            return None
        # tell the visitor only if the trip was theirs, or nobody else's trip is running here
        return notice(phase, modal=was_current or not self.busy, final=True, actions=("ok",))

    def tick(self, now: float) -> Notice | None:
        """Time passes: a request without any answer is given up."""
        pend = self.trips.get("")
        if pend is not None and now - pend.since > self.request_timeout:
            self.trips.pop("")
            if pend.tour_file and self.tour is not None and pend.tour_step <= 0:
                self.tour = None
            return Notice(LocalNotice.NO_ANSWER, None, goal_id=pend.goal_id, tour_file=pend.tour_file,
                          tour_step=pend.tour_step, final=True)
        return None

