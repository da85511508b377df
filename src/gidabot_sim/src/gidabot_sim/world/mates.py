"""Robots that share a floor but not a simulator (ROS-free): every robot's pose in one small file on this machine.

Each robot runs its own simulator on its own master (``launch/robot.launch sim:=true``), so two robots
of one floor are simulated by two processes. They still share one floor's world through this file
(the *mates* file, like the building's timeline, :mod:`gidabot_sim.world.timeline`): the runner creates
it with one slot per robot of the building (the building's order) holding its home pose; after each
step a simulator writes its own robot's pose, velocity (map frame), whether its navigation drives, its
sim time and a wall heartbeat into its slot; before each step it reads the slots of the other robots of
its floor and puts them into its world as *mates* (:meth:`gidabot_sim.world.world.World.add_mate`):
discs its laser sees (and its ``robots_seen``, the obstacle layer of its move_base), its robot collides
with (counted), deadlocks are watched against. A mate's pose is carried to this world's time along its
velocity (at most :data:`MAX_EXTRAPOLATION` s: the floors' clocks differ by at most the timeline's drift
bound); a mate whose simulator stopped writing for ``stale_after`` wall s stands where it was.

Layout, little endian: a header (magic, slots) then per slot a sequence number (odd while the slot is
being written: a reader retries) and :data:`FIELDS` as doubles. One writer per slot.
"""

from __future__ import annotations

import math
import mmap
import os
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from gidabot_navigation.building.geometry import Pose2D
from gidabot_sim.errors import SimConfigError

MAGIC = b"GBMATES1"
HEADER = struct.Struct("<8sII")                # magic, slots, pad
FIELDS = ("sim", "wall", "x", "y", "yaw", "vx", "vy", "active")
SLOT = struct.Struct("<Q" + "d" * len(FIELDS))
MAX_SLOTS = 64
READ_TRIES = 100
MAX_EXTRAPOLATION = 0.5     # sim s a mate's pose is carried along its velocity, at most (either way)
NEVER = -1.0                # ``sim`` of a slot its simulator never wrote: the robot stands at its home


@dataclass(frozen=True)
class MateState:
    """One robot as its own simulator last wrote it: pose and velocity (map frame of its floor) at sim time
    ``sim`` (``NEVER``: not started, at its home pose), heartbeat ``wall``; ``active``: its navigation drives."""

    sim: float
    wall: float
    x: float
    y: float
    yaw: float
    vx: float = 0.0
    vy: float = 0.0
    active: float = 0.0

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    def finite(self) -> bool:
        return all(math.isfinite(getattr(self, f)) for f in FIELDS)


class Mates:
    """A mates file mapped in memory; :meth:`create` (the runner) or :meth:`open` (a simulator)."""

    def __init__(self, path: Path, fd: int, mem: mmap.mmap, slots: int) -> None:
        self.path, self._fd, self._mem, self.slots = path, fd, mem, slots

    @classmethod
    def create(cls, path: Path, homes: Sequence[Pose2D]) -> Mates:
        """A new file with one slot per robot, each at its home pose, never written by a simulator."""
        if not 1 <= len(homes) <= MAX_SLOTS:
            raise SimConfigError(f"mates slots: {len(homes)} must be 1..{MAX_SLOTS}")
        path = Path(path)
        size = HEADER.size + len(homes) * SLOT.size
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o644)
        os.ftruncate(fd, size)
        mates = cls(path, fd, mmap.mmap(fd, size), len(homes))
        HEADER.pack_into(mates._mem, 0, MAGIC, len(homes), 0)
        for slot, home in enumerate(homes):
            mates.write(slot, MateState(NEVER, 0.0, home.x, home.y, home.yaw))
        return mates

    @classmethod
    def open(cls, path: Path) -> Mates:
        path = Path(path)
        try:
            fd = os.open(path, os.O_RDWR)
        except OSError as err:
            raise SimConfigError(f"mates file {path}: cannot open ({err.strerror})") from err
        try:
            size = os.fstat(fd).st_size
            if size < HEADER.size:
                raise SimConfigError(f"mates file {path}: {size} bytes is too short")
            mem = mmap.mmap(fd, size)
            magic, slots, _pad = HEADER.unpack_from(mem, 0)
            if magic != MAGIC or not 1 <= slots <= MAX_SLOTS or size != HEADER.size + slots * SLOT.size:
                mem.close()
                raise SimConfigError(f"mates file {path}: not a mates file (magic {magic!r}, {slots} slots, "
                                     f"{size} bytes)")
        except BaseException:
            os.close(fd)
            raise
        return cls(path, fd, mem, slots)

    def close(self) -> None:
        self._mem.close()
        os.close(self._fd)

    def __enter__(self) -> Mates:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _offset(self, slot: int) -> int:
        if not 0 <= slot < self.slots:
            raise SimConfigError(f"mates slot {slot!r}: expected 0..{self.slots - 1}")
        return HEADER.size + slot * SLOT.size

    def write(self, slot: int, state: MateState) -> None:
        """Publish ``state`` in ``slot`` (only that robot's simulator writes it)."""
        off = self._offset(slot)
        seq = struct.unpack_from("<Q", self._mem, off)[0]
        struct.pack_into("<Q", self._mem, off, seq | 1)                  # odd: being written
        SLOT.pack_into(self._mem, off, seq | 1, *(float(getattr(state, f)) for f in FIELDS))
        struct.pack_into("<Q", self._mem, off, (seq | 1) + 1)            # even again: complete

    def read(self, slot: int) -> MateState:
        """The slot's latest complete write (a writer stopped in the middle of one: the fields as they are)."""
        off = self._offset(slot)
        for _ in range(READ_TRIES):
            seq, *values = SLOT.unpack_from(self._mem, off)
            if seq % 2 == 0 and struct.unpack_from("<Q", self._mem, off)[0] == seq:
                break
        return MateState(**dict(zip(FIELDS, values, strict=True)))


def mate_motion(state: MateState, wall: float, stale_after: float) -> tuple[Pose2D, float, float, float, bool]:
    """(pose, vx, vy, at sim time, active) of a mate to put into a world: a mate never started or whose simulator
    stopped writing ``stale_after`` wall s ago stands still where it was (inactive)."""
    stale = state.sim == NEVER or wall - state.wall > stale_after
    if stale:
        return state.pose, 0.0, 0.0, state.sim, False
    return state.pose, state.vx, state.vy, state.sim, state.active > 0.5
