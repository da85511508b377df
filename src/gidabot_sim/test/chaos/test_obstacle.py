"""A person in a robot's way delays it and leaves a way around."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_sim.chaos.obstacle import choose_obstacle

REPO = Path(__file__).resolve().parents[4]


@pytest.fixture(scope="module")
def faculty():
    return load_building(REPO / "maps" / "faculty")


def test_a_person_in_the_corridor_leaves_a_way_around(faculty) -> None:
    from gidabot_navigation.building.planning import Circle, GridPlanner

    floor = faculty.floor(1.0)
    [robot] = faculty.robots_on(1.0)
    start, goal = (robot.home.x, robot.home.y), (faculty.location("110").pose.x, faculty.location("110").pose.y)
    planner = GridPlanner(floor.map, robot.radius + 0.05)
    plan = planner.plan(start, goal).points
    spot = choose_obstacle(faculty, 1.0, start, plan, robot.radius)
    assert spot is not None
    x, y, r = spot
    assert math.hypot(x - start[0], y - start[1]) > 3.0
    planner.add_obstacle("p", Circle(x, y, r))
    assert math.isfinite(planner.plan(start, goal).length)
    short = [start, (start[0] + 2.0, start[1])]
    assert choose_obstacle(faculty, 1.0, start, short, robot.radius) is None      # too short to block
