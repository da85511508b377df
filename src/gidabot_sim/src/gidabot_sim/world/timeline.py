"""The building's timeline (ROS-free): every floor's clock in one small file shared on this machine.

The runner creates it (one slot per floor) and passes its path to every floor's simulator. After
each step a simulator writes its sim time, a wall-clock heartbeat and its timing counters into its
slot; it reads the others' to stay at most ``max_drift`` sim seconds ahead of the slowest *live*
floor (heartbeat less than ``peer_timeout`` wall seconds old: a frozen or dead simulator does not
hold the others up for longer). The runner reads the slots for the progress line and the run's
timing, and may change the speed ceiling while the run goes (``--speed max``). A restarted
simulator resumes from its slot's sim time: a floor's time never goes back, and never jumps.

Layout, little endian: a header (magic, slots, ceiling in sim s per wall s with 0 = none,
max_drift, peer_timeout) then per slot a sequence number (odd while the slot is being written: a
reader retries) and the :data:`FIELDS` as doubles. One writer per slot.
"""

from __future__ import annotations

import math
import mmap
import struct
from dataclasses import dataclass
from pathlib import Path

from gidabot_sim.errors import SimConfigError
from gidabot_sim.world.slots import SlotFile

MAGIC = b"GBTLINE1"
HEADER = struct.Struct("<8sII3d")            # magic, slots, pad, ceiling, max_drift, peer_timeout
FIELDS = ("sim", "wall", "behind", "wait_controllers", "wait_floors", "wait_ceiling", "steps", "timeouts",
          "max_lead", "pid")
SLOT = struct.Struct("<Q" + "d" * len(FIELDS))
SIM_AND_WALL = struct.Struct("<2d")           # the first two fields of a slot


@dataclass(frozen=True)
class Clock:
    """One floor's slot: its sim time at wall time ``wall`` (its heartbeat), and its counters (wall s)."""

    sim: float
    wall: float
    behind: float = 0.0              # wall s behind the speed ceiling
    wait_controllers: float = 0.0    # wall s waiting for lockstep participants
    wait_floors: float = 0.0         # wall s waiting for slower floors (drift bound)
    wait_ceiling: float = 0.0        # wall s waiting for the ceiling (ahead of it)
    steps: float = 0.0
    timeouts: float = 0.0            # participants the world stopped waiting for
    max_lead: float = 0.0            # sim s ahead of the slowest live peer, at most
    pid: float = 0.0


class Timeline(SlotFile):
    """A timeline file mapped in memory; :meth:`create` (the runner) or :meth:`open` (a simulator)."""

    MAGIC, HEADER, FIELDS, SLOT, WHAT = MAGIC, HEADER, FIELDS, SLOT, "timeline"

    def __init__(self, path: Path, fd: int, mem: mmap.mmap, slots: int, peer_timeout: float) -> None:
        super().__init__(path, fd, mem, slots)
        self._peer_timeout = peer_timeout       # fixed when the timeline is created

    @classmethod
    def create(cls, path: Path, slots: int, ceiling: float | None, max_drift: float | None,
               peer_timeout: float = 5.0, start_wall: float = 0.0) -> Timeline:
        """A new timeline of ``slots`` floors, each at sim time 0 with its heartbeat at ``start_wall`` (a floor
        that has not started yet counts as live until ``peer_timeout`` after it)."""
        if not (math.isfinite(peer_timeout) and peer_timeout > 0):
            raise SimConfigError(f"peer_timeout: {peer_timeout!r} must be > 0 wall seconds")
        path, fd, mem = cls._map_new(path, slots)
        timeline = cls(path, fd, mem, slots, float(peer_timeout))
        HEADER.pack_into(timeline._mem, 0, MAGIC, slots, 0, 0.0, 0.0, peer_timeout)
        timeline.set_ceiling(ceiling)
        timeline.set_max_drift(max_drift)
        for slot in range(slots):
            timeline.write(slot, Clock(0.0, start_wall))
        return timeline

    @classmethod
    def open(cls, path: Path) -> Timeline:
        path, fd, mem, header = cls._map_existing(path)
        return cls(path, fd, mem, header[1], float(header[5]))

    # -- header ------------------------------------------------------------------------------
    def _header(self) -> tuple:
        return HEADER.unpack_from(self._mem, 0)

    @property
    def ceiling(self) -> float | None:
        """The speed ceiling of every floor (sim s per wall s), None: none."""
        value = self._header()[3]
        return value if value > 0 else None

    def set_ceiling(self, ceiling: float | None) -> None:
        if ceiling is not None and not (math.isfinite(ceiling) and ceiling > 0):
            raise SimConfigError(f"ceiling: {ceiling!r} must be > 0 sim seconds per wall second, or none")
        struct.pack_into("<d", self._mem, 16, ceiling or 0.0)

    @property
    def max_drift(self) -> float | None:
        value = self._header()[4]
        return value if value > 0 else None

    def set_max_drift(self, max_drift: float | None) -> None:
        if max_drift is not None and not (math.isfinite(max_drift) and max_drift > 0):
            raise SimConfigError(f"max_drift: {max_drift!r} must be > 0 sim seconds, or none")
        struct.pack_into("<d", self._mem, 24, max_drift or 0.0)

    @property
    def peer_timeout(self) -> float:
        return self._peer_timeout

    # -- slots -------------------------------------------------------------------------------
    def write(self, slot: int, clock: Clock) -> None:
        """Publish ``clock`` in ``slot`` (only its floor's simulator writes it)."""
        self._write_fields(slot, clock)

    def read(self, slot: int) -> Clock:
        """The slot's latest complete write (see :meth:`SlotFile._read_fields`)."""
        return Clock(**self._read_fields(slot))

    def clocks(self) -> list[Clock]:
        return [self.read(slot) for slot in range(self.slots)]

    def live(self, clock: Clock, wall: float) -> bool:
        return wall - clock.wall < self.peer_timeout

    def slowest_peer(self, slot: int, wall: float) -> float | None:
        """Sim time of the slowest live floor other than ``slot`` (None: no live peer). Reads only the sim time and
        the heartbeat of each slot (at every step of every floor: cheap)."""
        timeout, slowest = self.peer_timeout, None
        for i in range(self.slots):
            if i != slot:
                sim, beat = SIM_AND_WALL.unpack_from(self._mem, HEADER.size + i * SLOT.size + 8)
                if wall - beat < timeout and (slowest is None or sim < slowest):
                    slowest = sim
        return slowest
