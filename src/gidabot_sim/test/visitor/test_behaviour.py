"""How simulated people walk, drawn from their seeds (no ROS, no clock): the tidy default, every kind of visitor
within its bounds, bystanders, determinism, validation."""

from __future__ import annotations

import pytest

from gidabot_sim.errors import SimConfigError
from gidabot_sim.visitor.behaviour import SPEED_RANGE, TIDY, Behaviour, draw_behaviour, draw_bystanders


def test_the_default_visitor_is_tidy() -> None:
    assert draw_behaviour(-1) is TIDY
    assert TIDY.pauses == () and TIDY.group == 1 and not TIDY.wanders
    assert not TIDY.paused(100.0) and not TIDY.wandered(1e6)


def test_drawn_behaviours_cover_every_kind_within_bounds_and_repeat_from_the_seed() -> None:
    drawn = [draw_behaviour(seed) for seed in range(400)]
    assert drawn == [draw_behaviour(seed) for seed in range(400)]
    assert {b.kind for b in drawn} == {"steady", "slow", "pauses", "group", "wanders"}
    for b in drawn:
        assert SPEED_RANGE[0] <= b.speed <= SPEED_RANGE[1]
        assert (b.group > 1) == (b.kind == "group") and (b.pauses != ()) == (b.kind == "pauses")
        assert b.wanders == (b.kind == "wanders")
    assert all(b.speed <= 0.7 for b in drawn if b.kind == "slow")


def test_pauses_and_wandering_are_judged_from_the_visit_start() -> None:
    b = Behaviour(pauses=((10.0, 5.0), (40.0, 60.0)), wander_at=200.0)
    assert [b.paused(t) for t in (9.9, 10.0, 14.9, 15.0, 40.0, 99.9, 100.0)] == \
        [False, True, True, False, True, True, False]
    assert not b.wandered(199.9) and b.wandered(200.0)


def test_a_bad_behaviour_names_every_problem() -> None:
    with pytest.raises(SimConfigError, match=r"speed 2\.0 .*group 9.*pause \(-1"):
        Behaviour(speed=2.0, group=9, pauses=((-1.0, 5.0),))


def test_bystanders_are_drawn_per_floor_and_some_stand_in_the_way() -> None:
    people = draw_bystanders(30, 1, "0")
    assert people == draw_bystanders(30, 1, "0") and people != draw_bystanders(30, 1, "1")
    assert len({p.person_id for p in people}) == 30
    assert any(p.stand_s > 0 for p in people) and any(p.stand_s == 0 for p in people)
    assert all(SPEED_RANGE[0] <= p.speed <= SPEED_RANGE[1] for p in people)
    with pytest.raises(SimConfigError, match="people"):
        draw_bystanders(101, 1, "0")
