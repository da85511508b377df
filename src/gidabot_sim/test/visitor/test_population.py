"""A population of visitors: deterministic from the seed, checked when read back."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_sim.errors import SimConfigError
from gidabot_sim.visitor.population import (
    INTENT_CANCEL,
    INTENT_COMPLETE,
    INTENT_NO_SHOW,
    VisitorPlan,
    make_population,
    plans_from_list,
)

MAPS = Path(__file__).resolve().parents[4] / "maps"


@pytest.fixture(scope="module")
def faculty6():
    return load_building(MAPS / "faculty6")


def test_the_same_seed_gives_the_same_visitors_another_seed_others(faculty6) -> None:
    tours = {"real_world.tour": 8}
    a, b = make_population(faculty6, 40, 7, tours), make_population(faculty6, 40, 7, tours)
    assert a == b and len(a) == 40
    assert make_population(faculty6, 40, 8, tours) != a
    assert [p.arrive_s for p in a] == sorted(p.arrive_s for p in a)
    assert len({p.visitor_id for p in a}) == 40 and a[0].visitor_id == "visitor01"
    assert {p.robot for p in a} <= {r.name for r in faculty6.robots} and len({p.robot for p in a}) > 3


def test_the_population_mixes_what_the_visitors_do(faculty6) -> None:
    plans = make_population(faculty6, 200, 3, {"real_world.tour": 8})
    intents = [p.intent for p in plans]
    assert {INTENT_COMPLETE, INTENT_CANCEL, INTENT_NO_SHOW} == set(intents)
    assert {p.way for p in plans} == {"stairs", "lift"}
    assert 0 < sum(bool(p.tour_file) for p in plans) < 60
    for p in plans:
        assert bool(p.goal_id) != bool(p.tour_file)
        if p.no_show:       # only where a robot of another floor waits for the visitor
            goal = faculty6.location(p.goal_id).floor
            assert not math.isclose(goal, faculty6.robot(p.robot).floor) and faculty6.has_robot(goal)
    assert not any(p.tour_file for p in make_population(faculty6, 50, 3))        # no tours given


def test_plans_read_back_are_checked(faculty6) -> None:
    plans = make_population(faculty6, 5, 1)
    assert plans_from_list([p.to_dict() for p in plans], faculty6) == plans
    good = plans[0].to_dict()
    for change, match in (({"robot": "Nobody"}, "not a robot"), ({"goal_id": "999"}, "not a location"),
                          ({"way": "rope"}, "way"), ({"arrive_s": float("nan")}, "finite"),
                          ({"tour_file": "x.tour"}, "exactly one"), ({"extra": 1}, "unknown keys")):
        with pytest.raises(SimConfigError, match=match):
            plans_from_list([{**good, **change}], faculty6)
    with pytest.raises(SimConfigError, match="distinct"):
        plans_from_list([good, good], faculty6)
    with pytest.raises(SimConfigError, match="list"):
        plans_from_list("visitor01", faculty6)
    with pytest.raises(SimConfigError, match="visitors"):
        make_population(faculty6, 0, 1)
    assert VisitorPlan.from_dict({**good, "cancel_after_s": 12.0}).intent == INTENT_CANCEL


def test_patience_comes_from_a_stream_of_its_own(faculty6) -> None:
    """The patience is drawn apart: the same seed gives the same arrivals, robots, targets, cancels and no-shows
    with or without it, so runs stay comparable."""
    tours = {"real_world.tour": 8}
    with_patience = make_population(faculty6, 60, 4, tours)
    without = make_population(faculty6, 60, 4, tours, patience_s=None)
    assert [p.__class__(**{**p.to_dict(), "patience_s": -1.0}) for p in with_patience] == list(without)
    assert all(300.0 <= p.patience_s <= 1200.0 for p in with_patience)
    assert len({p.patience_s for p in with_patience}) > 50 and {p.patience_s for p in without} == {-1.0}
    assert make_population(faculty6, 60, 4, tours) == with_patience
    assert plans_from_list([p.to_dict() for p in with_patience], faculty6) == with_patience
    with pytest.raises(SimConfigError, match="patience"):
        make_population(faculty6, 5, 1, patience_s=(10.0, 5.0))


def test_the_same_seed_gives_the_same_visitors_on_both_faculties(faculty6) -> None:
    """maps/faculty and maps/faculty6 have robots on the same floors and the same places: the same visitors
    (arrival, floor, target, way, cancel, no-show, patience), only the robot of a two-robot floor may differ."""
    faculty = load_building(MAPS / "faculty")
    tours = {"real_world.tour": 8}
    four, six = make_population(faculty, 60, 1, tours), make_population(faculty6, 60, 1, tours)
    floor4 = [faculty.robot(p.robot).floor for p in four]
    assert floor4 == [faculty6.robot(p.robot).floor for p in six]
    assert [p.__class__(**{**p.to_dict(), "robot": ""}) for p in four] == \
        [p.__class__(**{**p.to_dict(), "robot": ""}) for p in six]
    assert {p.robot for p in six if faculty6.robot(p.robot).floor == 1.0} == {"Kbot", "Basajaun"}
    assert len(set(floor4)) == 4
