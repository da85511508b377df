"""The core of a relay end (ROS-free): what one end of the relay between two robots' masters decides.

A relay between robots A and B has two ends, each an ordinary node named
``/gidabot_relay_A_B`` on its own robot's master; the ends talk over one authenticated
TCP connection, the link (end b listens, end a connects). This module is everything an
end decides, with no sockets, threads or rospy: the adapter
(:mod:`gidabot_navigation.relay.end_node`) feeds
it local messages, connection events, received bytes and the time, and carries out
the :class:`Send` / :class:`Close` actions it returns and the deliveries it hands out.

- **Events** (exactly once, in order per source): every accepted local event gets the
  next sequence number of this end's stream (epoch + seq), is written to the journal,
  then sent; it stays queued until the peer acknowledges it (bounded: the oldest is
  dropped with a clear log). On every new connection the unacknowledged events are
  sent again. The receiver journals an event before acknowledging it, de-duplicates by
  (epoch, seq), and publishes it once delivery is open (the adapter holds delivery
  while its master restarts, until the old subscribers are back).
- **States** (latest value per (topic, publisher)): coalesced to ``state_rate`` per key,
  all re-sent on every new connection; the receiver publishes them latched.
- **No loops**: messages whose publisher is a relay (``/gidabot_relay_*``) are never
  forwarded, so a message crosses exactly one relay.
- **A message speaks only for its sender** (:mod:`gidabot_navigation.senders`): only this
  robot's own nodes' messages are forwarded (the adapter passes each message's callerid;
  any other publisher is an ``impostor``), and only if they speak for this robot; a message
  the peer sends must speak for the peer. "Speaks for" is the table
  ``senders.SPEAKS_FOR`` (a goal's or cancel's ``origin_robot``, an event's, status', pose's,
  pending list's, tour index's, staff command's or link summary's ``robot``, a tour's uid); an
  event's uid must be in that robot's namespace; a staff command or link summary only from the
  robot's dashboard (``senders.PUBLISHERS``). Else refused: ``foreign`` (another robot),
  ``wrong_namespace`` (uid), ``impostor`` (another node).
- **Security and hygiene**: HMAC-SHA256 on every frame when a secret is configured,
  size limits, whitelist of topics and types (md5); anything rejected is counted by reason
  (:data:`REJECT_REASONS`) and logged at a limited rate; a bad frame closes that connection,
  never the end.
- **Liveness** in monotonic wall time: heartbeats every ``heartbeat`` s; a connection
  with no frame for ``link_timeout`` s is closed (detected within 3 s with the defaults).
"""

from __future__ import annotations

import math
import secrets
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

import yaml

from gidabot_navigation.errors import FrameRejected, JournalError, RelayConfigError
from gidabot_navigation.interface import EVENT, STATE, TopicSpec, is_relay_end, relay_end_name
from gidabot_navigation.logs import Logger, RateLimitedLog
from gidabot_navigation.relay.journal import Journal, JournalState, event_digest
from gidabot_navigation.relay.protocol import (
    FRAME_OVERHEAD,
    NONCE_LEN,
    FrameReader,
    FrameType,
    Hello,
    Message,
    check_mac,
    decode_message,
    decode_ping,
    decode_u64,
    encode_frame,
    encode_message,
    encode_ping,
    encode_u64,
    hello_key,
    session_keys,
)
from gidabot_navigation.senders import FOREIGN, IMPOSTOR, WRONG_NAMESPACE, Claim, Senders, explain

REJECT_REASONS = ("auth", "oversize", "malformed", "type", IMPOSTOR, FOREIGN, WRONG_NAMESPACE)
# how an end process tells its supervisor (gidabot_navigation.relay.supervisor) why it stopped
EXIT_CONFIG = 2                          # bad options: restarting will not help
EXIT_PORT = 3                            # end b cannot bind the building's link port (taken, or not its address)
PARENT_ENV = "GIDABOT_RELAY_PARENT"      # set by the supervisor: an end exits when its parent is gone


# -- configuration --------------------------------------------------------------------------
def load_shared_topics(path: str | Path) -> tuple[TopicSpec, ...]:
    """Read the whitelist (``config/shared_topics.yaml``): ``topics: [{name, type, class}]``."""
    try:
        doc = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        raise RelayConfigError(f"cannot read the shared topics file {path}: {err}") from err
    return parse_shared_topics(doc, str(path))


def parse_shared_topics(doc: object, where: str = "shared topics") -> tuple[TopicSpec, ...]:
    if not isinstance(doc, dict) or not isinstance(doc.get("topics"), list) or not doc["topics"]:
        raise RelayConfigError(f"{where}: expected a mapping with a non-empty list 'topics', got {doc!r:.200}")
    specs: list[TopicSpec] = []
    for i, item in enumerate(doc["topics"]):
        if not isinstance(item, dict) or set(item) != {"name", "type", "class"}:
            raise RelayConfigError(f"{where}: topics[{i}] = {item!r:.200}: expected exactly the keys "
                                   "name, type, class")
        name, type_, kind = item["name"], item["type"], item["class"]
        if not isinstance(name, str) or not name.startswith("/") or " " in name or len(name) > 200:
            raise RelayConfigError(f"{where}: topics[{i}].name {name!r}: expected a global topic name (/...)")
        if not isinstance(type_, str) or type_.count("/") != 1 or len(type_) > 200:
            raise RelayConfigError(f"{where}: topics[{i}].type {type_!r}: expected package/Type")
        if kind not in (EVENT, STATE):
            raise RelayConfigError(f"{where}: topics[{i}].class {kind!r}: expected event or state")
        if any(s.name == name for s in specs):
            raise RelayConfigError(f"{where}: topic {name} is listed twice")
        specs.append(TopicSpec(name, type_, kind))
    return tuple(specs)


def read_secret(path: str | Path) -> bytes:
    """The shared secret from a file (surrounding whitespace stripped; at least 16 bytes)."""
    p = Path(path)
    try:
        st = p.stat()
        data = p.read_bytes().strip()
    except OSError as err:
        raise RelayConfigError(f"cannot read the relay secret file {p}: {err.strerror}") from err
    if st.st_size > 4096:
        raise RelayConfigError(f"relay secret file {p} is {st.st_size} bytes; expected a short secret (< 4 KiB)")
    if len(data) < 16:
        raise RelayConfigError(f"relay secret in {p} is {len(data)} bytes; expected at least 16")
    return data


@dataclass(frozen=True)
class RelayEndConfig:
    """One end of the relay between ``robot_a`` and ``robot_b`` (times in wall seconds)."""

    robot_a: str
    robot_b: str
    side: str                                   # "a" (connects) or "b" (listens)
    topics: tuple[TopicSpec, ...]
    md5s: dict[str, str]                        # topic -> md5 of its type
    secret: bytes | None = None
    max_message_bytes: int = 1 << 20            # serialized ROS message
    max_queue: int = 10000                      # unacknowledged outbound events
    max_inbound: int = 10000                    # received events waiting to be published
    max_queue_bytes: int = 64 << 20             # payload bytes of each of those two queues
    max_state_keys: int = 1000                  # (state topic, publisher) pairs remembered per direction
    heartbeat: float = 0.5                      # s between PINGs
    link_timeout: float = 2.0                   # s without any frame: the connection is dead
    handshake_timeout: float = 3.0              # s for a new connection to authenticate
    state_rate: float = 10.0                    # Hz, max sends per (state topic, publisher)
    max_pending_connections: int = 8            # connections not yet authenticated
    header_topics: frozenset[str] = frozenset()  # event topics whose type starts with std_msgs/Header
    # node names of this robot's relay ends (its links to every other robot): a local publisher named like a relay
    # end but none of them is an impostor (refused, counted); empty: every relay-named publisher is taken for one
    robot_ends: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        if self.side not in ("a", "b"):
            raise RelayConfigError(f"side {self.side!r}: expected a or b")
        for name in ("heartbeat", "link_timeout", "handshake_timeout", "state_rate"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise RelayConfigError(f"{name} must be a positive number of seconds (Hz), got {v!r}")
        if self.heartbeat >= self.link_timeout:
            raise RelayConfigError(f"heartbeat {self.heartbeat} s must be shorter than link_timeout "
                                   f"{self.link_timeout} s")
        for name in ("max_message_bytes", "max_queue", "max_inbound", "max_queue_bytes", "max_state_keys",
                     "max_pending_connections"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 1:
                raise RelayConfigError(f"{name} must be a positive integer, got {v!r}")
        missing = [t.name for t in self.topics if t.name not in self.md5s]
        if missing:
            raise RelayConfigError(f"no md5 for topic(s) {', '.join(missing)}")

    @property
    def pair(self) -> str:
        return f"{self.robot_a}_{self.robot_b}"

    @property
    def robot(self) -> str:
        return self.robot_a if self.side == "a" else self.robot_b

    @property
    def peer_robot(self) -> str:
        return self.robot_b if self.side == "a" else self.robot_a

    @property
    def node_name(self) -> str:
        return relay_end_name(self.robot_a, self.robot_b)


# -- actions --------------------------------------------------------------------------------
@dataclass(frozen=True)
class Send:
    conn: int
    data: bytes


@dataclass(frozen=True)
class Close:
    conn: int
    reason: str


Action = Send | Close


@dataclass(frozen=True)
class Delivery:
    """A message to publish on this end's master."""

    kind: str        # "event" or "state"
    msg: Message


class ConnState(Enum):
    WAIT_HELLO = "wait_hello"      # a: sent HELLO, waiting for b's; b: waiting for a's HELLO
    WAIT_READY = "wait_ready"      # b: answered HELLO, waiting for a's READY
    ACTIVE = "active"


@dataclass
class _Conn:
    id: int
    initiator: bool
    reader: FrameReader
    opened: float
    last_rx: float
    state: ConnState = ConnState.WAIT_HELLO
    nonce: bytes = b""
    peer: Hello | None = None
    tx_key: bytes | None = None
    rx_key: bytes | None = None
    tx_count: int = 0
    rx_count: int = 0
    last_ping: float = -math.inf


@dataclass
class Stats:
    forwarded_events: int = 0       # local events accepted (journaled and sent / queued)
    forwarded_states: int = 0       # state frames sent
    delivered_events: int = 0       # peer events published here
    delivered_states: int = 0       # peer states published here
    dropped: int = 0                # events dropped by a queue bound (outbound + inbound)
    duplicates_suppressed: int = 0  # peer events already received
    replays_ignored: int = 0        # local events already forwarded, published again (a replay, a restart)
    ignored_relay: int = 0          # local messages published by a relay (never forwarded again)
    resent: int = 0                 # events sent again on a new connection
    acked_on_reconnect: int = 0     # unacknowledged events the peer's HELLO said it had stored (ACK lost)
    connections: int = 0            # authenticated connections so far
    link_losses: int = 0            # active connections lost
    rejected: dict[str, int] = field(default_factory=lambda: dict.fromkeys(REJECT_REASONS, 0))


class RelayEndCore:
    """One end's decisions (see the module docstring). Not thread-safe: the adapter serialises calls.

    ``validate(topic, payload)`` returns None if the payload is a well-formed message of
    the topic's type, else a short description of what is wrong; ``speaker(topic, payload)``
    whom a (well-formed) message speaks for: ``senders.claim_of(topic, <the decoded message>)``,
    a :class:`~gidabot_navigation.senders.Claim` for every shared topic (None: the payload does
    not say; not checked).
    """

    def __init__(self, cfg: RelayEndConfig, journal: Journal, clock: Callable[[], float], log: Logger,
                 validate: Callable[[str, bytes], str | None] | None = None,
                 speaker: Callable[[str, bytes], Claim | None] | None = None) -> None:
        self.cfg = cfg
        self.journal = journal
        self.clock = clock
        self.log = log
        self.rlog = RateLimitedLog(log, clock, burst=1, window=5.0)
        self.validate = validate or (lambda topic, payload: None)
        self.speaker = speaker or (lambda topic, payload: None)
        self.topics = {t.name: t for t in cfg.topics}
        self.senders = Senders(cfg.robot, {cfg.node_name: cfg.peer_robot})
        self.key_hello = hello_key(cfg.secret) if cfg.secret else None
        self.max_body = cfg.max_message_bytes + FRAME_OVERHEAD
        self.state: JournalState = journal.open()
        if journal.truncated_bytes:
            log.warning(f"relay {cfg.pair} ({cfg.robot}): cut a torn tail of {journal.truncated_bytes} bytes off "
                        f"the journal (the process was killed while writing)")
        if self.state.outq or self.state.pending_in:
            log.info(f"relay {cfg.pair} ({cfg.robot}): journal holds {len(self.state.outq)} unacknowledged "
                     f"and {len(self.state.pending_in)} unpublished event(s); they will be delivered")
        self.stats = Stats()
        self._out_bytes = sum(len(m.payload) for m in self.state.outq)
        self._in_bytes = sum(len(m.payload) for _, m in self.state.pending_in)
        self.conns: dict[int, _Conn] = {}
        self.active: _Conn | None = None
        self.master_up = True
        self.master_down_since: float | None = None
        self.peer_master_up: bool | None = None
        self.peer_master_down_since: float | None = None
        self.rtt: float | None = None
        self.delivery_open = True
        self._handed_out = 0
        self._out_states: dict[tuple[str, str], Message] = {}
        self._in_states: dict[tuple[str, str], Message] = {}
        self._state_sent: dict[tuple[str, str], float] = {}
        self._state_dirty: set[tuple[str, str]] = set()
        self._state_deliveries: list[Message] = []
        self.last_error = ""
        self.link_down_since: float | None = clock()

    # -- helpers --------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return f"relay {self.cfg.pair} ({self.cfg.robot} end)"

    def _reject(self, reason: str, text: str) -> None:
        self.stats.rejected[reason] = self.stats.rejected.get(reason, 0) + 1
        self.last_error = text[:300]
        self.rlog.warning(f"reject:{reason}", f"{self.name}: rejected ({reason}): {text}")

    def _frame(self, conn: _Conn, ftype: FrameType, body: bytes) -> Send:
        data = encode_frame(ftype, body, conn.tx_key, conn.tx_count)
        conn.tx_count += 1
        return Send(conn.id, data)

    def _speaks_for(self, topic: str, payload: bytes, callerid: str, origin: str) -> bool:
        """Whether a message its publisher ``callerid`` (a local node, or this link's node name for the peer's)
        may send speaks for the robot that publisher may speak for (or does not say): else rejected, counted."""
        claim = self.speaker(topic, payload)
        if claim is None:
            return True
        sender = self.senders.attribute(callerid)
        kind = self.senders.refusal(sender, claim, topic)
        if kind is None:
            return True
        self._reject(kind, f"{origin} {topic}: {explain(kind, sender, claim)}: a message crosses only from the robot "
                           f"it speaks for")
        return False

    def _check_size(self, topic: str, payload: bytes, origin: str) -> bool:
        if len(payload) > self.cfg.max_message_bytes:
            self._reject("oversize", f"{origin} message on {topic} of {len(payload)} bytes is larger than "
                                     f"the {self.cfg.max_message_bytes} bytes allowed")
            return False
        return True

    # -- local messages (from this end's master) -------------------------------------------
    def local_message(self, topic: str, callerid: str, type_: str, md5: str, payload: bytes) -> list[Action]:
        """A message the local node ``callerid`` published on a shared topic; returns frames to send now. Only this
        robot's own nodes are forwarded, and only what speaks for this robot."""
        if is_relay_end(callerid):
            if self.cfg.robot_ends and callerid not in self.cfg.robot_ends:
                self._reject(IMPOSTOR, f"local publisher {callerid[:80]!r} on {topic} is named like a relay end but "
                                       f"is none of {self.cfg.robot}'s: not forwarded")
                return []
            self.stats.ignored_relay += 1       # another link's end published what its robot sent: not again
            return []
        sender = self.senders.attribute(callerid)
        if not sender.own:
            self._reject(IMPOSTOR, f"local publisher {callerid[:80]!r} on {topic} is not one of {self.cfg.robot}'s "
                                   f"nodes: not forwarded")
            return []
        spec = self.topics.get(topic)
        if spec is None:
            self._reject("type", f"local message on {topic}, which is not a shared topic")
            return []
        if md5 != self.cfg.md5s[topic] or (type_ and type_ != spec.type):
            self._reject("type", f"local publisher {callerid} sends {type_ or '?'} (md5 {md5[:12]}) on {topic}; "
                                 f"only {spec.type} (md5 {self.cfg.md5s[topic][:12]}) crosses")
            return []
        if not self._check_size(topic, payload, f"local publisher {callerid}'s"):
            return []
        problem = self.validate(topic, payload)
        if problem:
            self._reject("malformed", f"local publisher {callerid} on {topic}: {problem}")
            return []
        if not self._speaks_for(topic, payload, callerid, f"local publisher {callerid}'s"):
            return []
        if spec.kind == STATE:
            return self._local_state(Message(topic, callerid, md5, payload))
        digest = event_digest(topic, payload, 4 if topic in self.cfg.header_topics else 0)
        if digest in self.state.recent_out:
            self.stats.replays_ignored += 1     # published again (replayed to this end, a restarted node)
            return []
        return self._local_event(Message(topic, callerid, md5, payload, self.state.next_seq), digest)

    def _local_event(self, m: Message, digest: bytes | None = None) -> list[Action]:
        try:
            self.journal.out_event(m, digest)
        except JournalError as err:
            self.stats.dropped += 1
            self.rlog.warning("journal", f"{self.name}: event on {m.topic} from {m.callerid} dropped: {err}")
            return []
        self.state.next_seq = m.seq + 1
        if digest is not None:
            self.state.remember_out(digest)
        self.state.outq.append(m)
        self._out_bytes += len(m.payload)
        self.stats.forwarded_events += 1
        while len(self.state.outq) > 1 and (len(self.state.outq) > self.cfg.max_queue
                                            or self._out_bytes > self.cfg.max_queue_bytes):
            old = self.state.outq.popleft()
            self._out_bytes -= len(old.payload)
            self.stats.dropped += 1
            self._journal_quiet(lambda old=old: self.journal.out_done(old.seq))
            self.rlog.warning("queue_out", f"{self.name}: outbound queue full ({self.cfg.max_queue} events or "
                                           f"{self.cfg.max_queue_bytes} bytes unacknowledged by "
                                           f"{self.cfg.peer_robot}); dropped the oldest event, seq {old.seq} on "
                                           f"{old.topic} from {old.callerid} ({self.stats.dropped} dropped so far)")
        if self.active is not None:
            return [self._frame(self.active, FrameType.EVENT, encode_message(m, True))]
        return []

    def _local_state(self, m: Message) -> list[Action]:
        key = (m.topic, m.callerid)
        if key not in self._out_states and len(self._out_states) >= self.cfg.max_state_keys:
            self.stats.dropped += 1
            self.rlog.warning("state_keys", f"{self.name}: already {self.cfg.max_state_keys} (state topic, "
                                            f"publisher) pairs; state on {m.topic} from {m.callerid} dropped")
            return []
        self._out_states[key] = m
        now = self.clock()
        if self.active is not None and now - self._state_sent.get(key, -math.inf) >= 1.0 / self.cfg.state_rate:
            self._state_dirty.discard(key)
            return [self._send_state(self.active, key, now)]
        self._state_dirty.add(key)
        return []

    def _send_state(self, conn: _Conn, key: tuple[str, str], now: float) -> Send:
        self._state_sent[key] = now
        self.stats.forwarded_states += 1
        return self._frame(conn, FrameType.STATE, encode_message(self._out_states[key], False))

    def _journal_quiet(self, write: Callable[[], None]) -> None:
        try:
            write()
        except JournalError as err:
            self.rlog.warning("journal", f"{self.name}: {err}")

    # -- connections ----------------------------------------------------------------------
    def connection_opened(self, conn_id: int, initiator: bool) -> list[Action]:
        """A TCP connection exists (initiator: this end connected). Returns the first frames."""
        now = self.clock()
        pending = [c for c in self.conns.values() if c.state is not ConnState.ACTIVE]
        if len(pending) >= self.cfg.max_pending_connections:
            self.rlog.warning("pending", f"{self.name}: too many unauthenticated connections; refusing one")
            return [Close(conn_id, "too many unauthenticated connections")]
        conn = _Conn(conn_id, initiator, FrameReader(self.max_body), now, now, nonce=secrets.token_bytes(NONCE_LEN))
        self.conns[conn_id] = conn
        if not initiator:
            return []
        hello = Hello(self.cfg.pair, self.cfg.side, conn.nonce, b"", self.state.out_epoch, self.state.in_epoch,
                      self.state.in_last)
        return [Send(conn_id, encode_frame(FrameType.HELLO, hello.encode(), self.key_hello, 0))]

    def connection_closed(self, conn_id: int, reason: str = "closed") -> None:
        conn = self.conns.pop(conn_id, None)
        if conn is not None and conn is self.active:
            self.active = None
            self.rtt = None
            self.peer_master_up = None
            self.peer_master_down_since = None
            self.stats.link_losses += 1
            self.link_down_since = self.clock()
            self._handed_out = min(self._handed_out, len(self.state.pending_in))
            self.log.warning(f"{self.name}: link to {self.cfg.peer_robot} lost ({reason}); "
                             f"{len(self.state.outq)} event(s) queued")

    def data_received(self, conn_id: int, data: bytes) -> list[Action]:
        """Bytes from a connection; returns frames to send and Close actions."""
        conn = self.conns.get(conn_id)
        if conn is None:
            return []
        conn.reader.feed(data)
        out: list[Action] = []
        ack_due = False
        try:
            while True:
                frame = conn.reader.next()
                if frame is None:
                    break
                conn.last_rx = self.clock()
                if conn.state is ConnState.ACTIVE:
                    check_mac(frame, conn.rx_key, conn.rx_count)
                    conn.rx_count += 1
                    ack_due = self._active_frame(conn, frame.type, frame.body, out) or ack_due
                else:
                    self._handshake_frame(conn, frame, out)
                if conn.id not in self.conns:
                    break
        except FrameRejected as err:
            self._reject(err.reason, f"connection {conn_id}: {err}")
            out.append(Close(conn_id, f"rejected: {err}"))
            self.connection_closed(conn_id, f"rejected frame ({err.reason})")
            return out
        if ack_due and conn is self.active:
            out.append(self._frame(conn, FrameType.ACK, encode_u64(self.state.in_last)))
        return out

    def _handshake_frame(self, conn: _Conn, frame, out: list[Action]) -> None:
        if conn.state is ConnState.WAIT_HELLO and frame.type is FrameType.HELLO:
            check_mac(frame, self.key_hello, 0)
            hello = Hello.decode(frame.body)
            want_side = "b" if conn.initiator else "a"
            if hello.pair != self.cfg.pair or hello.side != want_side:
                raise FrameRejected("auth", f"HELLO for relay {hello.pair!r} side {hello.side!r}; this end is relay "
                                            f"{self.cfg.pair!r} and expects side {want_side!r}")
            conn.peer = hello
            if conn.initiator:
                if hello.echo != conn.nonce:
                    raise FrameRejected("auth", "HELLO does not echo this connection's nonce (replayed?)")
                self._derive_keys(conn, conn.nonce, hello.nonce)
                out.append(self._frame(conn, FrameType.READY, b""))
                self._activate(conn, out)
            else:
                reply = Hello(self.cfg.pair, self.cfg.side, conn.nonce, hello.nonce, self.state.out_epoch,
                              self.state.in_epoch, self.state.in_last)
                out.append(Send(conn.id, encode_frame(FrameType.HELLO, reply.encode(), self.key_hello, 0)))
                self._derive_keys(conn, hello.nonce, conn.nonce)
                conn.state = ConnState.WAIT_READY
        elif conn.state is ConnState.WAIT_READY and frame.type is FrameType.READY:
            check_mac(frame, conn.rx_key, conn.rx_count)
            conn.rx_count += 1
            if frame.body:
                raise FrameRejected("malformed", "READY frame with a body")
            self._activate(conn, out)
        else:
            raise FrameRejected("malformed", f"{frame.type.name} frame during the handshake ({conn.state.value})")

    def _derive_keys(self, conn: _Conn, nonce_a: bytes, nonce_b: bytes) -> None:
        if self.cfg.secret is None:
            return
        k_ab, k_ba = session_keys(self.cfg.secret, self.cfg.pair, nonce_a, nonce_b)
        conn.tx_key, conn.rx_key = (k_ab, k_ba) if self.cfg.side == "a" else (k_ba, k_ab)

    def _activate(self, conn: _Conn, out: list[Action]) -> None:
        now = self.clock()
        if self.active is not None and self.active is not conn:
            old = self.active
            out.append(Close(old.id, "replaced by a new authenticated connection"))
            self.conns.pop(old.id, None)
            self.active = None
        conn.state = ConnState.ACTIVE
        self.active = conn
        self.stats.connections += 1
        peer = conn.peer
        assert peer is not None
        st = self.state
        down_for = "" if self.link_down_since is None else f" after {now - self.link_down_since:.1f} s"
        self.link_down_since = None
        # what the peer already stored of our stream counts as acknowledged (its ACK was lost with the link)
        if peer.in_epoch == st.out_epoch and st.outq and st.outq[0].seq <= peer.in_last:
            queued = len(st.outq)
            self._acked(peer.in_last)
            self.stats.acked_on_reconnect += queued - len(st.outq)
        if peer.out_epoch != st.in_epoch:
            if st.in_epoch:
                self.log.warning(f"{self.name}: {self.cfg.peer_robot}'s event stream changed epoch "
                                 f"({st.in_epoch:#x} -> {peer.out_epoch:#x}: its journal was reset); "
                                 "counting sequence numbers afresh")
            st.in_epoch, st.in_last = peer.out_epoch, 0
            self._journal_quiet(lambda: self.journal.in_epoch(st.in_epoch, 0))
        self.log.info(f"{self.name}: link to {self.cfg.peer_robot} up{down_for}"
                      f"{'' if self.cfg.secret else ' (no secret: unauthenticated)'}; re-sending "
                      f"{len(st.outq)} queued event(s) and {len(self._out_states)} state(s)")
        self.stats.resent += len(st.outq)
        for m in st.outq:
            out.append(self._frame(conn, FrameType.EVENT, encode_message(m, True)))
        for key in list(self._out_states):
            out.append(self._send_state(conn, key, now))
        self._state_dirty.clear()
        conn.last_ping = now
        out.append(self._frame(conn, FrameType.PING, encode_ping(now, self.master_up)))

    def _acked(self, seq: int) -> None:
        st = self.state
        if not st.outq or st.outq[0].seq > seq:
            return
        while st.outq and st.outq[0].seq <= seq:
            self._out_bytes -= len(st.outq.popleft().payload)
        self._journal_quiet(lambda: self.journal.out_done(seq))

    def _active_frame(self, conn: _Conn, ftype: FrameType, body: bytes, out: list[Action]) -> bool:
        """Handle one authenticated frame; True if an ACK is due."""
        if ftype is FrameType.EVENT:
            return self._peer_event(decode_message(body, True))
        if ftype is FrameType.STATE:
            self._peer_state(decode_message(body, False))
        elif ftype is FrameType.ACK:
            seq = decode_u64(body, "ACK")
            if seq >= self.state.next_seq:
                raise FrameRejected("malformed", f"ACK of seq {seq}, which was never sent "
                                                 f"(next is {self.state.next_seq})")
            self._acked(seq)
        elif ftype is FrameType.PING:
            t, up = decode_ping(body)
            self._peer_master(up)
            out.append(self._frame(conn, FrameType.PONG, encode_ping(t, self.master_up)))
        elif ftype is FrameType.PONG:
            t, up = decode_ping(body, "PONG")
            self._peer_master(up)
            rtt = self.clock() - t
            if 0 <= rtt < 60:
                self.rtt = rtt
        elif ftype is FrameType.BYE:
            out.append(Close(conn.id, "peer said goodbye"))
            self.connection_closed(conn.id, "peer shut down")
        else:
            raise FrameRejected("malformed", f"{ftype.name} frame on an established link")
        return False

    def _check_peer_message(self, m: Message, kind: str) -> bool:
        spec = self.topics.get(m.topic)
        if spec is None or spec.kind != kind:
            self._reject("type", f"{self.cfg.peer_robot} sent a {kind} on {m.topic!r}, which is not a shared "
                                 f"{kind} topic here")
            return False
        if m.md5 != self.cfg.md5s[m.topic]:
            self._reject("type", f"{self.cfg.peer_robot} sent md5 {m.md5[:12]!r} on {m.topic}; this end has "
                                 f"{spec.type} with md5 {self.cfg.md5s[m.topic][:12]} (message definitions differ)")
            return False
        if not self._check_size(m.topic, m.payload, f"{self.cfg.peer_robot}'s"):
            return False
        problem = self.validate(m.topic, m.payload)
        if problem:
            self._reject("malformed", f"{self.cfg.peer_robot} on {m.topic}: {problem}")
            return False
        return self._speaks_for(m.topic, m.payload, self.cfg.node_name, f"{self.cfg.peer_robot}'s")

    def _peer_event(self, m: Message) -> bool:
        st = self.state
        if m.seq <= st.in_last:
            self.stats.duplicates_suppressed += 1
            return True
        if not self._check_peer_message(m, EVENT):
            st.in_last = m.seq                          # consumed: acknowledged, never published
            self._journal_quiet(lambda: self.journal.in_epoch(st.in_epoch, st.in_last))
            return True
        try:
            self.journal.in_event(st.in_epoch, m)
        except JournalError as err:
            # not stored: not acknowledged; the peer sends it again on the next connection
            raise FrameRejected("malformed", f"cannot store event seq {m.seq}: {err}") from err
        st.in_last = m.seq
        st.pending_in.append((st.in_epoch, m))
        self._in_bytes += len(m.payload)
        while len(st.pending_in) > 1 and (len(st.pending_in) > self.cfg.max_inbound
                                          or self._in_bytes > self.cfg.max_queue_bytes):
            _, old = st.pending_in.popleft()
            self._in_bytes -= len(old.payload)
            self._handed_out = max(0, self._handed_out - 1)
            self.stats.dropped += 1
            self._journal_quiet(lambda: self.journal.in_done(1))
            self.rlog.warning("queue_in", f"{self.name}: inbound queue full ({self.cfg.max_inbound} events or "
                                          f"{self.cfg.max_queue_bytes} bytes waiting for this master); dropped "
                                          f"the oldest, seq {old.seq} on {old.topic} from {old.callerid} "
                                          f"({self.stats.dropped} dropped so far)")
        return True

    def _peer_state(self, m: Message) -> None:
        if self._check_peer_message(m, STATE):
            key = (m.topic, m.callerid)
            if key not in self._in_states and len(self._in_states) >= self.cfg.max_state_keys:
                self.stats.dropped += 1
                self.rlog.warning("state_keys", f"{self.name}: already {self.cfg.max_state_keys} (state topic, "
                                                f"publisher) pairs from {self.cfg.peer_robot}; {m.topic} from "
                                                f"{m.callerid} dropped")
                return
            self._in_states[key] = m
            self._state_deliveries.append(m)

    # -- deliveries -----------------------------------------------------------------------
    def set_delivery_open(self, is_open: bool) -> None:
        """Hold (False) or release (True) the publication of received events."""
        self.delivery_open = is_open

    def take_deliveries(self) -> list[Delivery]:
        """Messages to publish now, in order; confirm events with :meth:`delivered` once published."""
        out = [Delivery(STATE, m) for m in self._state_deliveries]
        self._state_deliveries.clear()
        if self.delivery_open:
            pending = self.state.pending_in
            for i in range(self._handed_out, len(pending)):
                out.append(Delivery(EVENT, pending[i][1]))
            self._handed_out = len(pending)
        return out

    def delivered(self, events: int, states: int = 0) -> None:
        """``events`` handed-out events (from the head) were published; they are done."""
        events = min(events, self._handed_out, len(self.state.pending_in))
        if events:
            for _ in range(events):
                self._in_bytes -= len(self.state.pending_in.popleft()[1].payload)
            self._handed_out -= events
            self._journal_quiet(lambda: self.journal.in_done(events))
            self.stats.delivered_events += events
        self.stats.delivered_states += states

    def latest_states(self, topic: str) -> list[Message]:
        """The latest received value of every publisher of state ``topic`` (for late subscribers)."""
        return [m for (t, _), m in self._in_states.items() if t == topic]

    # -- time -----------------------------------------------------------------------------
    def set_master_up(self, up: bool) -> None:
        if up != self.master_up:
            self.master_down_since = None if up else self.clock()
        self.master_up = up

    def _peer_master(self, up: bool) -> None:
        if up is not self.peer_master_up:
            self.peer_master_down_since = None if up else self.clock()
        self.peer_master_up = up

    def tick(self) -> list[Action]:
        """Heartbeats, liveness, coalesced states, handshake timeouts, compaction."""
        now = self.clock()
        out: list[Action] = []
        for conn in list(self.conns.values()):
            if conn.state is not ConnState.ACTIVE and now - conn.opened > self.cfg.handshake_timeout:
                out.append(Close(conn.id, "handshake timeout"))
                self.rlog.warning("handshake", f"{self.name}: connection {conn.id} did not authenticate within "
                                               f"{self.cfg.handshake_timeout:g} s; closed")
                self.connection_closed(conn.id, "handshake timeout")
        conn = self.active
        if conn is not None:
            silent = now - conn.last_rx
            if silent > self.cfg.link_timeout:
                out.append(Close(conn.id, f"no frame for {silent:.1f} s"))
                self.connection_closed(conn.id, f"no frame from {self.cfg.peer_robot} for {silent:.1f} s")
            else:
                if now - conn.last_ping >= self.cfg.heartbeat:
                    conn.last_ping = now
                    out.append(self._frame(conn, FrameType.PING, encode_ping(now, self.master_up)))
                interval = 1.0 / self.cfg.state_rate
                for key in sorted(self._state_dirty):
                    if now - self._state_sent.get(key, -math.inf) >= interval:
                        self._state_dirty.discard(key)
                        out.append(self._send_state(conn, key, now))
        if self.journal.needs_compaction(self.state):
            try:
                self.journal.compact(self.state)
            except JournalError as err:
                self.rlog.warning("journal", f"{self.name}: {err}")
        return out

    def next_tick_in(self) -> float:
        """Seconds until :meth:`tick` has something to do (at most half a heartbeat)."""
        wait = self.cfg.heartbeat / 2
        if self._state_dirty and self.active is not None:
            now = self.clock()
            interval = 1.0 / self.cfg.state_rate
            soonest = min(self._state_sent.get(k, -math.inf) + interval for k in self._state_dirty)
            wait = min(wait, max(0.0, soonest - now))
        return wait

    def shutdown(self) -> list[Action]:
        out: list[Action] = []
        if self.active is not None:
            out.append(self._frame(self.active, FrameType.BYE, b""))
        self.journal.close()
        return out

    # -- diagnostics ----------------------------------------------------------------------
    def refusals(self) -> dict[str, int]:
        """Frames and messages refused so far, by reason (:data:`REJECT_REASONS`)."""
        return dict(self.stats.rejected)

    def snapshot(self) -> dict[str, object]:
        s = self.stats
        now = self.clock()

        def since(t: float | None) -> float | None:
            return None if t is None else round(now - t, 3)

        return {
            "connected": self.active is not None,
            "link_down_s": since(self.link_down_since),
            "master_down_s": since(self.master_down_since),
            "peer_master_down_s": since(self.peer_master_down_since),
            "master_up": self.master_up,
            "peer_master_up": self.peer_master_up,
            "rtt_ms": None if self.rtt is None else round(self.rtt * 1000, 3),
            "queue_depth": len(self.state.outq),
            "queue_bytes": self._out_bytes,
            "inbound_pending": len(self.state.pending_in),
            "delivery_open": self.delivery_open,
            "forwarded": s.forwarded_events + s.forwarded_states,
            "forwarded_events": s.forwarded_events,
            "forwarded_states": s.forwarded_states,
            "delivered_events": s.delivered_events,
            "delivered_states": s.delivered_states,
            "dropped": s.dropped,
            "duplicates_suppressed": s.duplicates_suppressed,
            "resent": s.resent,
            "acked_on_reconnect": s.acked_on_reconnect,
            "ignored_relay": s.ignored_relay,
            "replays_ignored": s.replays_ignored,
            "connections": s.connections,
            "link_losses": s.link_losses,
            "rejected": sum(s.rejected.values()),
            **{f"rejected_{k}": v for k, v in self.refusals().items()},
            "out_epoch": f"{self.state.out_epoch:#x}",
            "next_seq": self.state.next_seq,
            "in_last": self.state.in_last,
            "journal_bytes": self.journal.size,
            "last_error": self.last_error,
        }
