"""Keep-out zones (a floor's ``keep_out`` polygons), floors aligned to each other and drafts, in the building file:
loaded by the model, lethal for the planner, reported by reachability (gidabot check)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from gidabot_navigation import cli
from gidabot_navigation.building.geometry import Polygon
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.planning import GridPlanner, keep_out_mask
from gidabot_navigation.building.reachability import reachability_problems
from gidabot_navigation.errors import BuildingError, PlanningError

# floor 2's corridor runs x 6..66 at y 10.5..13.5; this zone takes its northern 2 m for x 42..46 (between the
# places in front of rooms 270 and 274)
GLASS = {"id": "glass_wall", "polygon": [[42.0, 11.5], [46.0, 11.5], [46.0, 13.6], [42.0, 13.6]]}
ACROSS = {"id": "works", "polygon": [[50.0, 10.3], [50.4, 10.3], [50.4, 13.7], [50.0, 13.7]]}


def _edit(path: Path, change) -> None:
    file = path / "building.yaml"
    doc = yaml.safe_load(file.read_text())
    change(doc)
    file.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


def test_polygon_contains_and_rasterises_with_half_a_cell_of_margin(faculty) -> None:
    zone = Polygon(tuple(map(tuple, GLASS["polygon"])))
    assert zone.area == pytest.approx(4.0 * 2.1)
    assert zone.contains_point(44.0, 12.0) and not zone.contains_point(44.0, 11.0)
    mask = keep_out_mask(faculty.floor(2).map, [zone])
    assert mask.sum() * 0.05 ** 2 == pytest.approx(zone.area, rel=0.06)
    with pytest.raises(ValueError, match="cross"):
        Polygon(((0.0, 0.0), (1.0, 1.0), (1.0, 0.0), (0.0, 1.0)))


def test_zones_load_with_the_floor(faculty_copy: Path) -> None:
    _edit(faculty_copy, lambda d: d["floors"][2].update(keep_out=[GLASS]))
    floor = load_building(faculty_copy).floor(2)
    [zone] = floor.keep_out
    assert zone.id == "glass_wall" and list(floor.keep_out_zones) == ["glass_wall"]
    assert floor.keep_out_at(44.0, 13.0) is zone and floor.keep_out_at(44.0, 11.0) is None


def test_the_planner_drives_around_a_zone_and_refuses_goals_inside(faculty) -> None:
    floor = faculty.floor(2)
    zone = Polygon(tuple(map(tuple, GLASS["polygon"])))
    planner = GridPlanner(floor.map, 0.27, keep_out={"glass_wall": zone})
    path = planner.plan((30.0, 12.5), (55.0, 12.5))
    for x, y in path.densified(0.05):
        assert not zone.contains(np.array(x), np.array(y), margin=0.27), (x, y)
    assert path.length > 25.0
    with pytest.raises(PlanningError, match="inside keep-out zone glass_wall"):
        planner.plan((30.0, 12.5), (44.0, 13.0))
    assert planner.keep_out_at(44.0, 13.0) == "glass_wall" and planner.keep_out_at(30.0, 12.0) is None
    bare = GridPlanner(floor.map, 0.27)
    assert bare.plan((30.0, 12.5), (55.0, 12.5)).length < path.length


def test_a_zone_across_the_corridor_walls_the_east_off(faculty_copy: Path) -> None:
    _edit(faculty_copy, lambda d: d["floors"][2].update(keep_out=[ACROSS]))
    found = {p.where: p for p in reachability_problems(load_building(faculty_copy))}
    problem = found["location 231"]
    assert "walled off (no free way at all): the way closes at (50." in problem.message
    assert "(keep-out zone works)" in problem.message
    assert problem.floor == 2 and [m[2] for m in problem.marks] == ["place", "closed", "reached"]
    assert "location 229" in found and "location 227" not in found


def test_drafts_are_refused_except_by_the_editor(faculty_copy: Path, capsys) -> None:
    _edit(faculty_copy, lambda d: d.update(draft=True))
    with pytest.raises(BuildingError, match="saved this building as a draft"):
        load_building(faculty_copy)
    assert load_building(faculty_copy, allow_draft=True).draft is True
    assert cli.main([str(faculty_copy)]) == 1
    assert f"gidabot edit {faculty_copy}" in capsys.readouterr().out
    _edit(faculty_copy, lambda d: d.update(draft=False))
    assert load_building(faculty_copy).draft is False


def test_floors_aligned_to_each_other(faculty_copy: Path) -> None:
    _edit(faculty_copy, lambda d: d["floors"][1].update(aligned_to={"floor": 0, "pose": [2.0, 1.0, math.pi / 2]}))
    b = load_building(faculty_copy)
    align = b.floor(1).aligned_to
    assert align is not None and align.floor == 0 and b.floor(0).aligned_to is None
    assert align.to_other(1.0, 0.0) == (pytest.approx(2.0), pytest.approx(2.0))
