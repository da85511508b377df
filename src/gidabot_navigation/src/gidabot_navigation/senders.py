"""Who may speak for whom on a robot's master, and the uids that say it (ROS-free).

A message speaks only for its sender. Every message on a shared topic *speaks for* one
robot (:data:`SPEAKS_FOR`: the robot named in its ``origin_robot`` / ``robot`` field, or,
for a Tour, the robot whose uid it carries), and an event's uid must be in that robot's
namespace. A message arriving on robot R's master is attributed by its publisher (the
ROS callerid, which the adapter passes with every message) with :meth:`Senders.attribute`:

1. one of R's own nodes (:data:`OWN_NODES`: the guiding nodes, the tour store, the GUI, the dashboard;
   in simulation also the simulated visitor) may speak only for R; on a topic of :data:`PUBLISHERS`
   only the own nodes listed there may (a staff command only R's dashboard);
2. the relay end of R's link to robot P (``interface.relay_end_name`` of one of R's
   links in the building) may speak only for P: it publishes what P's own nodes sent;
3. anything else is an *impostor*: a node of another name (``rostopic pub``, a probe,
   a node named like a relay end that is not one of R's, or the end of a link that does
   not exist); its messages are refused whatever they say.

:meth:`Senders.refusal` says why a message is refused (or None): ``impostor`` (3),
``foreign`` (it speaks for a robot its sender may not speak for, a robot not in the
building included), ``wrong_namespace`` (its uid is not one that robot could have made:
:data:`UID_FORMAT`). The cores add ``invalid`` (it fails validation) and ``conflict`` (a
handled uid with other content, :class:`HandledUids`), and count every refusal by kind
(:class:`Gate`), so a fault-injection run can account for every hostile message.

ROS 1 does not authenticate node names: a process that can reach R's master may register
under any name, ours included. The rule keeps messages of other nodes, of other robots'
relays and of robots outside the building away from R's trips; what each party can still
do is the threat model of docs/interfaces.md.
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
import secrets
import struct
import time
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from gidabot_navigation.interface import Node, Topic, global_name, relay_end_name
from gidabot_navigation.logs import Logger, RateLimitedLog

# ---------------------------------------------------------------------------
# Uids
# ---------------------------------------------------------------------------

UID_FORMAT = "<robot>/<scope>/<tag>.<token>"
"""Every event uid (Goal, Cancel, NavEvent, Tour, StaffCommand): ``robot`` is the robot that made it (its
namespace: the robot the message speaks for), ``scope`` says what it names (``event``,
``cancel``, ``tour``, ``staff``; a goal's is its visitor id, which the GUI matches), ``tag`` the maker
(``gm`` goal manager, ``nav`` multirobot_navigation, ``ts`` tour store, ``dash`` dashboard), ``token`` at least
16 lowercase hex digits drawn at random for each uid (64 bits: a uid cannot be guessed
before it is published, so it cannot be taken first). At most :data:`MAX_UID` characters."""
MAX_UID = 160
TOKEN_BYTES = 8
UID_RE = re.compile(r"(?P<robot>[A-Za-z0-9_.:@+-]{1,64})/(?P<scope>[A-Za-z0-9_.:@+-]{1,64})/"
                    r"(?P<tag>[a-z]{1,8})\.(?P<token>[0-9a-f]{16,64})\Z")
SCOPE_EVENT, SCOPE_CANCEL, SCOPE_TOUR, SCOPE_STAFF = "event", "cancel", "tour", "staff"
SCOPE_TOUR_EDIT = "tour-edit"        # an admin edit to this robot's tour store (a local topic: matches the answer)


def make_uid(robot: str, scope: str, tag: str) -> str:
    """A fresh uid of ``robot`` (:data:`UID_FORMAT`) with a random token of :data:`TOKEN_BYTES` bytes."""
    return f"{robot}/{scope}/{tag}.{secrets.token_hex(TOKEN_BYTES)}"


def uid_robot(uid: object) -> str | None:
    """The robot whose namespace ``uid`` is in, or None when ``uid`` is not a uid of :data:`UID_FORMAT`."""
    if not isinstance(uid, str) or len(uid) > MAX_UID:
        return None
    m = UID_RE.match(uid)
    return m.group("robot") if m else None


# ---------------------------------------------------------------------------
# What each shared message speaks for
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Speech:
    """Where a message says whom it speaks for: ``robot`` is the field naming that robot ("": the robot of the
    uid's namespace); ``uid`` the field holding its uid, which must be in that robot's namespace ("": none)."""

    robot: str
    uid: str


SPEAKS_FOR: dict[str, Speech] = {
    Topic.GOALS: Speech("origin_robot", "uid"),        # the robot where the visitor confirmed: the trip's only writer
    Topic.CANCELS: Speech("origin_robot", "uid"),      # the robot that drops the trip
    Topic.NAV_EVENTS: Speech("robot", "uid"),          # the robot whose phase, answer or assignment it is
    Topic.TOURS: Speech("", "uid"),                    # the robot that sends it (it may share another's tour)
    Topic.STATUS: Speech("robot", ""),
    Topic.POSES: Speech("robot", ""),
    Topic.PENDING: Speech("robot", ""),
    Topic.TOUR_INDEX: Speech("robot", ""),
    Topic.STAFF: Speech("robot", "uid"),             # the robot whose dashboard staff used
    Topic.MAKE_WAY: Speech("robot", ""),             # the robot that asks the idle robots of its floor to make way
    Topic.LINKS: Speech("robot", ""),                # the robot whose relay links it sums up (its dashboard's view)
}


@dataclass(frozen=True)
class Claim:
    """Whom a message speaks for (``robot``) and its uid (None: a message without uid, a state)."""

    robot: str
    uid: str | None = None


def as_text(value: object) -> str:
    """``value`` if it is a string, else "" (an untrusted field before validation)."""
    return value if isinstance(value, str) else ""


def claim_of(topic: str, msg: object) -> Claim | None:
    """Whom ``msg`` (a gidabot_msgs message or a core's dataclass with the same field names) on shared ``topic``
    speaks for, per :data:`SPEAKS_FOR`; None for a topic the table does not list."""
    speech = SPEAKS_FOR.get(topic)
    if speech is None:
        return None
    uid = as_text(getattr(msg, speech.uid, "")) if speech.uid else None
    robot = as_text(getattr(msg, speech.robot, "")) if speech.robot else (uid or "").partition("/")[0]
    return Claim(robot, uid)


# ---------------------------------------------------------------------------
# Who sent it
# ---------------------------------------------------------------------------

OWN_NODES = (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.TOUR_STORE, Node.GUI, Node.DASHBOARD)
SIMULATED_OWN_NODES = (*OWN_NODES, Node.VISITOR)      # the simulated visitor presses this robot's buttons

PUBLISHERS: dict[str, tuple[str, ...]] = {
    Topic.STAFF: (Node.DASHBOARD,),                  # staff act only at a robot's dashboard
    Topic.LINKS: (Node.DASHBOARD,),                  # the dashboard sums up its robot's links
}
"""The shared topics that only some of a robot's own nodes may publish (any other own node of it is an impostor
there); on the other shared topics any own node may."""

OWN, RELAY, IMPOSTOR = "own", "relay", "impostor"
# refusal kinds, counted by every core
FOREIGN, WRONG_NAMESPACE, CONFLICT, INVALID = "foreign", "wrong_namespace", "conflict", "invalid"
REFUSALS = (IMPOSTOR, FOREIGN, WRONG_NAMESPACE, CONFLICT, INVALID)
SENDER_REFUSALS = (IMPOSTOR, FOREIGN, WRONG_NAMESPACE)     # what Senders.refusal says: a message not its sender's


@dataclass(frozen=True)
class Sender:
    """The publisher of a message: ``kind`` :data:`OWN`, :data:`RELAY` or :data:`IMPOSTOR`; ``robot`` the one robot
    it may speak for ("" for an impostor)."""

    node: str
    kind: str
    robot: str

    @property
    def own(self) -> bool:
        return self.kind == OWN


class Senders:
    """Robot ``robot``'s attribution of the messages on its master.

    ``links``: the relay end node name of each of this robot's links -> the robot at the other end;
    ``own_nodes``: the base names of this robot's own nodes (:data:`OWN_NODES`).
    """

    def __init__(self, robot: str, links: Mapping[str, str], own_nodes: Iterable[str] = OWN_NODES) -> None:
        self.robot = robot
        self.links = dict(links)
        self._peers = {peer: node for node, peer in self.links.items()}
        self.own_nodes = frozenset(global_name(n) for n in own_nodes)

    @classmethod
    def of_building(cls, building: Any, robot: str, simulated: bool = False) -> Senders:
        """``robot``'s senders in ``building`` (its links: one per other robot of the building)."""
        links = {relay_end_name(a.name, b.name): (b.name if a.name == robot else a.name)
                 for a, b in building.relay_pairs() if robot in (a.name, b.name)}
        return cls(robot, links, SIMULATED_OWN_NODES if simulated else OWN_NODES)

    def attribute(self, callerid: object) -> Sender:
        """Who published a message with this callerid, and the robot it may speak for."""
        node = as_text(callerid)
        if node in self.own_nodes:
            return Sender(node, OWN, self.robot)
        peer = self.links.get(node)
        if peer is not None:
            return Sender(node, RELAY, peer)
        return Sender(node, IMPOSTOR, "")

    def relay_of(self, peer: str) -> str:
        """The node name of this robot's relay end of its link to ``peer`` (KeyError: no such link)."""
        return self._peers[peer]

    @staticmethod
    def refusal(sender: Sender, claim: Claim, topic: str = "") -> str | None:
        """Why a message of ``sender`` that makes ``claim`` (on shared ``topic``: :data:`PUBLISHERS`) is refused (a
        refusal kind), or None: it may."""
        if sender.kind == IMPOSTOR or not may_publish(sender, topic):
            return IMPOSTOR
        if claim.robot != sender.robot:
            return FOREIGN
        if claim.uid is not None and uid_robot(claim.uid) != claim.robot:
            return WRONG_NAMESPACE
        return None

    def check(self, callerid: object, claim: Claim, topic: str = "") -> tuple[Sender, str | None]:
        """:meth:`attribute` and :meth:`refusal` in one."""
        sender = self.attribute(callerid)
        return sender, self.refusal(sender, claim, topic)


def may_publish(sender: Sender, topic: str) -> bool:
    """False when ``sender`` is an own node that is not one of the publishers of ``topic`` (:data:`PUBLISHERS`)."""
    allowed = PUBLISHERS.get(topic)
    return sender.kind != OWN or allowed is None or sender.node in {global_name(n) for n in allowed}


def explain(kind: str, sender: Sender, claim: Claim) -> str:
    """A log line's reason for refusal ``kind`` of a message of ``sender`` claiming ``claim``."""
    who = repr(sender.node[:80])
    if kind == IMPOSTOR and sender.own:
        return f"{who} is a node of this robot that may not publish this"
    if kind == IMPOSTOR:
        return f"{who} is neither a node of this robot nor one of its relay ends"
    if kind == FOREIGN:
        return f"{who} may speak for {sender.robot}, not for {claim.robot[:64]!r}"
    if kind == WRONG_NAMESPACE:
        return f"uid {(claim.uid or '')[:80]!r} is not a uid of {claim.robot[:64]} ({UID_FORMAT})"
    return kind


# ---------------------------------------------------------------------------
# Handled uids and refusal counters
# ---------------------------------------------------------------------------

def fingerprint(msg: object, skip: Iterable[str] = ()) -> str:
    """The content of a message dataclass as a short digest, to tell a repeat (same content) from a conflict:
    every field but ``skip``; text and integers exactly, floats as the float32 a ROS message may carry them in
    (so a value that went through a float32 field once compares equal to the value sent)."""
    h = hashlib.blake2b(digest_size=8)
    skipped = set(skip)
    for f in dataclasses.fields(msg):  # type: ignore[arg-type]
        if f.name not in skipped:
            h.update(f.name.encode())
            h.update(b"=" + _canonical(getattr(msg, f.name)) + b";")
    return h.hexdigest()


def _canonical(value: object) -> bytes:
    if isinstance(value, bool):
        return b"b1" if value else b"b0"
    if isinstance(value, float):
        try:
            value = struct.unpack("<f", struct.pack("<f", value))[0]
        except (OverflowError, struct.error):
            return b"f" + repr(value).encode()
        if not value.is_integer():
            return b"f" + repr(value).encode()
        value = int(value)                   # 3.0 in a float field is the 3 a core may have put there
    if isinstance(value, int):
        return b"n" + str(value).encode()
    if isinstance(value, str):
        return b"s" + value.encode("utf-8", "surrogatepass")
    if isinstance(value, (list, tuple)):
        return b"[" + b",".join(_canonical(v) for v in value) + b"]"
    return b"?" + repr(value).encode()


NEW, DUPLICATE = "new", "duplicate"


class HandledUids:
    """The uids handled, each with the fingerprint of the content it came with (bounded: the oldest are
    forgotten first). A uid is added only for a message that was valid and from its rightful sender, so a
    forged message never takes a uid away from the real one. Fingerprint "": the content is not known (any
    repeat is a duplicate)."""

    def __init__(self, limit: int = 20000) -> None:
        self.limit = limit
        self._items: OrderedDict[str, str] = OrderedDict()

    def __contains__(self, uid: object) -> bool:
        return uid in self._items

    def __len__(self) -> int:
        return len(self._items)

    def check(self, uid: str, digest: str) -> str:
        """:data:`NEW`, :data:`DUPLICATE` (same content) or :data:`CONFLICT` (other content); records nothing."""
        held = self._items.get(uid)
        if held is None:
            return NEW
        return DUPLICATE if not held or not digest or held == digest else CONFLICT

    def add(self, uid: str, digest: str = "") -> bool:
        """Record ``uid`` with its content's ``digest``; False if it was handled already (nothing changes)."""
        if uid in self._items:
            return False
        self._items[uid] = digest
        while len(self._items) > self.limit:
            self._items.popitem(last=False)
        return True

    def discard(self, uid: str) -> None:
        self._items.pop(uid, None)

    def recent(self, n: int) -> list[list[str]]:
        """The ``n`` most recently handled ``[uid, digest]``, oldest first (what a restarted node must remember)."""
        if n <= 0:
            return []
        return [[uid, d] for uid, d in list(self._items.items())[-n:]]

    def update(self, items: Iterable[object]) -> None:
        """Add ``[uid, digest]`` pairs (or bare uids: content not known)."""
        for item in items:
            if isinstance(item, str):
                self.add(item)
            elif isinstance(item, (list, tuple)) and len(item) == 2 and all(isinstance(v, str) for v in item):
                self.add(item[0], item[1])


class Gate:
    """What a core lets in: every message is attributed (:class:`Senders`) before anything else, refusals are
    counted by kind (:data:`REFUSALS`, and any other a core needs) and logged at a limited rate per kind (a
    conflict once per uid). ``clock``: s, for the rate limit (default: the monotonic clock)."""

    def __init__(self, senders: Senders, log: Logger, clock: Callable[[], float] | None = None,
                 burst: int = 5, window: float = 60.0) -> None:
        self.senders = senders
        self.counts: dict[str, int] = dict.fromkeys(REFUSALS, 0)
        self._warn = RateLimitedLog(log, clock or time.monotonic, burst, window)
        self._logged: OrderedDict[str, None] = OrderedDict()

    def check(self, callerid: object, claim: Claim, what: str, topic: str = "") -> tuple[Sender, str | None]:
        """The sender of a message (``what``, for the log; on shared ``topic``: :data:`PUBLISHERS`) that makes
        ``claim`` and why it is refused (counted and logged), or None: it may."""
        sender, kind = self.senders.check(callerid, claim, topic)
        if kind is not None:
            self.refuse(kind, f"{what} of {claim.robot[:40]!r} at {self.senders.robot}: {explain(kind, sender, claim)}")
        return sender, kind

    def admit(self, callerid: object, claim: Claim, what: str, topic: str = "") -> Sender | None:
        """The sender of a message that makes ``claim``, if it may; else None (refused: :meth:`check`)."""
        sender, kind = self.check(callerid, claim, what, topic)
        return sender if kind is None else None

    def only(self, callerid: object, node: str, what: str) -> bool:
        """True when ``callerid`` is this robot's own node ``node`` (a base name of :class:`Node`), the one
        publisher of ``what`` (a local topic); else the message is refused as an impostor's."""
        if callerid == global_name(node):
            return True
        self.refuse(IMPOSTOR, f"{what} of {self.senders.robot} from {as_text(callerid)[:80]!r}, not from "
                              f"{global_name(node)}")
        return False

    def conflict(self, handled: HandledUids, uid: str, digest: str, what: str) -> bool:
        """True (refused) when ``uid`` was handled with another content than ``digest``: dropped, never answered."""
        if handled.check(uid, digest) != CONFLICT:
            return False
        self.refuse(CONFLICT, f"{what} {uid[:80]!r} came again at {self.senders.robot} with other content; dropped",
                    once=uid)
        return True

    def refuse(self, kind: str, text: str, once: str = "") -> None:
        """Count a refusal of ``kind``; log ``text`` (rate-limited per kind; with ``once``: only the first time
        for that key)."""
        self.counts[kind] = self.counts.get(kind, 0) + 1
        if once:
            if once in self._logged:
                return
            self._logged[once] = None
            while len(self._logged) > 1000:
                self._logged.popitem(last=False)
        self._warn.warning(f"refused_{kind}", f"refused ({kind}): {text}")

    def refusals(self) -> dict[str, int]:
        """Messages refused so far, by kind."""
        return dict(self.counts)
