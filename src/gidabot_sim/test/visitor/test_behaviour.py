"""How simulated people walk, drawn from their seeds (no ROS, no clock): the tidy default, every kind of visitor
within its bounds, bystanders, determinism, validation."""

from __future__ import annotations

import re

import pytest

from gidabot_sim.errors import SimConfigError
from gidabot_sim.visitor.behaviour import (
    SPEED_RANGE,
    TIDY,
    WALK_KIND,
    Behaviour,
    draw_behaviour,
    draw_bystanders,
    parse_walk,
)


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


def test_a_walk_is_read_from_its_keys_and_the_keys_left_out_stay_tidy() -> None:
    b = parse_walk("speed=0.5, pause=20:60,group=3,wander_at=40")
    assert b == Behaviour(speed=0.5, gap=TIDY.gap, pauses=((20.0, 60.0),), group=3, wander_at=40.0, kind=WALK_KIND)
    assert parse_walk("gap=1.5,pause=10:5,pause=40:20").pauses == ((10.0, 5.0), (40.0, 20.0))   # pause may repeat
    assert parse_walk("wander_at=0").wanders
    tidy = parse_walk("speed=1.1")
    assert (tidy.speed, tidy.gap, tidy.pauses, tidy.group, tidy.wanders) == (1.1, 1.0, (), 1, False)


@pytest.mark.parametrize(("text", "expected"), [
    ("colour=red", r"unknown key 'colour' \(keys: speed, gap, pause, group, wander_at\)"),
    ("speed=nan", r"speed nan m/s must be in 0\.5\.\.1\.4"),
    ("speed=-1", r"speed -1\.0 m/s must be in"),
    ("gap=-2", r"gap -2\.0 m must be in"),
    ("group=9", r"group 9 must be 1\.\.4 bodies"),
    ("group=2.5", r"group '2\.5': expected a whole number"),
    ("wander_at=-5", r"wander_at '-5': expected s >= 0"),
    ("wander_at=nan", r"wander_at 'nan': expected s >= 0"),
    ("pause=20", r"pause '20': expected START:DURATION"),
    ("pause=-1:60", r"pause \(-1\.0, 60\.0\) must be"),
    ("pause=10:nan", r"pause \(10\.0, nan\) must be"),
    ("speed=fast", r"speed 'fast': expected a number"),
    ("speed=0.5,speed=0.6", r"speed given twice"),
    ("speed", r"'speed': expected key=value"),
    ("speed=0.5,", r"'': expected key=value"),
    ("", r"empty: expected key=value"),
])
def test_a_bad_walk_names_the_bad_key_or_value(text: str, expected: str) -> None:
    with pytest.raises(SimConfigError, match=rf"^walk {re.escape(repr(text))}: .*{expected}"):
        parse_walk(text)


def test_a_bad_walk_names_every_problem() -> None:
    with pytest.raises(SimConfigError, match=r"colour.*group '2\.5'.*speed 2\.0 m/s must be"):
        parse_walk("colour=red,group=2.5,speed=2")
