"""A robot's laser in the building file (``sensors: {laser: ...}``): optional, all round by default, checked."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import pytest
import yaml

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import LaserSensor, load_building
from gidabot_navigation.errors import BuildingError


def _robot_edit(building_dir: Path, index: int, change: Callable[[dict], None]) -> None:
    file = building_dir / "building.yaml"
    doc = yaml.safe_load(file.read_text())
    change(doc["robots"][index])
    file.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))


def test_a_robot_without_sensors_has_a_laser_all_round(faculty) -> None:
    for robot in faculty.robots:
        assert robot.laser == LaserSensor() and robot.laser.full_circle
        assert robot.laser.mount == Pose2D(0.0, 0.0, 0.0) and robot.laser.range_max == 20.0


def test_a_front_laser_is_read(faculty_copy: Path) -> None:
    _robot_edit(faculty_copy, 1, lambda r: r.update(sensors={"laser": {"fov": 4.7124, "range_max": 10.0,
                                                                      "mount": [0.1, 0.0, 0.0]}}))
    _robot_edit(faculty_copy, 2, lambda r: r.update(sensors={"laser": {"fov": 6.2832}}))   # 2 pi, rounded up
    building = load_building(faculty_copy)
    kbot = building.robot("Kbot").laser
    assert kbot.fov == pytest.approx(1.5 * math.pi, abs=1e-4) and not kbot.full_circle
    assert (kbot.range_min, kbot.range_max, kbot.mount) == (0.05, 10.0, Pose2D(0.1, 0.0, 0.0))
    assert building.robot("Galtxagorri").laser.full_circle
    assert building.robot("Tartalo").laser == LaserSensor()


@pytest.mark.parametrize("sensors, expected", [
    ({"laser": {"fov": 0}}, "robots[1].sensors.laser.fov: 0 must be > 0"),
    ({"laser": {"fov": 7.0}}, "robots[1].sensors.laser.fov: 7.0 must be at most 2 pi"),
    ({"laser": {"range_min": 5.0, "range_max": 2.0}}, "robots[1].sensors.laser: range_min 5, range_max 2: must "
                                                      "satisfy 0 <= range_min < range_max"),
    ({"laser": {"mount": [0.1, 0.0]}}, "robots[1].sensors.laser.mount: [0.1, 0.0] must be a list [x, y, yaw]"),
    ({"laser": {"fov": "wide"}}, "robots[1].sensors.laser.fov: 'wide' is not a number"),
    ({"laser": {"fov": 3.0, "beams": 360}}, "robots[1].sensors.laser.beams: unknown key (expected one of: fov, "
                                            "range_min, range_max, mount)"),
    ({"sonar": {}}, "robots[1].sensors.sonar: unknown key (expected one of: laser)"),
    ("laser", "robots[1].sensors: expected a mapping, got 'laser'"),
], ids=["fov 0", "fov above 2 pi", "range_min above range_max", "mount without yaw", "fov not a number",
        "unknown laser key", "unknown sensor", "not a mapping"])
def test_a_bad_laser_is_reported_with_key_and_value(faculty_copy: Path, sensors: object, expected: str) -> None:
    _robot_edit(faculty_copy, 1, lambda r: r.update(sensors=sensors))
    with pytest.raises(BuildingError) as info:
        load_building(faculty_copy)
    assert any(expected in str(p) for p in info.value.problems), info.value
