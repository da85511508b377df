"""The building's timeline file: slots written by each floor, read by the others and by the runner."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from gidabot_sim.errors import SimConfigError
from gidabot_sim.world.timeline import HEADER, Clock, Timeline


def test_floors_see_each_other_and_the_runner_sets_the_ceiling(tmp_path: Path) -> None:
    path = tmp_path / "timeline"
    with Timeline.create(path, 3, ceiling=50.0, max_drift=1.0, peer_timeout=5.0, start_wall=100.0) as runner, \
            Timeline.open(path) as floor0, Timeline.open(path) as floor1:
        assert (floor0.ceiling, floor0.max_drift, floor0.peer_timeout, floor0.slots) == (50.0, 1.0, 5.0, 3)
        assert floor0.slowest_peer(0, wall=101.0) == 0.0        # not started yet: live until 105 wall
        floor0.write(0, Clock(sim=12.5, wall=101.0, behind=0.25, steps=125))
        floor1.write(1, Clock(sim=12.0, wall=101.0))
        assert floor1.read(0) == Clock(sim=12.5, wall=101.0, behind=0.25, steps=125)
        assert floor1.slowest_peer(1, wall=101.0) == 0.0        # floor 2 has not moved
        assert floor1.slowest_peer(1, wall=105.5) == 12.5       # floor 2 never started: no longer waited for
        assert floor0.slowest_peer(0, wall=106.5) is None       # nobody alive (heartbeats 5 s old)
        runner.set_ceiling(None)
        runner.set_max_drift(2.0)
        assert floor0.ceiling is None and floor1.max_drift == 2.0
        assert [c.sim for c in runner.clocks()] == [12.5, 12.0, 0.0]


def test_what_is_not_a_timeline_is_refused_with_the_reason(tmp_path: Path) -> None:
    with pytest.raises(SimConfigError, match="cannot open"):
        Timeline.open(tmp_path / "none")
    junk = tmp_path / "junk"
    junk.write_bytes(b"x" * 200)
    with pytest.raises(SimConfigError, match="not a timeline"):
        Timeline.open(junk)
    with pytest.raises(SimConfigError, match="slots"):
        Timeline.create(tmp_path / "t", 0, None, None)
    with Timeline.create(tmp_path / "t", 1, None, None) as t:
        with pytest.raises(SimConfigError, match="slot 1"):
            t.read(1)
        with pytest.raises(SimConfigError, match="ceiling"):
            t.set_ceiling(-1.0)


def test_a_slot_left_in_the_middle_of_a_write_is_still_read(tmp_path: Path) -> None:
    """A writer stopped (SIGSTOP, preempted, killed) between its two sequence updates must not stop the
    readers: they get the fields as they are."""
    with Timeline.create(tmp_path / "t", 1, None, None) as t:
        t.write(0, Clock(sim=5.0, wall=1.0))
        off = HEADER.size
        seq = struct.unpack_from("<Q", t._mem, off)[0]
        struct.pack_into("<Q", t._mem, off, seq | 1)          # as a writer leaves it mid-write
        assert t.read(0).sim == 5.0
