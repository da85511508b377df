"""The relay end's journal (ROS-free): an append-only file that survives a process kill.

It holds everything an end must not forget: the events it took from local publishers
and the peer has not acknowledged yet, the events it received and acknowledged but
has not published yet, and the sequence numbers needed to de-duplicate. Each record
is written with one ``write(2)`` before the end acts on it (before acknowledging an
event, before sending one), so a killed process loses nothing acknowledged; there is
no fsync per record (a power cut may lose the last records, a process kill cannot).

Record: ``length u32 | crc32 u32 | kind u8 | payload`` (crc over kind + payload). A
torn or corrupt tail (a kill in the middle of a write) is cut off on open. The file
is compacted (snapshot of the live state written to a temporary file, fsynced,
renamed) when it grows to several times its live size. A lock file keeps a second
process away from the same journal.

Kinds: ``S`` snapshot (out epoch, next sequence, in epoch, in last), ``O`` outbound
event, ``A`` outbound done up to seq (acknowledged or dropped), ``I`` inbound event,
``P`` inbound epoch changed, ``D`` k inbound events published (or dropped) from the head,
``H`` digests of local events already forwarded (kept by compaction: an event a restarted
node or publisher sends again, e.g. replayed to this end when it reconnects, is not
forwarded twice; :func:`event_digest`).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import secrets
import struct
import zlib
from collections import OrderedDict, deque
from dataclasses import dataclass, field
from pathlib import Path

from gidabot_navigation.errors import FrameRejected, JournalError
from gidabot_navigation.relay.protocol import Message, Reader, Writer

REC = struct.Struct(">II")
MAX_RECORD = 256 << 20
DIGEST_BYTES = 16
RECENT_DIGESTS = 4096        # local events remembered as forwarded (a replay covers the last minute)


def event_digest(topic: str, payload: bytes, skip: int = 0) -> bytes:
    """What identifies one local event: its topic and serialized message, without the first ``skip``
    bytes (4 for a message starting with std_msgs/Header: rospy rewrites ``header.seq`` on every
    publish, so the same message published again differs there only)."""
    return hashlib.blake2b(topic.encode() + b"\0" + payload[skip:], digest_size=DIGEST_BYTES).digest()


@dataclass
class JournalState:
    """The live state an end recovers from its journal."""

    out_epoch: int
    next_seq: int = 1
    outq: deque[Message] = field(default_factory=deque)                 # unacknowledged outbound events
    in_epoch: int = 0
    in_last: int = 0
    pending_in: deque[tuple[int, Message]] = field(default_factory=deque)  # (epoch, event) to publish
    recent_out: OrderedDict[bytes, None] = field(default_factory=OrderedDict)  # digests of events forwarded

    def live_bytes(self) -> int:
        return (sum(len(m.payload) + 64 for m in self.outq)
                + sum(len(m.payload) + 72 for _, m in self.pending_in) + DIGEST_BYTES * len(self.recent_out))

    def remember_out(self, digest: bytes) -> None:
        self.recent_out[digest] = None
        self.recent_out.move_to_end(digest)
        while len(self.recent_out) > RECENT_DIGESTS:
            self.recent_out.popitem(last=False)


def new_epoch() -> int:
    """A random non-zero 63-bit epoch naming one event stream (a fresh journal)."""
    return secrets.randbits(63) | 1


def _msg(w: Writer, m: Message) -> Writer:
    return w.u64(m.seq).str(m.topic).str(m.callerid).str(m.md5).blob(m.payload)


def _read_msg(r: Reader) -> Message:
    seq = r.u64()
    topic, callerid, md5 = r.str(), r.str(), r.str()
    return Message(topic, callerid, md5, r.blob(), seq)


def encode_record(kind: bytes, payload: bytes) -> bytes:
    body = kind + payload
    return REC.pack(len(body), zlib.crc32(body)) + body


def apply_record(state: JournalState, kind: bytes, payload: bytes) -> None:
    r = Reader(payload, f"journal record {kind!r}")
    if kind == b"S":
        state.out_epoch, state.next_seq, state.in_epoch, state.in_last = r.u64(), r.u64(), r.u64(), r.u64()
        state.outq.clear()
        state.pending_in.clear()
    elif kind == b"O":
        m = _read_msg(r)
        state.outq.append(m)
        state.next_seq = max(state.next_seq, m.seq + 1)
    elif kind == b"A":
        seq = r.u64()
        while state.outq and state.outq[0].seq <= seq:
            state.outq.popleft()
        state.next_seq = max(state.next_seq, seq + 1)
    elif kind == b"I":
        epoch = r.u64()
        m = _read_msg(r)
        if epoch != state.in_epoch:
            state.in_epoch, state.in_last = epoch, 0
        state.in_last = max(state.in_last, m.seq)
        state.pending_in.append((epoch, m))
    elif kind == b"P":
        state.in_epoch, state.in_last = r.u64(), r.u64()
    elif kind == b"D":
        for _ in range(min(r.u64(), len(state.pending_in))):
            state.pending_in.popleft()
    elif kind == b"H":
        blob = r.blob()
        for i in range(0, len(blob) - DIGEST_BYTES + 1, DIGEST_BYTES):
            state.remember_out(bytes(blob[i:i + DIGEST_BYTES]))
    else:
        raise FrameRejected("malformed", f"unknown journal record kind {kind!r}")
    r.end()


class Journal:
    """Append-only journal at ``path`` (``None``: kept in memory only, for tests and tools)."""

    def __init__(self, path: str | Path | None, compact_min_bytes: int = 4 << 20) -> None:
        self.path = Path(path) if path is not None else None
        self.compact_min_bytes = compact_min_bytes
        self._fd: int | None = None
        self._lock_fd: int | None = None
        self.size = 0
        self.truncated_bytes = 0       # bytes of a torn tail cut off on open
        self.compactions = 0

    # -- open / close ---------------------------------------------------------------------
    def open(self) -> JournalState:
        if self.path is None:
            return JournalState(out_epoch=new_epoch())
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._lock_fd = os.open(str(self.path) + ".lock", os.O_RDWR | os.O_CREAT, 0o600)
        except OSError as err:
            raise JournalError(f"cannot create the journal lock {self.path}.lock: {err.strerror}") from err
        try:
            fcntl.flock(self._lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            os.close(self._lock_fd)
            self._lock_fd = None
            raise JournalError(f"journal {self.path} is in use by another relay process") from err
        try:
            state = self._replay()
            self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o600)
        except OSError as err:
            self.close()
            raise JournalError(f"cannot open the journal {self.path}: {err.strerror}") from err
        if self.size == 0:
            self.write(self._snapshot_record(state))
        return state

    def _replay(self) -> JournalState:
        state = JournalState(out_epoch=new_epoch())
        assert self.path is not None
        try:
            data = self.path.read_bytes()
        except FileNotFoundError:
            self.size = 0
            return state
        pos = 0
        first = True
        while pos + REC.size <= len(data):
            length, crc = REC.unpack_from(data, pos)
            end = pos + REC.size + length
            if length < 1 or length > MAX_RECORD or end > len(data):
                break
            body = data[pos + REC.size:end]
            if zlib.crc32(body) != crc or (first and body[:1] != b"S"):
                break
            try:
                apply_record(state, body[:1], body[1:])
            except FrameRejected:
                break
            first = False
            pos = end
        if pos < len(data):
            self.truncated_bytes = len(data) - pos
            with open(self.path, "r+b") as f:
                f.truncate(pos)
        self.size = pos
        return state

    def close(self) -> None:
        for name in ("_fd", "_lock_fd"):
            fd = getattr(self, name)
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
                setattr(self, name, None)

    # -- records --------------------------------------------------------------------------
    def write(self, record: bytes) -> None:
        if self.path is None:
            self.size += len(record)
            return
        if self._fd is None:
            raise JournalError(f"journal {self.path} is not open")
        try:
            n = os.write(self._fd, record)
        except OSError as err:
            raise JournalError(f"cannot write the journal {self.path}: {err.strerror}") from err
        if n != len(record):
            raise JournalError(f"short write to the journal {self.path} ({n} of {len(record)} bytes)")
        self.size += n

    @staticmethod
    def _snapshot_record(state: JournalState) -> bytes:
        return encode_record(b"S", Writer().u64(state.out_epoch).u64(state.next_seq).u64(state.in_epoch)
                             .u64(state.in_last).bytes())

    def out_event(self, m: Message, digest: bytes | None = None) -> None:
        """An outbound event, and (same write) its digest as forwarded."""
        record = encode_record(b"O", _msg(Writer(), m).bytes())
        if digest is not None:
            record += encode_record(b"H", Writer().blob(digest).bytes())
        self.write(record)

    def out_done(self, seq: int) -> None:
        self.write(encode_record(b"A", Writer().u64(seq).bytes()))

    def in_event(self, epoch: int, m: Message) -> None:
        self.write(encode_record(b"I", _msg(Writer().u64(epoch), m).bytes()))

    def in_epoch(self, epoch: int, last: int) -> None:
        self.write(encode_record(b"P", Writer().u64(epoch).u64(last).bytes()))

    def in_done(self, count: int) -> None:
        self.write(encode_record(b"D", Writer().u64(count).bytes()))


    # -- compaction -----------------------------------------------------------------------
    def needs_compaction(self, state: JournalState) -> bool:
        return self.size > self.compact_min_bytes and self.size > 4 * state.live_bytes()

    def compact(self, state: JournalState) -> None:
        """Rewrite the journal as a snapshot of ``state`` (atomic: temporary file, fsync, rename)."""
        if self.path is None:
            self.size = state.live_bytes()
            self.compactions += 1
            return
        parts = [self._snapshot_record(state)]
        if state.recent_out:
            parts.append(encode_record(b"H", Writer().blob(b"".join(state.recent_out)).bytes()))
        parts += [encode_record(b"O", _msg(Writer(), m).bytes()) for m in state.outq]
        parts += [encode_record(b"I", _msg(Writer().u64(e), m).bytes()) for e, m in state.pending_in]
        data = b"".join(parts)
        tmp = self.path.with_name(self.path.name + ".tmp")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            try:
                view = memoryview(data)
                while view:
                    view = view[os.write(fd, view):]
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, self.path)
            dfd = os.open(self.path.parent, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)
            new_fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)
        except OSError as err:
            with contextlib.suppress(OSError):
                tmp.unlink()
            raise JournalError(f"cannot compact the journal {self.path}: {err.strerror}") from err
        if self._fd is not None:
            os.close(self._fd)
        self._fd = new_fd
        self.size = len(data)
        self.compactions += 1
