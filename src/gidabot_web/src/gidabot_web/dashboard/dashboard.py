"""The staff dashboard's core (ROS-free): the building as this robot sees it, alerts, history rules, staff actions.

Fed by the node with the messages this robot's master carries (every robot's status, pose, queue, goals, events,
cancels, staff commands and link summaries, through the relays; this robot's relay ends' diagnostics, its tour
catalog, which of its nodes are registered) and driven by :meth:`DashboardCore.step`; it never reads a clock:
every input comes with ``now`` (a monotonic s, the node's ``time.monotonic()``) and :meth:`step` gives the wall
clock too (for the history's days and the page's times). Its outputs:

- **sections** for the page (:meth:`versions`, :meth:`section_json`): ``building`` (floors, blueprints,
  places, robots: static), ``robots`` (live: position on the blueprint, heading, state, battery, queue with
  waits, online / offline / master down with the time last heard, out of service), ``trips`` (trips in
  progress with their legs: which robot, which connector, waiting for the visitor since when; a staff cancel and
  who still has to drop the trip), ``tours`` (tours under way and their steps), ``links`` (this robot's links
  from its relay ends, the others' from their ``/gidabot/links``), ``alerts``, ``history`` (the day's sums),
  ``catalog`` (this robot's tours), ``server``;
- **messages to publish**: a ``Cancel`` (:meth:`cancel_trip`), a ``StaffCommand`` (:meth:`set_service`), this
  robot's ``LinkSummary`` (:meth:`link_summary`).

Rules (docs/dashboard.md):

- *Offline*: no status for ``offline_after`` s (wall), or this robot's relay end to it says its master is down
  (its nodes may still talk on connections made before, so its status alone would not tell). An offline robot
  stays where it was last seen. A robot never heard is shown offline at its home, an alert after
  ``startup_grace`` s (the relays come up).
- *Alerts* (:class:`AlertKind`): one per (kind, subject) until acknowledged; a condition (offline, link down,
  battery low, a floor whose robots are all out of service) is *active* while it holds and may be acknowledged
  meanwhile (it is not raised again until it ended and came back); an occurrence (goal unreachable, a visitor
  who never came, a node restarted) raised again before it was acknowledged only counts up. A link between two
  other robots is reported down only while both are online here (a robot that is down takes its links with it:
  one alert, not n).
- *History* (written to :class:`~gidabot_web.dashboard.history.History`, idempotent per event uid): a trip's
  outcome is its first trip-ending event (:data:`OUTCOME_OF`; a cancel without such an event: its reason); the
  visitor's wait is the time from the goal to the first serving phase of its start leg (the robots' own stamps
  when the origin serves it, else the arrival times here); each leg's robot is the first to serve it.
- *Cancel*: confirmed when every robot involved (holding the trip in its queue or named for a leg, its part not
  over) has dropped it: a final event of it, or a queue without it received after the cancel.
- *Out of service*: for each robot, the staff command with the largest (version, robot) is in force.
- *Sender*: every message speaks for a robot (a status for its ``robot``...); the node says which robot its
  publisher may speak for (this robot for its own nodes, the peer for a relay end of this robot's links, none
  for anything else): a message speaking for another is refused and counted.
"""

from __future__ import annotations

import json
import math
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import StrEnum
from typing import TypeVar

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import GoalRejected
from gidabot_navigation.guiding.liveness import PeerLiveness
from gidabot_navigation.guiding.messages import (
    MAX_STAFF_DETAIL,
    CancelData,
    NavEventData,
    PendingData,
    PoseData,
    RobotStatusData,
    StaffCommandData,
    Trip,
    UidMaker,
    validate_cancel,
    validate_event,
    validate_staff,
    validate_trip,
)
from gidabot_navigation.interface import (
    FINAL_PHASES,
    LEG_COMMITTED,
    LEG_NONE,
    LEG_START,
    LEG_STATE_NAMES,
    LEGS,
    PHASE_NAMES,
    REASON_ADMIN,
    REASON_OFFLINE,
    REASON_TIMEOUT,
    REASON_UNREACHABLE,
    REASON_VISITOR,
    Phase,
    StaffCmd,
)
from gidabot_navigation.relay.links import DiagnosticData, LinkData, LinkSummaryData, link_of, own_ends
from gidabot_navigation.tours.tour_store import TourMessage
from gidabot_web.dashboard.history import History, day_of
from gidabot_web.errors import Refused

# what a trip-ending event says of the trip (a start leg's GO_TO_FLOOR only hands the visitor over)
OUTCOME_OF = {Phase.GOAL_REACHED: "completed", Phase.TOUR_STEP_DONE: "completed", Phase.TOUR_FINISHED: "completed",
              Phase.NO_ROBOT_ON_FLOOR: "completed", Phase.CANCELLED_HERE: "cancelled",
              Phase.CANCELLED_ELSEWHERE: "cancelled", Phase.TIMEOUT: "timed_out", Phase.UNREACHABLE: "failed",
              Phase.PARTNER_OFFLINE: "failed", Phase.REJECTED: "refused"}
OUTCOME_OF_REASON = {REASON_VISITOR: "cancelled", REASON_ADMIN: "cancelled", REASON_TIMEOUT: "timed_out",
                     REASON_UNREACHABLE: "failed", REASON_OFFLINE: "failed"}
# a robot starts to serve a leg (moves for the visitor) with one of these
STARTS_SERVING = frozenset({Phase.ON_THE_WAY, Phase.GOING_TO_MEETING})
MAX_STATE_TEXT = 32
M = TypeVar("M")


class AlertKind(StrEnum):
    ROBOT_OFFLINE = "robot_offline"
    LINK_DOWN = "link_down"
    BATTERY_LOW = "battery_low"
    GOAL_UNREACHABLE = "goal_unreachable"
    VISITOR_NO_SHOW = "visitor_no_show"
    NODE_RESTARTED = "node_restarted"
    FLOOR_OUT_OF_SERVICE = "floor_out_of_service"


CONDITIONS = frozenset({AlertKind.ROBOT_OFFLINE, AlertKind.LINK_DOWN, AlertKind.BATTERY_LOW,
                        AlertKind.FLOOR_OUT_OF_SERVICE})


class Section(StrEnum):
    BUILDING = "building"
    ROBOTS = "robots"
    TRIPS = "trips"
    TOURS = "tours"
    LINKS = "links"
    ALERTS = "alerts"
    HISTORY = "history"
    CATALOG = "catalog"
    SERVER = "server"


class Liveness(StrEnum):
    ONLINE = "online"
    OFFLINE = "offline"            # no status for offline_after s
    MASTER_DOWN = "master_down"    # this robot's relay end says its master does not answer
    LINK_DOWN = "link_down"        # this robot's relay end to it has no connection


@dataclass(frozen=True)
class DashboardConfig:
    robot: str
    offline_after: float = 5.0       # s (wall) without a status: offline
    startup_grace: float = 30.0      # s after start before a robot never heard is an alert (the relays come up)
    battery_low: float = 0.2         # fraction: an alert below ...
    battery_ok: float = 0.25         # ... until above this
    diag_stale: float = 5.0          # s without a relay end's diagnostics: the link is unknown
    summary_stale: float = 10.0      # s: another robot's link summary older than this is not current
    finished_kept: int = 40          # finished trips shown
    trip_forget: float = 300.0       # s: a trip no robot holds and nobody spoke of is dropped from the page
    tours_kept: float = 600.0        # s a finished tour stays on the page
    alerts_kept: int = 300
    history_period: float = 5.0      # s between two sums of the day (when it changed)


@dataclass
class RobotView:
    name: str
    floor: float
    x: float
    y: float
    yaw: float
    state: str = ""
    battery: float = -1.0
    linear: float = 0.0
    angular: float = 0.0
    pending: int = 0
    current_goal_uid: str = ""
    busy_for: float = 0.0
    heard: float | None = None       # now (monotonic) of the last status
    rx_wall: float = 0.0             # wall time the last status was received here (live delay measurements)
    queue: list[tuple[str, float]] = field(default_factory=list)   # (goal uid, eta s) head first
    queue_at: float | None = None    # now of the last pending list
    wait_new: float = 0.0
    live: Liveness = Liveness.OFFLINE


@dataclass
class TripView:
    trip: Trip
    first_seen: float                       # now
    created_wall: float
    last_news: float                        # now
    phases: dict[str, tuple[int, float, str]] = field(default_factory=dict)   # robot -> (phase, now, leg)
    done: set[str] = field(default_factory=set)          # robots whose part ended (a final event)
    waiting_since: dict[str, float] = field(default_factory=dict)   # robot -> now of WAITING_VISITOR
    outcome: str = ""
    ended_wall: float = 0.0
    cancel: CancelWatch | None = None


@dataclass
class CancelWatch:
    uid: str                  # the Cancel's uid
    user: str
    since: float              # now
    waiting: set[str]
    dropped: set[str] = field(default_factory=set)

    @property
    def confirmed(self) -> bool:
        return not self.waiting


@dataclass
class TourRun:
    id: int
    tour_file: str
    steps: int                               # of the tour (0 = unknown)
    done: list[int] = field(default_factory=list)
    current: int = -1
    current_uid: str = ""
    at_robot: str = ""                       # where the last step was done (the next one starts there)
    started_wall: float = 0.0
    last: float = 0.0                        # now
    finished: bool = False


@dataclass
class Alert:
    id: int
    kind: str
    subject: str
    params: dict[str, str]
    first_wall: float
    last_wall: float
    count: int = 1
    active: bool = True
    acked_by: str = ""
    acked_wall: float = 0.0

    def to_json(self) -> dict[str, object]:
        return {"id": self.id, "kind": self.kind, "subject": self.subject, "params": self.params,
                "first": round(self.first_wall, 3), "last": round(self.last_wall, 3), "count": self.count,
                "active": self.active, "acked_by": self.acked_by, "acked": round(self.acked_wall, 3)}

    @staticmethod
    def from_json(d: Mapping) -> Alert:
        return Alert(int(d["id"]), str(d["kind"]), str(d["subject"]), {str(k): str(v) for k, v in d["params"].items()},
                     float(d["first"]), float(d["last"]), int(d["count"]), bool(d["active"]), str(d["acked_by"]),
                     float(d["acked"]))


@dataclass(frozen=True)
class Service:
    """The staff command in force for one robot."""

    out: bool
    version: int
    robot: str
    user: str
    wall: float
    detail: str = ""

    @property
    def key(self) -> tuple[int, str]:
        return self.version, self.robot


def _finite(*values: object) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values)


class DashboardCore:
    def __init__(self, building: Building, config: DashboardConfig, history: History | None, now: float,
                 wall: float, uids: UidMaker | None = None) -> None:
        self.building, self.cfg, self.history = building, config, history
        self.me = building.robot(config.robot).name
        self.started = now
        self.wall_offset = wall - now
        self.uids = uids or UidMaker(self.me, "dash")
        self.liveness = PeerLiveness(config.offline_after, now)
        self.robots: dict[str, RobotView] = {
            r.name: RobotView(r.name, r.floor, r.home.x, r.home.y, r.home.yaw) for r in building.robots}
        self.trips: OrderedDict[str, TripView] = OrderedDict()
        self.tours: list[TourRun] = []
        self._tour_ids = 0
        self.catalog: dict[str, TourMessage] = {}
        self.ends = own_ends(building, self.me)
        self.links: dict[str, tuple[LinkData, float]] = {}          # peer -> (link, now heard)
        self.summaries: dict[str, tuple[LinkSummaryData, float]] = {}   # robot -> (its summary, now received)
        self.service: dict[str, Service] = {}
        self.node_uris: dict[str, str] = {}              # node -> the address it last registered with
        self.master_up = True
        self.master_pid: int | None = None
        self.alerts: OrderedDict[int, Alert] = OrderedDict()
        self._next_alert = 1
        self.counters: dict[str, int] = {}
        self.web_counters: Mapping[str, int] = {}
        self.clients = 0
        self._versions = {s: 1 for s in Section}
        self._cache: dict[str, tuple[int, str]] = {}
        self._history_due = 0.0
        self._history_dirty = True
        self._history_json: dict = {}
        self.now = now                                  # the latest now given: ages on the page count to it
        self._load()

    # ------------------------------------------------------------------ time, versions, counters
    def wall_at(self, now: float) -> float:
        return now + self.wall_offset

    def touch(self, *sections: Section) -> None:
        for s in sections:
            self._versions[s] += 1

    def versions(self) -> dict[str, int]:
        return {str(k): v for k, v in self._versions.items()}

    def count(self, key: str, n: int = 1) -> None:
        self.counters[key] = self.counters.get(key, 0) + n

    def _load(self) -> None:
        if self.history is None:
            return
        for d in self.history.alerts():
            try:
                a = Alert.from_json(d)
            except (KeyError, TypeError, ValueError):
                continue
            self.alerts[a.id] = a
            self._next_alert = max(self._next_alert, a.id + 1)
        for target, d in self.history.service().items():
            if self.building.find_robot(target) is not None:
                try:
                    self.service[target] = Service(bool(d["out"]), int(d["version"]), str(d["robot"]), str(d["user"]),
                                                   float(d["wall"]), str(d.get("detail", "")))
                except (KeyError, TypeError, ValueError):
                    continue

    def _accept(self, validate: Callable[[Building, M], M], msg: M, speaker: str | None,
                claimed: Callable[[M], str]) -> M | None:
        """``msg`` validated (``guiding/messages.py``), if it speaks for the robot its publisher may speak for;
        else None (counted)."""
        try:
            msg = validate(self.building, msg)
        except GoalRejected:
            self.count("refused_invalid")
            return None
        return msg if self._speaks(claimed(msg), speaker) else None

    def _first_time(self, uid: str, now: float) -> bool:
        """Whether the history applies event ``uid`` for the first time (always, without a history)."""
        return self.history.first_time(uid, self.wall_at(now)) if self.history is not None else True

    def _speaks(self, claimed: str, speaker: str | None) -> bool:
        """Whether a message claiming to speak for ``claimed`` may, from a publisher that may speak for
        ``speaker`` (None: an impostor); counts a refusal."""
        if speaker is None:
            self.count("refused_impostor")
            return False
        if claimed != speaker:
            self.count("refused_foreign")
            return False
        return True

    # ------------------------------------------------------------------ robots
    def on_status(self, s: RobotStatusData, speaker: str | None, now: float, rx_wall: float = 0.0) -> None:
        r = self.robots.get(s.robot) if isinstance(s.robot, str) else None
        if r is None or not _finite(s.x, s.y, s.yaw, s.battery, s.linear, s.angular, s.busy_for) or \
                not isinstance(s.state, str) or len(s.state) > MAX_STATE_TEXT:
            self.count("refused_invalid")
            return
        if not self._speaks(s.robot, speaker):
            return
        r.x, r.y, r.yaw = s.x, s.y, s.yaw
        r.state, r.battery, r.linear, r.angular = s.state, s.battery, s.linear, s.angular
        r.pending = s.pending if isinstance(s.pending, int) else 0
        r.current_goal_uid = s.current_goal_uid if isinstance(s.current_goal_uid, str) else ""
        r.busy_for, r.heard, r.rx_wall = s.busy_for, now, rx_wall
        self.liveness.heard(s.robot, now)
        self._battery_alert(r, now)
        self._update_liveness(now)
        self.touch(Section.ROBOTS)

    def on_pose(self, p: PoseData, speaker: str | None, now: float) -> None:
        r = self.robots.get(p.robot) if isinstance(p.robot, str) else None
        if r is None or not _finite(p.x, p.y, p.yaw):
            self.count("refused_invalid")
            return
        if not self._speaks(p.robot, speaker):
            return
        r.x, r.y, r.yaw = p.x, p.y, p.yaw
        self.touch(Section.ROBOTS)

    def on_pending(self, p: PendingData, speaker: str | None, now: float) -> None:
        r = self.robots.get(p.robot) if isinstance(p.robot, str) else None
        if r is None or not _finite(p.wait_new) or not all(_finite(e) for e in p.eta):
            self.count("refused_invalid")
            return
        if not self._speaks(p.robot, speaker):
            return
        queue = []
        for i, t in enumerate(p.goals):
            if isinstance(t.uid, str) and t.uid:
                queue.append((t.uid[:160], float(p.eta[i]) if i < len(p.eta) else -1.0))
                self._goal_seen(t, now, quiet=True)
        r.queue, r.queue_at, r.wait_new = queue, now, p.wait_new
        held = {uid for uid, _ in queue}
        for tv in self.trips.values():
            w = tv.cancel
            if w is not None and p.robot in w.waiting and tv.trip.uid not in held and now >= w.since:
                self._dropped(tv, p.robot, now)
        self.touch(Section.ROBOTS, Section.TRIPS)

    def _update_liveness(self, now: float) -> None:
        changed = False
        for r in self.robots.values():
            live = self._liveness_of(r.name, now)
            if live != r.live:
                r.live, changed = live, True
            grace = now - self.started >= (self.cfg.offline_after if r.heard is not None else self.cfg.startup_grace)
            if live is Liveness.ONLINE:
                self._resolve(AlertKind.ROBOT_OFFLINE, r.name, now)
            elif grace:
                self._raise(AlertKind.ROBOT_OFFLINE, r.name, {"robot": r.name, "why": str(live)}, now)
        if changed:
            self.touch(Section.ROBOTS)
            self._service_alerts(now)

    def _liveness_of(self, robot: str, now: float) -> Liveness:
        if self.liveness.last_heard(robot) is None:
            return Liveness.OFFLINE             # never heard: shown at its home, greyed (an alert after the grace)
        if robot == self.me:
            if not self.master_up:
                return Liveness.MASTER_DOWN
            return Liveness.ONLINE if self.liveness.online(robot, now) else Liveness.OFFLINE
        link = self._my_link(robot, now)
        if link is not None and not link.connected:
            return Liveness.LINK_DOWN           # its status crosses only this link
        if link is not None and not link.peer_master_up:
            return Liveness.MASTER_DOWN
        return Liveness.ONLINE if self.liveness.online(robot, now) else Liveness.OFFLINE

    def _battery_alert(self, r: RobotView, now: float) -> None:
        if 0.0 <= r.battery < self.cfg.battery_low:
            self._raise(AlertKind.BATTERY_LOW, r.name, {"robot": r.name, "percent": f"{100 * r.battery:.0f}"}, now)
        elif r.battery >= self.cfg.battery_ok:
            self._resolve(AlertKind.BATTERY_LOW, r.name, now)

    # ------------------------------------------------------------------ trips
    def on_goal(self, trip: Trip, speaker: str | None, now: float) -> None:
        valid = self._accept(validate_trip, trip, speaker, lambda t: t.origin_robot)
        if valid is not None:
            self._goal_seen(valid, now)

    def _goal_seen(self, trip: Trip, now: float, quiet: bool = False) -> TripView | None:
        """A goal (or a queued one of a pending list: ``quiet``, not validated again: only known trips are
        updated from it, never made)."""
        tv = self.trips.get(trip.uid)
        if tv is None:
            if quiet:
                return None
            wall = self.wall_at(now)
            tv = TripView(trip, now, wall, now)
            self.trips[trip.uid] = tv
            self._trip_history(tv, now)
            self._tour_goal(trip, now)
        elif trip.attempt > tv.trip.attempt:
            tv.trip = trip
            self._trip_history(tv, now)
        if not quiet:
            tv.last_news = now
        self.touch(Section.TRIPS)
        return tv

    def _trip_history(self, tv: TripView, now: float) -> None:
        if self.history is None:
            return
        t = tv.trip
        self.history.trip(t.uid, day_of(tv.created_wall), tv.created_wall, t.origin_robot, t.goal_id, t.initial_floor,
                          t.goal_floor, t.tour_file, t.tour_step, t.committed(LEG_START), t.committed("goal"))
        self._history_dirty = True

    def on_event(self, ev: NavEventData, speaker: str | None, now: float) -> None:
        ev = self._accept(validate_event, ev, speaker, lambda e: e.robot)   # type: ignore[assignment]
        if ev is None:
            return
        wall, first = self.wall_at(now), self._first_time(ev.uid, now)
        self.count("events")
        phase = ev.phase
        if ev.goal_uid:
            tv = self.trips.get(ev.goal_uid)
            if tv is None and first and phase not in (Phase.DECLINED,):
                tv = self._stub_trip(ev, now)
            if tv is not None:
                tv.last_news = now
                tv.phases[ev.robot] = (phase, now, ev.leg)
                if phase == Phase.WAITING_VISITOR:
                    tv.waiting_since.setdefault(ev.robot, now)
                else:
                    tv.waiting_since.pop(ev.robot, None)
                if phase in FINAL_PHASES:
                    tv.done.add(ev.robot)
                    if tv.cancel is not None and ev.robot in tv.cancel.waiting:
                        self._dropped(tv, ev.robot, now)
                if first:
                    self._event_history(tv, ev, now, wall)
                self._tour_event(ev, now)
                self.touch(Section.TRIPS)
        elif first and phase in OUTCOME_OF and self.history is not None:
            # a request answered at once (nothing queued): its answer is the trip
            self.history.trip(ev.uid, day_of(wall), wall, ev.robot, ev.location_id)
            self.history.outcome(ev.uid, "refused", wall)
            self._history_dirty = True
        if first and phase == Phase.UNREACHABLE:
            self._raise(AlertKind.GOAL_UNREACHABLE, ev.goal_uid or ev.uid,
                        {"robot": ev.robot, "place": ev.location_id, "trip": ev.goal_uid}, now)
        if first and phase == Phase.TIMEOUT:
            self._raise(AlertKind.VISITOR_NO_SHOW, ev.goal_uid or ev.uid,
                        {"robot": ev.robot, "place": ev.connector or ev.location_id, "trip": ev.goal_uid}, now)

    def _stub_trip(self, ev: NavEventData, now: float) -> TripView:
        """A trip first known by one of its events (this dashboard started after its goal went by)."""
        origin = ev.goal_uid.split("/", 1)[0]
        origin = origin if self.building.find_robot(origin) else ev.robot
        floor = self.building.robot(origin).floor
        trip = Trip(uid=ev.goal_uid, origin_robot=origin, visitor_id="", initial_floor=floor, initial_x=0.0,
                    initial_y=0.0, goal_floor=ev.target_floor if _finite(ev.target_floor) else floor, goal_x=0.0,
                    goal_y=0.0, goal_yaw=0.0, way=ev.way, connector=ev.connector, start_id="", goal_id="",
                    language=ev.language, tour_file=ev.tour_file, tour_step=ev.tour_step)
        wall = self.wall_at(now)
        tv = TripView(trip, now, wall, now)
        self.trips[trip.uid] = tv
        if self.history is not None:
            self.history.trip(trip.uid, day_of(wall), wall, origin, tour_file=ev.tour_file, tour_step=ev.tour_step)
        return tv

    def _event_history(self, tv: TripView, ev: NavEventData, now: float, wall: float) -> None:
        outcome = OUTCOME_OF.get(Phase(ev.phase))
        if ev.phase in STARTS_SERVING and ev.leg in LEGS and self.history is not None:
            self.history.leg(tv.trip.uid, ev.leg, ev.robot, day_of(tv.created_wall), wall)
            if ev.leg == LEG_START:
                if ev.robot == tv.trip.origin_robot and tv.trip.stamp > 0 and ev.stamp > 0:
                    wait = ev.stamp - tv.trip.stamp
                else:
                    wait = now - tv.first_seen
                self.history.wait(tv.trip.uid, wait)
        if outcome is not None and not tv.outcome:
            self._trip_over(tv, outcome, wall)
        self._history_dirty = True

    def _trip_over(self, tv: TripView, outcome: str, wall: float) -> None:
        tv.outcome, tv.ended_wall = outcome, wall
        if self.history is not None:
            self.history.outcome(tv.trip.uid, outcome, wall)
        self._history_dirty = True
        self.trips.move_to_end(tv.trip.uid)

    def on_cancel(self, c: CancelData, speaker: str | None, now: float) -> None:
        c = self._accept(validate_cancel, c, speaker, lambda x: x.origin_robot)   # type: ignore[assignment]
        if c is None:
            return
        wall, first = self.wall_at(now), self._first_time(c.uid, now)
        tv = self.trips.get(c.goal_uid)
        if tv is not None:
            tv.last_news = now
            if first and not tv.outcome:
                self._trip_over(tv, OUTCOME_OF_REASON.get(c.reason, "cancelled"), wall)
            self.touch(Section.TRIPS)

    def _dropped(self, tv: TripView, robot: str, now: float) -> None:
        w = tv.cancel
        if w is None:
            return
        w.waiting.discard(robot)
        w.dropped.add(robot)
        if w.confirmed and not tv.outcome:
            self._trip_over(tv, "cancelled", self.wall_at(now))
        self.touch(Section.TRIPS)

    def involved(self, tv: TripView) -> set[str]:
        """The robots that still have a part in a trip: holding it in their queue, or named for a leg, and whose
        part did not end."""
        t = tv.trip
        named = {t.leg_robot(leg) for leg in LEGS if t.leg_state(leg) != LEG_NONE and t.leg_robot(leg)}
        holders = {r.name for r in self.robots.values() if any(uid == t.uid for uid, _ in r.queue)}
        return (named | holders) - tv.done

    # ------------------------------------------------------------------ staff actions
    def cancel_trip(self, goal_uid: object, user: str, now: float) -> CancelData:
        """A staff cancel of a trip in progress: the Cancel to publish (reason admin, from this robot)."""
        tv = self.trips.get(goal_uid) if isinstance(goal_uid, str) else None
        if tv is None:
            raise Refused(404, "unknown_trip", f"no trip {str(goal_uid)[:80]!r} is known here")
        if tv.outcome:
            raise Refused(409, "trip_over", f"trip {tv.trip.uid} is over ({tv.outcome})")
        if tv.cancel is not None:
            raise Refused(409, "already_cancelled", f"trip {tv.trip.uid} is being cancelled already")
        cancel = CancelData(uid=self.uids.cancel(), goal_uid=tv.trip.uid, origin_robot=self.me, reason=REASON_ADMIN,
                            detail=f"staff {user} at the dashboard of {self.me}", stamp=0.0)
        tv.cancel = CancelWatch(cancel.uid, user, now, self.involved(tv))
        self._first_time(cancel.uid, now)          # this robot's own cancel: not applied again when it comes back
        if tv.cancel.confirmed:
            self._trip_over(tv, "cancelled", self.wall_at(now))
        self.count("staff_cancels")
        self.touch(Section.TRIPS)
        return cancel

    def set_service(self, target: object, out: bool, user: str, detail: object, now: float) -> StaffCommandData:
        """A staff command taking ``target`` out of service (or back): the StaffCommand to publish; applied here
        at once."""
        if not isinstance(target, str) or self.building.find_robot(target) is None:
            raise Refused(404, "unknown_robot", f"{str(target)[:80]!r} is not a robot of the building")
        text = detail if isinstance(detail, str) else ""
        if len(text) > MAX_STAFF_DETAIL or any(ord(ch) < 32 for ch in text):
            raise Refused(400, "detail", f"the reason may have at most {MAX_STAFF_DETAIL} characters "
                                                  "and no control characters")
        wall = self.wall_at(now)
        known = self.service.get(target)
        version = max(int(wall * 1e9), known.version + 1 if known else 1)
        cmd = StaffCommandData(uid=self.uids.staff(), robot=self.me, user=user,
                               command=int(StaffCmd.OUT_OF_SERVICE if out else StaffCmd.BACK_IN_SERVICE),
                               target_robot=target, version=version, detail=text, stamp=wall)
        self.count("staff_commands")
        self._apply_staff(cmd, now)
        return cmd

    def on_staff(self, cmd: StaffCommandData, speaker: str | None, now: float) -> None:
        valid = self._accept(validate_staff, cmd, speaker, lambda x: x.robot)
        if valid is not None:
            self._apply_staff(valid, now)

    def _apply_staff(self, cmd: StaffCommandData, now: float) -> None:
        known = self.service.get(cmd.target_robot)
        if known is not None and known.key >= cmd.key:
            return
        s = Service(cmd.command == StaffCmd.OUT_OF_SERVICE, cmd.version, cmd.robot, cmd.user, self.wall_at(now),
                    cmd.detail)
        self.service[cmd.target_robot] = s
        if self.history is not None:
            self.history.save_service(cmd.target_robot, {"out": s.out, "version": s.version, "robot": s.robot,
                                                         "user": s.user, "wall": s.wall, "detail": s.detail})
        self._service_alerts(now)
        self.touch(Section.ROBOTS)

    def out_of_service(self, robot: str) -> bool:
        s = self.service.get(robot)
        return s is not None and s.out

    def _service_alerts(self, now: float) -> None:
        for floor in self.building.floors:
            robots = self.building.robots_on(floor.id)
            if robots and all(self.out_of_service(r.name) for r in robots):
                self._raise(AlertKind.FLOOR_OUT_OF_SERVICE, floor.label, {"floor": floor.label}, now)
            else:
                self._resolve(AlertKind.FLOOR_OUT_OF_SERVICE, floor.label, now)

    # ------------------------------------------------------------------ tours
    def on_catalog(self, tours: Iterable[TourMessage]) -> None:
        self.catalog = {t.file_name: t for t in tours if isinstance(t.file_name, str)}
        self.touch(Section.CATALOG, Section.TOURS)

    def _tour_goal(self, trip: Trip, now: float) -> None:
        if not trip.tour_file:
            return
        def goes_on(r: TourRun) -> bool:
            """The trip is this run's step, or its next one: issued where its last step was done."""
            return r.current_uid == trip.uid or (r.at_robot == trip.origin_robot and trip.tour_step > r.current)

        run = next((r for r in reversed(self.tours)
                    if not r.finished and r.tour_file == trip.tour_file and goes_on(r)), None)
        if run is None or (trip.tour_step == 0 and run.current_uid != trip.uid):
            self._tour_ids += 1
            tour = self.catalog.get(trip.tour_file)
            run = TourRun(self._tour_ids, trip.tour_file, len(tour.tour_goals_info) if tour else 0,
                          started_wall=self.wall_at(now))
            self.tours.append(run)
        run.current, run.current_uid, run.last = trip.tour_step, trip.uid, now
        self.touch(Section.TOURS)

    def _tour_event(self, ev: NavEventData, now: float) -> None:
        run = next((r for r in self.tours if r.current_uid == ev.goal_uid), None)
        if run is None:
            return
        run.last = now
        if ev.phase in (Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED, Phase.NO_ROBOT_ON_FLOOR):
            if ev.tour_step >= 0 and ev.tour_step not in run.done and ev.phase != Phase.NO_ROBOT_ON_FLOOR:
                run.done.append(ev.tour_step)
            run.at_robot = ev.robot
            run.finished = ev.phase == Phase.TOUR_FINISHED
        elif ev.phase in OUTCOME_OF and OUTCOME_OF[Phase(ev.phase)] != "completed":
            run.finished = True
        self.touch(Section.TOURS)

    # ------------------------------------------------------------------ links, nodes, master
    def on_diagnostics(self, statuses: Sequence[DiagnosticData], now: float) -> None:
        changed = False
        for s in statuses:
            link = link_of(s, self.ends)
            if link is not None:
                self.links[link.peer] = (link, now)
                changed = True
        if changed:
            self._update_liveness(now)
            self.touch(Section.LINKS)

    def _my_link(self, peer: str, now: float) -> LinkData | None:
        got = self.links.get(peer)
        if got is None or now - got[1] > self.cfg.diag_stale:
            return None
        return replace(got[0], heard_s=round(now - got[1], 1))

    def link_summary(self, now: float) -> LinkSummaryData:
        """This robot's links now, for /gidabot/links."""
        links = []
        for r in self.building.robots:
            if r.name == self.me:
                continue
            link = self._my_link(r.name, now)
            if link is None:
                got = self.links.get(r.name)
                link = LinkData(r.name, known=False, heard_s=round(now - got[1], 1) if got else -1.0)
            links.append(link)
        return LinkSummaryData(self.me, tuple(links), self.wall_at(now))

    def on_links(self, summary: LinkSummaryData, speaker: str | None, now: float) -> None:
        if not isinstance(summary.robot, str) or self.building.find_robot(summary.robot) is None or \
                len(summary.links) >= len(self.building.robots) or \
                not all(isinstance(k.peer, str) and self.building.find_robot(k.peer) is not None and
                        _finite(k.down_s, k.heard_s, k.rtt_ms) for k in summary.links):
            self.count("refused_invalid")
            return
        if not self._speaks(summary.robot, speaker) or summary.robot == self.me:
            return
        self.summaries[summary.robot] = (summary, now)
        self.touch(Section.LINKS)

    def on_node(self, node: str, uri: str | None, now: float) -> None:
        """Node ``node`` of this robot is registered at ``uri`` (None: not registered now). A node registered
        at another address than before was restarted (a node that registers again with a restarted master keeps
        its address)."""
        if uri is None:
            return
        before = self.node_uris.get(node)
        self.node_uris[node] = uri
        if before is not None and before != uri:
            self._raise(AlertKind.NODE_RESTARTED, node, {"robot": self.me, "node": node}, now, occurrence=True)

    def on_master(self, pid: int | None, now: float) -> None:
        """This robot's master answered with ``pid`` (None: it does not answer)."""
        up = pid is not None
        if up and self.master_pid is not None and pid != self.master_pid:
            self._raise(AlertKind.NODE_RESTARTED, "master", {"robot": self.me, "node": "master"}, now,
                        occurrence=True)
        if up:
            self.master_pid = pid
        if up != self.master_up:
            self.master_up = up
            self._update_liveness(now)
            self.touch(Section.SERVER, Section.ROBOTS)

    # ------------------------------------------------------------------ alerts
    def _raise(self, kind: AlertKind, subject: str, params: dict[str, str], now: float,
               occurrence: bool | None = None) -> None:
        wall = self.wall_at(now)
        latest = next((a for a in reversed(self.alerts.values()) if a.kind == kind and a.subject == subject), None)
        one_shot = kind not in CONDITIONS if occurrence is None else occurrence
        if latest is not None:
            if kind in CONDITIONS and latest.active:
                return                          # still the same condition (acknowledged or not)
            if not latest.acked_by:
                latest.count += 1
                latest.last_wall, latest.active = wall, kind in CONDITIONS
                if kind in CONDITIONS:
                    latest.params = dict(params)      # a condition's latest values; an occurrence: its first report
                self._save_alert(latest)
                return
        a = Alert(self._next_alert, str(kind), subject, dict(params), wall, wall, active=not one_shot)
        self._next_alert += 1
        self.alerts[a.id] = a
        self.count("alerts_raised")
        self._save_alert(a)
        self._prune_alerts()

    def _resolve(self, kind: AlertKind, subject: str, now: float) -> None:
        for a in reversed(self.alerts.values()):
            if a.kind == kind and a.subject == subject:
                if a.active:
                    a.active, a.last_wall = False, self.wall_at(now)
                    self._save_alert(a)
                return

    def ack_alert(self, alert_id: object, user: str, now: float) -> Alert:
        a = self.alerts.get(alert_id) if isinstance(alert_id, int) and not isinstance(alert_id, bool) else None
        if a is None:
            raise Refused(404, "unknown_alert", f"no alert {str(alert_id)[:20]!r}")
        if not a.acked_by:
            a.acked_by, a.acked_wall = user, self.wall_at(now)
            self._save_alert(a)
        return a

    def _save_alert(self, a: Alert) -> None:
        if self.history is not None:
            self.history.save_alert(a.id, a.to_json())
        self.touch(Section.ALERTS)

    def _prune_alerts(self) -> None:
        extra = len(self.alerts) - self.cfg.alerts_kept
        if extra <= 0:
            return
        for aid in [k for k, a in self.alerts.items() if a.acked_by and not a.active][:extra]:
            del self.alerts[aid]
        if self.history is not None and self.alerts:
            self.history.drop_alerts_below(min(self.alerts))

    def open_alerts(self) -> list[Alert]:
        return [a for a in self.alerts.values() if not a.acked_by]

    # ------------------------------------------------------------------ step
    def step(self, now: float, wall: float) -> None:
        """Liveness, link alerts, forgetting old trips and tours, committing the history, the day's sums."""
        self.wall_offset, self.now = wall - now, now
        self._update_liveness(now)
        self._link_alerts(now)
        self._forget(now)
        if self.history is not None:
            self.history.commit()
            if self._history_dirty and now >= self._history_due:
                self._history_json = self.history.summary(day_of(wall))
                self._history_json["days"] = self.history.days()
                self._history_dirty, self._history_due = False, now + self.cfg.history_period
                self.touch(Section.HISTORY)
        self.touch(Section.ROBOTS, Section.SERVER)

    def _link_alerts(self, now: float) -> None:
        online = {r.name for r in self.robots.values() if r.live is Liveness.ONLINE}
        down: set[tuple[str, str]] = set()
        for robot, (summary, at) in self.summaries.items():
            if now - at > self.cfg.summary_stale:
                continue
            for link in summary.links:
                if link.known and not link.connected:
                    down.add(self._pair(robot, link.peer))
        for a, b in (self._pair(x.name, y.name) for x, y in self.building.relay_pairs()):
            subject = f"{a}-{b}"
            if (a, b) in down and a in online and b in online:
                self._raise(AlertKind.LINK_DOWN, subject, {"a": a, "b": b}, now)
            else:
                self._resolve(AlertKind.LINK_DOWN, subject, now)

    def _pair(self, x: str, y: str) -> tuple[str, str]:
        order = [r.name for r in self.building.robots]
        return (x, y) if order.index(x) < order.index(y) else (y, x)

    def _forget(self, now: float) -> None:
        held = {uid for r in self.robots.values() for uid, _ in r.queue}
        finished = [uid for uid, tv in self.trips.items() if tv.outcome]
        for uid in finished[:-self.cfg.finished_kept] if len(finished) > self.cfg.finished_kept else []:
            del self.trips[uid]
        for uid in [u for u, tv in self.trips.items() if not tv.outcome and u not in held
                    and now - tv.last_news > self.cfg.trip_forget]:
            del self.trips[uid]
            self.touch(Section.TRIPS)
        kept = [r for r in self.tours if not r.finished or now - r.last < self.cfg.tours_kept]
        if len(kept) != len(self.tours):
            self.tours = kept
            self.touch(Section.TOURS)

    # ------------------------------------------------------------------ the page's sections
    def section_json(self, name: str) -> str:
        version = self._versions[Section(name)]
        cached = self._cache.get(name)
        if cached is not None and cached[0] == version:
            return cached[1]
        text = json.dumps(self.section(name), separators=(",", ":"), allow_nan=False)
        self._cache[name] = (version, text)
        return text

    def section(self, name: str) -> object:
        return {Section.BUILDING: self._building_json, Section.ROBOTS: self._robots_json,
                Section.TRIPS: self._trips_json, Section.TOURS: self._tours_json, Section.LINKS: self._links_json,
                Section.ALERTS: self._alerts_json, Section.HISTORY: lambda: self._history_json,
                Section.CATALOG: self._catalog_json, Section.SERVER: self._server_json}[Section(name)]()

    def _building_json(self) -> dict:
        b = self.building
        return {
            "id": b.id, "name": b.name, "me": self.me,
            "floors": [{"id": f.id, "label": f.label, "names": f.names,
                        "blueprint": blueprint_name(i, f.blueprint_file), "width": f.blueprint_size[0],
                        "height": f.blueprint_size[1]} for i, f in enumerate(b.floors)],
            "locations": {loc.id: {"floor": loc.floor, "names": loc.names} for loc in b.locations},
            "connectors": {c.id: {"kind": c.kind, "names": c.names} for c in b.connectors},
            "robots": [{"name": r.name, "floor": r.floor} for r in b.robots],
            "phases": {int(p): PHASE_NAMES[p] for p in Phase},
            "final": sorted(int(p) for p in FINAL_PHASES),
        }

    def _robots_json(self) -> list[dict]:
        now = self.now
        out = []
        for name, r in self.robots.items():
            floor = self.building.floor(r.floor)
            u, v = floor.transform.to_pixel(r.x, r.y)
            s = self.service.get(name)
            out.append({
                "name": name, "floor": floor.id, "x": round(r.x, 2), "y": round(r.y, 2), "u": round(u, 1),
                "v": round(v, 1), "heading": round(math.degrees(floor.transform.yaw_to_pixel_angle(r.yaw)), 1),
                "state": r.state, "battery": round(r.battery, 3), "linear": round(r.linear, 2),
                "angular": round(r.angular, 2), "pending": r.pending, "current": r.current_goal_uid,
                "busy_for": round(r.busy_for, 1), "live": str(r.live),
                "heard_s": None if r.heard is None else round(max(0.0, now - r.heard), 1),
                "rx": round(r.rx_wall, 4),
                "queue": [{"trip": uid, "eta": round(eta, 1), "goal": self._goal_of(uid)} for uid, eta in r.queue],
                "wait_new": round(r.wait_new, 1),
                "out_of_service": bool(s and s.out),
                "service": None if s is None else {"out": s.out, "robot": s.robot, "user": s.user,
                                                   "wall": round(s.wall, 3), "detail": s.detail},
            })
        return out

    def _goal_of(self, uid: str) -> str:
        tv = self.trips.get(uid)
        return tv.trip.goal_id if tv else ""

    def _trips_json(self) -> list[dict]:
        now = self.now
        out = []
        for tv in reversed(self.trips.values()):
            t = tv.trip
            legs = []
            for leg in LEGS:
                state = t.leg_state(leg)
                if state == LEG_NONE:
                    continue
                robot = t.leg_robot(leg)
                phase = tv.phases.get(robot)
                waiting = tv.waiting_since.get(robot)
                legs.append({"leg": leg, "robot": robot, "state": LEG_STATE_NAMES[state],
                             "committed": state == LEG_COMMITTED, "phase": None if phase is None else phase[0],
                             "waiting_s": None if waiting is None else round(now - waiting, 1),
                             "done": robot in tv.done})
            w = tv.cancel
            out.append({
                "uid": t.uid, "origin": t.origin_robot, "start": t.start_id, "start_floor": t.initial_floor,
                "goal": t.goal_id, "goal_floor": t.goal_floor, "way": t.way, "connector": t.connector,
                "tour": t.tour_file, "step": t.tour_step, "created": round(tv.created_wall, 3),
                "age_s": round(now - tv.first_seen, 1), "legs": legs, "outcome": tv.outcome,
                "ended": round(tv.ended_wall, 3), "holders": sorted(self.involved(tv)),
                "cancel": None if w is None else {"user": w.user, "waiting": sorted(w.waiting),
                                                  "dropped": sorted(w.dropped), "confirmed": w.confirmed},
            })
        return out

    def _tours_json(self) -> list[dict]:
        out = []
        for run in reversed(self.tours):
            tour = self.catalog.get(run.tour_file)
            out.append({"id": run.id, "file": run.tour_file, "name": tour.tour_name if tour else run.tour_file,
                        "steps": [line for line in tour.tour_goals_info] if tour else [],
                        "done": sorted(run.done), "current": run.current, "trip": run.current_uid,
                        "at": run.at_robot, "started": round(run.started_wall, 3), "finished": run.finished})
        return out

    def _links_json(self) -> dict:
        now = self.now
        mine = [link_json(k) for k in self.link_summary(now).links]
        others = {}
        for robot, (summary, at) in self.summaries.items():
            others[robot] = {"age_s": round(now - at, 1), "current": now - at <= self.cfg.summary_stale,
                             "links": [link_json(k) for k in summary.links]}
        return {"me": self.me, "mine": mine, "others": others}

    def _alerts_json(self) -> list[dict]:
        return [a.to_json() for a in reversed(self.alerts.values())]

    def _catalog_json(self) -> list[dict]:
        return [{"file": t.file_name, "name": t.tour_name, "language": t.language, "floor": t.floor,
                 "goals": list(t.tour_goals_info)} for _, t in sorted(self.catalog.items())]

    def _server_json(self) -> dict:
        return {"robot": self.me, "master_up": self.master_up, "clients": self.clients,
                "refused": {k: v for k, v in sorted(self.web_counters.items()) if k.startswith("refused_")},
                "requests": self.web_counters.get("requests", 0),
                "inputs_refused": {k: v for k, v in sorted(self.counters.items()) if k.startswith("refused_")}}

    def diagnostics(self) -> dict[str, object]:
        """Counters for the node's /diagnostics."""
        return {**self.counters, **self.web_counters, "clients": self.clients,
                "open_alerts": len(self.open_alerts()), "trips": len(self.trips),
                "history_writes": self.history.writes if self.history is not None else 0}


def blueprint_name(index: int, path: object) -> str:
    """The name the page fetches floor ``index``'s blueprint by (never a path)."""
    suffix = str(getattr(path, "suffix", "")).lower()
    suffix = suffix if suffix in (".png", ".jpg", ".jpeg", ".pgm") else ""
    return f"floor-{index}{suffix}"


def link_json(k: LinkData) -> dict:
    return {"peer": k.peer, "known": k.known, "connected": k.connected, "down_s": round(k.down_s, 1),
            "heard_s": round(k.heard_s, 1), "rtt_ms": round(k.rtt_ms, 2), "queued": k.queued, "resent": k.resent,
            "dropped": k.dropped, "duplicates": k.duplicates_suppressed, "losses": k.link_losses,
            "peer_master_up": k.peer_master_up}
