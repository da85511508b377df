"""The goal manager (ROS-free core): the FIFO of pending requests of one robot (paper section 6.2).

Driven by explicit events, each returning the actions for the adapter
(:class:`~gidabot_navigation.guiding.messages.SendGoal`, ``SendCancel``, ``SendEvent``). Every
input names its publisher (``sender``: the ROS callerid) and is first attributed
(:class:`~gidabot_navigation.senders.Senders`): a message speaks only for its sender, and one
that speaks for another robot, comes from an impostor, carries a uid outside its robot's
namespace, fails validation or reuses a handled uid with other content is refused, counted
(:meth:`GoalManagerCore.refusals`) and never answered. Replies (REJECTED, ACCEPTED, DECLINED...)
go only to this robot's own visitor and to the origin robot of a trip:

* :meth:`GoalManagerCore.on_command` — the visitor at this robot: REQUEST a goal,
  CONTINUE after a tour step done here, CANCEL, START_TOUR, SKIP. A request becomes a
  :class:`Trip` (uid, this robot's floor and pose, the goal from the building, the
  connector minimising the whole trip) whose legs this robot then assigns
  (:class:`~gidabot_navigation.guiding.assignment.Assigner`): it is broadcast on
  /gidabot/goals again with every change of its assignment.
* :meth:`on_goal` — every goal broadcast by any robot (this robot's own included):
  validated; only the newest attempt of a trip counts; kept (FIFO) while it names this
  robot for a leg; a leg newly proposed here is answered once, ACCEPTED or DECLINED.
* :meth:`on_cancel` — drops a goal, queued or running; the visitor here is told why.
* :meth:`on_nav_event` — this robot's navigation reports the end of its part of a trip
  (a final phase: the goal leaves the queue) or a tour step done (tour mode); any
  robot's GO_TO_FLOOR tells when a visitor was released (wait estimate); the answers
  to this robot's proposals (ACCEPTED / DECLINED) commit a leg or move it on.
* :meth:`on_status`, :meth:`on_pending` — the other robots' liveness (wall time), poses and
  queues: which robot can serve a leg soonest.
* :meth:`tick` — proposals not answered in time move on; unconfirmed ones held here expire.

:meth:`pending` gives the list for /gidabot/pending with the wait estimate.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, replace
from typing import Any

from gidabot_navigation.building.model import Building, Location, format_floor
from gidabot_navigation.errors import GoalRejected, GuidingError, GuidingStateError, NoRouteError
from gidabot_navigation.guiding.assignment import AssignConfig, Assigned, Assigner, GaveUp, LegBook, Output, Publish
from gidabot_navigation.guiding.liveness import PeerLiveness
from gidabot_navigation.guiding.messages import (
    PHASE_OF_REASON,
    START_ROBOT,
    Action,
    CancelData,
    CommandData,
    Counters,
    NavEventData,
    PendingData,
    SeenSet,
    SendCancel,
    SendEvent,
    SendGoal,
    StaffCommandData,
    Trip,
    UidMaker,
    cancel_digest,
    nav_event_digest,
    own_event_digest,
    same_floor,
    trip_digest,
    validate_cancel,
    validate_command,
    validate_event,
    validate_staff,
    validate_trip,
)
from gidabot_navigation.guiding.state import (
    REMEMBERED_UIDS,
    dataclass_from_dict,
    number,
    str_list,
    trip_from_dict,
    trip_to_dict,
    uid_records,
)
from gidabot_navigation.guiding.tour_mode import TourBook, TourWait, TourWaits, next_robot_stop
from gidabot_navigation.guiding.trips import (
    Candidate,
    HeadProgress,
    RobotView,
    TripPlanner,
    WaitModel,
    estimate_queue,
    leg_point,
    needed_legs,
    rank_candidates,
    rendezvous_eta,
)
from gidabot_navigation.interface import (
    DEFAULT_LANGUAGE,
    LANGUAGES,
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_PROPOSED,
    LEG_START,
    REASON_ADMIN,
    REASON_OFFLINE,
    REASON_VISITOR,
    RELEASE_PHASES,
    WAY_STAIRS,
    WAYS,
    Cmd,
    Node,
    Phase,
    StaffCmd,
    Topic,
)
from gidabot_navigation.logs import Logger, RateLimitedLog
from gidabot_navigation.senders import INVALID, Claim, Gate, HandledUids, Senders, as_text
from gidabot_navigation.tours.tour_file import MAX_GOALS
from gidabot_navigation.tours.tour_store import TourMessage

PROGRESS_PHASES = (Phase.ON_THE_WAY, Phase.GOING_TO_MEETING, Phase.WAITING_VISITOR)


@dataclass(frozen=True)
class GoalManagerConfig:
    """``robot``: this robot's name; ``offline_after``: wall s without status before a robot is offline;
    ``max_queue``: goals kept at most (a leg proposed beyond it is declined; one committed is refused and
    cancelled everywhere); ``assign``: the leg assignment's timeouts and bounds; ``catalog_wait``: wall s after
    the start during which a tour command waits for the tour store's first catalog (a restarted node hears
    the visitor's replayed Continue before the catalog) instead of being refused; ``simulated``: the simulated
    visitor (node ``visitor``) is one of this robot's own nodes (senders.SIMULATED_OWN_NODES)."""

    robot: str
    default_way: str = WAY_STAIRS
    default_language: str = DEFAULT_LANGUAGE
    offline_after: float = 5.0
    max_queue: int = 50
    catalog_wait: float = 10.0
    wait: WaitModel = field(default_factory=WaitModel)
    assign: AssignConfig = field(default_factory=AssignConfig)
    simulated: bool = False


class GoalManagerCore:
    """The pending requests of one robot and the visitor commands that create or end them."""

    def __init__(self, building: Building, cfg: GoalManagerConfig, log: Logger, now_wall: float,
                 planner: TripPlanner | None = None) -> None:
        robot = building.find_robot(cfg.robot)
        if robot is None:
            raise GuidingError(f"robot {cfg.robot!r} is not in building {building.id} "
                               f"({', '.join(r.name for r in building.robots)})")
        if cfg.default_way not in WAYS:
            raise GuidingError(f"default way {cfg.default_way!r} is not one of {', '.join(WAYS)}")
        if cfg.default_language not in LANGUAGES:
            raise GuidingError(f"default language {cfg.default_language!r} is not one of {', '.join(LANGUAGES)}")
        if cfg.max_queue < 1:
            raise GuidingError(f"max_queue {cfg.max_queue!r} must be at least 1")
        self.building = building
        self.cfg = cfg
        self.robot = robot
        self.me = robot.name
        self.log = log
        self.warn = RateLimitedLog(log)
        self.planner = planner or TripPlanner(building)
        self.uids = UidMaker(self.me, "gm")
        self.gate = Gate(Senders.of_building(building, self.me, cfg.simulated), log)
        self.liveness = PeerLiveness(cfg.offline_after, now_wall)
        self.tours = TourBook(building)
        self.waits = TourWaits()
        self.queue: list[Trip] = []
        self.version = 0                                   # increases whenever the queue changes
        self.stats = Counters(received=0, accepted=0, rejected=0)
        self.pose: tuple[float, float, float] | None = None
        self._goals_seen = HandledUids()                  # uid -> the trip's content (every attempt has it)
        self._cancels_seen = HandledUids()
        self._events_seen = HandledUids()
        self._cancelled = SeenSet()
        self._commands_seen = SeenSet()                   # CommandData.key of the commands handled
        self._early_continues: dict[str, CommandData] = {}  # goal uid -> a tour Continue that came before its step
        self._phase: dict[str, tuple[int, float]] = {}    # own navigation's progress per held goal
        self._releases: OrderedDict[str, float] = OrderedDict()
        self._now_ros = 0.0                                # ROS time of the event being handled (ranking)
        self.service: dict[str, StaffCommandData] = {}     # robot -> the staff command in force for it
        self._handed = SeenSet()                           # trips whose leg this robot handed back (out of service)
        self.assigner = Assigner(self.me, cfg.assign, self._rank, self._alone)   # the trips this robot originated
        self.legs = LegBook(self.me)                       # the assignments naming this robot
        self.fleet: dict[str, RobotView] = {}              # the other robots' queues and poses
        self._started = now_wall
        self._catalog_known = False                        # the tour store's catalog arrived (even empty)
        self._awaiting_catalog: list[CommandData | Trip] = []   # tour commands / tours going on, until it does

    # ------------------------------------------------------------------ inputs
    def on_status(self, robot: str, now_wall: float, pose: tuple[float, float] | None = None, *,
                  sender: str) -> None:
        """A RobotStatus of ``robot`` published by ``sender`` was received (wall time), with its position (m, its
        floor's map)."""
        if self.gate.admit(sender, Claim(as_text(robot)), "status") is None:
            return
        found = self.building.find_robot(robot)
        if found is None:
            return
        self.liveness.heard(robot, now_wall)
        if robot != self.me and pose is not None and all(isinstance(v, (int, float)) and math.isfinite(v)
                                                         for v in pose):
            view = self.fleet.get(robot) or RobotView(found)
            self.fleet[robot] = replace(view, pose=(float(pose[0]), float(pose[1])))

    def on_pending(self, robot: str, goals: Iterable[Trip], wait_new: float, now_wall: float, *,
                   sender: str) -> None:
        """Another robot's /gidabot/pending published by ``sender``: its queue (each goal checked; bad ones left
        out) and its wait."""
        if self.gate.admit(sender, Claim(as_text(robot)), "pending list") is None:
            return
        found = self.building.find_robot(robot)
        if found is None or robot == self.me:
            return
        if isinstance(wait_new, bool) or not isinstance(wait_new, (int, float)) or not math.isfinite(wait_new):
            self.stats.inc("rejected_pending")       # a spoofed or broken list: the last good one is kept
            self.warn.warning("pending", f"pending list of {robot} with wait_new {wait_new!r} ignored")
            return
        queue = []
        for trip in list(goals)[:self.cfg.max_queue * 2]:
            try:
                queue.append(validate_trip(self.building, trip))
            except GoalRejected:
                self.stats.inc("rejected_pending")
        view = self.fleet.get(robot) or RobotView(found)
        self.fleet[robot] = replace(view, queue=tuple(queue), wait_new=max(0.0, float(wait_new)), heard=now_wall)

    def on_pose(self, x: float, y: float, yaw: float) -> None:
        """This robot's localisation (amcl_pose), map frame of its floor."""
        if all(isinstance(v, (int, float)) and math.isfinite(v) for v in (x, y, yaw)):
            self.pose = (float(x), float(y), float(yaw))

    def on_catalog(self, entries: Iterable[TourMessage], now_ros: float = 0.0, now_wall: float = 0.0, *,
                   sender: str) -> list[Action]:
        """The tour store's catalog changed (published by ``sender``: only this robot's tour store's is taken); the
        tour commands that waited for the first one are carried out."""
        if not self.gate.only(sender, Node.TOUR_STORE, "tour catalog"):
            return []
        for problem in self.tours.update(entries):
            self.warn.warning("catalog", problem)
        self._catalog_known = True
        return self._after_catalog(now_ros, now_wall)

    def _wait_for_catalog(self, item: CommandData | Trip, now_wall: float) -> bool:
        """Whether ``item`` (a tour command, or a tour that goes on after a floor without robot) needing a tour
        not (yet) known waits for the first catalog: only until ``catalog_wait`` after the start."""
        if self._catalog_known or now_wall - self._started >= self.cfg.catalog_wait:
            return False
        if item not in self._awaiting_catalog:          # a replay of the same command waits once
            self._awaiting_catalog.append(item)
            self.stats.inc("waited_for_catalog")
        return True

    def _after_catalog(self, now_ros: float, now_wall: float) -> list[Action]:
        """What waited for the catalog, in order (refused, as unknown tours, once the wait is over)."""
        items, self._awaiting_catalog = self._awaiting_catalog, []
        actions: list[Action] = []
        for item in items:
            if isinstance(item, Trip):
                actions += self._tour_goes_on(item, now_ros, now_wall)
                continue
            done = self._command(item, now_ros, now_wall)
            if item.key and not (done and all(isinstance(a, SendEvent) and a.event.phase == Phase.REJECTED
                                              for a in done)):
                self._commands_seen.add(item.key)
            actions += done
        return actions

    def on_command(self, cmd: CommandData, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """A VisitorCommand from this robot's GUI (or the simulated visitor), published by ``sender``; one
        replayed (same uid and stamp) is ignored, one from any other node refused (never answered)."""
        if self.gate.admit(sender, Claim(self.me), "visitor command") is None:
            return []
        key = cmd.key
        if key and key in self._commands_seen:
            self.stats.inc("duplicate_commands")
            return []
        try:
            cmd = validate_command(cmd)
        except GoalRejected as err:           # refused before anything is remembered: it changes no state
            self._count_rejection(err)
            self.gate.refuse(INVALID, f"visitor command from {sender[:80]!r}: {err}")
            return [self._event(Phase.REJECTED, None, now_ros, detail=f"command refused: {err}")]
        waiting = len(self._awaiting_catalog)
        actions = self._command(cmd, now_ros, now_wall)
        if len(self._awaiting_catalog) > waiting:
            return actions                    # waits for the catalog: remembered once carried out
        if key and not (actions and all(isinstance(a, SendEvent) and a.event.phase == Phase.REJECTED for a in actions)):
            self._commands_seen.add(key)      # a refused command is not remembered: it changes no state
        return actions

    def _command(self, cmd: CommandData, now_ros: float, now_wall: float) -> list[Action]:
        if cmd.command in (Cmd.REQUEST, Cmd.START_TOUR) and not self.in_service(self.me):
            self.stats.inc("refused_out_of_service")
            return [self._event(Phase.REJECTED, None, now_ros, location_id=cmd.goal_id[:64],
                                tour_file=cmd.tour_file, detail=f"{self.me} is {self._out_text(self.me)}")]
        if cmd.command == Cmd.REQUEST:
            if not cmd.goal_id:
                return [self._event(Phase.REJECTED, None, now_ros, detail="request without a goal_id")]
            return self._issue(cmd.goal_id, cmd.way, cmd.language, cmd.visitor_id, "", -1, now_ros, now_wall)
        if cmd.command == Cmd.CONTINUE:
            return self._continue(cmd, now_ros, now_wall)
        if cmd.command == Cmd.CANCEL:
            return self._cancel_command(cmd, now_ros)
        if cmd.command == Cmd.START_TOUR:
            return self._start_tour(cmd, now_ros, now_wall)
        return self._skip(cmd, now_ros, now_wall)

    def on_goal(self, trip: Trip, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """A goal from /gidabot/goals published by ``sender`` (this robot's own included): the newest assignment
        of a trip decides whether this robot holds it; a leg newly proposed here is answered. Only the trip's
        origin robot speaks for it (its own goal manager here, its relay end elsewhere)."""
        who = self.gate.admit(sender, Claim(as_text(trip.origin_robot), as_text(trip.uid)), "goal")
        if who is None:
            return []
        uid = trip.uid
        if uid not in self._goals_seen:      # a trip's goal comes again per attempt: counted once
            self.stats.inc("received")
        try:
            trip = validate_trip(self.building, trip)
        except GoalRejected as err:           # refused before anything is remembered: it changes no state
            self._count_rejection(err)
            self.gate.refuse(INVALID, f"goal {uid[:80]!r} of {who.robot}: {err}")
            if who.own:                       # a goal of this robot's own: its visitor is told
                return [self._event(Phase.REJECTED, None, now_ros, goal_uid=uid, detail=f"goal rejected: {err}")]
            return []                         # another robot's trip: never answered here
        digest = trip_digest(trip)
        if self.gate.conflict(self._goals_seen, trip.uid, digest, "goal"):
            return []
        self._goals_seen.add(trip.uid, digest)
        return self._on_snapshot(trip, now_ros, now_wall)

    def _on_snapshot(self, trip: Trip, now_ros: float, now_wall: float) -> list[Action]:
        """The holder's side of the assignment protocol for a valid goal (docs/guiding.md)."""
        if trip.uid in self._cancelled:
            self.stats.inc("cancelled_before_arrival")
            return []
        if not self.legs.newer(trip):
            self.stats.inc("duplicates")       # the same attempt again, or an older one overtaken
            return []
        held = self._held(trip.uid)
        leg = trip.leg_of(self.me)
        if leg is None:
            if held is not None:               # the newest assignment names other robots
                self.stats.inc("superseded")
                self.log.info(f"{trip.uid}: attempt {trip.attempt} names {trip.leg_robot(held.leg_of(self.me) or '')}"
                              f" for the leg proposed here; dropped")
                self._pop(trip.uid)
                self._phase.pop(trip.uid, None)
                self.legs.settled(trip.uid)
            return []
        state = trip.leg_state(leg)
        if held is not None:
            self.queue[self.queue.index(held)] = trip
            self.version += 1
            if state == LEG_COMMITTED:
                self.legs.settled(trip.uid)
                if not self.in_service(self.me) and not self._started_here(held):      # (as its navigation knew it)
                    return self._hand_back(trip, now_ros, now_wall)
            return []
        if state == LEG_PROPOSED:
            if not self.legs.first_answer(trip.uid, leg, trip.attempt):
                return []                      # this proposal was answered already (e.g. before a restart)
            eta = self._eta_for(trip, leg, now_ros, now_wall)
            # a long queue is no reason to decline (the visitor saw the wait and confirmed), unless the site set
            # a max_wait; a full queue is
            if len(self.queue) >= self.cfg.max_queue or self.cfg.assign.too_long(eta) or not self.in_service(self.me):
                why = (f"{self.me} is {self._out_text(self.me)}" if not self.in_service(self.me) else
                       f"the queue of {self.me} is full ({self.cfg.max_queue} goals)" if len(self.queue)
                       >= self.cfg.max_queue else f"{self.me} could be there in {eta:.0f} s only "
                       f"(more than max_wait {self.cfg.assign.max_wait:g} s)")
                self.stats.inc("declined")
                return [self._event(Phase.DECLINED, trip, now_ros, leg=leg, detail=why)]
            self.legs.first_answer(trip.uid, leg)      # accepted (an ACCEPTED per leg for a commit seen later)
            self._handed.discard(trip.uid)             # a new proposal accepted after a hand-back
            self.legs.holding(trip.uid, now_wall)
            return self._keep(trip, leg, eta, now_ros)
        if len(self.queue) >= self.cfg.max_queue:
            self.stats.inc("queue_full")
            self.warn.warning("queue_full", f"queue of {self.me} is full ({self.cfg.max_queue} goals); "
                                            f"goal {trip.uid} is cancelled")
            cancel = self._new_cancel(trip.uid, REASON_ADMIN, f"the queue of {self.me} is full", now_ros)
            self._cancels_seen.add(cancel.uid, cancel_digest(cancel))
            self._cancelled.add(trip.uid)
            self.assigner.close(trip.uid)
            phase = Phase.REJECTED if trip.origin_robot == self.me else Phase.CANCELLED_HERE
            return [SendCancel(cancel), self._event(phase, trip, now_ros, detail=f"the queue of {self.me} is full")]
        # committed here without an answer seen here (its proposal expired, or never reached this robot); a commit
        # that crossed this robot's hand-back of the proposal is handed back again
        if not self.in_service(self.me) or trip.uid in self._handed:
            return self._hand_back(trip, now_ros, now_wall)
        actions = self._keep(trip, leg, self._eta_for(trip, leg, now_ros, now_wall), now_ros)
        return actions if self.legs.first_answer(trip.uid, leg) else []

    def _keep(self, trip: Trip, leg: str, eta: float, now_ros: float) -> list[Action]:
        self.queue.append(trip)
        self.version += 1
        self.stats.inc("accepted")
        return [self._event(Phase.ACCEPTED, trip, now_ros, leg=leg, eta=eta)]

    def _eta_for(self, trip: Trip, leg: str, now_ros: float, now_wall: float) -> float:
        """s until this robot could be where ``leg`` meets the visitor, after its queue."""
        point = leg_point(self.planner, trip, leg)
        if point is None:
            return 0.0
        return rendezvous_eta(self.planner, self.cfg.wait, self._view(now_ros, now_wall), point, now_wall)

    def _view(self, now_ros: float, now_wall: float) -> RobotView:
        snap = self.pending(now_ros)
        pose = (self.pose[0], self.pose[1]) if self.pose else None
        return RobotView(self.robot, snap.goals, snap.wait_new, pose, now_wall)

    def _rank(self, trip: Trip, leg: str, exclude: Iterable[str], now_wall: float) -> list[Candidate]:
        views = dict(self.fleet)
        views[self.me] = self._view(self._now_ros, now_wall)
        return rank_candidates(self.planner, self.cfg.wait, trip, leg, views,
                               lambda r: (r == self.me or self.liveness.online(r, now_wall)) and self.in_service(r),
                               now_wall,
                               prefer=trip.origin_robot if leg == LEG_START else "",
                               prefer_gain=self.cfg.assign.helper_gain, exclude=exclude)

    def _assign(self, outputs: list[Output], now_ros: float, now_wall: float) -> list[Action]:
        """Carry out the assigner's outputs: snapshots are applied here at once (this robot's own answers go
        straight back to the assigner) and broadcast, the last of each trip only."""
        self._now_ros = now_ros
        todo = list(outputs)
        latest: dict[str, Trip] = {}
        fresh: set[str] = set()                 # trips made in this step: nobody else knows them yet
        actions: list[Action] = []
        while todo:
            out = todo.pop(0)
            if isinstance(out, Publish):
                latest[out.trip.uid] = out.trip
                if out.trip.attempt == 1:
                    fresh.add(out.trip.uid)
                for act in self._on_snapshot(out.trip, now_ros, now_wall):
                    actions.append(act)
                    ev = act.event if isinstance(act, SendEvent) else None
                    if ev is not None and ev.phase in (Phase.ACCEPTED, Phase.DECLINED):
                        todo += self.assigner.on_answer(ev.goal_uid, ev.leg, self.me, ev.attempt,
                                                        ev.phase == Phase.ACCEPTED, ev.eta, ev.detail, now_wall)
            elif isinstance(out, Assigned):
                actions.append(self._event(Phase.ASSIGNED, out.trip, now_ros, leg=out.leg, assignee=out.robot,
                                           eta=out.eta))
            elif isinstance(out, GaveUp):
                unknown = out.trip.attempt == 0 or out.trip.uid in fresh
                if unknown:
                    latest.pop(out.trip.uid, None)
                actions += self._give_up(out, now_ros, now_wall, unknown)
        return [SendGoal(t) for t in latest.values()] + actions

    def _give_up(self, out: GaveUp, now_ros: float, now_wall: float, unknown: bool) -> list[Action]:
        """No robot can serve a leg. A request nobody else knows yet is answered at once and nothing is queued:
        PARTNER_OFFLINE (the goal floor's robots are offline or busy), REJECTED (this floor's robots cannot take
        it: queues full). A trip under way is cancelled everywhere (reason offline) and the visitor here told."""
        self.stats.inc("partner_offline" if out.leg != LEG_START else "start_leg_refused")
        trip = out.trip
        floor_robots = self.building.robots_on(trip.goal_floor if out.leg != LEG_START else trip.initial_floor)
        detail = f"{out.detail} ({'; '.join(self._heard(r.name, now_wall) for r in floor_robots)})"
        if unknown:
            self._pop(trip.uid)
            self._cancelled.add(trip.uid)
            phase = Phase.REJECTED if out.leg == LEG_START else Phase.PARTNER_OFFLINE
            return [self._event(phase, None, now_ros, language=trip.language, way=trip.way,
                                location_id=trip.goal_id, target_floor=trip.goal_floor, tour_file=trip.tour_file,
                                tour_step=trip.tour_step, detail=f"{detail}; the request was not queued")]
        cancel = self._new_cancel(trip.uid, REASON_OFFLINE, detail, now_ros)
        return [SendCancel(cancel), *self._apply_cancel(cancel, now_ros, here=True, quiet=True),
                self._event(Phase.PARTNER_OFFLINE, trip, now_ros, leg=out.leg, detail=detail)]

    def _heard(self, robot: str, now_wall: float) -> str:
        if robot == self.me or self.liveness.online(robot, now_wall):
            return f"{robot} online"
        last = self.liveness.last_heard(robot)
        return f"{robot}: no status for {now_wall - last:.0f} s" if last is not None else f"{robot}: never heard"

    def on_cancel(self, cancel: CancelData, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """A Cancel from /gidabot/cancels published by ``sender``: drop the goal, queued or running, and tell the
        visitor why. It speaks for the robot that issued it (``origin_robot``)."""
        if self.gate.admit(sender, Claim(as_text(cancel.origin_robot), as_text(cancel.uid)), "cancel") is None:
            return []
        try:
            cancel = validate_cancel(self.building, cancel)
        except GoalRejected as err:
            self._count_rejection(err)
            self.gate.refuse(INVALID, f"cancel {as_text(cancel.uid)[:80]!r}: {err}")
            return []
        if self.gate.conflict(self._cancels_seen, cancel.uid, cancel_digest(cancel), "cancel"):
            return []
        return self._apply_cancel(cancel, now_ros, here=False)

    def on_nav_event(self, ev: NavEventData, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """A NavEvent of any robot (this robot's navigation included) published by ``sender``; it speaks for the
        robot that emits it (``robot``): an answer to a proposal counts only from the robot proposed."""
        if self.gate.admit(sender, Claim(as_text(ev.robot), as_text(ev.uid)), "nav event") is None:
            return []
        try:
            ev = validate_event(self.building, ev)
        except GoalRejected as err:
            self._count_rejection(err)
            self.gate.refuse(INVALID, f"nav event {as_text(ev.uid)[:80]!r}: {err}")
            return []
        digest = nav_event_digest(ev)
        if self.gate.conflict(self._events_seen, ev.uid, digest, "nav event"):
            return []
        answer = bool(ev.leg) and ev.goal_uid in self.assigner    # about a leg this robot is assigning
        if not ev.goal_uid or not (ev.phase in RELEASE_PHASES or (ev.robot == self.me and ev.phase != Phase.REJECTED)
                                   or answer):
            return []        # nothing here depends on it: not even remembered, so it changes no state
        if not self._events_seen.add(ev.uid, digest):
            return []
        if ev.phase in RELEASE_PHASES:
            self._releases[ev.goal_uid] = now_ros
            while len(self._releases) > 1000:
                self._releases.popitem(last=False)
        actions: list[Action] = []
        if answer:
            if ev.phase in (Phase.ACCEPTED, Phase.DECLINED):
                actions = self._assign(self.assigner.on_answer(ev.goal_uid, ev.leg, ev.robot, ev.attempt,
                                                               ev.phase == Phase.ACCEPTED, ev.eta, ev.detail, now_wall),
                                       now_ros, now_wall)
            elif ev.final:
                self.assigner.on_done(ev.goal_uid, ev.leg, ev.robot)
        if ev.robot != self.me:
            return actions
        trip = self._held(ev.goal_uid)
        if ev.phase == Phase.TOUR_STEP_DONE and ev.tour_file:
            self.waits.add(TourWait(ev.goal_uid, ev.tour_file, ev.tour_step,
                                    way=(trip.way if trip else ev.way) or self.cfg.default_way,
                                    language=trip.language if trip else ev.language,
                                    visitor_id=trip.visitor_id if trip else "", since=now_ros))
        early = self._early_continues.pop(ev.goal_uid, None) if ev.final else None
        if ev.final:
            self._phase.pop(ev.goal_uid, None)
            if self._pop(ev.goal_uid) is not None:
                self.stats.inc("finished")
        elif ev.phase in PROGRESS_PHASES and trip is not None:
            self._phase[ev.goal_uid] = (ev.phase, now_ros)
        if ev.phase == Phase.NO_ROBOT_ON_FLOOR and trip is not None and trip.tour_file:
            actions += self._tour_goes_on(trip, now_ros, now_wall)
        # both stamps are this robot's (its visitor's button, its navigation's event): robots' clocks may disagree
        if early is not None and ev.phase in (Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED) and ev.robot == self.me \
                and early.stamp >= ev.stamp > 0:
            self.stats.inc("early_continues")
            return actions + self._continue(early, now_ros, now_wall)
        return actions

    def tick(self, now_ros: float, now_wall: float) -> list[Action]:
        """Proposals made here that nobody answered in time (or to a robot now offline) move on to the next
        robot; proposals held here that were never confirmed are forgotten after ``proposal_ttl``."""
        self._now_ros = now_ros
        actions: list[Action] = []
        if self._awaiting_catalog and now_wall - self._started >= self.cfg.catalog_wait:
            self.log.warning(f"goal_manager of {self.me}: no tour catalog {self.cfg.catalog_wait:g} s after the "
                             f"start; {len(self._awaiting_catalog)} tour command(s) that waited for it go on without")
            actions += self._after_catalog(now_ros, now_wall)
        if len(self.assigner):
            outputs = self.assigner.tick(now_wall, lambda r: r == self.me or self.liveness.online(r, now_wall))
            actions = self._assign(outputs, now_ros, now_wall)
        for uid in self.legs.expired(now_wall, self.cfg.assign.proposal_ttl):
            trip = self._held(uid)
            leg = trip.leg_of(self.me) if trip is not None else None
            if trip is not None and leg is not None and trip.leg_state(leg) == LEG_PROPOSED:
                self.stats.inc("proposals_expired")
                self.log.info(f"{uid}: the {leg} leg proposed to {self.me} was never confirmed; forgotten")
                self._pop(uid)
        return actions

    # ------------------------------------------------------------------ out of service
    def on_staff(self, cmd: StaffCommandData, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """A staff command from a robot's dashboard (/gidabot/staff): for each robot, the one with the largest
        (version, robot) is in force. A robot out of service is proposed no leg, declines the legs proposed to it,
        and a visitor at its screen is refused (REJECTED, saying so); a floor whose robots are all out of service
        is a floor without robot (the goal leg goes to nobody: the visitor finds the place alone). This robot,
        taken out of service, finishes the trip it is running and hands back every other leg it holds
        (:meth:`_hand_back`); back in service, it is proposed legs again. Only the dashboard of ``cmd.robot`` may
        send it (``sender``: this robot's dashboard node, or the relay end of the link from that robot)."""
        claim = Claim(as_text(cmd.robot), as_text(cmd.uid))
        if self.gate.admit(sender, claim, "staff command", Topic.STAFF) is None:
            return []
        try:
            cmd = validate_staff(self.building, cmd)
        except GoalRejected as err:
            self._count_rejection(err)
            self.gate.refuse(INVALID, f"staff command {as_text(cmd.uid)[:80]!r}: {err}")
            return []
        known = self.service.get(cmd.target_robot)
        if known is not None and cmd.key <= known.key:
            return []                          # a replay, or older than the one in force
        was_in = self.in_service(cmd.target_robot)
        self.service[cmd.target_robot] = cmd
        self.version += 1
        self.log.info(f"staff {cmd.user} at {cmd.robot}'s dashboard: {cmd.target_robot} "
                      f"{'out of service' if cmd.command == StaffCmd.OUT_OF_SERVICE else 'back in service'}"
                      + (f" ({cmd.detail})" if cmd.detail else ""))
        if cmd.target_robot != self.me or not was_in or self.in_service(self.me):
            return []
        actions: list[Action] = []
        for trip in list(self.queue):
            if not self._started_here(trip):
                actions += self._hand_back(trip, now_ros, now_wall)
        return actions

    def in_service(self, robot: str) -> bool:
        cmd = self.service.get(robot)
        return cmd is None or cmd.command != StaffCmd.OUT_OF_SERVICE

    def _out_text(self, robot: str) -> str:
        cmd = self.service.get(robot)
        if cmd is None:
            return "in service"
        return f"out of service (staff {cmd.user} at {cmd.robot}" + (f": {cmd.detail})" if cmd.detail else ")")

    def _alone(self, trip: Trip, leg: str) -> bool:
        """True when the leg's floor has robots but none in service: nobody serves the leg."""
        floor = trip.goal_floor if leg == LEG_GOAL else trip.initial_floor
        robots = self.building.robots_on(floor)
        return bool(robots) and not any(self.in_service(r.name) for r in robots)

    def _started_here(self, trip: Trip) -> bool:
        """Whether this robot may have started ``trip``: its navigation reported progress, or it heads the queue
        committed here (the navigation runs the queue in order and may have started it before saying so)."""
        leg = trip.leg_of(self.me)
        return trip.uid in self._phase or (bool(self.queue) and self.queue[0].uid == trip.uid and leg is not None
                                           and trip.leg_state(leg) == LEG_COMMITTED)

    def _hand_back(self, trip: Trip, now_ros: float, now_wall: float) -> list[Action]:
        """This robot, out of service, hands back its leg of ``trip`` (not started): it drops the trip and says so
        with a DECLINED for that leg; the requester asks the other robots of the floor (docs/guiding.md)."""
        leg = trip.leg_of(self.me)
        if leg is None:
            return []
        self._pop(trip.uid)
        self._phase.pop(trip.uid, None)
        self.legs.settled(trip.uid)
        self._handed.add(trip.uid)
        self.stats.inc("handed_back")
        why = f"{self.me} is {self._out_text(self.me)}: it hands the {leg} leg back"
        self.log.info(f"{trip.uid}: {why}")
        event = self._event(Phase.DECLINED, trip, now_ros, leg=leg, detail=why)
        if trip.uid not in self.assigner:
            return [event]
        outputs = self.assigner.on_answer(trip.uid, leg, self.me, trip.attempt, False, 0.0, why, now_wall)
        return [event, *self._assign(outputs, now_ros, now_wall)]

    # ------------------------------------------------------------------ restarts
    @staticmethod
    def durable(actions: list[Action]) -> list[Action]:
        """The actions a restarted node must still publish (kept with the state until published): all but the
        REJECTED answers, which change no state."""
        return [a for a in actions if not (isinstance(a, SendEvent) and a.event.phase == Phase.REJECTED)]

    def state(self, remember: int = REMEMBERED_UIDS) -> dict[str, Any]:
        """What a restarted goal manager needs (JSON-able): the queue, the ``remember`` most recent
        handled uids of each kind, the own navigation's progress, releases and the tour steps waiting."""
        return {
            "queue": [trip_to_dict(t) for t in self.queue],
            "goals_seen": self._goals_seen.recent(remember), "cancels_seen": self._cancels_seen.recent(remember),
            "events_seen": self._events_seen.recent(remember), "cancelled": self._cancelled.recent(remember),
            "commands_seen": self._commands_seen.recent(remember),
            "phase": {uid: [phase, since] for uid, (phase, since) in self._phase.items()},
            "releases": [[uid, t] for uid, t in self._releases.items()][-remember:],
            "waits": [asdict(w) for w in self.waits.all()],
            "early_continues": [asdict(c) for c in self._early_continues.values()],
            "assignments": self.assigner.state(), "legs": self.legs.state(remember),
            "service": [asdict(c) for c in self.service.values()], "handed": self._handed.recent(remember),
            "stats": dict(self.stats),
        }

    def load_state(self, state: dict[str, Any]) -> None:
        """Resume from :meth:`state` of a previous run (raises GuidingStateError, changing nothing, if damaged)."""
        try:
            self._load_state(state)
        except (TypeError, ValueError, KeyError, IndexError, AttributeError) as err:
            raise GuidingStateError(f"goal manager state: {err!r}") from err

    def _load_state(self, state: dict[str, Any]) -> None:
        queue = [trip_from_dict(t) for t in state.get("queue", [])]
        seen: dict[str, list] = {name: uid_records(state.get(name, []), name) for name in
                                 ("goals_seen", "cancels_seen", "events_seen")}
        seen.update({name: str_list(state.get(name, []), name) for name in ("cancelled", "commands_seen", "handed")})
        phase_raw = state.get("phase", {})
        if not isinstance(phase_raw, dict):
            raise GuidingStateError("phase: expected an object")
        phase = {str(uid): (int(number(v[0], "phase")), number(v[1], "phase since")) for uid, v in phase_raw.items()}
        releases = [(str(r[0]), number(r[1], "release")) for r in state.get("releases", [])]
        waits = [dataclass_from_dict(TourWait, w) for w in state.get("waits", [])]
        early = [dataclass_from_dict(CommandData, c) for c in state.get("early_continues", [])]
        assigner = Assigner(self.me, self.cfg.assign, self._rank, self._alone)
        assigner.load_state(state.get("assignments", []))
        service = [validate_staff(self.building, dataclass_from_dict(StaffCommandData, c))
                   for c in state.get("service", [])]
        legs = LegBook(self.me)
        legs.load_state(state.get("legs", {}))
        self.assigner, self.legs = assigner, legs
        self.service = {c.target_robot: c for c in service}
        self.queue = queue
        for name, uids in seen.items():
            getattr(self, f"_{name}").update(uids)
        self._phase = {uid: p for uid, p in phase.items() if any(t.uid == uid for t in queue)}
        for uid, t in releases:
            self._releases[uid] = t
        for w in waits:
            self.waits.add(w)
        self._early_continues = {c.goal_uid: c for c in early if any(t.uid == c.goal_uid for t in queue)}
        stats = state.get("stats", {})
        if isinstance(stats, dict):
            self.stats.update({str(k): v for k, v in stats.items() if isinstance(v, int)})
        self.version += 1

    # ------------------------------------------------------------------ outputs
    def pending(self, now_ros: float) -> PendingData:
        """The pending list with the wait estimate (s) for /gidabot/pending."""
        head = None
        if self.queue and self.queue[0].uid in self._phase:
            phase, since = self._phase[self.queue[0].uid]
            head = HeadProgress(self.queue[0].uid, phase, since)
        pos = (self.pose[0], self.pose[1]) if self.pose else None
        eta = estimate_queue(self.planner, self.cfg.wait, self.robot, pos, self.queue, head, self._releases,
                             now_ros).eta
        return PendingData(self.me, self.robot.floor, len(self.queue), eta[-1] if eta else 0.0, tuple(self.queue),
                           tuple(eta), now_ros)

    # ------------------------------------------------------------------ requests
    def _issue(self, goal_id: str, way: str, language: str, visitor_id: str, tour_file: str, tour_step: int,
               now_ros: float, now_wall: float, start: Location | None = None) -> list[Action]:
        """Make a goal to ``goal_id`` from this robot's floor and pose (or from ``start``, a place on a floor
        without robot where a tour goes on) and start assigning its legs."""
        language = language if language in LANGUAGES else self.cfg.default_language
        way = way if way in WAYS else self.cfg.default_way
        visitor_id = visitor_id or "visitor"
        ctx = {"language": language, "way": way, "location_id": goal_id[:64], "tour_file": tour_file,
               "tour_step": tour_step}
        loc = self.building.find_location(goal_id)
        if loc is None:
            self.stats.inc("rejected_location")
            return [self._event(Phase.REJECTED, None, now_ros, detail=f"unknown goal {goal_id[:64]!r}", **ctx)]
        ctx["target_floor"] = loc.floor
        if start is None:
            a = self.robot.floor
            x, y, _ = self.pose if self.pose else (self.robot.home.x, self.robot.home.y, self.robot.home.yaw)
        else:
            a, x, y = start.floor, start.pose.x, start.pose.y
        b = loc.floor
        goal_xy = (loc.pose.x, loc.pose.y)
        connector = ""
        if not same_floor(a, b):
            try:
                choice = self.planner.choose_connector(a, (x, y), b, goal_xy, way)
            except NoRouteError as err:
                self.stats.inc("unreachable")
                return [self._event(Phase.UNREACHABLE, None, now_ros, detail=str(err), **ctx)]
            way, connector = choice.way, choice.connector.id
        elif not math.isfinite(self.planner.leg_length(a, (x, y), goal_xy)):
            self.stats.inc("unreachable")
            return [self._event(Phase.UNREACHABLE, None, now_ros, **ctx,
                                detail=f"no path from ({x:.1f}, {y:.1f}) to {goal_id} on floor {format_floor(a)}")]
        trip = Trip(uid=self.uids.goal(visitor_id), origin_robot=self.me, visitor_id=visitor_id, initial_floor=a,
                    initial_x=x, initial_y=y, goal_floor=b, goal_x=loc.pose.x, goal_y=loc.pose.y,
                    goal_yaw=loc.pose.yaw, way=way, connector=connector,
                    start_id=START_ROBOT if start is None else start.id, goal_id=goal_id, language=language,
                    tour_file=tour_file, tour_step=tour_step, stamp=now_ros)
        self._now_ros = now_ros
        legs = [leg for leg in needed_legs(self.building, trip) if not (leg == LEG_GOAL and self._alone(trip, leg))]
        return self._assign(self.assigner.open(trip, legs, now_wall), now_ros, now_wall)

    def _tour_goes_on(self, trip: Trip, now_ros: float, now_wall: float) -> list[Action]:
        """This robot sent the visitor of a tour to a floor without robot (NO_ROBOT_ON_FLOOR): the tour goes on
        at its next stop on a floor with a robot, from the last stop the visitor finds alone."""
        tour = self.tours.get(trip.tour_file)
        if tour is None and self._wait_for_catalog(trip, now_wall):
            return []
        nxt = next_robot_stop(tour, self.building, trip.tour_step) if tour is not None else None
        if tour is None or nxt is None:
            return []
        start = self.building.find_location(tour.goals[nxt - 1].room)
        if start is None:
            return []
        self.stats.inc("tour_continuations")
        return self._issue(tour.goals[nxt].room, trip.way, trip.language, trip.visitor_id, trip.tour_file, nxt,
                           now_ros, now_wall, start=start)

    def _continue(self, cmd: CommandData, now_ros: float, now_wall: float) -> list[Action]:
        if cmd.goal_uid:
            wait = self.waits.get(cmd.goal_uid)
        else:
            wait = None if self._navigation_meets_visitor() else self.waits.latest()
        if wait is None:
            trip = self._held(cmd.goal_uid) if cmd.goal_uid else None
            if trip is not None and trip.tour_file:
                # A Continue at this trip's meeting point (multirobot_navigation's), or the visitor's Continue
                # after this tour step that overtook the step's TOUR_STEP_DONE (both replayed to this node
                # after a restart, by different publishers): kept; if the step turns out to be done before
                # the button was pressed (stamps), it is acted on then.
                self._early_continues[trip.uid] = cmd
                while len(self._early_continues) > 32:
                    self._early_continues.pop(next(iter(self._early_continues)))
            return []          # a Continue at a meeting point: multirobot_navigation's
        return self._tour_step(wait.tour_file, wait.step + 1, cmd, wait, now_ros, now_wall, finishing=True)

    def _start_tour(self, cmd: CommandData, now_ros: float, now_wall: float) -> list[Action]:
        if not cmd.tour_file:
            return [self._event(Phase.REJECTED, None, now_ros, detail="start tour without a tour_file")]
        return self._tour_step(cmd.tour_file, 0, cmd, None, now_ros, now_wall)

    def _skip(self, cmd: CommandData, now_ros: float, now_wall: float) -> list[Action]:
        latest = self.waits.latest()
        tour_file = cmd.tour_file or (latest.tour_file if latest else "")
        if not tour_file:
            return [self._event(Phase.REJECTED, None, now_ros, detail="skip without a tour_file")]
        wait = next((w for w in (self.waits.get(cmd.goal_uid), latest) if w and w.tour_file == tour_file
                     and (not cmd.visitor_id or not w.visitor_id or w.visitor_id == cmd.visitor_id)), None)
        return self._tour_step(tour_file, cmd.tour_step, cmd, wait, now_ros, now_wall)

    def _tour_step(self, tour_file: str, step: int, cmd: CommandData, wait: TourWait | None, now_ros: float,
                   now_wall: float, finishing: bool = False) -> list[Action]:
        """Issue step ``step`` of ``tour_file`` from here, ending what this visitor had of that tour here.

        ``finishing``: a Continue after the last step ends the tour (TOUR_FINISHED) instead of a rejection.
        """
        ctx = {"tour_file": tour_file, "tour_step": step if 0 <= step < MAX_GOALS else -1,
               "language": cmd.language or (wait.language if wait else "")}
        tour = self.tours.get(tour_file)
        if tour is None and self._wait_for_catalog(cmd, now_wall):
            return []
        if tour is None:
            self.stats.inc("rejected_tour")
            return [self._event(Phase.REJECTED, None, now_ros, detail=f"tour {tour_file!r} is not in this robot's "
                                                                f"catalog ({len(self.tours)} tours)", **ctx)]
        if finishing and wait is not None and step >= len(tour.goals):
            self.waits.pop(wait.goal_uid)
            return [self._event(Phase.TOUR_FINISHED, None, now_ros, goal_uid=wait.goal_uid, detail="no further goal",
                                **ctx)]
        if not 0 <= step < len(tour.goals):
            return [self._event(Phase.REJECTED, None, now_ros,
                                detail=f"tour {tour_file} has steps 0..{len(tour.goals) - 1}, not {step}", **ctx)]
        visitor = cmd.visitor_id or (wait.visitor_id if wait else "")
        actions = self._end_tour_here(tour_file, visitor, now_ros, detail=f"the visitor went to step {step}")
        self.waits.clear_tour(tour_file, visitor or None)     # this visitor's: others may follow the same tour
        way = cmd.way or (wait.way if wait else "")
        language = cmd.language or (wait.language if wait else "")
        actions += self._issue(tour.goals[step].room, way, language, visitor, tour_file, step, now_ros, now_wall)
        return actions

    def _end_tour_here(self, tour_file: str, visitor: str, now_ros: float, detail: str) -> list[Action]:
        """Cancel (everywhere) the goals of ``tour_file`` this robot holds for this visitor (skip / restart)."""
        actions: list[Action] = []
        for trip in [t for t in self.queue if t.tour_file == tour_file and (not visitor or t.visitor_id == visitor)]:
            cancel = self._new_cancel(trip.uid, REASON_VISITOR, detail, now_ros)
            actions += [SendCancel(cancel), *self._apply_cancel(cancel, now_ros, here=True, quiet=True)]
        return actions

    # ------------------------------------------------------------------ cancels
    def _cancel_command(self, cmd: CommandData, now_ros: float) -> list[Action]:
        if cmd.goal_uid:
            trip = self._held(cmd.goal_uid)
            if trip is None:
                wait = self.waits.pop(cmd.goal_uid)
                if wait is not None:
                    return [self._tour_ended(wait, now_ros)]
                if cmd.goal_uid in self._goals_seen and cmd.goal_uid not in self._cancelled:
                    # a trip this robot does not hold (any more), e.g. one another robot of this floor comes
                    # to serve: the others may still hold it
                    cancel = self._new_cancel(cmd.goal_uid, REASON_VISITOR, f"the visitor cancelled at {self.me}",
                                              now_ros)
                    self._cancels_seen.add(cancel.uid, cancel_digest(cancel))
                    self._cancelled.add(cmd.goal_uid)
                    self.assigner.close(cmd.goal_uid)
                    return [SendCancel(cancel), self._event(Phase.CANCELLED_HERE, None, now_ros, goal_uid=cmd.goal_uid)]
                self.stats.inc("cancel_unknown")
                self.warn.warning("cancel_unknown", f"cancel of unknown trip {cmd.goal_uid!r} ignored")
                return []
        else:
            trip = self._current()
            if trip is None:
                wait = self.waits.latest()
                if wait is not None:
                    self.waits.pop(wait.goal_uid)
                    return [self._tour_ended(wait, now_ros)]
                self.stats.inc("cancel_unknown")
                return []
        if trip.tour_file:
            self.waits.clear_tour(trip.tour_file, trip.visitor_id or None)
        cancel = self._new_cancel(trip.uid, REASON_VISITOR, f"the visitor cancelled at {self.me}", now_ros)
        return [SendCancel(cancel), *self._apply_cancel(cancel, now_ros, here=True)]

    def _tour_ended(self, wait: TourWait, now_ros: float) -> SendEvent:
        self.waits.clear_tour(wait.tour_file, wait.visitor_id or None)
        return self._event(Phase.CANCELLED_HERE, None, now_ros, goal_uid=wait.goal_uid, tour_file=wait.tour_file,
                           tour_step=wait.step, language=wait.language, way=wait.way, detail="tour ended")

    def _apply_cancel(self, cancel: CancelData, now_ros: float, here: bool, quiet: bool = False) -> list[Action]:
        if not self._cancels_seen.add(cancel.uid, cancel_digest(cancel)):
            self.stats.inc("duplicate_cancels")
            return []
        self._cancelled.add(cancel.goal_uid)
        self.assigner.close(cancel.goal_uid)
        self.legs.settled(cancel.goal_uid)
        trip = self._pop(cancel.goal_uid)
        self._phase.pop(cancel.goal_uid, None)
        if trip is None:
            if cancel.goal_uid not in self._goals_seen:
                self.stats.inc("cancel_unknown")     # kept (its goal may still come), and counted
            return []
        self.stats.inc("cancelled")
        leg = trip.leg_of(self.me)
        if leg is None or trip.leg_state(leg) != LEG_COMMITTED:
            return []            # only proposed here: this robot never served it, nobody here to tell
        if cancel.origin_robot == self.me:
            if not here or quiet:
                return []        # our navigation gave the trip up and told the visitor already
            phase = Phase.CANCELLED_HERE
        else:
            phase = PHASE_OF_REASON[cancel.reason]
        detail = f"{cancel.origin_robot}: {cancel.reason}" + (f": {cancel.detail}" if cancel.detail else "")
        return [self._event(phase, trip, now_ros, detail=detail)]

    # ------------------------------------------------------------------ helpers
    def _held(self, goal_uid: str) -> Trip | None:
        return next((t for t in self.queue if t.uid == goal_uid), None)

    def _pop(self, goal_uid: str) -> Trip | None:
        for i, t in enumerate(self.queue):
            if t.uid == goal_uid:
                del self.queue[i]
                self.version += 1
                return t
        return None

    def _current(self) -> Trip | None:
        """The trip "Cancel" without a goal_uid means: the one in progress here, else the newest made here."""
        running = next((t for t in self.queue if t.uid in self._phase), None)
        if running is not None:
            return running
        return next((t for t in reversed(self.queue) if t.origin_robot == self.me), None)

    def _navigation_meets_visitor(self) -> bool:
        return any(p in (Phase.GOING_TO_MEETING, Phase.WAITING_VISITOR) for p, _ in self._phase.values())

    def _new_cancel(self, goal_uid: str, reason: str, detail: str, now_ros: float) -> CancelData:
        return CancelData(uid=self.uids.cancel(), goal_uid=goal_uid, origin_robot=self.me, reason=reason,
                          detail=detail, stamp=now_ros)

    def _count_rejection(self, err: GoalRejected) -> None:
        self.stats.inc("rejected")
        self.stats.inc(f"rejected_{err.reason}")

    def refusals(self) -> dict[str, int]:
        """Messages refused so far, by kind (impostor, foreign, wrong_namespace, conflict, invalid)."""
        return self.gate.refusals()

    def _event(self, phase: int, trip: Trip | None, now_ros: float, **fields: object) -> SendEvent:
        ev = NavEventData(uid=self.uids.event(), robot=self.me, floor=self.robot.floor,
                          goal_uid=trip.uid if trip else "", phase=phase,
                          language=trip.language if trip else self.cfg.default_language,
                          way=trip.way if trip else "", connector=trip.connector if trip else "",
                          target_floor=trip.goal_floor if trip else self.robot.floor,
                          location_id=trip.goal_id if trip else "", tour_file=trip.tour_file if trip else "",
                          tour_step=trip.tour_step if trip else -1, stamp=now_ros,
                          leg=(trip.leg_of(self.me) or "") if trip else "", attempt=trip.attempt if trip else 0)
        fields = {k: v for k, v in fields.items() if not (k == "language" and not v)}
        ev = replace(ev, **fields)
        if ev.goal_uid and phase != Phase.REJECTED:     # its echo is ignored (an answer to a refusal needs nothing)
            self._events_seen.add(ev.uid, own_event_digest(self.building, ev))
        return SendEvent(ev)
