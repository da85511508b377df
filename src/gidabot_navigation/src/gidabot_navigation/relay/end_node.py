"""ROS adapter of one relay end: the node ``/gidabot_relay_<A>_<B>`` on one robot's master.

It wires rospy to the ROS-free parts: the end's decisions (:mod:`gidabot_navigation.relay.end`),
its socket loop (:mod:`gidabot_navigation.relay.link_io`, run in the main thread) and the delivery
hold (:mod:`gidabot_navigation.relay.delivery_hold`). This module reads the options once,
subscribes the shared topics as raw bytes and hands them to the core, publishes what the peer
sends with the real type, reports the master watch's events, and publishes diagnostics.
Started by the relay supervisor (:mod:`gidabot_navigation.relay.supervisor`) as
``python -m gidabot_navigation.relay.end_node``, never by hand.
"""

from __future__ import annotations

import contextlib
import http.client
import io
import os
import socket
import struct
import sys
import time
import xmlrpc.client
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import genpy
import rospy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from gidabot_navigation.errors import GidaBotError, RelayConfigError
from gidabot_navigation.interface import EVENT, STATE, Topic, TopicSpec, is_relay_end, relay_end_name
from gidabot_navigation.relay.delivery_hold import DeliveryHold, subscribers_in_system_state
from gidabot_navigation.relay.end import (
    EXIT_CONFIG,
    EXIT_PORT,
    PARENT_ENV,
    RelayEndConfig,
    RelayEndCore,
    load_shared_topics,
    read_secret,
)
from gidabot_navigation.relay.journal import Journal
from gidabot_navigation.relay.link_io import LinkIO, Periodic, open_listener, tcp_connector
from gidabot_navigation.resources import resource
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.master_watch import MasterEvent, MasterWatch, bound_master_calls, keep_registered, proxy
from gidabot_navigation.ros.replay import DEFAULT_WINDOW, ReplayBuffer, replay_to_peer
from gidabot_navigation.ros.rospy_internals import close_connections_from, connected_subscribers, publisher_lock


@dataclass(frozen=True)
class Params:
    robot_a: str
    robot_b: str
    side: str
    link_host: str
    link_port: int
    bind_ip: str
    topics_file: str
    secret_file: str
    state_dir: str
    max_message_bytes: int
    max_queue: int
    max_inbound: int
    max_queue_bytes: int
    heartbeat: float
    link_timeout: float
    state_rate: float
    hold_grace: float
    diagnostics_rate: float
    replay_window: float = DEFAULT_WINDOW
    replay_limit: int = 500

    @staticmethod
    def parse(argv: list[str]) -> Params:
        """The end's options (command line, never the parameter server: the end must start, and
        queue, while its master is down). ROS remappings (``x:=y``) in ``argv`` are ignored."""
        import argparse

        ap = argparse.ArgumentParser(prog="relay_end", description="one end of a GidaBot relay")
        ap.add_argument("--robot_a", required=True)
        ap.add_argument("--robot_b", required=True)
        ap.add_argument("--side", required=True, choices=("a", "b"))
        ap.add_argument("--link_host", required=True)
        ap.add_argument("--link_port", required=True, type=int)
        ap.add_argument("--bind_ip", default=os.environ.get("ROS_IP", ""))
        ap.add_argument("--topics_file", default="")
        ap.add_argument("--secret_file", default="")
        ap.add_argument("--state_dir", required=True)
        ap.add_argument("--max_message_bytes", type=int, default=1 << 20)
        ap.add_argument("--max_queue", type=int, default=10000)
        ap.add_argument("--max_inbound", type=int, default=10000)
        ap.add_argument("--max_queue_bytes", type=int, default=64 << 20)
        ap.add_argument("--heartbeat", type=float, default=0.5)
        ap.add_argument("--link_timeout", type=float, default=2.0)
        ap.add_argument("--state_rate", type=float, default=10.0)
        ap.add_argument("--hold_grace", type=float, default=1.5)
        ap.add_argument("--diagnostics_rate", type=float, default=1.0)
        ap.add_argument("--replay_window", type=float, default=DEFAULT_WINDOW)
        ap.add_argument("--replay_limit", type=int, default=500)
        args = [a for a in argv if ":=" not in a]
        try:
            ns = ap.parse_args(args)
        except SystemExit as err:
            raise RelayConfigError(f"bad relay_end options: {' '.join(args)}") from err
        for name in ("max_message_bytes", "max_queue", "max_inbound", "max_queue_bytes", "heartbeat", "link_timeout",
                     "state_rate", "hold_grace", "diagnostics_rate"):
            value = getattr(ns, name)
            if not value > 0 or value != value or value == float("inf"):
                raise RelayConfigError(f"--{name} must be positive and finite, got {value!r}")
        if not (0 <= ns.replay_window < float("inf") and 0 <= ns.replay_limit <= ns.max_inbound):
            raise RelayConfigError(f"--replay_window {ns.replay_window!r} s and --replay_limit {ns.replay_limit!r} "
                                   f"must be >= 0 (the limit at most --max_inbound)")
        if not 0 < ns.link_port <= 65535:
            raise RelayConfigError(f"--link_port {ns.link_port} is not a TCP port")
        _check_ip(ns.link_host, "--link_host")
        if ns.bind_ip:
            _check_ip(ns.bind_ip, "--bind_ip")
        for name in ("robot_a", "robot_b"):
            value = getattr(ns, name)
            if not value.replace("_", "").isalnum() or not value.isascii():
                raise RelayConfigError(f"--{name} {value!r}: robot names are letters, digits and '_'")
        return Params(**vars(ns))


def _check_ip(value: str, what: str) -> None:
    try:
        socket.inet_aton(value)
    except OSError as err:
        raise RelayConfigError(f"{what} {value!r} is not an IPv4 address (relays use IP addresses only)") from err
    if value.count(".") != 3:
        raise RelayConfigError(f"{what} {value!r} is not a dotted IPv4 address")


def raw_class(cls: type) -> type:
    """An AnyMsg subclass that publishes raw bytes under ``cls``'s type, md5 and definition."""
    return type(f"Raw_{cls._type.replace('/', '_')}", (rospy.AnyMsg,),
                {"_type": cls._type, "_md5sum": cls._md5sum, "_full_text": cls._full_text,
                 "_has_header": False, "__slots__": ()})


def make_validator(classes: dict[str, type]) -> Callable[[str, bytes], str | None]:
    """validate(topic, payload): None if ``payload`` is exactly a well-formed message of the topic's type."""

    def validate(topic: str, payload: bytes) -> str | None:
        cls = classes[topic]
        msg = cls()
        try:
            msg.deserialize(payload)
            again = io.BytesIO()
            msg.serialize(again)
        except (genpy.DeserializationError, genpy.SerializationError, struct.error, ValueError, TypeError,
                IndexError, UnicodeError) as err:
            return f"not a valid {cls._type} ({len(payload)} bytes): {err}"
        if again.getvalue() != payload:
            return f"not a valid {cls._type} ({len(payload)} bytes): invalid UTF-8 or trailing bytes"
        return None

    return validate


def make_speaker(classes: dict[str, type]) -> Callable[[str, bytes], str | None]:
    """speaker(topic, payload): the ``robot`` field of a message whose type has one (the state topics), else
    None (also for a payload that does not decode: the validator reports that)."""

    def speaker(topic: str, payload: bytes) -> str | None:
        cls = classes[topic]
        if "robot" not in getattr(cls, "__slots__", ()):
            return None
        msg = cls()
        try:
            msg.deserialize(payload)
        except (genpy.DeserializationError, struct.error, ValueError, TypeError, IndexError, UnicodeError):
            return None
        return msg.robot if isinstance(msg.robot, str) else None

    return speaker


class _StateLatch(rospy.SubscribeListener):
    """Gives a new subscriber of a state topic the latest value of every publisher (rospy's latch
    holds only the last one published, which it sends itself right after this)."""

    def __init__(self, node: RelayEndNode, topic: str) -> None:
        self.node, self.topic = node, topic

    def peer_subscribe(self, topic_name: str, topic_publish: Callable, peer_publish: Callable) -> None:
        lock = publisher_lock(self.node.pubs[self.topic])
        for msg in self.node.states_for_new_subscriber(self.topic):
            with lock:
                peer_publish(msg)


class _EventReplay(rospy.SubscribeListener):
    """Gives a new (non-relay) subscriber of an event topic the events this end published in the last
    ``--replay_window`` s: a node that was restarted gets what it missed (it ignores uids it handled)."""

    def __init__(self, node: RelayEndNode, topic: str) -> None:
        self.node, self.topic = node, topic

    def peer_subscribe(self, topic_name: str, topic_publish: Callable, peer_publish: Callable) -> None:
        # relays never forward what a relay published: no replay to the other relay ends of this master
        replay_to_peer(self.node.replays[self.topic], publisher_lock(self.node.pubs[self.topic]), peer_publish,
                       skip_relays=True)


class RelayEndNode:
    """One end of the relay between robots A and B, on this robot's master.

    Node name: ``/gidabot_relay_<A>_<B>`` (the same on both masters; any node named
    ``/gidabot_relay_*`` is a relay, and relays never forward what a relay published).

    Subscribed topics (raw bytes, ``rospy.AnyMsg``): every shared topic of ``--topics_file``
    (default ``config/shared_topics.yaml``): ``/gidabot/goals``, ``/gidabot/cancels``,
    ``/gidabot/nav_events``, ``/gidabot/tours`` (events) and ``/gidabot/status``,
    ``/gidabot/poses``, ``/gidabot/pending``, ``/gidabot/tour_index`` (states). Messages of
    another type/md5, larger than ``--max_message_bytes``, malformed, or published by a relay
    are not forwarded (counted); subscriptions to relay publishers are closed.

    Published topics: the same shared topics, with the messages of the other robot (events
    queue 10000; states latched, every publisher's latest value given to late subscribers);
    ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, stamped with WALL time: relays never use
    ROS time and do not subscribe ``/clock``) at ``--diagnostics_rate``: status
    ``relay <A>-<B>: <this robot>`` with connected, rtt_ms, queue_depth, forwarded, dropped,
    duplicates_suppressed, rejected_auth / _oversize / _malformed / _type / _foreign and more (docs/relay.md).

    Link: end ``b`` listens on ``--link_host``:``--link_port``; end ``a`` connects there from
    ``--bind_ip``. Frames are authenticated with HMAC-SHA256 when ``--secret_file`` names a file.

    Options (command line, ``--name value``; not ``~params``, because an end must start and
    queue while its master is down, and rospy uploads ``_param:=`` arguments to the master):
      - ``--robot_a``, ``--robot_b`` (str, required): the pair, in building order.
      - ``--side`` (``a`` or ``b``, required): which robot's master this end is on.
      - ``--link_host`` (IPv4, required), ``--link_port`` (int, required): end b's address.
      - ``--bind_ip`` (IPv4, default ``$ROS_IP``): end a's source address.
      - ``--topics_file`` (path, default the package's ``config/shared_topics.yaml``): the shared topics whitelist.
      - ``--secret_file`` (path, default ''): shared secret (>= 16 bytes); '' = no authentication.
      - ``--state_dir`` (path, required): where the journal ``<A>_<B>.<side>.journal`` lives.
      - ``--max_message_bytes`` (bytes, 1048576), ``--max_queue`` (events, 10000: unacknowledged
        outbound), ``--max_inbound`` (events, 10000: received, not yet published),
        ``--max_queue_bytes`` (bytes, 67108864: payload bytes of each of those queues).
      - ``--heartbeat`` (s, 0.5), ``--link_timeout`` (s, 2.0): liveness, wall time.
      - ``--state_rate`` (Hz, 10): max sends per (state topic, publisher).
      - ``--hold_grace`` (s, 1.5): after this master restarted, events are held until the
        subscribers seen before are back, or this long.
      - ``--replay_window`` (s, 60), ``--replay_limit`` (events, 500): a new subscriber that is not a
        relay (e.g. a node that was restarted) gets the events this end published in the last
        ``--replay_window`` s again (at most ``--replay_limit`` per topic); receivers ignore uids they
        already handled (docs/interfaces.md).
      - ``--diagnostics_rate`` (Hz, 1).
    """

    def __init__(self, params: Params, watch: MasterWatch | None) -> None:
        self.params = params
        name = rospy.get_name()
        if name != relay_end_name(params.robot_a, params.robot_b):
            raise RelayConfigError(f"this end is named {name} (remapped?); the relay between {params.robot_a} and "
                                   f"{params.robot_b} must be named {relay_end_name(params.robot_a, params.robot_b)}")
        specs = load_shared_topics(params.topics_file or resource("config", "shared_topics.yaml"))
        self.specs = {s.name: s for s in specs}
        classes = {s.name: _message_class(s) for s in specs}
        self.cfg = end_config(params, specs, classes)
        journal = Journal(Path(params.state_dir) / f"{self.cfg.pair}.{params.side}.journal")
        self.core = RelayEndCore(self.cfg, journal, time.monotonic, RosLog(), make_validator(classes),
                                 make_speaker(classes))
        self.raw = {n: raw_class(c) for n, c in classes.items()}
        self._last_latched: dict[str, str] = {}
        self.pruned = 0                      # subscriptions to relay publishers closed
        self.pubs: dict[str, rospy.Publisher] = {}
        self.events = [s.name for s in specs if s.kind == EVENT]
        self.replays = {t: ReplayBuffer(params.replay_window, params.replay_limit) for t in self.events}
        # at start (journal replay) too: events are held until this master's subscribers are connected
        self.hold = DeliveryHold(self.events, params.hold_grace, time.monotonic())
        self.core.set_delivery_open(False)
        self.io = LinkIO(self.core, time.monotonic,
                         connect=tcp_connector(params.link_host, params.link_port, params.bind_ip)
                         if params.side == "a" else None,
                         on_heartbeat=self._housekeeping,
                         jobs=(Periodic(1.0 / params.diagnostics_rate, self._publish_diagnostics),),
                         after_io=self._deliver)
        for s in specs:
            if s.kind == STATE:
                self.pubs[s.name] = rospy.Publisher(s.name, self.raw[s.name], queue_size=100, latch=True,
                                                    subscriber_listener=_StateLatch(self, s.name))
            else:
                self.pubs[s.name] = rospy.Publisher(s.name, self.raw[s.name], queue_size=10000,
                                                    subscriber_listener=_EventReplay(self, s.name))
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=5)
        self.subs = [rospy.Subscriber(s.name, rospy.AnyMsg, self._on_local, callback_args=s.name)
                     for s in specs]
        self.supervisor_pid = os.environ.get(PARENT_ENV, "")    # the end exits when its supervisor is gone
        self.watch = watch
        if watch is not None:
            watch.add_listener(self._on_master_event)

    def listen(self) -> None:
        """End b: bind the link port (raises OSError if it cannot)."""
        if self.params.side == "b":
            self.io.listen(open_listener(self.params.link_host, self.params.link_port))

    def run(self) -> None:
        """The I/O loop, until rospy shuts down, :meth:`stop`, or the supervisor is gone."""
        self.io.run(self._keep_running)

    def stop(self) -> None:
        self.io.stop()

    def _keep_running(self) -> bool:
        if rospy.is_shutdown():
            return False
        parent = self.supervisor_pid
        if parent and str(os.getppid()) != parent:
            rospy.logerr(f"{self.core.name}: the relay supervisor (pid {parent}) is gone; exiting")
            return False
        return True

    # -- rospy callbacks (any thread): hand over and return --------------------------------
    def _on_local(self, msg: rospy.AnyMsg, topic: str) -> None:
        header = msg._connection_header or {}
        payload = msg._buff if isinstance(msg._buff, bytes) else bytes(msg._buff)
        self.io.perform(lambda core: core.local_message(topic, header.get("callerid", ""), header.get("type", ""),
                                                        header.get("md5sum", ""), payload))

    def states_for_new_subscriber(self, topic: str) -> list[rospy.AnyMsg]:
        with self.io.lock:
            latest = self.core.latest_states(topic)
            skip = self._last_latched.get(topic)
        out = []
        for m in latest:
            if m.callerid != skip:
                r = self.raw[topic]()
                r._buff = m.payload
                out.append(r)
        return out

    def _on_master_event(self, event: MasterEvent, watch: MasterWatch) -> None:
        now = time.monotonic()
        with self.io.lock:
            if event is MasterEvent.DOWN:
                self.core.set_master_up(False)
                self.hold.master_down()
                self.core.set_delivery_open(False)
            elif event is MasterEvent.REREGISTER:
                self.core.set_master_up(True)
                self.hold.master_back(now)
                self.core.set_delivery_open(False)
        self.io.wake()

    # -- the I/O loop's jobs (its thread only, so deliveries stay in order) ------------------
    def _deliver(self) -> None:
        with self.io.lock:
            deliveries = self.core.take_deliveries()
        if not deliveries:
            return
        events = states = 0
        for d in deliveries:
            raw = self.raw[d.msg.topic]()
            raw._buff = d.msg.payload
            try:
                if d.kind == STATE:
                    with self.io.lock:
                        self._last_latched[d.msg.topic] = d.msg.callerid
                    self.pubs[d.msg.topic].publish(raw)
                    states += 1
                else:
                    self.replays[d.msg.topic].add(raw)
                    self.pubs[d.msg.topic].publish(raw)
                    events += 1
            except rospy.ROSException as err:       # shutting down
                rospy.logwarn(f"{self.core.name}: cannot publish on {d.msg.topic}: {err}")
                break
        with self.io.lock:
            self.core.delivered(events, states)

    def _housekeeping(self, now: float) -> None:
        self._update_hold(now)
        # subscriptions to relay publishers (itself, the other relay ends of this master): their messages
        # are never forwarded (dropped by caller id), so receiving them only costs CPU
        self.pruned += sum(close_connections_from(sub, is_relay_end) for sub in self.subs)

    def _update_hold(self, now: float) -> None:
        connected = {t: connected_subscribers(self.pubs[t]) for t in self.events}
        with self.io.lock:
            ask = self.hold.deciding(self.core.master_up)
        registered = self._registered_subscribers() if ask else {}     # XML-RPC: not under the lock
        with self.io.lock:
            release = self.hold.update(now, connected, self.core.master_up, registered)
            if release is None:
                return
            self.core.set_delivery_open(True)
            held_events = len(self.core.state.pending_in)
        rospy.loginfo(f"{self.core.name}: delivering {held_events} held event(s): {release.why}")

    def _registered_subscribers(self) -> dict[str, set[str]]:
        """Subscribers of the shared event topics registered with this end's master ({} if it does not answer)."""
        if self.watch is None:
            return {}
        try:
            code, _, state = proxy(self.watch.master_uri, 0.3).getSystemState(self.watch.caller_id)
        except (OSError, xmlrpc.client.Error, http.client.HTTPException, ValueError):
            return {}
        return subscribers_in_system_state(state, self.events) if code == 1 else {}

    def _publish_diagnostics(self, now: float) -> None:
        with self.io.lock:
            snap = self.core.snapshot()
            down_since = self.core.link_down_since
        snap["link_address"] = f"{self.params.link_host}:{self.params.link_port}"
        snap["pruned_relay_connections"] = self.pruned
        snap["side"] = self.params.side
        snap["replayed_events"] = sum(r.replayed for r in self.replays.values())
        arr = DiagnosticArray()
        arr.header.stamp = rospy.Time.now()
        arr.status = [diagnostic_status(self.cfg, snap, None if down_since is None else now - down_since)]
        with contextlib.suppress(rospy.ROSException):
            self.diag_pub.publish(arr)


def end_config(params: Params, specs: tuple[TopicSpec, ...], classes: dict[str, type]) -> RelayEndConfig:
    """The core's configuration from the options and the shared topics' message classes."""
    return RelayEndConfig(robot_a=params.robot_a, robot_b=params.robot_b, side=params.side, topics=specs,
                          md5s={n: c._md5sum for n, c in classes.items()},
                          secret=read_secret(params.secret_file) if params.secret_file else None,
                          max_message_bytes=params.max_message_bytes, max_queue=params.max_queue,
                          max_inbound=params.max_inbound, max_queue_bytes=params.max_queue_bytes,
                          heartbeat=params.heartbeat, link_timeout=params.link_timeout,
                          state_rate=params.state_rate,
                          header_topics=frozenset(s.name for s in specs
                                                  if s.kind == EVENT and classes[s.name]._has_header))


def diagnostic_status(cfg: RelayEndConfig, snap: dict[str, object], down_for: float | None) -> DiagnosticStatus:
    """The end's ``/diagnostics`` status from the core's snapshot (plus the adapter's values);
    ``down_for``: s since the link went down (None: up)."""
    status = DiagnosticStatus()
    status.name = f"relay {cfg.robot_a}-{cfg.robot_b}: {cfg.robot}"
    status.hardware_id = cfg.node_name
    if not snap["connected"]:
        status.level = DiagnosticStatus.ERROR
        since = "" if down_for is None else f" for {down_for:.1f} s"
        status.message = f"link to {cfg.peer_robot} down{since}; {snap['queue_depth']} event(s) queued"
    elif snap["peer_master_up"] is False or not snap["master_up"] or not snap["delivery_open"]:
        status.level = DiagnosticStatus.WARN
        who = cfg.peer_robot if snap["peer_master_up"] is False else cfg.robot
        status.message = f"connected; master of {who} down or restarting, events held"
    else:
        status.level = DiagnosticStatus.OK
        status.message = f"connected to {cfg.peer_robot}, rtt {snap['rtt_ms']} ms"
    status.values = [KeyValue(k, "" if v is None else str(v)) for k, v in snap.items()]
    return status


def _message_class(spec: TopicSpec) -> type:
    import roslib.message

    try:
        cls = roslib.message.get_message_class(spec.type)
    except (ImportError, ValueError, AttributeError) as err:
        raise RelayConfigError(f"shared topic {spec.name}: cannot load message type {spec.type}: {err}") from err
    if cls is None:
        raise RelayConfigError(f"shared topic {spec.name}: unknown message type {spec.type} (is the workspace built?)")
    return cls


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv if argv is None else argv)
    try:
        params = Params.parse(argv[1:])
    except RelayConfigError as err:
        print(f"relay_end: {err}", file=sys.stderr)
        return EXIT_CONFIG
    from gidabot_navigation.ros.exit_guard import rospy_exit_guard

    bound_master_calls()     # init_node's own calls to a master that does not answer are bounded too
    guard = rospy_exit_guard("relay_end")   # exit within 1 s of SIGINT/SIGTERM, master frozen or not
    # no ROS time: liveness is wall time, and /clock (100 Hz at 10x sim speed) would cost ~1 % of a core
    rospy.init_node(relay_end_name(params.robot_a, params.robot_b).lstrip("/"), argv=argv, disable_rostime=True,
                    disable_signals=True)
    watch = keep_registered()
    try:
        node = RelayEndNode(params, watch)
    except (GidaBotError, OSError) as err:
        rospy.logfatal(f"relay end {rospy.get_name()} cannot start: {err}")
        return EXIT_CONFIG
    try:
        node.listen()
    except OSError as err:
        rospy.logfatal(f"{node.core.name}: cannot listen on {params.link_host}:{params.link_port}: {err.strerror}")
        node.core.journal.close()
        return EXIT_PORT
    rospy.loginfo(f"{node.core.name}: {'listening on' if params.side == 'b' else 'connecting to'} "
                  f"{params.link_host}:{params.link_port}, {len(node.specs)} shared topics, "
                  f"{'HMAC-SHA256' if node.cfg.secret else 'NO authentication'}")
    rospy.on_shutdown(node.stop)
    node.run()
    guard.spin(rospy.is_shutdown)     # the shutdown runs in the guard's thread, never in this one
    return 0


if __name__ == "__main__":      # the supervisor starts each end as ``python -m gidabot_navigation.relay.end_node``
    sys.exit(main())
