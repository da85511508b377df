"""Reachability (gidabot check): every place on a robot's floor is reachable from its home for its radius;
a place behind a closed door or past a too narrow passage is reported by id with where the way is blocked."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

from building_support import paint

from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.reachability import reachability_problems

EAST = {"location 229", "location 231", "location 276", "location 278", "location 280",
        "connector stairs_east (meeting point on floor 2)"}


def by_place(problems) -> dict[str, str]:
    return {p.where: p.message for p in problems}


def test_every_place_of_the_faculty_is_reachable(faculty) -> None:
    assert reachability_problems(faculty) == []


def test_a_closed_fire_door_across_the_corridor(faculty_copy: Path) -> None:
    paint(faculty_copy, 2, 50.0, 50.2, 10.0, 14.0)          # a wall across the corridor at x = 50
    found = by_place(reachability_problems(load_building(faculty_copy)))
    assert set(found) == EAST, found
    text = found["location 231"]
    assert text.startswith("(63, 11.4) on floor 2 is not reachable by Galtxagorri (radius 0.27 m) from its home "
                           "(30, 12): walled off"), text
    wx, wy, lx, ly = map(float, re.search(r"the way closes at \(([\d.]+), ([\d.]+)\) \(a closed door or a wall "
                                          r"without its gap\?\); the last point the robot reaches on it is "
                                          r"\(([\d.]+), ([\d.]+)\)", text).groups())
    assert 50.0 <= wx <= 50.2 and 10.5 < wy < 13.5, (wx, wy)
    assert 49.5 < lx < 50.0 and 10.5 < ly < 13.5, (lx, ly)


def test_a_corridor_too_narrow_for_the_robot(faculty_copy: Path) -> None:
    paint(faculty_copy, 2, 50.0, 50.2, 10.0, 11.8)          # leaves a gap of 0.4 m at y 11.8..12.2
    paint(faculty_copy, 2, 50.0, 50.2, 12.2, 14.0)
    found = by_place(reachability_problems(load_building(faculty_copy)))
    assert set(found) == EAST, found
    match = re.search(r"too narrow: at \(([\d.]+), ([\d.]+)\) the robot's centre keeps at most ([\d.]+) m from the "
                      r"walls, it needs 0.27 m \(its radius\)", found["location 229"])
    assert match, found["location 229"]
    x, y, clearance = map(float, match.groups())
    assert 49.9 <= x <= 50.3 and 11.8 <= y <= 12.2 and 0.1 <= clearance <= 0.25


def test_a_location_inside_a_closed_room(faculty_copy: Path) -> None:
    text = (faculty_copy / "building.yaml").read_text()
    (faculty_copy / "building.yaml").write_text(text.replace("pose: [37.0, 11.4, -1.5708]",   # 223, in the room
                                                             "pose: [37.0, 8.0, -1.5708]"))
    assert reachability_problems(load_building(faculty_copy)) == []   # through its 1 m door
    paint(faculty_copy, 2, 36.0, 38.5, 10.3, 10.6)                      # the door closed
    found = by_place(reachability_problems(load_building(faculty_copy)))
    assert list(found) == ["location 223"] and "walled off" in found["location 223"]


def test_the_rule_is_per_robot(faculty_copy: Path) -> None:
    """Two robots on floor 2 (as buildings with several robots per floor will have): the gap fits the small
    one only, so only the big one's places are reported."""
    paint(faculty_copy, 2, 50.0, 50.2, 10.0, 11.5)          # a gap of 1.0 m
    paint(faculty_copy, 2, 50.0, 50.2, 12.5, 14.0)
    building = load_building(faculty_copy)
    small = building.robot("Galtxagorri")
    big = replace(small, name="Big", radius=0.6, master_uri="http://127.0.0.99:11311/")
    both = replace(building, robots=(*building.robots, big))
    problems = reachability_problems(both)
    assert {p.where for p in problems} == EAST
    assert all("by Big (radius 0.6 m)" in p.message and "too narrow" in p.message for p in problems)


def test_a_home_walled_off_from_everything(faculty_copy: Path) -> None:
    paint(faculty_copy, 1, 29.0, 29.2, 10.0, 14.0)          # Kbot's home (30, 12) shut in between two walls
    paint(faculty_copy, 1, 31.0, 31.2, 10.0, 14.0)
    found = by_place(reachability_problems(load_building(faculty_copy)))
    assert len(found) > 10 and all("by Kbot" in m and "walled off" in m for m in found.values())
