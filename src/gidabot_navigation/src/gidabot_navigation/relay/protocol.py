"""Wire format of the relay link (ROS-free): frames, HMAC-SHA256, handshake keys, bodies.

Frame::

    magic "GR" | version u8 | type u8 | flags u8 | body length u32 | body | MAC (32 bytes if flags & MAC)

All integers big-endian. With a shared secret every frame carries a MAC; the
receiver rejects a frame without one, with a wrong one, or with one when it has no
secret itself. MAC = HMAC-SHA256(key, counter u64 | header | body) where

- HELLO frames use ``hello_key = HMAC(secret, "gidabot-relay-v1 hello")`` and counter 0;
- every later frame uses the session key of its direction, derived from the secret,
  the relay pair name (``<A>_<B>``) and both HELLO nonces, and the number of frames sent before it in
  that direction on this connection (so frames cannot be replayed, reordered,
  reflected or moved to another connection or relay).

Strings are u16 length + UTF-8, payloads u32 length + bytes. Every decoding error
raises :class:`FrameRejected` with a ``reason`` (``auth``, ``oversize``,
``malformed``) used for the relay's counters; nothing is trusted before its MAC
is checked.
"""

from __future__ import annotations

import hashlib
import hmac
import struct
from dataclasses import dataclass
from enum import IntEnum

from gidabot_navigation.errors import FrameRejected

MAGIC = b"GR"
VERSION = 1
HEADER = struct.Struct(">2sBBBI")
MAC_LEN = 32
FLAG_MAC = 0x01
NONCE_LEN = 16
MAX_STRING = 4096           # topic names, caller ids, relay pair names
FRAME_OVERHEAD = 1024       # room for the fixed fields of an EVENT/STATE frame around its payload


class FrameType(IntEnum):
    HELLO = 1
    READY = 2
    EVENT = 16
    STATE = 17
    ACK = 18
    PING = 19
    PONG = 20
    BYE = 21


# -- keys ----------------------------------------------------------------------------------
def hello_key(secret: bytes) -> bytes:
    return hmac.new(secret, b"gidabot-relay-v1 hello", hashlib.sha256).digest()


def session_keys(secret: bytes, pair: str, nonce_a: bytes, nonce_b: bytes) -> tuple[bytes, bytes]:
    """(key of frames a -> b, key of frames b -> a) for one connection of the relay ``pair`` (``<A>_<B>``)."""
    base = b"gidabot-relay-v1 session|" + pair.encode() + b"|" + nonce_a + nonce_b
    return (hmac.new(secret, base + b"|a>b", hashlib.sha256).digest(),
            hmac.new(secret, base + b"|b>a", hashlib.sha256).digest())


def mac(key: bytes, counter: int, header: bytes, body: bytes) -> bytes:
    m = hmac.new(key, counter.to_bytes(8, "big"), hashlib.sha256)
    m.update(header)
    m.update(body)
    return m.digest()


def encode_frame(ftype: FrameType, body: bytes, key: bytes | None = None, counter: int = 0) -> bytes:
    """One frame; with ``key`` it carries the MAC of (counter, header, body)."""
    header = HEADER.pack(MAGIC, VERSION, int(ftype), FLAG_MAC if key else 0, len(body))
    if key is None:
        return header + body
    return header + body + mac(key, counter, header, body)


@dataclass(frozen=True)
class Frame:
    type: FrameType
    body: bytes
    header: bytes
    mac: bytes | None


class FrameReader:
    """Splits a byte stream into frames, enforcing the size limit before buffering a body.

    ``feed`` bytes, then ``next()`` returns frames until None (need more bytes). A bad
    header raises :class:`FrameRejected`; the stream is then unusable (close it).
    MACs are not checked here (the caller knows the key and counter).
    """

    def __init__(self, max_body: int) -> None:
        self.max_body = max_body
        self._buf = bytearray()

    def feed(self, data: bytes) -> None:
        self._buf += data

    @property
    def buffered(self) -> int:
        return len(self._buf)

    def next(self) -> Frame | None:
        if len(self._buf) < HEADER.size:
            return None
        magic, version, ftype, flags, length = HEADER.unpack_from(self._buf)
        if magic != MAGIC:
            raise FrameRejected("malformed", f"bad frame magic {bytes(magic)!r} (expected {MAGIC!r})")
        if version != VERSION:
            raise FrameRejected("malformed", f"frame version {version} (expected {VERSION})")
        if length > self.max_body:
            raise FrameRejected("oversize", f"frame of {length} bytes is larger than the {self.max_body} allowed")
        if flags & ~FLAG_MAC:
            raise FrameRejected("malformed", f"unknown frame flags {flags:#x}")
        try:
            kind = FrameType(ftype)
        except ValueError as err:
            raise FrameRejected("malformed", f"unknown frame type {ftype}") from err
        total = HEADER.size + length + (MAC_LEN if flags & FLAG_MAC else 0)
        if len(self._buf) < total:
            return None
        header = bytes(self._buf[:HEADER.size])
        body = bytes(self._buf[HEADER.size:HEADER.size + length])
        tag = bytes(self._buf[HEADER.size + length:total]) if flags & FLAG_MAC else None
        del self._buf[:total]
        return Frame(kind, body, header, tag)


def check_mac(frame: Frame, key: bytes | None, counter: int) -> None:
    """Raise ``FrameRejected("auth")`` unless the frame's MAC matches (or both sides use none)."""
    if key is None:
        if frame.mac is not None:
            raise FrameRejected("auth", f"{frame.type.name} frame carries a MAC but this end has no secret "
                                        "(secrets differ between the two ends)")
        return
    if frame.mac is None:
        raise FrameRejected("auth", f"{frame.type.name} frame without a MAC (this end requires HMAC-SHA256)")
    if not hmac.compare_digest(frame.mac, mac(key, counter, frame.header, frame.body)):
        raise FrameRejected("auth", f"{frame.type.name} frame with a wrong MAC")


# -- bodies --------------------------------------------------------------------------------
class Writer:
    def __init__(self) -> None:
        self.parts: list[bytes] = []

    def u8(self, v: int) -> Writer:
        self.parts.append(struct.pack(">B", v))
        return self

    def u64(self, v: int) -> Writer:
        self.parts.append(struct.pack(">Q", v))
        return self

    def f64(self, v: float) -> Writer:
        self.parts.append(struct.pack(">d", v))
        return self

    def raw(self, v: bytes) -> Writer:
        self.parts.append(v)
        return self

    def str(self, v: str) -> Writer:
        b = v.encode("utf-8")
        if len(b) > MAX_STRING:
            raise ValueError(f"string of {len(b)} bytes is longer than {MAX_STRING}")
        self.parts.append(struct.pack(">H", len(b)) + b)
        return self

    def blob(self, v: bytes) -> Writer:
        self.parts.append(struct.pack(">I", len(v)))
        self.parts.append(v)
        return self

    def bytes(self) -> bytes:
        return b"".join(self.parts)


class Reader:
    """Bounds-checked reader; every error is ``FrameRejected("malformed")``."""

    def __init__(self, data: bytes, what: str) -> None:
        self.data = memoryview(data)
        self.pos = 0
        self.what = what

    def _take(self, n: int) -> memoryview:
        if self.pos + n > len(self.data):
            raise FrameRejected("malformed", f"{self.what}: truncated at byte {self.pos} (needs {n} more)")
        v = self.data[self.pos:self.pos + n]
        self.pos += n
        return v

    def u8(self) -> int:
        return self._take(1)[0]

    def u64(self) -> int:
        return int.from_bytes(self._take(8), "big")

    def f64(self) -> float:
        return struct.unpack(">d", self._take(8))[0]

    def raw(self, n: int) -> bytes:
        return bytes(self._take(n))

    def str(self) -> str:
        n = int.from_bytes(self._take(2), "big")
        if n > MAX_STRING:
            raise FrameRejected("malformed", f"{self.what}: string of {n} bytes (at most {MAX_STRING})")
        try:
            return bytes(self._take(n)).decode("utf-8")
        except UnicodeDecodeError as err:
            raise FrameRejected("malformed", f"{self.what}: string is not UTF-8") from err

    def blob(self) -> bytes:
        n = int.from_bytes(self._take(4), "big")
        return bytes(self._take(n))

    def end(self) -> None:
        if self.pos != len(self.data):
            raise FrameRejected("malformed", f"{self.what}: {len(self.data) - self.pos} trailing byte(s)")


@dataclass(frozen=True)
class Hello:
    pair: str
    side: str              # "a" or "b": the sender's side
    nonce: bytes
    echo: bytes            # b: the nonce of a's HELLO; a: empty
    out_epoch: int         # epoch of the sender's event stream
    in_epoch: int          # epoch of the receiver's stream the sender has seen (0 = none)
    in_last: int           # last sequence number of that stream the sender has stored

    def encode(self) -> bytes:
        return (Writer().str(self.pair).str(self.side).raw(self.nonce).u8(len(self.echo)).raw(self.echo)
                .u64(self.out_epoch).u64(self.in_epoch).u64(self.in_last).bytes())

    @staticmethod
    def decode(body: bytes) -> Hello:
        r = Reader(body, "HELLO")
        pair, side, nonce = r.str(), r.str(), r.raw(NONCE_LEN)
        echo = r.raw(r.u8())
        out_epoch, in_epoch, in_last = r.u64(), r.u64(), r.u64()
        r.end()
        if side not in ("a", "b") or len(echo) not in (0, NONCE_LEN):
            raise FrameRejected("malformed", f"HELLO with side {side!r} and a {len(echo)}-byte echo")
        return Hello(pair, side, nonce, echo, out_epoch, in_epoch, in_last)


@dataclass(frozen=True)
class Message:
    """A relayed message: topic, original publisher, md5 of its type, serialized ROS message."""

    topic: str
    callerid: str
    md5: str
    payload: bytes
    seq: int = 0           # events: sequence number in the sender's stream; states: 0


def encode_message(m: Message, event: bool) -> bytes:
    w = Writer()
    if event:
        w.u64(m.seq)
    return w.str(m.topic).str(m.callerid).str(m.md5).blob(m.payload).bytes()


def decode_message(body: bytes, event: bool) -> Message:
    r = Reader(body, "EVENT" if event else "STATE")
    seq = r.u64() if event else 0
    topic, callerid, md5 = r.str(), r.str(), r.str()
    payload = r.blob()
    r.end()
    return Message(topic, callerid, md5, payload, seq)


def encode_u64(v: int) -> bytes:
    return struct.pack(">Q", v)


def decode_u64(body: bytes, what: str) -> int:
    r = Reader(body, what)
    v = r.u64()
    r.end()
    return v


def encode_ping(t: float, master_up: bool) -> bytes:
    return Writer().f64(t).u8(1 if master_up else 0).bytes()


def decode_ping(body: bytes, what: str = "PING") -> tuple[float, bool]:
    r = Reader(body, what)
    t, up = r.f64(), r.u8()
    r.end()
    return t, bool(up)
