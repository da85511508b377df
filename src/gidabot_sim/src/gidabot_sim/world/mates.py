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
import struct
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from gidabot_navigation.building.geometry import Pose2D
from gidabot_sim.world.slots import SlotFile

MAGIC = b"GBMATES1"
HEADER = struct.Struct("<8sII")                # magic, slots, pad
FIELDS = ("sim", "wall", "x", "y", "yaw", "vx", "vy", "active")
SLOT = struct.Struct("<Q" + "d" * len(FIELDS))
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


class Mates(SlotFile):
    """A mates file mapped in memory; :meth:`create` (the runner) or :meth:`open` (a simulator)."""

    MAGIC, HEADER, FIELDS, SLOT, WHAT = MAGIC, HEADER, FIELDS, SLOT, "mates file"

    @classmethod
    def create(cls, path: Path, homes: Sequence[Pose2D]) -> Mates:
        """A new file with one slot per robot, each at its home pose, never written by a simulator."""
        path, fd, mem = cls._map_new(path, len(homes))
        mates = cls(path, fd, mem, len(homes))
        HEADER.pack_into(mates._mem, 0, MAGIC, len(homes), 0)
        for slot, home in enumerate(homes):
            mates.write(slot, MateState(NEVER, 0.0, home.x, home.y, home.yaw))
        return mates

    @classmethod
    def open(cls, path: Path) -> Mates:
        path, fd, mem, header = cls._map_existing(path)
        return cls(path, fd, mem, header[1])

    def write(self, slot: int, state: MateState) -> None:
        """Publish ``state`` in ``slot`` (only that robot's simulator writes it)."""
        self._write_fields(slot, state)

    def read(self, slot: int) -> MateState:
        """The slot's latest complete write (see :meth:`SlotFile._read_fields`)."""
        return MateState(**self._read_fields(slot))


def mate_motion(state: MateState, wall: float, stale_after: float) -> tuple[Pose2D, float, float, float, bool]:
    """(pose, vx, vy, at sim time, active) of a mate to put into a world: a mate never started or whose simulator
    stopped writing ``stale_after`` wall s ago stands still where it was (inactive)."""
    stale = state.sim == NEVER or wall - state.wall > stale_after
    if stale:
        return state.pose, 0.0, 0.0, state.sim, False
    return state.pose, state.vx, state.vy, state.sim, state.active > 0.5
