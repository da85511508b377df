"""ROS adapter of the staff dashboard: the ``dashboard`` node (one per robot, on its own master, a process of its own).

The logic lives in :mod:`gidabot_web.dashboard.dashboard` (ROS-free) and the web application in
:mod:`gidabot_web.dashboard.app`; this module converts messages, hands them over and publishes. rospy's
callbacks only convert and put a record into an :class:`~gidabot_gui.core.inbox.Inbox` (states: the latest per
robot; events: in order), then wake the asyncio loop (``call_soon_threadsafe``); that loop, in the main thread,
owns the core, the web server and the history, drains the inbox, steps the core every 0.2 s and publishes.
A watch thread asks this robot's master, once a second, for its pid and where its nodes are registered (a node
at a new address was restarted). The node uses no ROS time (it never subscribes ``/clock``).
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import sys
import threading
import time
import xmlrpc.client
from dataclasses import dataclass
from pathlib import Path

import rosgraph
import rospy
from aiohttp import web
from diagnostic_msgs.msg import DiagnosticArray

from gidabot_gui.core.inbox import Inbox
from gidabot_msgs.msg import (
    Cancel,
    Goal,
    LinkSummary,
    NavEvent,
    NavPose,
    PendingRequests,
    RobotStatus,
    StaffCommand,
    Tour,
    TourCatalog,
    TourEditResult,
)
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.guiding.messages import CancelData, StaffCommandData
from gidabot_navigation.interface import Node, Topic, global_name
from gidabot_navigation.relay.links import own_ends
from gidabot_navigation.ros.adapter import diagnostics, sender, simulated
from gidabot_navigation.ros.convert import (
    cancel_from_msg,
    cancel_to_msg,
    catalog_from_msg,
    diagnostic_from_msg,
    edit_result_from_msg,
    event_from_msg,
    links_from_msg,
    links_to_msg,
    pending_from_msg,
    pose_from_msg,
    staff_from_msg,
    staff_to_msg,
    status_from_msg,
    tour_to_msg,
    trip_from_msg,
)
from gidabot_navigation.ros.exit_guard import ExitGuard, rospy_exit_guard
from gidabot_navigation.ros.master_watch import keep_registered, proxy
from gidabot_navigation.ros.params import param_number, param_text
from gidabot_navigation.ros.replay import ReplayPublisher
from gidabot_navigation.senders import IMPOSTOR, Senders, may_publish
from gidabot_navigation.tours.tour_store import TourMessage
from gidabot_web.dashboard.app import DashboardApp
from gidabot_web.dashboard.dashboard import DashboardConfig, DashboardCore
from gidabot_web.dashboard.history import History
from gidabot_web.dashboard.texts import catalogs
from gidabot_web.errors import ConfigError, WebError
from gidabot_web.web.app import WebConfig

STEP_PERIOD = 0.2        # wall s between two steps of the core
PUBLISH_PERIOD = 1.0     # wall s between two link summaries and diagnostics
WATCH_PERIOD = 1.0       # wall s between two looks at the master
BIND_RETRY = 5.0         # wall s between two attempts to listen on the port
DEFAULT_PORT = 8080
USERS_FILE = "users.json"
HISTORY_FILE = "history.sqlite"
WATCHED_NODES = (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.TOUR_STORE, Node.RELAY_SUPERVISOR, Node.GUI)


def default_dashboard_dir(robot: str) -> str:
    """``$ROS_HOME/gidabot/<robot>/dashboard`` (ROS_HOME defaults to ``~/.ros``): the password file and the
    history."""
    home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return os.path.join(home, "gidabot", robot, "dashboard")


# ---------------------------------------------------------------------- the node
@dataclass(frozen=True)
class Params:
    building: str
    robot: str
    host: str
    port: int
    state_dir: Path
    offline_after: float
    push_period: float
    secure_cookies: bool
    trusted_proxies: frozenset[str]
    origins: frozenset[str]
    hosts: frozenset[str]

    @staticmethod
    def read() -> Params:
        building = param_text("~building", required=True)
        robot = param_text("~robot", required=True)
        port = int(param_number("~port", DEFAULT_PORT, low=1, high=65535, strict=False))

        def words(name: str) -> frozenset[str]:
            return frozenset(w for w in param_text(name, "").replace(",", " ").split() if w)

        secure = rospy.get_param("~secure_cookies", False)
        if not isinstance(secure, bool):
            raise ConfigError(f"{rospy.resolve_name('~secure_cookies')} must be true or false, got {secure!r}")
        return Params(building, robot, param_text("~host", ""), port,
                      Path(param_text("~state_dir", "") or default_dashboard_dir(robot)),
                      param_number("~offline_after", 5.0), param_number("~push_period", 0.25), secure,
                      words("~trusted_proxies"), words("~origins"), words("~hosts"))


class DashboardNode:
    """This robot's staff web dashboard (docs/dashboard.md).

    Serves HTTP on ``~host`` (default: this robot's address in the building file) and ``~port`` (8080).

    Subscribed topics: ``/gidabot/status``, ``/gidabot/poses``, ``/gidabot/pending``, ``/gidabot/goals``,
    ``/gidabot/cancels``, ``/gidabot/nav_events``, ``/gidabot/staff``, ``/gidabot/links`` (every robot's,
    through the relays), ``/diagnostics`` (this robot's relay ends), ``tour_store/catalog``,
    ``tour_store/edit_result``.

    Published topics:
      - ``/gidabot/cancels`` (gidabot_msgs/Cancel, event, replayed 60 s): a staff cancel (reason ``admin``).
      - ``/gidabot/staff`` (gidabot_msgs/StaffCommand, event, replayed 60 s): out of service and back.
      - ``/gidabot/links`` (gidabot_msgs/LinkSummary, state, latched): this robot's links, 1 Hz.
      - ``tour_store/edit`` (gidabot_msgs/Tour): an admin's tour upload, edit or deletion.
      - ``/diagnostics``: ``dashboard: <robot>`` (requests refused by reason, clients, alerts...), 1 Hz.

    Parameters: ``~building``, ``~robot`` (required); ``~host`` (''), ``~port`` (8080); ``~state_dir`` ('' =
    ``$ROS_HOME/gidabot/<robot>/dashboard``: ``users.json`` (``gidabot dashboard-passwd``) and
    ``history.sqlite``); ``~offline_after`` (wall s, 5); ``~push_period`` (wall s between two updates to one
    client, 0.25); ``~secure_cookies`` (false; true behind an HTTPS proxy); ``~trusted_proxies`` (addresses
    whose X-Forwarded-For is believed); ``~origins`` (more origins the page is served from, e.g. the proxy's);
    ``~hosts`` (names, without port, staff reach the robot by besides its address: a request for any other
    name is refused, DNS rebinding).
    """

    def __init__(self, params: Params) -> None:
        self.params = params
        self.building = load_building(params.building)
        me = self.building.robot(params.robot)
        self.host = params.host or me.ip
        self.ends = own_ends(self.building, me.name)
        self.senders = Senders.of_building(self.building, me.name, simulated())
        params.state_dir.mkdir(parents=True, exist_ok=True)
        self.history = History(params.state_dir / HISTORY_FILE)
        now, wall = time.monotonic(), time.time()
        self.core = DashboardCore(self.building, DashboardConfig(me.name, offline_after=params.offline_after),
                                  self.history, now, wall)
        config = WebConfig(users_file=params.state_dir / USERS_FILE, secure_cookies=params.secure_cookies,
                           trusted_proxies=params.trusted_proxies, origins=params.origins, hosts=params.hosts)
        self.app = DashboardApp(self.core, config, self, catalogs(), push_period=params.push_period)
        self.inbox = Inbox(max_events=5000)
        self.loop: asyncio.AbstractEventLoop | None = None
        self._wake: asyncio.Event | None = None
        self._wake_pending = False
        self._wake_lock = threading.Lock()
        self._stop = threading.Event()
        self.cancel_pub = ReplayPublisher(Topic.CANCELS, Cancel, queue_size=50)
        self.staff_pub = ReplayPublisher(Topic.STAFF, StaffCommand, queue_size=50)
        self.links_pub = rospy.Publisher(Topic.LINKS, LinkSummary, queue_size=2, latch=True)
        self.edit_pub = rospy.Publisher(Topic.TOUR_EDIT, Tour, queue_size=10)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=2)
        subs = ((Topic.STATUS, RobotStatus, self._status), (Topic.POSES, NavPose, self._pose),
                (Topic.PENDING, PendingRequests, self._pending), (Topic.GOALS, Goal, self._goal),
                (Topic.CANCELS, Cancel, self._cancel), (Topic.NAV_EVENTS, NavEvent, self._event),
                (Topic.STAFF, StaffCommand, self._staff), (Topic.LINKS, LinkSummary, self._links),
                (Topic.DIAGNOSTICS, DiagnosticArray, self._diagnostics),
                (Topic.TOUR_CATALOG, TourCatalog, self._catalog),
                (Topic.TOUR_EDIT_RESULT, TourEditResult, self._edit_result))
        self.subs = [rospy.Subscriber(topic, cls, cb, queue_size=200) for topic, cls, cb in subs]

    # -- who a message may speak for ------------------------------------------------------
    def speaker(self, msg: object, topic: str = "") -> str | None:
        """The robot the publisher of ``msg`` (on ``topic``) may speak for (:class:`Senders`): this robot for its own
        nodes (on a topic of ``senders.PUBLISHERS`` only those listed), the peer for a relay end of this robot's
        links, None for any other node."""
        who = self.senders.attribute(sender(msg))
        return None if who.kind == IMPOSTOR or not may_publish(who, topic) else who.robot

    # -- callbacks: convert, hand over, return -----------------------------------------------
    def _state(self, kind: str, key: str, record: object) -> None:
        self.inbox.put_state(kind, key, record)
        self._poke()

    def _put(self, kind: str, record: object) -> None:
        self.inbox.put_event(kind, record)
        self._poke()

    def _poke(self) -> None:
        with self._wake_lock:
            if self._wake_pending or self.loop is None or self._wake is None:
                return
            self._wake_pending = True
        with contextlib.suppress(RuntimeError):       # the loop closed: shutting down
            self.loop.call_soon_threadsafe(self._wake.set)

    def _status(self, m: RobotStatus) -> None:
        self._state("status", m.robot, (status_from_msg(m), self.speaker(m), time.monotonic(), time.time()))

    def _pose(self, m: NavPose) -> None:
        self._state("pose", m.robot, (pose_from_msg(m), self.speaker(m), time.monotonic()))

    def _pending(self, m: PendingRequests) -> None:
        self._state("pending", m.robot, (pending_from_msg(m), self.speaker(m), time.monotonic()))

    def _links(self, m: LinkSummary) -> None:
        self._state("links", m.robot, (links_from_msg(m), self.speaker(m, Topic.LINKS), time.monotonic()))

    def _goal(self, m: Goal) -> None:
        self._put("goal", (trip_from_msg(m), self.speaker(m), time.monotonic()))

    def _cancel(self, m: Cancel) -> None:
        self._put("cancel", (cancel_from_msg(m), self.speaker(m), time.monotonic()))

    def _event(self, m: NavEvent) -> None:
        self._put("event", (event_from_msg(m), self.speaker(m), time.monotonic()))

    def _staff(self, m: StaffCommand) -> None:
        self._put("staff", (staff_from_msg(m), self.speaker(m, Topic.STAFF), time.monotonic()))

    def _diagnostics(self, m: DiagnosticArray) -> None:
        found = [diagnostic_from_msg(s) for s in m.status if s.hardware_id in self.ends]
        if found:
            self._state("diagnostics", found[0].hardware_id, (found, time.monotonic()))

    def _catalog(self, m: TourCatalog) -> None:
        if sender(m) == global_name(Node.TOUR_STORE):
            self._state("catalog", "", catalog_from_msg(m).tours)

    def _edit_result(self, m: TourEditResult) -> None:
        if sender(m) == global_name(Node.TOUR_STORE):
            self._put("edit_result", edit_result_from_msg(m))

    # -- the loop -------------------------------------------------------------------------
    def _drain(self) -> None:
        core = self.core
        drained = self.inbox.drain()
        for kind, item in drained.states:
            if kind == "status":
                core.on_status(item[0], item[1], item[2], item[3])
            elif kind == "pose":
                core.on_pose(*item)
            elif kind == "pending":
                core.on_pending(*item)
            elif kind == "links":
                core.on_links(*item)
            elif kind == "diagnostics":
                core.on_diagnostics(*item)
            elif kind == "catalog":
                core.on_catalog(item)
        handlers = {"goal": core.on_goal, "cancel": core.on_cancel, "event": core.on_event, "staff": core.on_staff}
        for kind, item in drained.events:
            if kind in handlers:
                handlers[kind](*item)
            elif kind == "edit_result":
                self.app.on_edit_result(item)
            elif kind == "node":
                core.on_node(item[0], item[1], item[2])
            elif kind == "master":
                core.on_master(item[0], item[1])
        if drained.dropped:
            core.count("inbox_dropped", drained.dropped)
        if drained.events:
            self.app.changed()

    async def _main(self, guard: ExitGuard) -> None:
        self.loop = asyncio.get_running_loop()
        self._wake = asyncio.Event()
        guard.set_wake(lambda: self.loop.call_soon_threadsafe(self._wake.set))
        runner = web.AppRunner(self.app.app, access_log=None, handle_signals=False)
        await runner.setup()
        site_up = False
        next_bind = next_step = next_publish = 0.0
        try:
            while not guard.requested and not rospy.is_shutdown():
                now = time.monotonic()
                if not site_up and now >= next_bind:
                    site_up = await self._listen(runner)
                    next_bind = now + BIND_RETRY
                with self._wake_lock:
                    self._wake_pending = False
                self._drain()
                if now >= next_step:
                    self.core.step(now, time.time())
                    next_step = now + STEP_PERIOD
                if now >= next_publish:
                    self._publish_state(now)
                    next_publish = now + PUBLISH_PERIOD
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(self._wake.wait(), timeout=max(0.01, next_step - time.monotonic()))
                self._wake.clear()
        finally:
            await runner.cleanup()
            self.history.close()

    async def _listen(self, runner: web.AppRunner) -> bool:
        try:
            await web.TCPSite(runner, self.host, self.params.port, reuse_address=True, shutdown_timeout=0.5).start()
        except OSError as err:
            rospy.logerr(f"dashboard of {self.core.me}: cannot listen on {self.host}:{self.params.port}: "
                         f"{err.strerror}; trying again in {BIND_RETRY:g} s")
            return False
        rospy.loginfo(f"dashboard of {self.core.me}: http://{self.host}:{self.params.port}/")
        return True

    def _publish_state(self, now: float) -> None:
        stats = self.core.diagnostics()
        with contextlib.suppress(rospy.ROSException):
            self.links_pub.publish(links_to_msg(self.core.link_summary(now)))
            self.diag_pub.publish(diagnostics(f"dashboard: {self.core.me}", self.core.me, stats,
                                              bool(stats["open_alerts"]),
                                              f"{stats['clients']} live clients, {stats['open_alerts']} open alerts",
                                              time.time()))

    def _watch(self) -> None:
        """This robot's master and nodes, once a second (a thread: the calls block up to 0.5 s)."""
        uri = rosgraph.get_master_uri()
        caller = rospy.get_name()
        names = [global_name(n) for n in WATCHED_NODES] + sorted(self.ends)
        last: dict[str, str | None] = {}
        last_pid: object = -1
        while not self._stop.wait(WATCH_PERIOD):
            master = proxy(uri, 0.5)
            try:
                code, _, pid = master.getPid(caller)
                pid = pid if code == 1 else None
            except (OSError, xmlrpc.client.Error):
                pid = None
            if pid != last_pid:
                self._put("master", (pid, time.monotonic()))
                last_pid = pid
            if pid is None:
                continue
            for name in names:
                try:
                    code, _, node_uri = master.lookupNode(caller, name)
                except (OSError, xmlrpc.client.Error):
                    break
                found = node_uri if code == 1 else None
                if found != last.get(name):
                    last[name] = found
                    self._put("node", (name, found, time.monotonic()))

    def run(self, guard: ExitGuard) -> None:
        watcher = threading.Thread(target=self._watch, name="dashboard_watch", daemon=True)
        watcher.start()
        try:
            asyncio.run(self._main(guard))
        finally:
            self._stop.set()
            guard.loop_stopped()

    # -- the Bus of the web application ------------------------------------------------------
    def cancel(self, cancel: CancelData) -> None:
        self.cancel_pub.publish(cancel_to_msg(cancel))

    def staff(self, command: StaffCommandData) -> None:
        self.staff_pub.publish(staff_to_msg(command))

    def tour_edit(self, tour: TourMessage) -> None:
        self.edit_pub.publish(tour_to_msg(tour))


def main(argv: list[str] | None = None) -> int:
    guard = rospy_exit_guard(Node.DASHBOARD, main_loop=True)
    # no ROS time: every time here is wall time, and /clock would cost CPU for nothing
    rospy.init_node(Node.DASHBOARD, argv=argv if argv is not None else sys.argv, disable_signals=True,
                    disable_rostime=True)
    keep_registered()
    try:
        node = DashboardNode(Params.read())
    except (GidaBotError, WebError, OSError, ValueError, KeyError) as err:
        rospy.logfatal(f"{Node.DASHBOARD} cannot start: {err}")
        return 1
    node.run(guard)
    guard.spin(rospy.is_shutdown)
    return 0
