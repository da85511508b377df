"""Helpers of the relay unit tests: the cores of two relay ends joined by an in-memory wire (no sockets, no master)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from gidabot_navigation.interface import EVENT, SHARED_TOPICS, Node, Topic, global_name
from gidabot_navigation.relay.end import Close, RelayEndConfig, RelayEndCore, Send
from gidabot_navigation.relay.journal import Journal
from gidabot_navigation.senders import Claim

TOPICS = tuple(t for t in SHARED_TOPICS if t.name in (Topic.GOALS, Topic.CANCELS, Topic.STATUS, Topic.STAFF))
MD5 = {Topic.GOALS: "a" * 32, Topic.CANCELS: "b" * 32, Topic.STATUS: "c" * 32, Topic.STAFF: "d" * 32}
TYPES = {t.name: t.type for t in TOPICS}
SECRET = b"correct horse battery staple"


class Log:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, msg: str) -> None:
        self.lines.append("I " + msg)

    def warning(self, msg: str) -> None:
        self.lines.append("W " + msg)

    def error(self, msg: str) -> None:
        self.lines.append("E " + msg)

    def has(self, text: str) -> bool:
        return any(text in line for line in self.lines)


class Clock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def validate(topic: str, payload: bytes) -> str | None:
    return "garbage" if payload.startswith(b"BAD") else None


def speaker(topic: str, payload: bytes) -> Claim | None:
    """A test payload b"robot=<name>;uid=<uid>;..." speaks for <name> with that uid (b"robot=<name>;...": no uid);
    any other does not say."""
    if not payload.startswith(b"robot="):
        return None
    fields = dict(part.split(b"=", 1) for part in payload.split(b";") if b"=" in part)
    uid = fields.get(b"uid")
    return Claim(fields[b"robot"].decode(), None if uid is None else uid.decode())


def make_core(side: str, journal: Journal, clock: Clock, log: Log, secret: bytes | None = SECRET,
              **kw: object) -> RelayEndCore:
    cfg = RelayEndConfig(robot_a="Tartalo", robot_b="Kbot", side=side, topics=TOPICS, md5s=MD5, secret=secret,
                         **kw)  # type: ignore[arg-type]
    return RelayEndCore(cfg, journal, clock, log, validate, speaker)


@dataclass
class Wire:
    """Joins end a and end b; ``conn`` is the id of the current connection on both sides."""

    a: RelayEndCore
    b: RelayEndCore
    conn: int = 0
    open: bool = False
    published: dict[str, list] = field(default_factory=lambda: {"a": [], "b": []})
    tap: list[tuple[str, bytes]] = field(default_factory=list)     # every (from side, bytes) sent

    def connect(self) -> None:
        self.conn += 1
        self.open = True
        self.b.connection_opened(self.conn, initiator=False)
        self.run("a", self.a.connection_opened(self.conn, initiator=True))

    def cut(self) -> None:
        """Both ends see the connection drop (no more bytes flow)."""
        if self.open:
            self.open = False
            self.a.connection_closed(self.conn, "cut")
            self.b.connection_closed(self.conn, "cut")

    def run(self, side: str, actions: list) -> None:
        """Deliver ``side``'s actions and everything they cause until the wire is quiet."""
        queue = [(side, act) for act in actions]
        while queue:
            frm, act = queue.pop(0)
            if not self.open or act.conn != self.conn:
                continue
            if isinstance(act, Close):
                self.cut()
                continue
            assert isinstance(act, Send)
            self.tap.append((frm, act.data))
            to = "b" if frm == "a" else "a"
            core = self.b if to == "b" else self.a
            queue += [(to, x) for x in core.data_received(self.conn, act.data)]
        self.deliver()

    def deliver(self) -> None:
        for side, core in (("a", self.a), ("b", self.b)):
            ds = core.take_deliveries()
            events = [d for d in ds if d.kind == EVENT]
            self.published[side] += [(d.kind, d.msg.topic, d.msg.callerid, d.msg.payload) for d in ds]
            core.delivered(len(events), len(ds) - len(events))

    def local(self, side: str, topic: str, payload: bytes, callerid: str = global_name(Node.GOAL_MANAGER)) -> None:
        core = self.a if side == "a" else self.b
        self.run(side, core.local_message(topic, callerid, TYPES[topic], MD5[topic], payload))

    def tick(self) -> None:
        self.run("a", self.a.tick())
        self.run("b", self.b.tick())

    def payloads(self, side: str, topic: str = Topic.GOALS) -> list[bytes]:
        return [p for kind, t, _, p in self.published[side] if t == topic]


def pair(tmp: Path | None, clock: Clock | None = None, secret_a: bytes | None = SECRET,
         secret_b: bytes | None = SECRET, **kw: object) -> tuple[Wire, Log, Log, Clock]:
    clock = clock or Clock()
    la, lb = Log(), Log()
    ja = Journal(tmp / "a.journal" if tmp else None)
    jb = Journal(tmp / "b.journal" if tmp else None)
    a = make_core("a", ja, clock, la, secret_a, **kw)
    b = make_core("b", jb, clock, lb, secret_b, **kw)
    return Wire(a, b), la, lb, clock
