"""ROS adapter of multirobot navigation: the ``multirobot_navigation`` node (one per robot).

The logic lives in :mod:`gidabot_navigation.guiding.navigation` (ROS-free). Callbacks
only enqueue; one loop owns the core: it converts each input (:mod:`gidabot_navigation.ros.convert`),
hands it to the core, drives move_base (actionlib ActionClient, one goal handle per leg) and
publishes the events, the robot's status and pose.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, replace
from pathlib import Path

import actionlib
import rospy
from actionlib_msgs.msg import GoalStatus
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseWithCovarianceStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import Odometry
from sensor_msgs.msg import BatteryState
from std_msgs.msg import Bool, Float32

from gidabot_msgs.msg import (
    Cancel,
    MakeWay,
    NavEvent,
    NavPose,
    PendingRequests,
    PersonArray,
    RobotStatus,
    TourCatalog,
    VisitorCommand,
    VisitorTrack,
)
from gidabot_navigation.building.model import load_building
from gidabot_navigation.guiding.meeting import ArrivalConfig
from gidabot_navigation.guiding.messages import Action, MoveTo, PoseData, SendAsk, SendCancel, SendEvent, StopMoving
from gidabot_navigation.guiding.navigation import (
    ABORTED,
    LOST,
    PREEMPTED,
    RECALLED,
    REJECTED_BY_SERVER,
    SUCCEEDED,
    NavigationConfig,
    NavigationCore,
    freshest_time,
)
from gidabot_navigation.guiding.pacing import PacingConfig
from gidabot_navigation.guiding.state import DEFAULT_MAX_AGE, StateFile, default_state_dir
from gidabot_navigation.interface import Node, Topic
from gidabot_navigation.loop_meter import LoopMeter
from gidabot_navigation.ros import convert
from gidabot_navigation.ros.adapter import Inbox, carry_out, diagnostics, refusal_values, sender, simulated
from gidabot_navigation.ros.exit_guard import ExitGuard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.node_main import run_loop, run_node
from gidabot_navigation.ros.params import param_number, param_text, robot_params
from gidabot_navigation.ros.replay import DEFAULT_WINDOW, ReplayPublisher
from gidabot_navigation.ros.rospy_internals import connected_subscribers

QUEUE_SIZE = 2000
DURABLE_INPUTS = ("pending", "cancel", "event", "command", "result")   # may change the state kept across restarts
ACK_TIMEOUT = 3.0       # wall s: a move_base goal not acknowledged by then is sent again
ACK_RETRIES = 3
MAX_HANDLES = 16
LOOP_PERIOD = 0.2          # wall s: the loop runs at least this often (LoopMeter's nominal rate)
STATUS_WALL_PERIOD = 1.0   # wall s: a status at least this often, even when the sim clock is slow or stopped
STATES = {GoalStatus.SUCCEEDED: SUCCEEDED, GoalStatus.ABORTED: ABORTED, GoalStatus.REJECTED: REJECTED_BY_SERVER,
          GoalStatus.PREEMPTED: PREEMPTED, GoalStatus.RECALLED: RECALLED, GoalStatus.LOST: LOST}
STATE_NAMES = {v: k for k, v in vars(GoalStatus).items() if k.isupper() and isinstance(v, int)}


@dataclass(frozen=True)
class Params:
    building: str
    cfg: NavigationConfig
    status_rate: float
    pose_rate: float
    move_base: str
    frame_id: str
    state_dir: str = ""
    state_max_age: float = DEFAULT_MAX_AGE
    replay_window: float = DEFAULT_WINDOW

    @staticmethod
    def read() -> Params:
        building, robot = robot_params()
        cfg = NavigationConfig(robot=robot,
                               continue_timeout=param_number("~continue_timeout", 300.0),
                               partner_timeout=param_number("~partner_timeout", 120.0),
                               offline_after=param_number("~offline_after", 5.0),
                               pickup_distance=param_number("~pickup_distance", 1.5),
                               nav_lost_timeout=param_number("~nav_lost_timeout", 30.0), simulated=simulated(),
                               pacing=pacing_params(), arrival=arrival_params(),
                               watch_within=param_number("~watch_within", 8.0))
        return Params(building, cfg, param_number("~status_rate", 2.0),
                      param_number("~pose_rate", 5.0), param_text("~move_base", Topic.MOVE_BASE, required=True),
                      param_text("~frame_id", "map", required=True),
                      param_text("~state_dir", "") or default_state_dir(cfg.robot),
                      param_number("~state_max_age", DEFAULT_MAX_AGE),
                      param_number("~replay_window", DEFAULT_WINDOW, strict=False))


def config_params(prefix: str, defaults: object) -> dict[str, float | int]:
    """``~<prefix><field>`` for every field of the dataclass instance ``defaults`` (its value by default; whole
    fields stay whole)."""
    return {name: (int(param_number(f"~{prefix}{name}", value)) if isinstance(value, int)
                   else param_number(f"~{prefix}{name}", value))
            for name, value in vars(defaults).items()}


def pacing_params() -> PacingConfig | None:
    """``~pace`` (bool, true) and ``~pace_<bound>`` (every field of :class:`PacingConfig`, its default)."""
    if not bool(rospy.get_param("~pace", True)):
        return None
    return PacingConfig(**config_params("pace_", PacingConfig()))


def arrival_params() -> ArrivalConfig:
    """``~meeting_<field>``: every field of :class:`ArrivalConfig`, its default."""
    return ArrivalConfig(**config_params("meeting_", ArrivalConfig()))


class NavigationNode:
    """Runs the head of this robot's pending list through move_base (paper Algorithm 1).

    Action client:
      - ``move_base`` (move_base_msgs/MoveBaseAction; ``~move_base``; actionlib ActionClient, one
        handle per leg): every leg (pick-up, guiding, to the meeting point) is one goal in
        ``~frame_id``; ABORTED / REJECTED / LOST -> UNREACHABLE; a goal not acknowledged within 3 s
        is sent again.

    Subscribed topics:
      - ``/gidabot/pending`` (gidabot_msgs/PendingRequests): this robot's queue, only from its own
        ``goal_manager`` node.

    Every input is handed to the core with its publisher (the callerid): a message that is not its sender's to
    send (gidabot_navigation.senders) is refused and counted, never answered.
      - ``/gidabot/cancels`` (gidabot_msgs/Cancel): stop the running trip at once.
      - ``/gidabot/nav_events`` (gidabot_msgs/NavEvent): the start robot's GO_TO_FLOOR (starts the
        Continue timeout of the goal-floor robot).
      - ``/gidabot/status`` (gidabot_msgs/RobotStatus): partner liveness (wall time).
      - ``visitor/command`` (gidabot_msgs/VisitorCommand): CONTINUE at the meeting point (goal_uid of
        the trip, or "").
      - ``amcl_pose`` (geometry_msgs/PoseWithCovarianceStamped), ``odom`` (nav_msgs/Odometry),
        ``battery`` (sensor_msgs/BatteryState): for the status; the odometry's stamp is also the time of
        the events when it is ahead of the ROS time (``navigation.freshest_time``: a simulated ``/clock``
        ticks more coarsely than the simulator's steps).
      - ``tour_store/catalog`` (gidabot_msgs/TourCatalog): which tour step is the last.
      - ``people/visitor`` (gidabot_msgs/VisitorTrack): the visitor the robot guides, from its own laser (the
        ``people`` node): the visitor's pace (``guiding/pacing.py``).
      - ``people/tracks`` (gidabot_msgs/PersonArray): at the meeting point, someone arriving is asked to press
        Continue.

    Published topics (events: the last ``~replay_window`` s are sent again to a late subscriber):
      - ``/gidabot/nav_events`` (gidabot_msgs/NavEvent, event): ON_THE_WAY, GO_TO_FLOOR,
        GOING_TO_MEETING, WAITING_VISITOR, GOAL_REACHED, TOUR_STEP_DONE, TOUR_FINISHED, UNREACHABLE,
        NO_ROBOT_ON_FLOOR, TIMEOUT, PARTNER_LOST, PARTNER_BACK, PARTNER_OFFLINE.
      - ``/gidabot/cancels`` (gidabot_msgs/Cancel, event): when this robot gives a trip up
        (unreachable, timeout, offline), so the other robots drop it too.
      - ``/gidabot/status`` (gidabot_msgs/RobotStatus, state): at ``~status_rate`` (ROS time).
      - ``/gidabot/poses`` (gidabot_msgs/NavPose, state): at ``~pose_rate`` (ROS time), once localised, when the
        pose changed (at rest: every fifth tick; ``NavigationCore.pose_to_publish``).
      - ``/gidabot/make_way`` (gidabot_msgs/MakeWay, state): the idle robots of its floor it asks to make way along
        a leg's way (empty when the move ends); the asks of the others (relayed) make it step aside while idle.
      - ``/diagnostics``: ``guiding: navigation <robot>`` counters, 1 Hz wall; ``refused_<kind>``: the
        messages refused by kind (impostor, foreign, wrong_namespace, conflict, invalid); ``guiding: pace <robot>``
        once per guided leg that ended: the trip, the leg, the visitor's mean and worst distance behind, the time
        waiting for them, slow-downs, waits, searches, lost, found again.
      - ``people/visitor_lock`` (std_msgs/Bool, latched): lock the visitor's track while guiding (false then
        true: look for the visitor anew, when searching).
      - ``people/watch`` (std_msgs/Bool, latched): have the people around the robot watched, during a trip once
        near the visitor (``~watch_within``; the people node reads the laser only while this or the lock is true).
      - ``move_base/speed_limit`` (std_msgs/Float32, latched): m/s, the most the robot may drive now (0: its own
        limits). The simulator's move_base honours it; on a robot, a bridge sets the local planner's
        ``max_vel_x`` through dynamic_reconfigure.

    Parameters:
      - ``~building`` (str, required), ``~robot`` (str, required).
      - ``~continue_timeout`` (ROS s, 300): the goal-floor robot waits this long for Continue, counted
        from when it is at the meeting point and the start robot released the visitor.
      - ``~partner_timeout`` (wall s, 120): a goal-floor robot whose start robot stays offline gives up.
      - ``~offline_after`` (wall s, 5): a robot without status this long is offline.
      - ``~pickup_distance`` (m, 1.5): farther from the request point, the robot first picks the visitor up.
      - ``~watch_within`` (m, 8): driving alone to the request point or the meeting point, the robot has the
        people around it watched (``people/watch``) from this far from it on; guiding and waiting, always.
      - ``~nav_lost_timeout`` (ROS s, 30): move_base gone this long during a leg -> UNREACHABLE.
      - ``~pace`` (bool, true): guide at the visitor's pace; ``~pace_<bound>``: the bounds of
        ``guiding.pacing.PacingConfig`` (``near``, ``hysteresis``, ``far``, ``resume``, ``slow_speed``,
        ``still_speed``, ``still_for``, ``look_after``, ``lost_after``, ``wait_for``, ``search_for``, ``look_step``,
        ``look_turns``, ``relock_every``); ``~meeting_<field>``: ``guiding.meeting.ArrivalConfig``.
      - ``~status_rate`` (Hz, 2), ``~pose_rate`` (Hz, 5), ROS time.
      - ``~move_base`` (move_base), ``~frame_id`` (map).
      - ``~state_dir`` (str, '' = ``$ROS_HOME/gidabot/<robot>/guiding``): ``multirobot_navigation.json``
        there keeps the running leg and the handled uids across a restart (the leg goes on: its
        move_base goal is sent again); ``~state_max_age`` (wall s, 600); ``~replay_window`` (wall s, 60).
    """

    def __init__(self, params: Params) -> None:
        self.params = params
        building = load_building(params.building)
        self.core = NavigationCore(building, params.cfg, RosLog(), time.monotonic())
        self.robot = self.core.me
        name = Node.MULTIROBOT_NAVIGATION
        self.store = StateFile(Path(params.state_dir) / f"{name}.json", name, self.robot, RosLog(),
                               max_age=params.state_max_age) if params.state_dir else None
        outbox = self.store.resume(self.core.load_state) if self.store is not None else None
        if outbox is not None:
            leg = self.core.leg
            rospy.loginfo(f"multirobot_navigation of {self.robot}: resumed from {self.params.state_dir}"
                          + (f": {leg.trip.uid}, {leg.stage.value} leg" if leg else ": no leg running")
                          + f"; {len(outbox)} message(s) not yet published")
        self.inbox = Inbox(QUEUE_SIZE)
        self.loop = LoopMeter(1.0 / LOOP_PERIOD)
        self._next_diag = time.monotonic() + 1.0
        self.client = actionlib.ActionClient(params.move_base, MoveBaseAction)
        self._active: tuple[int, MoveBaseGoal, float, int] | None = None    # token, goal, sent (wall), sends
        self._handles: dict[int, tuple[actionlib.ClientGoalHandle, int]] = {}   # token -> (handle, sends)
        self._status_wall = 0.0
        self._pending_uids: tuple[str, ...] | None = None
        self._latest_pose: tuple[float, float, float] | None = None
        self._latest_odom: tuple[float, float] | None = None
        self._latest_odom_stamp: float | None = None        # ROS s
        self._latest_battery: float | None = None
        self.events_pub = ReplayPublisher(Topic.NAV_EVENTS, NavEvent, queue_size=200, window=params.replay_window)
        self.cancels_pub = ReplayPublisher(Topic.CANCELS, Cancel, queue_size=100, window=params.replay_window)
        self.status_pub = rospy.Publisher(Topic.STATUS, RobotStatus, queue_size=10, latch=True)
        self.poses_pub = rospy.Publisher(Topic.POSES, NavPose, queue_size=10, latch=True)
        self.make_way_pub = rospy.Publisher(Topic.MAKE_WAY, MakeWay, queue_size=10, latch=True)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=20)
        self.lock_pub = rospy.Publisher(Topic.PEOPLE_VISITOR_LOCK, Bool, queue_size=2, latch=True)
        self.watch_pub = rospy.Publisher(Topic.PEOPLE_WATCH, Bool, queue_size=2, latch=True)
        self.speed_pub = rospy.Publisher(Topic.MOVE_BASE_SPEED_LIMIT, Float32, queue_size=2, latch=True)
        self._lock: tuple[bool, int] = (False, 0)       # published visitor lock, relocks
        self._speed_cap: float | None = None
        self._watch = False                             # published people watch
        self.lock_pub.publish(Bool(data=False))
        self.watch_pub.publish(Bool(data=False))
        self.speed_pub.publish(Float32(data=0.0))
        self.subs = [
            rospy.Subscriber(Topic.PENDING, PendingRequests, self._on_pending, queue_size=20),
            rospy.Subscriber(Topic.CANCELS, Cancel, self._enqueue, callback_args="cancel", queue_size=200),
            rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, self._enqueue, callback_args="event", queue_size=500),
            rospy.Subscriber(Topic.STATUS, RobotStatus, self._enqueue, callback_args="status", queue_size=50),
            rospy.Subscriber(Topic.MAKE_WAY, MakeWay, self._enqueue, callback_args="make_way", queue_size=50),
            rospy.Subscriber(Topic.VISITOR_COMMAND, VisitorCommand, self._enqueue, callback_args="command",
                             queue_size=50),
            rospy.Subscriber(Topic.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=1),
            rospy.Subscriber(Topic.ODOM, Odometry, self._on_odom, queue_size=1),
            rospy.Subscriber(Topic.BATTERY, BatteryState, self._on_battery, queue_size=1),
            rospy.Subscriber(Topic.TOUR_CATALOG, TourCatalog, self._enqueue, callback_args="catalog", queue_size=2),
            rospy.Subscriber(Topic.PEOPLE_VISITOR, VisitorTrack, self._enqueue, callback_args="visitor", queue_size=5),
            rospy.Subscriber(Topic.PEOPLE_TRACKS, PersonArray, self._enqueue, callback_args="people", queue_size=2),
        ]
        self.timers = [rospy.Timer(rospy.Duration(1.0 / params.status_rate), lambda _e: self._enqueue(None, "tick")),
                       rospy.Timer(rospy.Duration(1.0 / params.pose_rate), lambda _e: self._enqueue(None, "pose_tick"))]
        self.execute(outbox or [])   # published before the crash or not: receivers ignore what they handled

    # -- callbacks: copy and enqueue ------------------------------------------------------
    def _enqueue(self, msg: object, kind: str) -> None:
        self.inbox.put(kind, msg)

    def _on_pending(self, msg: PendingRequests) -> None:
        if msg.robot == self.robot:       # the other robots' lists (1 Hz each) are not this node's business
            self._enqueue(msg, "pending")

    # high-rate inputs: only the latest value is kept (one assignment), applied by the loop
    def _on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        p = msg.pose.pose
        self._latest_pose = (p.position.x, p.position.y, convert.yaw_of(p.orientation))

    def _on_odom(self, msg: Odometry) -> None:
        self._latest_odom = (msg.twist.twist.linear.x, msg.twist.twist.angular.z)
        self._latest_odom_stamp = msg.header.stamp.to_sec()

    def _on_battery(self, msg: BatteryState) -> None:
        self._latest_battery = msg.percentage

    def _apply_latest(self) -> None:
        pose, odom, battery = self._latest_pose, self._latest_odom, self._latest_battery   # never reset: no race
        if pose is not None:
            self.core.on_pose(*pose)
        if odom is not None:
            self.core.on_odom(*odom)
        if battery is not None:
            self.core.on_battery(battery)

    def _transition(self, token: int, sends: int, gh: actionlib.ClientGoalHandle) -> None:
        if gh.get_comm_state() != actionlib.CommState.DONE:
            return
        state = gh.get_terminal_state()
        text = gh.get_goal_status_text() or f"goal status {STATE_NAMES.get(state, state)}"
        # when move_base ended the goal: its result's stamp (actionlib keeps the last result message)
        result = getattr(getattr(gh, "comm_state_machine", None), "latest_result", None)
        done = result.header.stamp.to_sec() if result is not None else 0.0
        self._enqueue((token, sends, STATES.get(state, ABORTED), text, done if done > 0 else None), "result")

    # -- the loop that owns the core --------------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """The loop until shutdown or the guard's signal; then the running move_base goal is cancelled and the
        state saved."""
        run_loop(guard, self.spin_once, LOOP_PERIOD, lambda: self.inbox.put(""), self._stop)

    def _stop(self) -> None:
        if self._active is not None:
            self._cancel(self._active[0])
        if self.store is not None:
            self.store.flush(self.core.state, force=True)

    def spin_once(self, timeout: float) -> None:
        """One turn of the loop: a status if the last is a wall second old, at most one input (waiting up to
        ``timeout`` wall s), the latest pose, odometry and battery, the core's tick, move_base's acknowledgement,
        the diagnostics once a wall second."""
        if time.monotonic() - self._status_wall > STATUS_WALL_PERIOD:
            self.publish_status()      # liveness never depends on the (sim) clock running
        kind, msg = self.inbox.get(timeout)
        now_ros, now_wall = rospy.get_time(), time.monotonic()
        self.loop.tick(now_ros, now_wall)
        now_ros = freshest_time(now_ros, self._latest_odom_stamp)     # events stamped with the odometry's time
        self._apply_latest()
        self.core.on_move_base_available(self._server_up(), now_ros)
        if kind:
            self.commit(self.handle(kind, msg, now_ros, now_wall), self._changes_state(kind, msg))
        self.commit(self.core.tick(now_ros, now_wall), False)
        self._publish_pace(now_ros)
        self._check_ack(now_wall)
        if now_wall >= self._next_diag:
            self._next_diag = now_wall + 1.0
            self.publish_diagnostics()

    def handle(self, kind: str, msg: object, now_ros: float, now_wall: float) -> list[Action]:
        core = self.core
        if kind == "pending":
            pending = convert.pending_from_msg(msg)
            eta_last = float(pending.eta[-1]) if pending.eta else 0.0
            return core.on_pending(list(pending.goals), eta_last, now_ros, now_wall, robot=pending.robot,
                                   sender=sender(msg))
        if kind == "cancel":
            return core.on_cancel(convert.cancel_from_msg(msg), now_ros, now_wall, sender=sender(msg))
        if kind == "event":
            return core.on_nav_event(convert.event_from_msg(msg), now_ros, now_wall, sender=sender(msg))
        if kind == "command":
            return core.on_command(convert.command_from_msg(msg), now_ros, now_wall, sender=sender(msg))
        if kind == "result":
            token, sends, status, text, done_ros = msg
            if self._handles.get(token, (None, -1))[1] != sends:
                return []                   # a goal sent again, or stopped: its result is not the leg's
            del self._handles[token]
            if self._active is not None and self._active[0] == token:
                self._active = None
            return core.on_move_base_result(token, status, text, now_ros, now_wall, done_ros)
        if kind == "visitor":
            return core.on_visitor(convert.visitor_track_from_msg(msg).report, now_ros, now_wall, sender=sender(msg))
        if kind == "people":
            return core.on_people(convert.people_from_msg(msg).tracks, now_ros, sender=sender(msg))
        if kind == "status":
            status = convert.status_from_msg(msg)
            if core.on_status(status.robot, now_wall, sender=sender(msg)):
                core.on_mate(status)
        elif kind == "make_way":
            core.on_make_way(convert.make_way_from_msg(msg), now_ros, sender=sender(msg))
        elif kind == "catalog":
            core.on_catalog(convert.catalog_from_msg(msg).tours, sender=sender(msg))
        elif kind == "tick":
            self.publish_status()
        elif kind == "pose_tick":
            self.publish_pose()
        return []

    def _changes_state(self, kind: str, msg: object) -> bool:
        """Whether an input may change the state kept across restarts (the 1 Hz unchanged pending does not)."""
        if kind == "pending":
            uids = tuple(g.uid for g in msg.goals)  # type: ignore[attr-defined]
            if uids == self._pending_uids:
                return False
            self._pending_uids = uids
        return kind in DURABLE_INPUTS

    def commit(self, actions: list[Action], changed: bool) -> None:
        """Publish ``actions``, the state saved first with the durable ones (a restart publishes them again)."""
        carry_out(self.store, self.core.state, actions, self.core.durable(actions), self.execute, changed)

    def execute(self, actions: list[Action]) -> None:
        for act in actions:
            if isinstance(act, MoveTo):
                goal = MoveBaseGoal()
                goal.target_pose.header.frame_id = self.params.frame_id
                goal.target_pose.header.stamp = rospy.Time.now()
                goal.target_pose.pose = convert.pose_msg(act.x, act.y, act.yaw)
                self._send(act.token, goal, 1)
            elif isinstance(act, StopMoving):
                self._cancel(act.token)
            elif isinstance(act, SendEvent):
                self.events_pub.publish(convert.event_to_msg(act.event))
            elif isinstance(act, SendCancel):
                self.cancels_pub.publish(convert.cancel_to_msg(act.cancel))
            elif isinstance(act, SendAsk):
                self.make_way_pub.publish(convert.make_way_to_msg(replace(act.ask, frame_id=self.params.frame_id)))

    # -- move_base ------------------------------------------------------------------------
    def _send(self, token: int, goal: MoveBaseGoal, sends: int) -> None:
        old = self._handles.get(token)
        if old is not None:
            old[0].cancel()
        self._active = (token, goal, time.monotonic(), sends)
        gh = self.client.send_goal(goal, transition_cb=functools.partial(self._transition, token, sends))
        self._handles[token] = (gh, sends)
        while len(self._handles) > MAX_HANDLES:           # handles of goals whose server vanished
            self._handles.pop(next(iter(self._handles)))

    def _cancel(self, token: int) -> None:
        """Cancel goal ``token``; its late result (PREEMPTED) is dropped."""
        entry = self._handles.pop(token, None)
        if entry is not None and entry[0].get_comm_state() != actionlib.CommState.DONE:
            entry[0].cancel()
        if self._active is not None and self._active[0] == token:
            self._active = None

    def _check_ack(self, now_wall: float) -> None:
        """Send a goal again if move_base never acknowledged it (lost on a fresh connection)."""
        if self._active is None:
            return
        token, goal, sent, sends = self._active
        gh = self._handles.get(token, (None, 0))[0]
        if gh is None or now_wall - sent < ACK_TIMEOUT:
            return
        if gh.get_comm_state() == actionlib.CommState.WAITING_FOR_GOAL_ACK and sends <= ACK_RETRIES \
                and self._server_up():
            rospy.logwarn(f"move_base did not acknowledge goal {token}; sending it again")
            self._send(token, goal, sends + 1)

    def _server_up(self) -> bool:
        """The move_base action server is connected (non-blocking)."""
        ac = self.client
        status = ac.last_status_msg
        if status is None:
            return False
        server = sender(status)
        return bool(server) and server in connected_subscribers(ac.pub_goal) \
            and server in connected_subscribers(ac.pub_cancel)

    # -- outputs --------------------------------------------------------------------------
    def _publish_pace(self, now_ros: float) -> None:
        """What the core wants of the people node (people watched, the visitor locked) and of move_base (a speed
        cap), on a change; each ended guided leg's summary."""
        if self.core.wants_people != self._watch:
            self._watch = self.core.wants_people
            self.watch_pub.publish(Bool(data=self._watch))
        want = (self.core.wants_visitor, self.core.relocks)
        if want != self._lock:
            if want[0] and self._lock[0] and want[1] != self._lock[1]:
                self.lock_pub.publish(Bool(data=False))          # look for the visitor anew
            self.lock_pub.publish(Bool(data=want[0]))
            self._lock = want
        cap = self.core.speed_cap
        if cap != self._speed_cap:
            self.speed_pub.publish(Float32(data=cap or 0.0))
            self._speed_cap = cap
        while self.core.pace_done:
            uid, leg, stats = self.core.pace_done.pop(0)
            self.diag_pub.publish(diagnostics(f"guiding: pace {self.robot}", self.robot,
                                              {"goal_uid": uid, "leg": leg, **stats}, bool(stats["lost"]),
                                              f"{uid} {leg}: the visitor's pace", now_ros))

    def publish_status(self) -> None:
        self._status_wall = time.monotonic()
        status = self.core.status(rospy.get_time())
        self.status_pub.publish(convert.status_to_msg(replace(status, frame_id=self.params.frame_id)))

    def publish_pose(self) -> None:
        pose = self.core.pose_to_publish()
        if pose is None:
            return
        self.poses_pub.publish(convert.pose_to_msg(PoseData(self.robot, self.core.floor, pose.x, pose.y, pose.yaw,
                                                    rospy.get_time(), self.params.frame_id)))

    def publish_diagnostics(self) -> None:
        stats = dict(self.core.stats)
        stats.update(state_saves=self.store.saves if self.store else 0,
                     state_save_failures=self.store.failures if self.store else 0,
                     replayed=self.events_pub.buffer.replayed + self.cancels_pub.buffer.replayed)
        stats.update(self.loop.values())
        stats.update(refusal_values(self.core.refusals()))
        stats.update(queue_dropped=self.inbox.dropped,
                     move_base=int(self.core.available), leg=self.core.leg.stage.value if self.core.leg else "")
        now = rospy.get_time()
        self.diag_pub.publish(diagnostics(f"guiding: navigation {self.robot}", self.robot, stats,
                                          not self.core.available or bool(self.inbox.dropped),
                                          self.core.status(now).state, now))


def main(argv: list[str] | None = None) -> int:
    return run_node(Node.MULTIROBOT_NAVIGATION, lambda: NavigationNode(Params.read()),
                    lambda n: f"multirobot_navigation of {n.robot} (floor {n.core.floor:g}) running", argv)
