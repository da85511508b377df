"""The faults of a chaos run from a seed: every kind, the profiles, overlaps, the clock offsets."""

from __future__ import annotations

from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_sim.chaos.hostile import hostile_by_name
from gidabot_sim.chaos.schedule import (
    KINDS,
    LINK_CUTS,
    MACHINES_ONLY,
    PROFILES,
    Kind,
    clock_offsets,
    make_schedule,
    schedule_seconds,
)

REPO = Path(__file__).resolve().parents[4]


@pytest.fixture(scope="module")
def faculty():
    return load_building(REPO / "maps" / "faculty")


def test_full_schedule_has_every_kind_the_issue_asks_for(faculty) -> None:
    faults = make_schedule(1, faculty, PROFILES["full"])
    assert faults == make_schedule(1, faculty, PROFILES["full"])        # deterministic
    assert faults != make_schedule(2, faculty, PROFILES["full"])
    kinds = [f.kind for f in faults]
    assert len(faults) >= 20
    cuts = [f for f in faults if f.kind in (Kind.CUT_IPTABLES, Kind.CUT_RELAY_END)]
    assert all(1.0 <= f.duration <= 60.0 for f in cuts)
    assert min(f.duration for f in cuts) <= 3.0 and max(f.duration for f in cuts) >= 45.0
    assert sorted(f.robot for f in faults if f.kind == Kind.MASTER_RESTART) == sorted(r.name for r in faculty.robots)
    assert sorted(f.target for f in faults if f.kind == Kind.NODE_RESTART) == ["goal_manager", "multirobot_navigation"]
    assert kinds.count(Kind.HOSTILE) == 10
    assert len({f.target for f in faults if f.kind == Kind.HOSTILE}) == 10
    assert all(hostile_by_name(f.target) for f in faults if f.kind == Kind.HOSTILE)
    assert kinds.count(Kind.CUT_SUPERVISOR) == 1 and kinds.count(Kind.CORRIDOR) == 2 and kinds.count(Kind.FREEZE) == 2
    pairs = {(a.name, b.name) for a, b in faculty.relay_pairs()}
    assert all((f.robot, f.other) in pairs for f in faults if f.kind in LINK_CUTS[:2])
    assert all(f.gap == 0.0 for f in faults if f.kind == Kind.HOSTILE)
    assert schedule_seconds(faults) > sum(f.duration for f in faults)


def test_quick_profile_has_every_kind(faculty) -> None:
    faults = make_schedule(3, faculty, PROFILES["quick"])
    assert {f.kind for f in faults} == set(KINDS) - set(MACHINES_ONLY) - {Kind.PARTITION}
    assert all(f.duration <= 6.0 for f in faults)
    machines = make_schedule(3, faculty, PROFILES["quick"], machines=True)
    assert {f.kind for f in machines} == set(KINDS) - {Kind.CLOCK_OFFSET}      # offsets are set at start
    assert all(f.duration <= 15.0 for f in machines)


def test_full_profile_overlaps_faults_and_on_machines_adds_the_network_faults(faculty) -> None:
    loop = make_schedule(1, faculty, PROFILES["full"])
    kinds = [f.kind for f in loop]
    assert kinds.count(Kind.MASTERS_DOWN) == 1 and kinds.count(Kind.CUT_MASTER_RESTART) == 1
    [long] = [f for f in loop if f.kind == Kind.PARTITION]
    assert long.duration > 120.0 and long.active                  # longer than partner_timeout, at the trip
    two = next(f for f in loop if f.kind == Kind.MASTERS_DOWN)
    assert two.robot != two.other
    cut = next(f for f in loop if f.kind == Kind.CUT_MASTER_RESTART)
    assert cut.target in (cut.robot, cut.other)
    assert not set(kinds) & set(MACHINES_ONLY)
    net = make_schedule(1, faculty, PROFILES["full"], machines=True)
    kinds = [f.kind for f in net]
    assert len(net) >= 20 and {Kind.FLAPPING, Kind.ONE_WAY, Kind.LOSSY, Kind.MACHINE_DOWN} <= set(kinds)
    assert kinds.count(Kind.PARTITION) == 3
    down = next(f for f in net if f.kind == Kind.MACHINE_DOWN)
    assert down.duration >= 300.0 and down.robot == ""            # chosen when injected
    one = next(f for f in net if f.kind == Kind.ONE_WAY)
    assert one.robot != one.other


def test_clock_offsets_spread_over_five_minutes_either_way(faculty) -> None:
    offsets = clock_offsets(1, faculty, PROFILES["full"])
    assert sorted(offsets) == sorted(r.name for r in faculty.robots)
    assert min(offsets.values()) == -300.0 and max(offsets.values()) == 300.0
    assert offsets == clock_offsets(1, faculty, PROFILES["full"])
