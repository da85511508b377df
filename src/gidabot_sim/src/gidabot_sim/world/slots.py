"""A small file of slots shared by processes of this machine (ROS-free): the timeline's and the mates' layout.

A header (``HEADER``, starting with the magic and the number of slots) then per slot a sequence number
(odd while the slot is being written: a reader retries) and ``FIELDS`` as doubles. One writer per slot:
the file is mapped in memory, a write never blocks and a reader never sees half a write (seqlock).
A subclass names its ``MAGIC``, ``HEADER``, ``FIELDS``, ``SLOT`` and what the file is called in errors.
"""

from __future__ import annotations

import mmap
import os
import struct
from pathlib import Path
from typing import ClassVar

from gidabot_sim.errors import SimConfigError

MAX_SLOTS = 64
READ_TRIES = 100
SEQ = struct.Struct("<Q")


class SlotFile:
    """A slot file mapped in memory (see the module); subclasses add the meaning of the header and the slots."""

    MAGIC: ClassVar[bytes]
    HEADER: ClassVar[struct.Struct]           # starts with magic (8s), slots (I), pad (I)
    FIELDS: ClassVar[tuple[str, ...]]
    SLOT: ClassVar[struct.Struct]             # "<Q" + one "d" per field
    WHAT: ClassVar[str]                       # "timeline", "mates file": in every error

    def __init__(self, path: Path, fd: int, mem: mmap.mmap, slots: int) -> None:
        self.path, self._fd, self._mem, self.slots = path, fd, mem, slots

    @classmethod
    def _map_new(cls, path: Path, slots: int) -> tuple[Path, int, mmap.mmap]:
        """A new file of ``slots`` zeroed slots (header not written yet) mapped in memory."""
        if not 1 <= slots <= MAX_SLOTS:
            raise SimConfigError(f"{cls.WHAT} slots: {slots!r} must be 1..{MAX_SLOTS}")
        path = Path(path)
        size = cls.HEADER.size + slots * cls.SLOT.size
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o644)
        os.ftruncate(fd, size)
        return path, fd, mmap.mmap(fd, size)

    @classmethod
    def _map_existing(cls, path: Path) -> tuple[Path, int, mmap.mmap, tuple]:
        """An existing file mapped in memory, checked (magic, slots, size), and its header's values."""
        path = Path(path)
        try:
            fd = os.open(path, os.O_RDWR)
        except OSError as err:
            raise SimConfigError(f"{cls.WHAT} {path}: cannot open ({err.strerror})") from err
        try:
            size = os.fstat(fd).st_size
            if size < cls.HEADER.size:
                raise SimConfigError(f"{cls.WHAT} {path}: {size} bytes is too short for a {cls.WHAT}")
            mem = mmap.mmap(fd, size)
            header = cls.HEADER.unpack_from(mem, 0)
            magic, slots = header[0], header[1]
            if magic != cls.MAGIC or not 1 <= slots <= MAX_SLOTS or size != cls.HEADER.size + slots * cls.SLOT.size:
                mem.close()
                raise SimConfigError(f"{cls.WHAT} {path}: not a {cls.WHAT} (magic {magic!r}, {slots} slots, "
                                     f"{size} bytes)")
        except BaseException:
            os.close(fd)
            raise
        return path, fd, mem, header

    def close(self) -> None:
        self._mem.close()
        os.close(self._fd)

    def __enter__(self):
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _offset(self, slot: int) -> int:
        if not 0 <= slot < self.slots:
            raise SimConfigError(f"{self.WHAT} slot {slot!r}: expected 0..{self.slots - 1}")
        return self.HEADER.size + slot * self.SLOT.size

    def _write_fields(self, slot: int, record: object) -> None:
        """Publish ``record``'s ``FIELDS`` in ``slot`` (only that slot's writer calls it)."""
        off = self._offset(slot)
        seq = SEQ.unpack_from(self._mem, off)[0]
        SEQ.pack_into(self._mem, off, seq | 1)                                # odd: being written
        self.SLOT.pack_into(self._mem, off, seq | 1, *(float(getattr(record, f)) for f in self.FIELDS))
        SEQ.pack_into(self._mem, off, (seq | 1) + 1)                          # even again: complete

    def _read_fields(self, slot: int) -> dict[str, float]:
        """The slot's latest complete write; if its writer stays in the middle of one (stopped, preempted, died
        there), the fields as they are: each is a whole double of one write or the next."""
        off = self._offset(slot)
        for _ in range(READ_TRIES):
            seq, *values = self.SLOT.unpack_from(self._mem, off)
            if seq % 2 == 0 and SEQ.unpack_from(self._mem, off)[0] == seq:
                break
        return dict(zip(self.FIELDS, values, strict=True))
