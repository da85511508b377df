"""ROS adapter of the goal manager: the ``goal_manager`` node (one per robot, on its own master).

The logic lives in :mod:`gidabot_navigation.guiding.goal_manager` (ROS-free). Callbacks
only enqueue; one loop owns the core: it converts each input (:mod:`gidabot_navigation.ros.convert`),
hands it to the core, publishes the actions the core returns and the pending list.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import rospy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseWithCovarianceStamped

from gidabot_msgs.msg import (
    Cancel,
    Goal,
    NavEvent,
    PendingRequests,
    RobotStatus,
    StaffCommand,
    TourCatalog,
    VisitorCommand,
)
from gidabot_navigation.building.model import load_building
from gidabot_navigation.guiding.assignment import AssignConfig
from gidabot_navigation.guiding.goal_manager import GoalManagerConfig, GoalManagerCore
from gidabot_navigation.guiding.messages import Action, SendCancel, SendEvent, SendGoal
from gidabot_navigation.guiding.state import DEFAULT_MAX_AGE, StateFile, default_state_dir
from gidabot_navigation.guiding.trips import WaitModel
from gidabot_navigation.interface import DEFAULT_LANGUAGE, WAY_STAIRS, Node, Topic
from gidabot_navigation.loop_meter import LoopMeter
from gidabot_navigation.ros import convert
from gidabot_navigation.ros.adapter import Inbox, carry_out, diagnostics, refusal_values, sender, simulated
from gidabot_navigation.ros.exit_guard import ExitGuard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.node_main import run_loop, run_node
from gidabot_navigation.ros.params import param_number, param_text, robot_params
from gidabot_navigation.ros.replay import DEFAULT_WINDOW, ReplayPublisher

QUEUE_SIZE = 2000
LOOP_PERIOD = 0.5          # wall s: the loop runs at least this often (LoopMeter's nominal rate)
# inputs that may change the state kept across restarts
DURABLE_INPUTS = ("command", "goal", "cancel", "event", "catalog", "staff")


@dataclass(frozen=True)
class Params:
    building: str
    cfg: GoalManagerConfig
    pending_period: float      # wall s between unchanged /gidabot/pending messages
    state_dir: str = ""        # where the node's state survives a restart ("" = none)
    state_max_age: float = DEFAULT_MAX_AGE
    replay_window: float = DEFAULT_WINDOW

    @staticmethod
    def read() -> Params:
        building, robot = robot_params()
        wait = WaitModel(speed_factor=param_number("~speed_factor", WaitModel.speed_factor),
                         stairs_s_per_floor=param_number("~stairs_s_per_floor", WaitModel.stairs_s_per_floor,
                                                         strict=False),
                         lift_wait_s=param_number("~lift_wait", WaitModel.lift_wait_s, strict=False),
                         lift_s_per_floor=param_number("~lift_s_per_floor", WaitModel.lift_s_per_floor, strict=False),
                         continue_s=param_number("~continue_time", WaitModel.continue_s, strict=False),
                         leg_overhead_s=param_number("~leg_overhead", WaitModel.leg_overhead_s, strict=False),
                         pickup_distance=param_number("~pickup_distance", WaitModel.pickup_distance),
                         unguided_s=param_number("~unguided_time", WaitModel.unguided_s, strict=False))
        assign = AssignConfig(answer_timeout=param_number("~answer_timeout", AssignConfig.answer_timeout),
                              proposal_ttl=param_number("~proposal_ttl", AssignConfig.proposal_ttl),
                              max_wait=param_number("~max_wait", AssignConfig.max_wait, strict=False),
                              helper_gain=param_number("~helper_gain", AssignConfig.helper_gain, strict=False),
                              requeue_after=param_number("~requeue_after", AssignConfig.requeue_after))
        cfg = GoalManagerConfig(robot=robot, default_way=param_text("~default_way", WAY_STAIRS),
                                default_language=param_text("~default_language", DEFAULT_LANGUAGE),
                                offline_after=param_number("~offline_after", 5.0),
                                max_queue=int(param_number("~max_queue", 50, low=1, strict=False)), wait=wait,
                                assign=assign, simulated=simulated())
        state_dir = param_text("~state_dir", "") or default_state_dir(robot)
        return Params(building, cfg, 1.0 / param_number("~pending_rate", 1.0), state_dir,
                      param_number("~state_max_age", DEFAULT_MAX_AGE),
                      param_number("~replay_window", DEFAULT_WINDOW, strict=False))


class GoalManagerNode:
    """Keeps this robot's pending requests (FIFO) and turns the visitor's commands into goals.

    Subscribed topics:
      - ``visitor/command`` (gidabot_msgs/VisitorCommand): REQUEST (goal_id, way, language),
        CONTINUE after a tour step done here (goal_uid of that step, or ""), CANCEL (goal_uid or ""
        = the trip in progress here), START_TOUR (tour_file), SKIP (tour_file, tour_step).
        A CONTINUE at a meeting point is multirobot_navigation's.
      - ``/gidabot/goals`` (gidabot_msgs/Goal): every robot's goals (this robot's own included).
      - ``/gidabot/cancels`` (gidabot_msgs/Cancel): drop a goal, queued or running.
      - ``/gidabot/nav_events`` (gidabot_msgs/NavEvent): this robot's navigation ends its part of
        a trip (a final phase) or reports TOUR_STEP_DONE; GO_TO_FLOOR of any robot (wait estimate).
      - ``/gidabot/status`` (gidabot_msgs/RobotStatus): the robots' liveness (wall time) and poses.
      - ``/gidabot/pending`` (gidabot_msgs/PendingRequests): the other robots' queues and waits (which robot
        of a floor can serve a leg soonest).
      - ``amcl_pose`` (geometry_msgs/PoseWithCovarianceStamped): where new trips start.
      - ``tour_store/catalog`` (gidabot_msgs/TourCatalog, latched): the tours for tour mode.

    Published topics (events: the last ``~replay_window`` s are sent again to a subscriber that connects
    late, e.g. a restarted node; subscribers ignore uids they handled):
      - ``/gidabot/goals`` (gidabot_msgs/Goal, event): goals made here.
      - ``/gidabot/cancels`` (gidabot_msgs/Cancel, event): the visitor's cancels here.
      - ``/gidabot/nav_events`` (gidabot_msgs/NavEvent, event): ACCEPTED / DECLINED (answers to a leg proposed
        here), ASSIGNED (a leg of a trip made here is committed to a robot), REJECTED, PARTNER_OFFLINE /
        UNREACHABLE for a request that cannot be queued, CANCELLED_HERE / CANCELLED_ELSEWHERE /
        UNREACHABLE / TIMEOUT / PARTNER_OFFLINE when a cancel drops a goal held here, TOUR_FINISHED
        on a Continue after the last step.
      - ``/gidabot/pending`` (gidabot_msgs/PendingRequests, state, latched): the queue with eta per
        goal and wait_new (s); on change and every ``1/~pending_rate`` wall s.
      - ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): ``guiding: goal_manager <robot>`` counters
        (received, accepted, rejected_<reason>, duplicates, ...; ``refused_<kind>``: the messages refused by
        kind, impostor, foreign, wrong_namespace, conflict, invalid), with the pending list.

    Every input is handed to the core with its publisher (the callerid): a message that is not its sender's to
    send (gidabot_navigation.senders) is refused and counted, never answered.

    Parameters:
      - ``~building`` (str, required), ``~robot`` (str, required).
      - ``~default_way`` (stairs), ``~default_language`` (en): for commands without them.
      - ``~offline_after`` (wall s, 5.0): a robot without status this long is offline.
      - ``~max_queue`` (50): goals kept at most; further ones are refused and cancelled everywhere.
      - ``~pending_rate`` (Hz wall, 1.0).
      - ``~state_dir`` (str, '' = ``$ROS_HOME/gidabot/<robot>/guiding``): ``goal_manager.json`` there keeps
        the queue, the handled uids and the tour steps waiting across a restart of this node (written
        atomically before what a change produced is published, other changes within 1 s: guiding/state.py);
        ``~state_max_age`` (wall s, 600): an older state is not resumed. ``~replay_window`` (wall s, 60; 0 = none).
      - Wait estimate: ``~speed_factor`` (0.5 of max_linear), ``~stairs_s_per_floor`` (s, 20),
        ``~lift_wait`` (s, 25), ``~lift_s_per_floor`` (s, 5), ``~continue_time`` (s, 10),
        ``~leg_overhead`` (s, 5), ``~pickup_distance`` (m, 1.5), ``~unguided_time`` (s, 120: a visitor's stops
        on floors without robot before a trip from there).
      - Who serves a leg (docs/guiding.md): ``~answer_timeout`` (wall s, 3: a robot asked to serve a leg that
        has not answered by then is passed over), ``~proposal_ttl`` (wall s, 60: a proposal held here that is
        never confirmed is forgotten), ``~max_wait`` (s, 0 = off, the default: a leg this robot could not reach
        sooner is declined; off, a long queue is never a reason to decline: the visitor saw the wait and chose),
        ``~helper_gain`` (s, 20: another robot of this floor comes to this robot's visitor only if that much
        sooner), ``~requeue_after`` (wall s, 10: a leg every robot of its floor declined, queues full, is
        proposed again after this, a new round).
    """

    def __init__(self, params: Params) -> None:
        self.params = params
        building = load_building(params.building)
        self.core = GoalManagerCore(building, params.cfg, RosLog(), time.monotonic())
        self.core.planner.warm_up()         # not at the first tour step, while the floors wait for the CPU
        self.robot = self.core.me
        self.store = StateFile(Path(params.state_dir) / f"{Node.GOAL_MANAGER}.json", Node.GOAL_MANAGER, self.robot,
                               RosLog(), max_age=params.state_max_age) if params.state_dir else None
        outbox = self.store.resume(self.core.load_state) if self.store is not None else None
        if outbox is not None:
            rospy.loginfo(f"goal_manager of {self.robot}: resumed {len(self.core.queue)} pending goal(s) and "
                          f"{len(outbox)} message(s) not yet published from {self.params.state_dir}")
        self.inbox = Inbox(QUEUE_SIZE)
        self.loop = LoopMeter(1.0 / LOOP_PERIOD)
        self._published_version = -1
        self._next_pending = time.monotonic()
        self._latest_pose: tuple[float, float, float] | None = None
        window = params.replay_window
        self.goals_pub = ReplayPublisher(Topic.GOALS, Goal, queue_size=100, window=window)
        self.cancels_pub = ReplayPublisher(Topic.CANCELS, Cancel, queue_size=100, window=window)
        self.events_pub = ReplayPublisher(Topic.NAV_EVENTS, NavEvent, queue_size=200, window=window)
        self.pending_pub = rospy.Publisher(Topic.PENDING, PendingRequests, queue_size=10, latch=True)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=2)
        self.subs = [
            rospy.Subscriber(Topic.VISITOR_COMMAND, VisitorCommand, self._enqueue, callback_args="command",
                             queue_size=50),
            rospy.Subscriber(Topic.GOALS, Goal, self._enqueue, callback_args="goal", queue_size=200),
            rospy.Subscriber(Topic.CANCELS, Cancel, self._enqueue, callback_args="cancel", queue_size=200),
            rospy.Subscriber(Topic.STAFF, StaffCommand, self._enqueue, callback_args="staff", queue_size=50),
            rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, self._enqueue, callback_args="event", queue_size=500),
            rospy.Subscriber(Topic.STATUS, RobotStatus, self._enqueue, callback_args="status", queue_size=50),
            rospy.Subscriber(Topic.PENDING, PendingRequests, self._enqueue, callback_args="pending", queue_size=50),
            rospy.Subscriber(Topic.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=1),
            rospy.Subscriber(Topic.TOUR_CATALOG, TourCatalog, self._enqueue, callback_args="catalog", queue_size=2),
        ]
        self.execute(outbox or [])   # published before the crash or not: receivers ignore what they handled

    # -- callbacks: copy and enqueue ------------------------------------------------------
    def _enqueue(self, msg: object, kind: str) -> None:
        self.inbox.put(kind, msg)

    def _on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        p = msg.pose.pose              # only the latest pose matters: one assignment, applied by the loop
        self._latest_pose = (p.position.x, p.position.y, convert.yaw_of(p.orientation))

    # -- the loop that owns the core --------------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """The loop until shutdown or the guard's signal; then the state is saved."""
        run_loop(guard, self.spin_once, LOOP_PERIOD, lambda: self.inbox.put(""), self._save)

    def _save(self) -> None:
        if self.store is not None:
            self.store.flush(self.core.state, force=True)

    def spin_once(self, timeout: float) -> None:
        """One turn of the loop: at most one input (waiting up to ``timeout`` wall s, less when the pending list
        is due), the core's tick, and the pending list (with the state saved first) when it changed or is due."""
        kind, msg = self.inbox.get(max(0.0, min(timeout, self._next_pending - time.monotonic())))
        self.loop.tick(rospy.get_time(), time.monotonic())
        pose = self._latest_pose          # never reset: no race with the callback
        if pose is not None:
            self.core.on_pose(*pose)
        if kind:
            self.commit(self.handle(kind, msg), kind in DURABLE_INPUTS)
        now = time.monotonic()
        version = self.core.version         # the tick may drop a proposal held too long
        actions = self.core.tick(rospy.get_time(), now)
        self.commit(actions, self.core.version != version)
        if self.core.version != self._published_version or now >= self._next_pending:
            if self.store is not None:      # saved first: what its navigation acts on survives a restart
                self.store.publish_state(self.core.state, self.publish_pending)
            else:
                self.publish_pending()
            if now >= self._next_pending:
                self._next_pending = now + self.params.pending_period
                self.publish_diagnostics()

    def handle(self, kind: str, msg: object) -> list[Action]:
        """Hand one input to the core with its publisher (the core refuses what is not the sender's to send)."""
        now_ros, now_wall = rospy.get_time(), time.monotonic()
        core, by = self.core, sender(msg)
        if kind == "command":
            return core.on_command(convert.command_from_msg(msg), now_ros, now_wall, sender=by)
        if kind == "goal":
            return core.on_goal(convert.trip_from_msg(msg), now_ros, now_wall, sender=by)
        if kind == "cancel":
            return core.on_cancel(convert.cancel_from_msg(msg), now_ros, now_wall, sender=by)
        if kind == "event":
            return core.on_nav_event(convert.event_from_msg(msg), now_ros, now_wall, sender=by)
        if kind == "staff":
            return core.on_staff(convert.staff_from_msg(msg), now_ros, now_wall, sender=by)
        if kind == "status":
            status = convert.status_from_msg(msg)
            core.on_status(status.robot, now_wall, (status.x, status.y), sender=by)
        elif kind == "pending":
            pending = convert.pending_from_msg(msg)
            core.on_pending(pending.robot, pending.goals, pending.wait_new, now_wall, sender=by)
        elif kind == "catalog":
            return core.on_catalog(convert.catalog_from_msg(msg).tours, now_ros, now_wall, sender=by)
        return []

    def commit(self, actions: list[Action], changed: bool) -> None:
        """Publish ``actions``, the state saved first with the durable ones (a restart publishes them again)."""
        carry_out(self.store, self.core.state, actions, self.core.durable(actions), self.execute, changed)

    def execute(self, actions: list[Action]) -> None:
        for act in actions:
            if isinstance(act, SendGoal):
                self.goals_pub.publish(convert.trip_to_msg(act.trip))
            elif isinstance(act, SendCancel):
                self.cancels_pub.publish(convert.cancel_to_msg(act.cancel))
            elif isinstance(act, SendEvent):
                self.events_pub.publish(convert.event_to_msg(act.event))

    def publish_pending(self) -> None:
        self._published_version = self.core.version
        self.pending_pub.publish(convert.pending_to_msg(self.core.pending(rospy.get_time())))

    def publish_diagnostics(self) -> None:
        stats = dict(self.core.stats)
        stats.update(self.loop.values())
        stats.update(refusal_values(self.core.refusals()))
        stats.update(queue_dropped=self.inbox.dropped, pending=len(self.core.queue), tours=len(self.core.tours),
                     plans=self.core.planner.plans,
                     state_saves=self.store.saves if self.store else 0,
                     state_save_failures=self.store.failures if self.store else 0,
                     replayed=sum(p.buffer.replayed for p in (self.goals_pub, self.cancels_pub, self.events_pub)))
        self.diag_pub.publish(diagnostics(f"guiding: goal_manager {self.robot}", self.robot, stats,
                                          bool(self.inbox.dropped),
                                          f"{len(self.core.queue)} pending, {stats.get('rejected', 0)} rejected",
                                          rospy.get_time()))


def main(argv: list[str] | None = None) -> int:
    return run_node(Node.GOAL_MANAGER, lambda: GoalManagerNode(Params.read()),
                    lambda n: f"goal_manager of {n.robot} (floor {n.core.robot.floor:g}) running", argv)
