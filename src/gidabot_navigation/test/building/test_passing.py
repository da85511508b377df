"""gidabot check warns (does not fail) when a robot parked at its home or a meeting point leaves too little room for
another robot of its floor to pass."""

from __future__ import annotations

from pathlib import Path

import yaml
from building_support import paint

from gidabot_navigation import cli
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.passing import PASSING_MARGIN, passing_warnings


def _edit(path: Path, change) -> None:
    file = path / "building.yaml"
    doc = yaml.safe_load(file.read_text())
    change(doc)
    file.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


def _second_robot_on_floor_0(home: list[float], radius: float = 0.33):
    def change(d: dict) -> None:
        d["robots"][1].update(floor=0, home=home, radius=radius)
        d["robots"][0].update(radius=radius)
    return change


def test_the_faculty_and_its_variants_give_no_warning(faculty, faculty6, faculty3) -> None:
    for building in (faculty, faculty6, faculty3):
        assert passing_warnings(building) == [], building.id


def test_a_home_in_the_middle_of_a_2_6_m_corridor_warns(faculty_copy: Path, capsys) -> None:
    paint(faculty_copy, 0, 44.0, 56.0, 13.1, 13.5)     # floor 0's corridor: 2.6 m wide (y 10.5..13.1) at x 44..56
    _edit(faculty_copy, _second_robot_on_floor_0([47.5, 11.8, 0.0]))
    [warning] = passing_warnings(load_building(faculty_copy))
    assert warning.where == "robot Kbot"
    assert warning.message.startswith("(47.5, 11.8) on floor 0: Kbot (radius 0.33 m) parked there leaves 0.98 m "
                                      "beside it (the way is 2.60 m wide there); Tartalo needs "
                                      f"{0.66 + PASSING_MARGIN:.2f} m to pass"), warning.message
    assert warning.floor == 0 and [m[2] for m in warning.marks] == ["place", "narrow"]
    assert cli.main([str(faculty_copy)]) == 0                  # a warning, not an error
    out = capsys.readouterr().out
    assert out.startswith(f"ok   {faculty_copy}: ") and "1 warning(s)" in out
    assert f"WARN {faculty_copy / 'building.yaml'}: robot Kbot: (47.5, 11.8) on floor 0" in out


def test_parked_against_the_wall_or_alone_on_its_floor_no_warning(faculty_copy: Path) -> None:
    paint(faculty_copy, 0, 44.0, 56.0, 13.1, 13.5)
    _edit(faculty_copy, _second_robot_on_floor_0([47.5, 10.9, 0.0]))      # 0.4 m from the south wall
    assert passing_warnings(load_building(faculty_copy)) == []
    _edit(faculty_copy, lambda d: d["robots"][1].update(floor=1, home=[47.5, 11.8, 0.0]))
    assert passing_warnings(load_building(faculty_copy)) == []


def test_a_narrow_meeting_point_warns_for_the_robots_of_its_floor(faculty_copy: Path) -> None:
    paint(faculty_copy, 0, 33.0, 38.0, 10.5, 11.9)     # the corridor by the lift: y 11.9..13.5 (1.6 m)
    _edit(faculty_copy, _second_robot_on_floor_0([47.5, 12.0, 0.0], radius=0.3))
    [warning] = passing_warnings(load_building(faculty_copy))
    assert warning.where == "connector lift (meeting point on floor 0)", warning
