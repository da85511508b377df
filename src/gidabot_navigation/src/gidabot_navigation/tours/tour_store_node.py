"""ROS adapter of the tour store: the ``tour_store`` node (one per robot, on the robot's own master).

The logic lives in :mod:`gidabot_navigation.tours.tour_store` (ROS-free). This module
reads the parameters once, converts messages, and runs one loop that owns the
store: callbacks only check sizes and enqueue raw bytes.
"""

from __future__ import annotations

import contextlib
import io
import os
import queue
import struct
import time
from dataclasses import dataclass
from pathlib import Path

import genpy
import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from gidabot_msgs.msg import Tour, TourCatalog, TourEditResult, TourIndex
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import TourRejected, TourStoreError
from gidabot_navigation.interface import DEFAULT_LANGUAGE, LANGUAGES, Node, Topic
from gidabot_navigation.ros.exit_guard import ExitGuard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.node_main import run_node
from gidabot_navigation.ros.params import param_number
from gidabot_navigation.tours.tour_store import NS, StoreLimits, TourMessage, TourRecord, TourStore, index_entries

QUEUE_SIZE = 1000


@dataclass(frozen=True)
class Params:
    building: str
    robot: str
    tours_dir: str
    seed_dir: str
    default_language: str
    index_rate: float
    limits: StoreLimits

    @staticmethod
    def read() -> Params:
        building = str(rospy.get_param("~building", ""))
        robot = str(rospy.get_param("~robot", ""))
        if not building or not robot:
            raise TourStoreError("~building (path of building.yaml or its directory) and ~robot (robot name) "
                                 "are required")
        ros_home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
        default_dir = os.path.join(ros_home, "gidabot", robot, "tours")
        tours_dir = str(rospy.get_param("~tours_dir", "") or default_dir)
        language = str(rospy.get_param("~default_language", DEFAULT_LANGUAGE))
        if language not in LANGUAGES:
            raise TourStoreError(f"~default_language {language!r} is not one of {', '.join(LANGUAGES)}")

        limits = StoreLimits(max_message_bytes=int(param_number("~max_message_bytes", StoreLimits.max_message_bytes)),
                        max_tours=int(param_number("~max_tours", StoreLimits.max_tours)),
                        max_future_ns=int(param_number("~max_clock_skew", StoreLimits.max_future_ns / NS) * NS),
                        tombstone_ttl_ns=int(param_number("~tombstone_ttl", StoreLimits.tombstone_ttl_ns / NS) * NS),
                        resend_period=param_number("~resend_period", StoreLimits.resend_period))
        return Params(building, robot, tours_dir, str(rospy.get_param("~seed_dir", "")), language,
                      param_number("~index_rate", 1.0), limits)


def to_core(msg: Tour) -> TourMessage:
    return TourMessage(uid=msg.uid, origin_robot=msg.origin_robot, editor_robot=msg.editor_robot,
                       version=int(msg.version), deleted=bool(msg.deleted), language=msg.language,
                       floor=float(msg.floor), tour_name=msg.tour_name, file_name=msg.file_name,
                       tour_goals_info=tuple(msg.tour_goals_info))


def to_ros(tm: TourMessage, stamp: rospy.Time | None = None) -> Tour:
    msg = Tour()
    msg.header.stamp = rospy.Time.now() if stamp is None else stamp
    msg.uid, msg.origin_robot, msg.editor_robot = tm.uid, tm.origin_robot, tm.editor_robot
    msg.version, msg.deleted, msg.language, msg.floor = tm.version, tm.deleted, tm.language, tm.floor
    msg.tour_name, msg.file_name, msg.tour_goals_info = tm.tour_name, tm.file_name, list(tm.tour_goals_info)
    return msg


def decode(cls: type, raw: bytes) -> genpy.Message:
    """Deserialise ``raw`` as ``cls``; ValueError if it is malformed or not valid UTF-8.

    genpy replaces undecodable bytes silently, so the message is serialised again and
    must give back exactly the bytes received.
    """
    msg = cls()
    try:
        msg.deserialize(raw)
        again = io.BytesIO()
        msg.serialize(again)
    except (genpy.DeserializationError, genpy.SerializationError, struct.error, ValueError, TypeError,
            IndexError) as err:
        raise ValueError(f"malformed {cls._type} message ({len(raw)} bytes): {err}") from err
    if again.getvalue() != raw:
        raise ValueError(f"{cls._type} message ({len(raw)} bytes) holds text that is not valid UTF-8 "
                         "or trailing bytes")
    return msg


class TourStoreNode:
    """Keeps this robot's tour directory and shares every change with the other robots.

    Published topics:
      - ``/gidabot/tours`` (gidabot_msgs/Tour, event, relayed): every local create / edit /
        delete (``deleted: true``), and re-sends of records a peer's index shows it lacks
        or holds in an older version (anti-entropy). Each message has a fresh ``uid``.
      - ``/gidabot/tour_index`` (gidabot_msgs/TourIndex, state, relayed, latched): every
        record this robot holds (tours and tombstones) with versions; on change and at
        ``~index_rate``.
      - ``tour_store/catalog`` (gidabot_msgs/TourCatalog, latched): the tours in this robot's
        directory, for the GUI and tour mode; on change.
      - ``tour_store/edit_result`` (gidabot_msgs/TourEditResult): the outcome of each admin
        action (ok and version, or the reason it was refused).
      - ``/diagnostics`` (diagnostic_msgs/DiagnosticArray): ``tour_store: <robot>`` with the
        counters (accepted, rejected by reason, blocked, resent...), at ``~index_rate``.

    Subscribed topics (all as raw bytes: the size is checked before anything is decoded):
      - ``/gidabot/tours`` (gidabot_msgs/Tour): tours from other robots, via the relays.
      - ``/gidabot/tour_index`` (gidabot_msgs/TourIndex): the other robots' indexes.
      - ``tour_store/edit`` (gidabot_msgs/Tour): admin create / edit / delete from the GUI;
        only ``file_name``, ``tour_name``, ``tour_goals_info``, ``language``, ``deleted``
        (and ``uid``, echoed in the result) are used; the store assigns versions.

    Parameters:
      - ``~building`` (str, required): building.yaml or its directory.
      - ``~robot`` (str, required): this robot's name in the building.
      - ``~tours_dir`` (str, default ``$ROS_HOME/gidabot/<robot>/tours``): the robot's own tour
        directory (created if missing; one store per directory, locked).
      - ``~seed_dir`` (str, default none): initial tours copied on first start if the directory
        is empty (the repository's ``tours/``).
      - ``~default_language`` (str, default ``en``): language of tours created without one.
      - ``~index_rate`` (Hz, default 1.0): index and diagnostics rate.
      - ``~resend_period`` (s, default 2.0): minimum time between re-sends of one tour to one peer.
      - ``~max_message_bytes`` (bytes, default 262144): larger Tour/TourIndex messages are
        rejected before decoding.
      - ``~max_tours`` (default 500): tours plus tombstones a directory may hold.
      - ``~max_clock_skew`` (s, default 86400): remote versions further in the future are rejected.
      - ``~tombstone_ttl`` (s, default 2592000 = 30 days): age after which deletions are forgotten.
    """

    def __init__(self, params: Params) -> None:
        self.params = params
        building = load_building(params.building)
        self.robot = params.robot
        self.store = TourStore(params.tours_dir, building, params.robot, wall_ns=time.time_ns, log=RosLog(),
                               seed_dir=params.seed_dir or None, default_language=params.default_language,
                               limits=params.limits)
        self.store.open()
        self.inbox: queue.Queue[tuple[str, bytes, str] | None] = queue.Queue(QUEUE_SIZE)   # None: wake up
        self.dropped = 0
        self.tours_pub = rospy.Publisher(Topic.TOURS, Tour, queue_size=100)
        self.index_pub = rospy.Publisher(Topic.TOUR_INDEX, TourIndex, queue_size=10, latch=True)
        self.catalog_pub = rospy.Publisher(Topic.TOUR_CATALOG, TourCatalog, queue_size=2, latch=True)
        self.result_pub = rospy.Publisher(Topic.TOUR_EDIT_RESULT, TourEditResult, queue_size=20)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=2)
        self.subs = [rospy.Subscriber(topic, rospy.AnyMsg, self._enqueue, callback_args=kind, queue_size=100)
                     for topic, kind in ((Topic.TOURS, "tour"), (Topic.TOUR_INDEX, "index"), (Topic.TOUR_EDIT, "edit"))]
        self._publish_state()

    # -- callbacks: size check, enqueue, return ---------------------------------------
    def _enqueue(self, msg: rospy.AnyMsg, kind: str) -> None:
        raw = msg._buff
        sender = msg._connection_header.get("callerid", "?") if msg._connection_header else "?"
        if len(raw) > self.params.limits.max_message_bytes:
            raw = len(raw).to_bytes(8, "little")     # only the size travels on
            kind = "oversized_" + kind
        try:
            self.inbox.put_nowait((kind, raw, sender))
        except queue.Full:
            self.dropped += 1

    def _wake(self) -> None:
        """End the loop's wait at once (from the exit guard's thread)."""
        with contextlib.suppress(queue.Full):
            self.inbox.put_nowait(None)

    # -- the loop that owns the store ---------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """The loop, until shutdown or the guard's signal (which wakes it); then the store is closed and the
        guard told the loop has stopped (it then closes the topics)."""
        guard.set_wake(self._wake)
        period = 1.0 / self.params.index_rate
        next_tick = time.monotonic() + period
        try:
            while not rospy.is_shutdown() and not guard.requested:
                try:
                    item = self.inbox.get(timeout=max(0.0, min(0.2, next_tick - time.monotonic())))
                except queue.Empty:
                    item = None
                if item is not None and self.handle(*item):
                    self._publish_state()
                now = time.monotonic()
                if now >= next_tick:
                    next_tick = max(next_tick + period, now)
                    self.tick()
        finally:
            self.store.close()
            guard.loop_stopped()

    def handle(self, kind: str, raw: bytes, sender: str) -> bool:
        """Handle one queued message; True if the store changed."""
        if kind.startswith("oversized_"):
            size = int.from_bytes(raw, "little")
            self.store.reject("oversized", f"{kind[10:]} message of {size} bytes from {sender} is larger than "
                                           f"the {self.params.limits.max_message_bytes} bytes allowed; not decoded")
            if kind == "oversized_edit":
                self._result(TourMessage(), None, "oversized", f"message of {size} bytes is too large")
            return False
        cls = {"tour": Tour, "index": TourIndex, "edit": Tour}[kind]
        try:
            msg = decode(cls, raw)
        except ValueError as err:
            self.store.reject("encoding", f"{err} from {sender}")
            return False
        if kind == "tour":
            return self.store.receive(to_core(msg)).changed
        if kind == "index":
            try:
                entries = index_entries(msg.file_names, msg.versions, msg.editor_robots, msg.deleted)
            except ValueError as err:
                self.store.reject("index", f"tour index of {msg.robot!r} from {sender}: {err}")
                return False
            for out in self.store.peer_index(msg.robot, entries, time.monotonic()):
                self.tours_pub.publish(to_ros(out))
            return False
        return self._edit(to_core(msg))

    def _edit(self, tm: TourMessage) -> bool:
        try:
            rec = self.store.edit(tm)
        except TourRejected as err:
            rospy.logwarn(f"admin {'delete' if tm.deleted else 'edit'} of tour {tm.file_name!r} refused: {err}")
            self._result(tm, None, err.reason, str(err))
            return False
        except TourStoreError as err:
            rospy.logerr(f"admin edit of tour {tm.file_name!r} failed: {err}")
            self._result(tm, None, "io", str(err))
            return False
        self.tours_pub.publish(to_ros(self.store.outgoing(rec)))
        self._result(tm, rec, "", "")
        return True

    def _result(self, tm: TourMessage, rec: TourRecord | None, reason: str, error: str) -> None:
        res = TourEditResult()
        res.header.stamp = rospy.Time.now()
        res.uid = tm.uid if isinstance(tm.uid, str) else ""
        res.file_name = tm.file_name if isinstance(tm.file_name, str) else ""
        res.deleted = bool(tm.deleted)
        res.ok = rec is not None
        res.version = rec.version if rec else 0
        res.reason, res.error = reason, error
        self.result_pub.publish(res)

    def tick(self) -> None:
        if self.store.step():
            self._publish_state()
        else:
            self._publish_index()
        self._publish_diagnostics()

    # -- outputs ------------------------------------------------------------------------
    def _publish_state(self) -> None:
        self._publish_index()
        cat = TourCatalog()
        cat.header.stamp = rospy.Time.now()
        cat.robot = self.robot
        cat.tours = [to_ros(rec.message("")) for rec in self.store.catalog()]
        self.catalog_pub.publish(cat)

    def _publish_index(self) -> None:
        entries = self.store.index()
        idx = TourIndex()
        idx.header.stamp = rospy.Time.now()
        idx.robot = self.robot
        idx.file_names = [e.file_name for e in entries]
        idx.versions = [e.version for e in entries]
        idx.editor_robots = [e.editor_robot for e in entries]
        idx.deleted = [e.deleted for e in entries]
        self.index_pub.publish(idx)

    def _publish_diagnostics(self) -> None:
        stats = self.store.stats()
        stats["queue_dropped"] = self.dropped
        status = DiagnosticStatus()
        status.name = f"tour_store: {self.robot}"
        status.hardware_id = self.robot
        status.level = DiagnosticStatus.WARN if stats["blocked"] else DiagnosticStatus.OK
        status.message = (f"{stats['tours']} tours, {stats['blocked']} blocked, "
                          f"{stats.get('rejected', 0)} rejected")
        if self.store.last_rejection:
            stats_text = {"last_rejection": self.store.last_rejection[:300]}
        else:
            stats_text = {}
        status.values = [KeyValue(k, str(v)) for k, v in sorted(stats.items())] + \
                        [KeyValue(k, v) for k, v in stats_text.items()]
        arr = DiagnosticArray()
        arr.header.stamp = rospy.Time.now()
        arr.status = [status]
        self.diag_pub.publish(arr)


def main(argv: list[str] | None = None) -> int:
    return run_node(Node.TOUR_STORE, lambda: TourStoreNode(Params.read()),
                    lambda n: f"tour_store of {n.robot}: {Path(n.params.tours_dir)}", argv)
