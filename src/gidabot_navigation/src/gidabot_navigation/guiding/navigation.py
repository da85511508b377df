"""Multirobot navigation (ROS-free core): the guiding state machine of paper Algorithm 1.

One robot runs its pending list (kept by the goal manager) leg by leg through
move_base, in order, each trip once the trip's assignment commits a leg to this robot
(``docs/guiding.md``, *Who serves a leg*). Roles (see :func:`gidabot_navigation.guiding.trips.role`):

* **same floor** — [pick the visitor up] -> ON_THE_WAY to the goal -> GOAL_REACHED
  (TOUR_STEP_DONE / TOUR_FINISHED for a tour step);
* **start floor** of a cross-floor trip — [pick up] -> ON_THE_WAY to the connector's
  meeting point -> GO_TO_FLOOR (target floor, way, connector, the robot that waits
  there), or NO_ROBOT_ON_FLOOR when no robot serves the goal floor (a tour whose
  remaining stops are all on floors without robot: TOUR_FINISHED); the robot's part is
  then over. A goal leg not committed yet when the robot gets there: it waits with the
  visitor (PARTNER_LOST) until it is;
* **goal floor** — as soon as the trip is at the head: GOING_TO_MEETING -> at the
  meeting point WAITING_VISITOR -> Continue -> ON_THE_WAY to the goal -> GOAL_REACHED.
  Nobody presses Continue within ``continue_timeout`` (ROS s, counted from when the
  robot is at the meeting point *and* the start robot released the visitor) ->
  TIMEOUT, and the trip is dropped everywhere.

Failures: move_base ABORTED/REJECTED/LOST -> UNREACHABLE here and a Cancel (reason
unreachable) so every other robot drops the trip and tells its visitor. A Cancel for
the running trip stops move_base at once. A partner robot that goes offline while
the trip still needs it -> PARTNER_LOST (the trip waits), PARTNER_BACK when it
returns; the goal-floor robot gives up after ``partner_timeout`` wall s
(PARTNER_OFFLINE, Cancel reason offline).

The visitor's pace (:mod:`gidabot_navigation.guiding.pacing`): while it guides, the robot reads what its laser
knows of the visitor (``on_visitor``): it caps its speed (:attr:`NavigationCore.speed_cap`), stops its goal to
wait facing the visitor (WAITING_FOR_YOU; a move_base goal on the spot, facing them), goes on (FOLLOW_ME),
goes back to where it last saw them and looks round (SEARCHING_VISITOR, with the place), and ends the trip when
they are not found (VISITOR_LOST with the place, and a Cancel, reason visitor_lost, so every robot drops it: the
goal-floor robot waiting at the meeting point at once). :attr:`NavigationCore.wants_visitor` and
:attr:`NavigationCore.relocks` say when to lock the visitor's track. At the meeting point (``on_people``) the
goal-floor robot asks someone who arrives there to press Continue (PRESS_CONTINUE), again while they stand.

Inputs are explicit events (:meth:`NavigationCore.on_pending`, ``on_move_base_result``,
``on_continue``, ``on_cancel``, ``on_nav_event``, ``on_status``, ``on_visitor``, ``on_people``, ``tick``); each
returns actions (MoveTo, StopMoving, SendEvent, SendCancel) for the adapter. Every message names its
publisher (``sender``, the ROS callerid) and speaks only for it
(:class:`~gidabot_navigation.senders.Senders`): the pending list only from this robot's goal
manager, Continue only from this robot's GUI or visitor, a cancel, event or status only from
the robot it names, the visitor's track and the people tracked only from this robot's people node;
anything else is refused and counted (:meth:`NavigationCore.refusals`).
"""

from __future__ import annotations

import enum
import math
from collections import OrderedDict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building, format_floor
from gidabot_navigation.errors import GoalRejected, GuidingError, GuidingStateError
from gidabot_navigation.guiding.liveness import PeerLiveness
from gidabot_navigation.guiding.make_way import MakeWay, Mate
from gidabot_navigation.guiding.meeting import ArrivalConfig, ArrivalWatch
from gidabot_navigation.guiding.messages import (
    Action,
    CancelData,
    CommandData,
    Counters,
    MoveTo,
    NavEventData,
    RobotStatusData,
    SeenSet,
    SendAsk,
    SendCancel,
    SendEvent,
    StopMoving,
    Trip,
    UidMaker,
    WayAsk,
    cancel_digest,
    nav_event_digest,
    own_event_digest,
    same_floor,
    validate_ask,
    validate_cancel,
    validate_event,
)
from gidabot_navigation.guiding.pacing import Decision, Pace, Pacer, PacingConfig, Say
from gidabot_navigation.guiding.state import (
    REMEMBERED_UIDS,
    number,
    str_list,
    trip_from_dict,
    trip_to_dict,
    uid_records,
)
from gidabot_navigation.guiding.tour_mode import TourBook, next_robot_stop
from gidabot_navigation.guiding.trips import Role, role
from gidabot_navigation.interface import (
    DEFAULT_LANGUAGE,
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_NONE,
    LEG_START,
    REASON_OFFLINE,
    REASON_TIMEOUT,
    REASON_UNREACHABLE,
    REASON_VISITOR_LOST,
    RELEASE_PHASES,
    Cmd,
    Node,
    Phase,
    RobotState,
)
from gidabot_navigation.logs import Logger, RateLimitedLog
from gidabot_navigation.perception.people import Track, VisitorReport
from gidabot_navigation.senders import INVALID, Claim, Gate, HandledUids, Senders, as_text
from gidabot_navigation.tours.tour_store import TourMessage

# move_base (actionlib) terminal states, as the adapter names them
SUCCEEDED = "succeeded"
ABORTED = "aborted"
REJECTED_BY_SERVER = "rejected"
PREEMPTED = "preempted"
RECALLED = "recalled"
LOST = "lost"


class Stage(enum.Enum):
    PICKUP = "pickup"            # driving to where the visitor made the request (start / same floor)
    GUIDING = "guiding"          # ON_THE_WAY with the visitor
    TO_MEETING = "to_meeting"    # goal floor: driving alone to the connector's meeting point
    WAITING = "waiting"          # goal floor: at the meeting point, waiting for Continue
    HANDOVER = "handover"        # start floor: at the connector with the visitor, the goal leg not committed yet


# odometry stamped further ahead of the ROS time than this is not trusted as the time (s)
MAX_ODOM_LEAD_S = 10.0


ASK_PERIOD = 2.0    # ROS s between two looks, during a move, at the idle robots in its way (one came back)


def freshest_time(ros_now: float, odom_stamp: float | None) -> float:
    """The ROS time (s) the core is told of: the odometry's stamp when it is ahead of ``ros_now`` by at most
    :data:`MAX_ODOM_LEAD_S`, else ``ros_now``.

    On a robot the two agree. In simulation ``ros_now`` comes from ``/clock``, which ticks every
    speed / clock rate sim s (1.2 s at 60x and 50 Hz), while the simulator stamps the odometry at every step
    (0.1 s): an ON_THE_WAY stamped with the ``/clock`` time is on average half a tick early, and a guiding leg
    (Table 5: from its ON_THE_WAY to move_base's result, which move_base stamps at its step) half a tick too
    long, more the faster the run.
    """
    if odom_stamp is not None and math.isfinite(odom_stamp) and 0.0 < odom_stamp - ros_now <= MAX_ODOM_LEAD_S:
        return odom_stamp
    return ros_now


STATE_OF_STAGE = {Stage.PICKUP: RobotState.TO_MEETING, Stage.GUIDING: RobotState.GUIDING,
                  Stage.TO_MEETING: RobotState.TO_MEETING, Stage.WAITING: RobotState.WAITING,
                  Stage.HANDOVER: RobotState.WAITING}


@dataclass(frozen=True)
class NavigationConfig:
    """Times: ``continue_timeout``, ``nav_lost_timeout`` in ROS s; ``partner_timeout``, ``offline_after``
    in wall s; ``pickup_distance`` in m; ``simulated``: the simulated visitor (node ``visitor``) is one of this
    robot's own nodes (it presses Continue). ``/gidabot/poses`` (:meth:`NavigationCore.pose_to_publish`): a pose
    is published when it moved ``pose_min_move`` m or turned ``pose_min_turn`` rad since the last one published,
    else at every ``pose_keepalive``-th tick of the pose timer (a robot at rest costs its peers little).
    ``pacing``: the visitor's pace (None: the robot drives at its own pace whatever its laser sees); ``arrival``:
    asking who arrives at the meeting point to press Continue. ``watch_within`` (m): driving alone to meet its
    visitor (to the request point, to the meeting point), the robot has the people around it watched from this
    far from that place on (:attr:`NavigationCore.wants_people`)."""

    robot: str
    continue_timeout: float = 300.0
    partner_timeout: float = 120.0
    offline_after: float = 5.0
    pickup_distance: float = 1.5
    nav_lost_timeout: float = 30.0
    simulated: bool = False
    pose_min_move: float = 0.01
    pose_min_turn: float = 0.01
    pose_keepalive: int = 5
    pacing: PacingConfig | None = field(default_factory=PacingConfig)
    arrival: ArrivalConfig = field(default_factory=ArrivalConfig)
    watch_within: float = 8.0

    def __post_init__(self) -> None:
        for name in ("continue_timeout", "partner_timeout", "offline_after", "pickup_distance", "nav_lost_timeout",
                     "pose_min_move", "pose_min_turn", "watch_within"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise GuidingError(f"{name}: {value!r} must be a positive number")
        if not (isinstance(self.pose_keepalive, int) and self.pose_keepalive >= 1):
            raise GuidingError(f"pose_keepalive: {self.pose_keepalive!r} must be an integer >= 1")


@dataclass
class Leg:
    """This robot's part of the trip at the head of its queue."""

    trip: Trip
    role: Role
    stage: Stage
    token: int
    target: Pose2D
    moving: bool = True
    arrived_at: float | None = None     # ROS s, reached the meeting point
    continued: bool = False             # the visitor pressed Continue (possibly before arrival)
    partner: str | None = None          # the other robot of a cross-floor trip
    partner_lost: float | None = None   # wall s since which the partner is offline (notice given)
    started: float = 0.0                # ROS s
    resend: bool = False                # resumed after a restart: send the move_base goal again
    pacer: Pacer | None = None          # guiding: the visitor's pace
    detour: bool = False                # the move_base goal is pacing's (turn to the visitor, search), not target
    arrivals: ArrivalWatch | None = None   # waiting at the meeting point: who arrives
    near: bool = False                  # driving alone to the visitor: came within watch_within of the target


class NavigationCore:
    """Runs the head of this robot's pending list (Algorithm 1)."""

    def __init__(self, building: Building, cfg: NavigationConfig, log: Logger, now_wall: float) -> None:
        robot = building.find_robot(cfg.robot)
        if robot is None:
            raise GuidingError(f"robot {cfg.robot!r} is not in building {building.id} "
                               f"({', '.join(r.name for r in building.robots)})")
        self.building = building
        self.cfg = cfg
        self.robot = robot
        self.me = robot.name
        self.floor = robot.floor
        self.log = log
        self.warn = RateLimitedLog(log)
        self.uids = UidMaker(self.me, "nav")
        self.gate = Gate(Senders.of_building(building, self.me, cfg.simulated), log)
        self.liveness = PeerLiveness(cfg.offline_after, now_wall)
        self.tours = TourBook(building)
        self.stats = Counters()
        self.queue: list[Trip] = []
        self.leg: Leg | None = None
        self.available = False                  # the move_base action server is connected
        self.pose: Pose2D | None = None
        self._pose_sent: Pose2D | None = None   # the last pose published on /gidabot/poses
        self._pose_ticks = 0                    # pose timer ticks since then
        self.linear = 0.0
        self.angular = 0.0
        self.battery = -1.0
        self._token = 0
        self._unavailable_since: float | None = None
        self._finished = SeenSet()
        self._cancelled = SeenSet()
        self._cancels_seen = HandledUids()
        self._events_seen = HandledUids()
        self._early_continue: set[str] = set()
        self._commands_seen = SeenSet()     # CommandData.key of the Continues handled
        self._releases: OrderedDict[str, tuple[str, float]] = OrderedDict()   # goal uid -> (robot, ROS s)
        self._eta_last = 0.0
        self._eta_at = 0.0
        self.way = MakeWay(building, robot.name, log)
        self.mates: dict[str, Mate] = {}        # the other robots of this floor, as their statuses show them
        self._asked_way: tuple | None = None    # the leg's way (trip, stage, target) whose ask was sent (None: none)
        self._asking = False                    # the last ask sent named robots
        self._asked_at = 0.0                    # ROS s of the last look at who is in the way
        self._asked_robots: tuple[str, ...] = ()
        self._way_token: int | None = None      # the make-way move running (None: none)
        self.relocks = 0                    # times pacing asked for the visitor's track anew
        self.pace_done: list[tuple[str, str, dict[str, float]]] = []   # (trip uid, leg, stats) of ended guided legs

    # ------------------------------------------------------------------ sensor-like inputs
    def on_pose(self, x: float, y: float, yaw: float) -> None:
        if all(isinstance(v, (int, float)) and math.isfinite(v) for v in (x, y, yaw)):
            self.pose = Pose2D(float(x), float(y), float(yaw))
            if self.leg is not None:
                self._near(self.leg)

    def _near(self, leg: Leg) -> None:
        """Mark ``leg`` near once the robot is within ``watch_within`` m of its target (:attr:`wants_people`)."""
        if not leg.near and self.pose is not None and self.pose.distance_to(leg.target) <= self.cfg.watch_within:
            leg.near = True

    def pose_to_publish(self) -> Pose2D | None:
        """At a tick of the pose timer: the pose to publish on ``/gidabot/poses``, or None (not localised yet, or
        it has not moved since the last one and that was less than ``pose_keepalive`` ticks ago)."""
        if self.pose is None:
            return None
        self._pose_ticks += 1
        last = self._pose_sent
        if (last is not None and self._pose_ticks < self.cfg.pose_keepalive
                and self.pose.distance_to(last) < self.cfg.pose_min_move
                and abs(math.remainder(self.pose.yaw - last.yaw, math.tau)) < self.cfg.pose_min_turn):
            return None
        self._pose_sent, self._pose_ticks = self.pose, 0
        return self.pose

    def on_odom(self, linear: float, angular: float) -> None:
        if all(isinstance(v, (int, float)) and math.isfinite(v) for v in (linear, angular)):
            self.linear, self.angular = float(linear), float(angular)

    def on_battery(self, fraction: float) -> None:
        if isinstance(fraction, (int, float)) and math.isfinite(fraction):
            self.battery = min(1.0, max(0.0, float(fraction)))

    def on_status(self, robot: str, now_wall: float, *, sender: str) -> bool:
        """A RobotStatus of ``robot`` published by ``sender``: that robot is online. True when admitted (then
        the node hands the status to :meth:`on_mate`)."""
        if not self.gate.admit(sender, Claim(as_text(robot)), "status") or self.building.find_robot(robot) is None:
            return False
        self.liveness.heard(robot, now_wall)
        return True

    def on_mate(self, status: RobotStatusData) -> None:
        """A robot's status: the robots of this floor, where they are and whether they are idle (make way)."""
        other = self.building.find_robot(status.robot) if isinstance(status.robot, str) else None
        if other is None or other.name == self.me or not same_floor(other.floor, self.floor) \
                or not (math.isfinite(status.x) and math.isfinite(status.y)):
            return
        self.mates[other.name] = Mate(other.name, status.x, status.y, other.radius, status.state == RobotState.IDLE)
        self.way.on_asker_pose(other.name, status.x, status.y)

    def on_make_way(self, ask: WayAsk, now_ros: float, *, sender: str) -> None:
        """An ask to make way (gidabot_msgs/MakeWay) published by ``sender``: it speaks only for its sender's robot;
        this robot's own ask, heard back, is ignored."""
        if not self.gate.admit(sender, Claim(as_text(ask.robot)), "make_way"):
            return
        try:
            ask = validate_ask(self.building, ask)
        except GoalRejected as err:
            self.stats.inc(f"rejected_{err.reason}")
            self.warn.warning("make_way", f"make_way rejected: {err}")
            return
        if ask.robot != self.me:
            self.way.on_ask(ask, now_ros)

    def on_catalog(self, entries: Iterable[TourMessage], *, sender: str) -> None:
        """The tour store's catalog (published by ``sender``: only this robot's tour store's is taken)."""
        if not self.gate.only(sender, Node.TOUR_STORE, "tour catalog"):
            return
        for problem in self.tours.update(entries):
            self.warn.warning("catalog", problem)

    # ------------------------------------------------------------------ events
    def on_move_base_available(self, available: bool, now_ros: float) -> None:
        if available:
            self._unavailable_since = None
        elif self.available or self._unavailable_since is None:
            self._unavailable_since = now_ros
        self.available = available

    def on_pending(self, goals: Sequence[Trip], eta_last: float, now_ros: float, now_wall: float, *, robot: str,
                   sender: str) -> list[Action]:
        """The pending list of ``robot`` published by ``sender``: this robot's list from its goal manager is the
        queue to run; another robot's is not this node's business; any other publisher is refused."""
        if robot != self.me:
            return []
        if not self.gate.only(sender, Node.GOAL_MANAGER, "pending list"):
            return []
        self.queue = list(goals)
        self._eta_last = eta_last if math.isfinite(eta_last) else 0.0
        self._eta_at = now_ros
        actions: list[Action] = []
        leg = self.leg
        newest = next((t for t in self.queue if leg is not None and t.uid == leg.trip.uid), None)
        if leg is not None and (newest is None or newest.committed(newest.leg_of(self.me) or "") != self.me):
            self.log.info(f"{leg.trip.uid} left the pending list (or no longer names {self.me}); stopping it")
            actions += self._stop(leg)
            self._finish(leg.trip)
        elif leg is not None and newest is not None:
            leg.trip = newest             # the newest assignment: who serves the other leg
            leg.partner = self._partner(newest, leg.role)
            if leg.stage is Stage.HANDOVER:
                actions += self._hand_over(leg, now_ros)
        return actions + self._advance(now_ros, now_wall)

    def on_cancel(self, cancel: CancelData, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """A Cancel (from this robot or another) published by ``sender``: stop the trip at once if it runs here."""
        if not self.gate.admit(sender, Claim(as_text(cancel.origin_robot), as_text(cancel.uid)), "cancel"):
            return []
        try:
            cancel = validate_cancel(self.building, cancel)
        except GoalRejected as err:
            self.stats.inc(f"rejected_{err.reason}")
            self.gate.refuse(INVALID, f"cancel {as_text(cancel.uid)[:80]!r}: {err}")
            return []
        digest = cancel_digest(cancel)
        if self.gate.conflict(self._cancels_seen, cancel.uid, digest, "cancel") \
                or not self._cancels_seen.add(cancel.uid, digest):
            return []
        self._cancelled.add(cancel.goal_uid)
        self._early_continue.discard(cancel.goal_uid)
        leg = self.leg
        if leg is None or leg.trip.uid != cancel.goal_uid:
            return []
        self.log.info(f"{leg.trip.uid} cancelled by {cancel.origin_robot} ({cancel.reason}); stopping")
        actions = self._stop(leg)
        self._finish(leg.trip)
        return actions + self._advance(now_ros, now_wall)

    def on_command(self, cmd: CommandData, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """A visitor command at this robot published by ``sender``: a Continue (:meth:`on_continue`); the others
        are the goal manager's."""
        if cmd.command != Cmd.CONTINUE:
            return []
        return self.on_continue(cmd.goal_uid, now_ros, now_wall, key=cmd.key, sender=sender)

    def on_continue(self, goal_uid: str, now_ros: float, now_wall: float, key: str = "", *,
                    sender: str) -> list[Action]:
        """The visitor pressed Continue at this robot (``goal_uid`` "" = the trip waiting here): a VisitorCommand
        published by ``sender``, which must be this robot's GUI or visitor.

        ``key`` (:attr:`CommandData.key`): a Continue replayed to a restarted node is ignored."""
        if not self.gate.admit(sender, Claim(self.me), "Continue") or not isinstance(goal_uid, str):
            return []
        if key and not self._commands_seen.add(key):
            self.stats.inc("duplicate_commands")
            return []
        leg = self.leg
        if leg is not None and leg.role is Role.GOAL and leg.stage in (Stage.TO_MEETING, Stage.WAITING) \
                and goal_uid in ("", leg.trip.uid):
            if leg.stage is Stage.WAITING:
                return self._go_on(leg, now_ros)
            leg.continued = True          # the visitor is already here: go on as soon as we arrive
            return []
        if goal_uid and any(t.uid == goal_uid and role(t, self.me) is Role.GOAL for t in self.queue):
            self._early_continue.add(goal_uid)
        return []

    def on_nav_event(self, ev: NavEventData, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """Any robot's NavEvent published by ``sender``: a start robot's GO_TO_FLOOR releases the visitor towards
        this floor."""
        if not self.gate.admit(sender, Claim(as_text(ev.robot), as_text(ev.uid)), "nav event"):
            return []
        try:
            ev = validate_event(self.building, ev)
        except GoalRejected as err:
            self.stats.inc(f"rejected_{err.reason}")
            self.gate.refuse(INVALID, f"nav event {as_text(ev.uid)[:80]!r}: {err}")
            return []
        digest = nav_event_digest(ev)
        if self.gate.conflict(self._events_seen, ev.uid, digest, "nav event") \
                or not self._events_seen.add(ev.uid, digest):
            return []
        if ev.phase in RELEASE_PHASES and ev.goal_uid and ev.robot != self.me:
            self._releases[ev.goal_uid] = (ev.robot, now_ros)
            while len(self._releases) > 1000:
                self._releases.popitem(last=False)
        return []

    def on_move_base_result(self, token: int, status: str, text: str, now_ros: float,
                            now_wall: float, done_ros: float | None = None) -> list[Action]:
        """The move_base goal ``token`` ended with ``status`` (SUCCEEDED, ABORTED, ...). ``done_ros``: when move_base
        ended it (its result's stamp; None: ``now_ros``): the events that end the guiding carry it, so the time the
        result took to get here is not counted as guiding (Table 5)."""
        if token == self._way_token:
            self._way_token = None
            self.way.arrived(status == SUCCEEDED)
            return []
        leg = self.leg
        if leg is None or token != leg.token or not leg.moving:
            self.stats.inc("stale_results")
            return []
        leg.moving = False
        if leg.detour:                  # a pacing goal (turned to the visitor, reached the search place): never fails
            leg.detour = False
            if leg.pacer is not None and leg.pacer.pace is Pace.SEARCH:
                return self._apply_pace(leg, leg.pacer.on_search_arrived(now_ros), now_ros) \
                    + self._advance(now_ros, now_wall)
            return []
        if status == SUCCEEDED:
            ended = now_ros if done_ros is None else min(done_ros, now_ros)
            return self._arrived(leg, now_ros, ended) + self._advance(now_ros, now_wall)
        what = {Stage.PICKUP: "to the visitor", Stage.GUIDING: f"to {self._where(leg)}",
                Stage.TO_MEETING: f"to the meeting point of {leg.trip.connector}"}.get(leg.stage, "")
        reason = f"move_base {status} on the way {what}" + (f": {text[:200]}" if text else "")
        if status in (PREEMPTED, RECALLED):
            reason += " (another client took over move_base)"
        return self._fail(leg, reason, now_ros) + self._advance(now_ros, now_wall)

    def on_visitor(self, report: VisitorReport, now_ros: float, now_wall: float, *, sender: str) -> list[Action]:
        """What the robot's laser knows of the visitor it guides (after a scan), published by ``sender``: only this
        robot's people node is heard."""
        if not self.gate.only(sender, Node.PEOPLE, "visitor track"):
            return []
        leg = self.leg
        if leg is None or leg.pacer is None or leg.stage is not Stage.GUIDING:
            return []
        if self.pose is not None:
            leg.pacer.on_robot(self.pose)
        return self._apply_pace(leg, leg.pacer.on_visitor(report, now_ros), now_ros) + self._advance(now_ros, now_wall)

    def on_people(self, tracks: Sequence[Track], now_ros: float, *, sender: str) -> list[Action]:
        """The people the robot's laser sees, published by ``sender`` (only this robot's people node is heard): at the
        meeting point, someone arriving is asked to press Continue."""
        if not self.gate.only(sender, Node.PEOPLE, "people tracks"):
            return []
        leg = self.leg
        if leg is None or leg.arrivals is None or leg.stage is not Stage.WAITING or leg.continued \
                or self.pose is None:
            return []
        ask = leg.arrivals.on_people(self.pose, tracks, now_ros)
        if ask is None:
            return []
        self.stats.inc("meeting_prompts")
        return [self._event(Phase.PRESS_CONTINUE, leg.trip, now_ros, location_id=leg.trip.connector,
                            detail=f"someone is at the meeting point ({ask}): asked to press Continue")]

    @property
    def speed_cap(self) -> float | None:
        """m/s: the most the robot may drive now (None: its own limits)."""
        leg = self.leg
        if leg is None or leg.pacer is None or leg.stage is not Stage.GUIDING or leg.pacer.pace is not Pace.SLOW:
            return None
        return leg.pacer.cfg.slow_speed

    @property
    def wants_people(self) -> bool:
        """Whether the people around the robot should be watched now: while it guides or waits with a leg (someone
        arriving at a meeting point is seen), and driving alone to meet its visitor once it came within
        ``watch_within`` m of that place (the tracks are warm when guiding starts; from then on for the whole leg,
        a path that winds away again does not stop and start the laser). Idle, or driving alone farther away,
        the laser need not be read (a simulated laser not read costs its simulator no rays)."""
        leg = self.leg
        if leg is None:
            return False
        return leg.near or leg.stage not in (Stage.PICKUP, Stage.TO_MEETING) or self.pose is None

    @property
    def wants_visitor(self) -> bool:
        """Whether the visitor's track should be locked now (guiding with pacing)."""
        leg = self.leg
        return leg is not None and leg.pacer is not None and leg.stage is Stage.GUIDING \
            and leg.pacer.pace is not Pace.LOST

    def tick(self, now_ros: float, now_wall: float) -> list[Action]:
        """Timeouts (Continue, partner offline, navigation lost, the visitor's pace) and starting the next trip."""
        actions: list[Action] = []
        leg = self.leg
        if leg is not None and leg.pacer is not None and leg.stage is Stage.GUIDING:
            if self.pose is not None:
                leg.pacer.on_robot(self.pose)
            actions += self._apply_pace(leg, leg.pacer.step(now_ros), now_ros)
        leg = self.leg
        if leg is not None and leg.resend and self.available:
            leg.resend = False
            if leg.moving:
                self.log.info(f"{leg.trip.uid}: resuming the {leg.stage.value} leg after a restart")
                self._next_move(leg, leg.stage, leg.target)
                actions.append(self._move(leg))
        leg = self.leg
        if leg is not None and leg.stage is Stage.WAITING and not leg.continued:
            start = self._timer_start(leg)
            if start is not None and now_ros - start >= self.cfg.continue_timeout:
                actions += self._timeout(leg, now_ros)
        leg = self.leg
        if leg is not None:
            actions += self._check_partner(leg, now_ros, now_wall)
        leg = self.leg
        if leg is not None and leg.moving and not self.available and self._unavailable_since is not None \
                and now_ros - self._unavailable_since >= self.cfg.nav_lost_timeout:
            actions += self._fail(leg, f"the navigation stack (move_base) is gone for "
                                       f"{now_ros - self._unavailable_since:.0f} s", now_ros)
        actions += self._advance(now_ros, now_wall)
        return actions + self._make_way(now_ros)

    def _make_way(self, now_ros: float) -> list[Action]:
        """Asking for the way as a leg starts driving to its target, and again when more robots stand in it (one
        that made way for another came back; looked at every :data:`ASK_PERIOD` s while it drives); ending the ask
        when the leg has another target or ends; making way when idle.

        A robot asked stays asked until then (or until it sees this robot pass it), whether or not it is still in
        the way: released once it stood aside, or while this robot waits for its visitor or turns to look for
        them, it would go back into the way before this robot passed, be asked again, and so on for ever."""
        actions: list[Action] = []
        leg = self.leg
        way = (leg.trip.uid, leg.stage, leg.target) if leg is not None else None
        if way is not None and leg is not None and leg.moving and not leg.detour and self.pose is not None \
                and (way != self._asked_way or now_ros - self._asked_at >= ASK_PERIOD):
            first = way != self._asked_way
            self._asked_way, self._asked_at = way, now_ros
            ask = self.way.asks_for((self.pose.x, self.pose.y), (leg.target.x, leg.target.y),
                                    list(self.mates.values()), now_ros)
            kept = () if first else self._asked_robots
            robots = tuple(dict.fromkeys((*kept, *(ask.robots if ask is not None else ()))))
            if ask is not None and (first or robots != self._asked_robots):
                self._asking = True
                actions.append(SendAsk(replace(ask, robots=robots)))
            elif first and ask is None and self._asking:
                self._asking = False
                actions.append(SendAsk(self.way.end_ask(now_ros)))
            self._asked_robots = robots
        elif self._asking and way != self._asked_way:
            self._asking = False
            self._asked_way, self._asked_robots = None, ()
            actions.append(SendAsk(self.way.end_ask(now_ros)))
        if leg is not None:
            if self._way_token is not None or self.way.aside is not None:
                self.way.drop()
                self._way_token = None
            return actions
        target = self.way.step(self.pose, self.available, now_ros)
        if target is not None:
            self._token += 1
            self._way_token = self._token
            actions.append(MoveTo(self._token, target.x, target.y, target.yaw))
        return actions

    # ------------------------------------------------------------------ restarts
    @staticmethod
    def durable(actions: list[Action]) -> list[Action]:
        """The actions a restarted node must still carry out (kept with the state until published): the events
        and cancels; move_base goals follow from the state again."""
        return [a for a in actions if isinstance(a, (SendEvent, SendCancel))]

    def state(self, remember: int = REMEMBERED_UIDS) -> dict[str, Any]:
        """What a restarted navigation needs (JSON-able): the running leg, the handled uids, releases."""
        leg = self.leg
        return {
            "queue": [trip_to_dict(t) for t in self.queue],
            "leg": None if leg is None else {
                "trip": trip_to_dict(leg.trip), "role": leg.role.value, "stage": leg.stage.value,
                "target": [leg.target.x, leg.target.y, leg.target.yaw], "moving": leg.moving,
                "arrived_at": leg.arrived_at, "continued": leg.continued, "partner": leg.partner,
                "started": leg.started},
            "token": self._token,
            "finished": self._finished.recent(remember), "cancelled": self._cancelled.recent(remember),
            "cancels_seen": self._cancels_seen.recent(remember), "events_seen": self._events_seen.recent(remember),
            "commands_seen": self._commands_seen.recent(remember),
            "early_continue": sorted(self._early_continue),
            "releases": [[uid, r, t] for uid, (r, t) in self._releases.items()][-remember:],
            "stats": dict(self.stats),
        }

    def load_state(self, state: dict[str, Any]) -> None:
        """Resume from :meth:`state` of a previous run: the leg goes on (its move_base goal is sent again
        once move_base is there). Raises GuidingStateError, changing nothing, if the state is damaged."""
        try:
            self._load_state(state)
        except (TypeError, ValueError, KeyError, IndexError, AttributeError) as err:
            raise GuidingStateError(f"navigation state: {err!r}") from err

    def _load_state(self, state: dict[str, Any]) -> None:
        queue = [trip_from_dict(t) for t in state.get("queue", [])]
        raw = state.get("leg")
        leg = None
        if raw is not None:
            x, y, yaw = (number(v, "leg target") for v in raw["target"])
            arrived = raw.get("arrived_at")
            arrived_at = None if arrived is None else number(arrived, "arrived")
            leg = Leg(trip_from_dict(raw["trip"]), Role(raw["role"]), Stage(raw["stage"]), 0, Pose2D(x, y, yaw),
                      moving=bool(raw.get("moving")), arrived_at=arrived_at,
                      continued=bool(raw.get("continued")),
                      partner=raw["partner"] if isinstance(raw.get("partner"), str) else None,
                      started=number(raw.get("started", 0.0), "started"), resend=True)
        seen: dict[str, list] = {name: str_list(state.get(name, []), name) for name in
                                 ("finished", "cancelled", "commands_seen", "early_continue")}
        seen.update({name: uid_records(state.get(name, []), name) for name in ("cancels_seen", "events_seen")})
        releases = [(str(r[0]), str(r[1]), number(r[2], "release")) for r in state.get("releases", [])]
        token = int(number(state.get("token", 0), "token"))
        self.queue = queue
        self._token = token
        if leg is not None:
            self._token += 1
            leg.token = self._token
        self.leg = leg
        for name in ("finished", "cancelled", "cancels_seen", "events_seen", "commands_seen"):
            getattr(self, f"_{name}").update(seen[name])
        self._early_continue = set(seen["early_continue"])
        for uid, robot, t in releases:
            self._releases[uid] = (robot, t)
        stats = state.get("stats", {})
        if isinstance(stats, dict):
            self.stats.update({str(k): v for k, v in stats.items() if isinstance(v, int)})

    # ------------------------------------------------------------------ outputs
    def status(self, now_ros: float) -> RobotStatusData:
        pose = self.pose or self.robot.home
        leg = self.leg
        if not self.available:
            state = RobotState.ERROR
        elif leg is None:
            state = RobotState.IDLE
        else:
            state = STATE_OF_STAGE[leg.stage]
        pending = sum(1 for t in self.queue if t.uid not in self._finished and t.uid not in self._cancelled)
        busy = max(0.0, self._eta_last - max(0.0, now_ros - self._eta_at)) if pending else 0.0
        return RobotStatusData(self.me, self.floor, pose.x, pose.y, pose.yaw, self.linear, self.angular, self.battery,
                               state, min(pending, 255), leg.trip.uid if leg else "", round(busy, 1), now_ros)

    # ------------------------------------------------------------------ the state machine
    def _advance(self, now_ros: float, now_wall: float) -> list[Action]:
        actions: list[Action] = []
        while self.leg is None and self.available:
            trip = next((t for t in self.queue if t.uid not in self._finished and t.uid not in self._cancelled
                         and t.committed(t.leg_of(self.me) or "") == self.me), None)
            if trip is None:
                break
            actions += self._start(trip, now_ros)
        return actions

    def _partner(self, trip: Trip, r: Role) -> str | None:
        """The robot serving the other leg of a cross-floor trip, once committed (None: none, or not yet)."""
        other = {Role.START: LEG_GOAL, Role.GOAL: LEG_START}.get(r)
        return (trip.committed(other) or None) if other is not None else None

    def _start(self, trip: Trip, now_ros: float) -> list[Action]:
        r = role(trip, self.me)
        if r is None:
            self._finished.add(trip.uid)
            return []
        partner_name = self._partner(trip, r)
        if r is Role.GOAL:
            meet = self._meeting(trip)
            if meet is None:
                return self._fail_unstarted(trip, r, f"connector {trip.connector!r} has no meeting point on floor "
                                                     f"{format_floor(self.floor)}", now_ros)
            leg = self._new_leg(trip, r, Stage.TO_MEETING, meet, partner_name, now_ros)
            leg.continued = trip.uid in self._early_continue
            return [self._move(leg), self._event(Phase.GOING_TO_MEETING, trip, now_ros, location_id=trip.connector)]
        target = Pose2D(trip.goal_x, trip.goal_y, trip.goal_yaw) if r is Role.SAME else self._meeting(trip)
        if target is None:
            return self._fail_unstarted(trip, r, f"connector {trip.connector!r} has no meeting point on floor "
                                                 f"{format_floor(self.floor)}", now_ros)
        pickup = Pose2D(trip.initial_x, trip.initial_y, self.pose.yaw if self.pose else 0.0)
        if self.pose is not None and self.pose.distance_to(pickup) > self.cfg.pickup_distance:
            leg = self._new_leg(trip, r, Stage.PICKUP, pickup, partner_name, now_ros)
            return [self._move(leg), self._event(Phase.GOING_TO_MEETING, trip, now_ros, location_id=trip.start_id,
                                                 detail="picking the visitor up where the request was made")]
        leg = self._new_leg(trip, r, Stage.GUIDING, target, partner_name, now_ros)
        return [self._move(leg), self._event(Phase.ON_THE_WAY, trip, now_ros, location_id=self._where(leg))]

    def _arrived(self, leg: Leg, now_ros: float, ended: float) -> list[Action]:
        """Leg ``leg`` reached its target at sim time ``ended`` (known at ``now_ros``)."""
        trip = leg.trip
        if leg.stage is Stage.PICKUP:
            target = Pose2D(trip.goal_x, trip.goal_y, trip.goal_yaw) if leg.role is Role.SAME else self._meeting(trip)
            assert target is not None
            self._next_move(leg, Stage.GUIDING, target, now_ros)
            return [self._move(leg), self._event(Phase.ON_THE_WAY, trip, now_ros, location_id=self._where(leg))]
        if leg.stage is Stage.TO_MEETING:
            leg.stage = Stage.WAITING
            leg.arrived_at = now_ros
            leg.arrivals = ArrivalWatch(self.cfg.arrival)
            actions: list[Action] = [self._event(Phase.WAITING_VISITOR, trip, now_ros, location_id=trip.connector)]
            if leg.continued:
                actions += self._go_on(leg, now_ros)
            return actions
        # GUIDING: this robot's part is done
        if leg.role is Role.START:
            leg.stage = Stage.HANDOVER
            return self._hand_over(leg, ended)
        self._finish(trip)
        return [self._event(self._done_phase(trip), trip, ended)]

    def _hand_over(self, leg: Leg, now_ros: float) -> list[Action]:
        """Start floor, at the connector with the visitor: send the visitor on to the robot serving the goal leg
        (GO_TO_FLOOR), or alone to a floor without robot (NO_ROBOT_ON_FLOOR; TOUR_FINISHED when the tour ends on
        such floors). A goal leg still being assigned: wait with the visitor until it is committed."""
        trip = leg.trip
        if trip.goal_state == LEG_NONE:
            self._finish(trip)
            floor = format_floor(trip.goal_floor)
            tour = self.tours.get(trip.tour_file) if trip.tour_file else None
            if tour is not None and next_robot_stop(tour, self.building, trip.tour_step) is None:
                return [self._event(Phase.TOUR_FINISHED, trip, now_ros,
                                    detail=f"no robot serves floor {floor}: the visitor finds {trip.goal_id} "
                                           "and the tour's last stops alone; the tour ends there")]
            return [self._event(Phase.NO_ROBOT_ON_FLOOR, trip, now_ros,
                                detail=f"no robot serves floor {floor}: take the {trip.way} "
                                       f"({self._connector_name(trip)}) to floor {floor} and find {trip.goal_id} "
                                       "yourself")]
        if trip.goal_state != LEG_COMMITTED:
            if leg.arrived_at is None:
                leg.arrived_at = now_ros
                return [self._event(Phase.PARTNER_LOST, trip, now_ros, location_id=trip.connector,
                                    detail=f"waiting with the visitor until a robot of floor "
                                           f"{format_floor(trip.goal_floor)} takes the goal leg")]
            return []
        self._finish(trip)
        return [self._event(Phase.GO_TO_FLOOR, trip, now_ros, assignee=trip.goal_robot)]

    def _go_on(self, leg: Leg, now_ros: float) -> list[Action]:
        """Goal floor: the visitor is here; guide to the goal."""
        leg.continued = True
        self._early_continue.discard(leg.trip.uid)
        self._next_move(leg, Stage.GUIDING, Pose2D(leg.trip.goal_x, leg.trip.goal_y, leg.trip.goal_yaw), now_ros)
        return [self._move(leg), self._event(Phase.ON_THE_WAY, leg.trip, now_ros, location_id=leg.trip.goal_id)]

    def _timer_start(self, leg: Leg) -> float | None:
        """ROS s from which the Continue timeout runs: at the meeting point and the visitor released (a trip from a
        floor without robot: from the arrival)."""
        if leg.arrived_at is None:
            return None
        start_robot = leg.trip.committed(LEG_START)
        if leg.trip.start_state == LEG_NONE or start_robot == self.me:
            return leg.arrived_at
        release = self._releases.get(leg.trip.uid)
        if release is None or release[0] != start_robot:
            return None
        return max(leg.arrived_at, release[1])

    def _released(self, trip: Trip) -> bool:
        release = self._releases.get(trip.uid)
        return release is not None and bool(trip.committed(LEG_START)) and release[0] == trip.committed(LEG_START)

    def _timeout(self, leg: Leg, now_ros: float) -> list[Action]:
        trip = leg.trip
        detail = f"nobody pressed Continue at {trip.connector} within {self.cfg.continue_timeout:g} s"
        self.log.warning(f"{trip.uid}: {detail}; dropped")
        self.stats.inc("timeouts")
        self._finish(trip)
        return [self._event(Phase.TIMEOUT, trip, now_ros, location_id=trip.connector, detail=detail),
                SendCancel(self._cancel(trip, REASON_TIMEOUT, detail, now_ros))]

    def _check_partner(self, leg: Leg, now_ros: float, now_wall: float) -> list[Action]:
        if leg.partner is None:
            return []
        if leg.role is Role.START:
            needed = leg.stage in (Stage.PICKUP, Stage.GUIDING, Stage.HANDOVER)
        else:
            needed = not leg.continued and not self._released(leg.trip)
        if not needed:
            if leg.partner_lost is None:
                return []
            leg.partner_lost = None          # the visitor was released / is here: the trip goes on
            return [self._event(Phase.PARTNER_BACK, leg.trip, now_ros, assignee=leg.partner, detail="the trip goes on")]
        if self.liveness.online(leg.partner, now_wall):
            if leg.partner_lost is None:
                return []
            leg.partner_lost = None
            return [self._event(Phase.PARTNER_BACK, leg.trip, now_ros, assignee=leg.partner,
                                detail=f"{leg.partner} is back; the trip goes on")]
        actions: list[Action] = []
        if leg.partner_lost is None:
            leg.partner_lost = self.liveness.offline_since(leg.partner, now_wall) or now_wall
            wait = f"; waiting up to {self.cfg.partner_timeout:g} s for it" if leg.role is Role.GOAL else ""
            actions.append(self._event(Phase.PARTNER_LOST, leg.trip, now_ros, assignee=leg.partner,
                                       detail=f"{leg.partner} is offline{wait}"))
        if leg.role is Role.GOAL and now_wall - leg.partner_lost >= self.cfg.partner_timeout:
            detail = f"{leg.partner} has been offline for {now_wall - leg.partner_lost:.0f} s; the trip is given up"
            self.log.warning(f"{leg.trip.uid}: {detail}")
            actions += self._stop(leg)
            self._finish(leg.trip)
            actions += [self._event(Phase.PARTNER_OFFLINE, leg.trip, now_ros, assignee=leg.partner, detail=detail),
                        SendCancel(self._cancel(leg.trip, REASON_OFFLINE, detail, now_ros))]
        return actions

    def _fail(self, leg: Leg, detail: str, now_ros: float) -> list[Action]:
        """Navigation failed: UNREACHABLE here, and every other robot drops the trip too."""
        self.log.warning(f"{leg.trip.uid}: {detail}")
        self.stats.inc("unreachable")
        actions = self._stop(leg)
        self._finish(leg.trip)
        return actions + [self._event(Phase.UNREACHABLE, leg.trip, now_ros, location_id=self._where(leg),
                                      detail=detail),
                          SendCancel(self._cancel(leg.trip, REASON_UNREACHABLE, f"{self.me}: {detail}", now_ros))]

    def _fail_unstarted(self, trip: Trip, r: Role, detail: str, now_ros: float) -> list[Action]:
        self.log.warning(f"{trip.uid}: {detail}")
        self._finish(trip)
        return [self._event(Phase.UNREACHABLE, trip, now_ros, detail=detail),
                SendCancel(self._cancel(trip, REASON_UNREACHABLE, f"{self.me}: {detail}", now_ros))]

    # ------------------------------------------------------------------ helpers
    def refusals(self) -> dict[str, int]:
        """Messages refused so far, by kind (impostor, foreign, wrong_namespace, conflict, invalid)."""
        return self.gate.refusals()

    def _new_leg(self, trip: Trip, r: Role, stage: Stage, target: Pose2D, partner: str | None,
                 now_ros: float) -> Leg:
        self._token += 1
        self.leg = Leg(trip, r, stage, self._token, target, partner=partner, started=now_ros)
        self._near(self.leg)
        self._pace(self.leg, now_ros)
        return self.leg

    def _next_move(self, leg: Leg, stage: Stage, target: Pose2D, now_ros: float | None = None) -> None:
        self._token += 1
        leg.token, leg.stage, leg.target, leg.moving, leg.detour = self._token, stage, target, True, False
        self._pace(leg, now_ros if now_ros is not None else leg.started)

    def _pace(self, leg: Leg, now_ros: float) -> None:
        """A guided move begins: pace it (once per leg; the visitor's track is locked from now on)."""
        if leg.stage is Stage.GUIDING and leg.pacer is None and self.cfg.pacing is not None:
            leg.pacer = Pacer(self.cfg.pacing)
            leg.pacer.start(now_ros)

    def _apply_pace(self, leg: Leg, d: Decision | None, now_ros: float) -> list[Action]:
        """Carry out a pacing decision on the guided leg ``leg``."""
        if d is None or self.leg is not leg:
            return []
        pacer = leg.pacer
        assert pacer is not None
        actions: list[Action] = []
        if d.relock:
            self.relocks += 1
        if d.pace is Pace.LOST:
            seen = pacer.last_seen or self.pose or leg.target
            detail = (f"the visitor was not found again within {pacer.cfg.search_for:g} s; last seen at "
                      f"({seen.x:.1f}, {seen.y:.1f})")
            self.log.warning(f"{leg.trip.uid}: {detail}; the trip ends")
            actions += self._stop(leg)
            self._finish(leg.trip)
            return actions + [self._event(Phase.VISITOR_LOST, leg.trip, now_ros, detail=detail, x=seen.x, y=seen.y),
                              SendCancel(self._cancel(leg.trip, REASON_VISITOR_LOST, f"{self.me}: {detail}", now_ros))]
        if d.drive:
            if not leg.moving or leg.detour:
                actions += self._stop(leg)
                self._next_move(leg, Stage.GUIDING, leg.target, now_ros)
                actions.append(self._move(leg))
            if d.say is Say.FOLLOW:
                actions.append(self._event(Phase.FOLLOW_ME, leg.trip, now_ros, location_id=self._where(leg),
                                           detail="found again: the guiding goes on" if d.found_again
                                           else "the visitor is close again: the guiding goes on"))
            return actions
        pose = self.pose
        goal: Pose2D | None = None
        if d.search_at is not None and d.look_yaw is None:
            start = pose or d.search_at
            goal = Pose2D(d.search_at.x, d.search_at.y,
                          math.atan2(d.search_at.y - start.y, d.search_at.x - start.x))
        elif d.look_yaw is not None and pose is not None:
            goal = Pose2D(pose.x, pose.y, d.look_yaw)
        elif d.face is not None and pose is not None:
            goal = Pose2D(pose.x, pose.y, math.atan2(d.face[1] - pose.y, d.face[0] - pose.x))
        if goal is not None or d.pace is Pace.WAIT:
            actions += self._stop(leg)
        if goal is not None:
            self._token += 1
            leg.token, leg.moving, leg.detour = self._token, True, True
            actions.append(MoveTo(leg.token, goal.x, goal.y, goal.yaw))
        if d.say is Say.WAITING:
            actions.append(self._event(Phase.WAITING_FOR_YOU, leg.trip, now_ros, location_id=self._where(leg),
                                       detail=f"waiting for the visitor: {d.why or 'they fell behind or stopped'}"))
        elif d.say is Say.SEARCHING and d.search_at is not None:
            actions.append(self._event(Phase.SEARCHING_VISITOR, leg.trip, now_ros, location_id=self._where(leg),
                                       detail="going back to where the visitor was last seen",
                                       x=d.search_at.x, y=d.search_at.y))
        return actions

    def _move(self, leg: Leg) -> MoveTo:
        return MoveTo(leg.token, leg.target.x, leg.target.y, leg.target.yaw)

    def _stop(self, leg: Leg) -> list[Action]:
        if not leg.moving:
            return []
        leg.moving = False
        return [StopMoving(leg.token)]

    def _finish(self, trip: Trip) -> None:
        self._finished.add(trip.uid)
        self._early_continue.discard(trip.uid)
        if self.leg is not None and self.leg.trip.uid == trip.uid:
            self._pace_summary(self.leg)
            self.leg = None

    def _pace_summary(self, leg: Leg) -> None:
        if leg.pacer is None:
            return
        stats = leg.pacer.stats
        self.pace_done.append((leg.trip.uid, leg.trip.leg_of(self.me) or "", stats.as_dict()))
        del self.pace_done[:-100]
        leg.pacer = None
        for name in ("slowdowns", "waits", "searches", "lost", "found_again"):
            self.stats.inc(f"pace_{name}", getattr(stats, name))

    def _meeting(self, trip: Trip) -> Pose2D | None:
        conn = self.building.find_connector(trip.connector)
        return conn.meeting.get(self.floor) if conn is not None else None

    def _connector_name(self, trip: Trip) -> str:
        """The name of the trip's lift or staircase in the default language (details are English), else its id."""
        conn = self.building.find_connector(trip.connector)
        return conn.name(DEFAULT_LANGUAGE) if conn is not None else trip.connector

    def _where(self, leg: Leg) -> str:
        """Where the robot is going now: the connector of a start leg, else the goal."""
        if leg.stage is Stage.TO_MEETING or (leg.role is Role.START and leg.stage is Stage.GUIDING):
            return leg.trip.connector
        if leg.stage is Stage.PICKUP:
            return leg.trip.start_id
        return leg.trip.goal_id

    def _done_phase(self, trip: Trip) -> int:
        if not trip.tour_file:
            return Phase.GOAL_REACHED
        length = self.tours.length(trip.tour_file)
        return Phase.TOUR_FINISHED if length is not None and trip.tour_step >= length - 1 else Phase.TOUR_STEP_DONE

    def _cancel(self, trip: Trip, reason: str, detail: str, now_ros: float) -> CancelData:
        cancel = CancelData(uid=self.uids.cancel(), goal_uid=trip.uid, origin_robot=self.me, reason=reason,
                            detail=detail, stamp=now_ros)
        self._cancels_seen.add(cancel.uid, cancel_digest(cancel))
        self._cancelled.add(trip.uid)
        return cancel

    def _event(self, phase: int, trip: Trip, now_ros: float, **fields: object) -> SendEvent:
        ev = NavEventData(uid=self.uids.event(), robot=self.me, floor=self.floor, goal_uid=trip.uid, phase=phase,
                          language=trip.language, way=trip.way, connector=trip.connector,
                          target_floor=trip.goal_floor, location_id=trip.goal_id, tour_file=trip.tour_file,
                          tour_step=trip.tour_step, stamp=now_ros, leg=trip.leg_of(self.me) or "",
                          attempt=trip.attempt)
        if fields:
            ev = replace(ev, **fields)
        self._events_seen.add(ev.uid, own_event_digest(self.building, ev))
        self.stats.inc(f"events_{phase}")
        return SendEvent(ev)
