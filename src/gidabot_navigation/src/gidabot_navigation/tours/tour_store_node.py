"""ROS adapter of the tour store: the ``tour_store`` node (one per robot, on the robot's own master).

The logic lives in :mod:`gidabot_navigation.tours.tour_store` (ROS-free). Callbacks only check sizes and
enqueue raw bytes; one loop owns the store: it decodes each message (exactly, :func:`decode`), converts it
(:mod:`gidabot_navigation.ros.convert`), hands it to the store and publishes what the store answers.
"""

from __future__ import annotations

import io
import os
import struct
import time
from dataclasses import dataclass, replace
from pathlib import Path

import genpy
import rospy
from diagnostic_msgs.msg import DiagnosticArray

from gidabot_msgs.msg import Tour, TourCatalog, TourEditResult, TourIndex
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import ParamError
from gidabot_navigation.interface import DEFAULT_LANGUAGE, LANGUAGES, Node, Topic
from gidabot_navigation.ros import convert
from gidabot_navigation.ros.adapter import Inbox, diagnostics, sender
from gidabot_navigation.ros.exit_guard import ExitGuard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.node_main import run_loop, run_node
from gidabot_navigation.ros.params import param_number, param_text, robot_params
from gidabot_navigation.tours.tour_store import (
    NS,
    EditResultData,
    StoreLimits,
    TourMessage,
    TourStore,
    edit_result,
)

QUEUE_SIZE = 1000
OVERSIZED = "oversized_"      # prefix of the kind of a message too large to decode (only its size is queued)


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
        building, robot = robot_params()
        ros_home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
        tours_dir = param_text("~tours_dir", "") or os.path.join(ros_home, "gidabot", robot, "tours")
        language = param_text("~default_language", DEFAULT_LANGUAGE)
        if language not in LANGUAGES:
            raise ParamError(f"~default_language {language!r} is not one of {', '.join(LANGUAGES)}")
        limits = StoreLimits(max_message_bytes=int(param_number("~max_message_bytes", StoreLimits.max_message_bytes)),
                             max_tours=int(param_number("~max_tours", StoreLimits.max_tours)),
                             max_future_ns=int(param_number("~max_clock_skew", StoreLimits.max_future_ns / NS) * NS),
                             tombstone_ttl_ns=int(param_number("~tombstone_ttl",
                                                               StoreLimits.tombstone_ttl_ns / NS) * NS),
                             resend_period=param_number("~resend_period", StoreLimits.resend_period))
        return Params(building, robot, tours_dir, param_text("~seed_dir", ""), language,
                      param_number("~index_rate", 1.0), limits)


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
        self.inbox = Inbox(QUEUE_SIZE)
        self._next_tick = time.monotonic() + 1.0 / params.index_rate
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
        if len(raw) > self.params.limits.max_message_bytes:
            raw = len(raw).to_bytes(8, "little")     # only the size travels on
            kind = OVERSIZED + kind
        self.inbox.put(kind, (raw, sender(msg) or "?"))

    # -- the loop that owns the store ---------------------------------------------------
    def run(self, guard: ExitGuard) -> None:
        """The loop until shutdown or the guard's signal; then the store is closed."""
        run_loop(guard, self.spin_once, 0.2, lambda: self.inbox.put(""), self.store.close)

    def spin_once(self, timeout: float) -> None:
        """One turn of the loop: at most one message (waiting up to ``timeout`` wall s, less when the index is
        due), then the periodic work when due."""
        kind, item = self.inbox.get(max(0.0, min(timeout, self._next_tick - time.monotonic())))
        if kind and self.handle(kind, *item):  # type: ignore[misc]
            self._publish_state()
        now = time.monotonic()
        if now >= self._next_tick:
            self._next_tick = max(self._next_tick + 1.0 / self.params.index_rate, now)
            self.tick()

    def handle(self, kind: str, raw: bytes, sender: str) -> bool:
        """Handle one queued message; True if the store changed."""
        if kind.startswith(OVERSIZED):
            size = int.from_bytes(raw, "little")
            kind = kind[len(OVERSIZED):]
            self.store.reject("oversized", f"{kind} message of {size} bytes from {sender} is larger than "
                                           f"the {self.params.limits.max_message_bytes} bytes allowed; not decoded")
            if kind == "edit":
                self._answer(edit_result(TourMessage(), None, "oversized", f"message of {size} bytes is too large"))
            return False
        try:
            msg = decode(TourIndex if kind == "index" else Tour, raw)
        except ValueError as err:
            self.store.reject("encoding", f"{err} from {sender}")
            return False
        if kind == "tour":
            return self.store.receive(convert.tour_from_msg(msg)).changed
        if kind == "index":
            try:
                index = convert.index_from_msg(msg)
            except ValueError as err:
                self.store.reject("index", f"tour index of {msg.robot!r} from {sender}: {err}")
                return False
            for out in self.store.peer_index(index.robot, index.entries, time.monotonic()):
                self._share(out)
            return False
        result, out = self.store.admin_edit(convert.tour_from_msg(msg))
        self._answer(result)
        if out is None:
            return False
        self._share(out)
        return True

    def tick(self) -> None:
        if self.store.step():
            self._publish_state()
        else:
            self._publish_index()
        self._publish_diagnostics()

    # -- outputs ------------------------------------------------------------------------
    def _share(self, tour: TourMessage) -> None:
        self.tours_pub.publish(convert.tour_to_msg(replace(tour, stamp=rospy.get_time())))

    def _answer(self, result: EditResultData) -> None:
        self.result_pub.publish(convert.edit_result_to_msg(replace(result, stamp=rospy.get_time())))

    def _publish_state(self) -> None:
        self._publish_index()
        self.catalog_pub.publish(convert.catalog_to_msg(replace(self.store.catalog_data(), stamp=rospy.get_time())))

    def _publish_index(self) -> None:
        self.index_pub.publish(convert.index_to_msg(replace(self.store.index_data(), stamp=rospy.get_time())))

    def _publish_diagnostics(self) -> None:
        stats: dict[str, object] = dict(self.store.stats())
        stats["queue_dropped"] = self.inbox.dropped
        if self.store.last_rejection:
            stats["last_rejection"] = self.store.last_rejection[:300]
        self.diag_pub.publish(diagnostics(f"tour_store: {self.robot}", self.robot, stats, bool(stats["blocked"]),
                                          f"{stats['tours']} tours, {stats['blocked']} blocked, "
                                          f"{stats.get('rejected', 0)} rejected", rospy.get_time()))


def main(argv: list[str] | None = None) -> int:
    return run_node(Node.TOUR_STORE, lambda: TourStoreNode(Params.read()),
                    lambda n: f"tour_store of {n.robot}: {Path(n.params.tours_dir)}", argv)
