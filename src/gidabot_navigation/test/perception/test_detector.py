"""The people detector on synthetic scans: bodies and pairs of legs are people; walls, wall edges, door frames,
pillars and stray returns are not; scans off the bus are checked; the cost of a scan is measured."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.occupancy import FREE, OCCUPIED, OccupancyMap
from gidabot_navigation.errors import PerceptionError, ScanError
from gidabot_navigation.perception import synthetic as sy
from gidabot_navigation.perception.benchmark import benchmark
from gidabot_navigation.perception.detector import (
    Detector,
    DetectorParams,
    FieldOfView,
    Kind,
    Scan,
    fov_mismatch,
    occupied_lookup,
)

ROBOT = Pose2D(0.0, 0.0, 0.0)
ROOM = sy.box(0.0, 0.0, 12.0, 8.0)           # the walls of a 12 x 8 m room around the robot
TRIALS = 40
LASERS = {"360 beams": sy.Laser(beams=360), "720 beams": sy.Laser(beams=720)}


def detect(scene: sy.Scene, laser: sy.Laser, seed: int = 0, trials: int = TRIALS, robot: Pose2D = ROBOT,
           detector: Detector | None = None) -> list:
    """The detections of ``trials`` noisy scans of ``scene`` inside the room."""
    rng = np.random.default_rng(seed)
    det = detector or Detector(mount=laser.mount)
    return [det.detect(sy.scan(scene + ROOM, robot, laser, rng), robot) for _ in range(trials)]


def people_counts(results: list) -> Counter:
    return Counter(len(r.people) for r in results)


@pytest.mark.parametrize("laser", LASERS.values(), ids=LASERS.keys())
@pytest.mark.parametrize("where", [(2.0, 0.5), (1.0, -0.8), (-2.5, 1.0), (4.0, -1.5)])
def test_a_body_is_one_person_at_its_centre(laser: sy.Laser, where: tuple[float, float]) -> None:
    results = detect(sy.person(*where), laser)
    assert people_counts(results)[1] >= 0.9 * TRIALS and not people_counts(results)[2], people_counts(results)
    found = [r.people[0] for r in results if len(r.people) == 1]
    assert all(d.kind == Kind.BODY for d in found)
    error = max(math.hypot(d.x - where[0], d.y - where[1]) for d in found)
    assert error < 0.06, error
    assert min(d.confidence for d in found) > 0.5


@pytest.mark.parametrize("where, laser", [((1.5, 0.4), LASERS["360 beams"]), ((2.0, -0.6), LASERS["360 beams"]),
                                          ((2.0, 0.5), LASERS["720 beams"]), ((1.2, -1.0), LASERS["720 beams"])],
                         ids=["1.6 m, 360", "2.1 m, 360", "2.1 m, 720", "1.6 m, 720"])
@pytest.mark.parametrize("turn", [0.0, 0.8], ids=["legs side by side", "one leg ahead"])
def test_a_pair_of_legs_is_one_person_between_them(where: tuple[float, float], laser: sy.Laser,
                                                   turn: float) -> None:
    """Legs side by side as the laser sees them, or turned by ``turn`` rad (one leg partly behind the other)."""
    results = detect(sy.person(*where, legs=True, heading=math.atan2(where[1], where[0]) + turn), laser)
    assert people_counts(results)[1] >= 0.8 * TRIALS and not people_counts(results)[2], people_counts(results)
    found = [r.people[0] for r in results if len(r.people) == 1]
    assert all(d.kind == Kind.LEG for d in found)
    assert max(math.hypot(d.x - where[0], d.y - where[1]) for d in found) < 0.1
    assert all(r.count(Kind.LEG) == 2 for r in results if r.people)


def test_legs_of_a_1_degree_laser_fade_out_beyond_3_m() -> None:
    """A leg 3 m away spans two or three beams of a 1 degree laser: too few points to be one (a known limit)."""
    results = detect(sy.person(3.0, 0.5, legs=True), LASERS["360 beams"])
    assert people_counts(results)[0] == TRIALS


WALLS = {
    "a wall edge (outside corner)": sy.Scene(walls=(sy.Wall(2.0, 0.0, 2.0, 3.0), sy.Wall(2.0, 0.0, 4.0, 0.0))),
    "the free end of a wall": sy.Scene(walls=(sy.Wall(1.0, 1.0, 5.0, 1.0),)),
    "a wall seen at a grazing angle": sy.Scene(walls=(sy.Wall(0.5, 0.6, 5.9, 1.2),)),
    "a door frame in a wall": sy.Scene(walls=(sy.Wall(3.0, -3.9, 3.0, -0.45), sy.Wall(3.0, 0.45, 3.0, 3.9),
                                              sy.Wall(3.0, -0.45, 3.15, -0.45), sy.Wall(3.0, 0.45, 3.15, 0.45))),
    "two free-standing jambs": sy.Scene(walls=(sy.Wall(1.5, -0.45, 1.65, -0.45), sy.Wall(1.5, 0.45, 1.65, 0.45),
                                               sy.Wall(1.5, -0.45, 1.5, -0.6), sy.Wall(1.5, 0.45, 1.5, 0.6))),
    "a square pillar (corner on)": sy.box(2.0, 1.0, 0.3, 0.3, 0.7),
    "a square pillar (face on)": sy.box(2.5, 0.0, 0.3, 0.3),
    "a round pillar wider than a body": sy.Scene(discs=(sy.Disc(2.0, 1.0, 0.4),)),
    "an empty room": sy.Scene(),
}


@pytest.mark.parametrize("laser", LASERS.values(), ids=LASERS.keys())
@pytest.mark.parametrize("name", WALLS)
def test_walls_door_frames_and_pillars_are_no_people(name: str, laser: sy.Laser) -> None:
    results = detect(WALLS[name], laser)
    assert people_counts(results)[0] >= TRIALS - 1, (people_counts(results), Counter(
        Kind(k).name for r in results for k in r.kinds if k >= Kind.SHAPE))


def _grid_with(disc: sy.Disc) -> OccupancyMap:
    """A 12 x 8 m map at 0.05 m holding the disc (the room's walls are left out: only the pillar matters)."""
    res = 0.05
    cells = np.full((160, 240), FREE, dtype=np.int8)
    rows, cols = np.mgrid[0:160, 0:240]
    x, y = -6.0 + (cols + 0.5) * res, -4.0 + (rows + 0.5) * res
    cells[np.hypot(x - disc.x, y - disc.y) <= disc.radius] = OCCUPIED
    return OccupancyMap(cells, res, -6.0, -4.0)


@pytest.mark.parametrize("laser", LASERS.values(), ids=LASERS.keys())
def test_a_pillar_the_size_of_a_body_is_a_person_without_the_static_map_and_static_with_it(laser: sy.Laser) -> None:
    pillar = sy.Disc(2.0, 1.0, sy.BODY_RADIUS)
    alone = detect(sy.Scene(discs=(pillar,)), laser)
    assert people_counts(alone)[1] == TRIALS           # geometry alone cannot tell it from a torso
    with_map = Detector(occupied=occupied_lookup(_grid_with(pillar), margin=0.1))
    mapped = detect(sy.Scene(discs=(pillar,)) + sy.person(-2.0, 0.5), laser, detector=with_map)
    assert all(len(r.people) == 1 and r.people[0].x < 0 for r in mapped)   # the person is still one
    assert all(r.count(Kind.STATIC) == 1 for r in mapped)


def test_the_static_map_is_read_where_the_robot_is() -> None:
    """The lookup gets map coordinates: the robot elsewhere and turned sees the pillar at another bearing."""
    pillar = sy.Disc(2.0, 1.0, sy.BODY_RADIUS)
    detector = Detector(occupied=occupied_lookup(_grid_with(pillar)))
    robot = Pose2D(3.0, -1.0, 2.0)
    results = detect(sy.Scene(discs=(pillar,)), LASERS["360 beams"], robot=robot, detector=detector, trials=5)
    assert all(not r.people and r.count(Kind.STATIC) == 1 for r in results)


@pytest.mark.parametrize("laser", LASERS.values(), ids=LASERS.keys())
@pytest.mark.parametrize("legs, gap", [(False, 0.6), (True, 0.7)], ids=["bodies 0.6 m apart", "legs, 0.7 m apart"])
def test_two_people_side_by_side_are_two_people(laser: sy.Laser, legs: bool, gap: float) -> None:
    scene = sy.person(2.0, gap / 2, legs=legs) + sy.person(2.0, -gap / 2, legs=legs)
    results = detect(scene, laser)
    assert people_counts(results)[2] >= 0.9 * TRIALS, people_counts(results)
    for r in results:
        if len(r.people) == 2:
            assert sorted(round(d.y / gap) for d in r.people) == [0, 1] or \
                sorted(d.y for d in r.people) == pytest.approx([-gap / 2, gap / 2], abs=0.1)


def test_stray_returns_and_dropouts_are_no_people() -> None:
    """Isolated returns (dust, a reflection) anywhere in the room, and beams without a return, make no person."""
    rng = np.random.default_rng(4)
    detector = Detector()
    laser = sy.Laser(beams=720, dropout=0.05)
    for _ in range(TRIALS):
        scan = sy.scan(ROOM, ROBOT, laser, rng)
        stray = rng.choice(scan.beams, 40, replace=False)
        scan.ranges[stray] = rng.uniform(0.3, 5.0, 40)
        assert not detector.detect(scan, ROBOT).people


def test_a_dropped_beam_does_not_split_a_body() -> None:
    rng = np.random.default_rng(5)
    laser = sy.Laser(beams=720)
    detector = Detector()
    for _ in range(TRIALS):
        scan = sy.scan(sy.person(1.5, 0.0) + ROOM, ROBOT, laser, rng)
        near = np.flatnonzero(scan.ranges < 2.0)
        scan.ranges[rng.choice(near[1:-1])] = math.inf
        assert len(detector.detect(scan, ROBOT).people) == 1


def test_detections_are_in_the_map_frame_with_the_laser_mounted_off_centre() -> None:
    laser = sy.Laser(beams=720, fov=math.radians(270), mount=Pose2D(0.2, 0.05, 0.1))
    robot = Pose2D(2.0, -1.0, 2.5)
    results = detect(sy.person(0.5, 0.0), laser, robot=robot, trials=10)
    assert all(len(r.people) == 1 for r in results)
    assert max(math.hypot(r.people[0].x - 0.5, r.people[0].y) for r in results) < 0.06


def test_a_full_circle_scan_joins_its_last_beam_to_its_first() -> None:
    """Straight behind the robot the beams of a full-circle scan wrap from +pi to -pi: a person there is one arc."""
    results = detect(sy.person(-1.5, 0.0), sy.Laser(beams=360), trials=10)
    assert all(len(r.people) == 1 and r.people[0].x == pytest.approx(-1.5, abs=0.06) for r in results)


def test_the_field_of_view_of_a_front_laser() -> None:
    scan = sy.scan(sy.Scene(), ROBOT, sy.Laser(beams=181, fov=math.pi, range_max=10.0, mount=Pose2D(0.1, 0, 0)))
    fov = FieldOfView.of(scan, Pose2D(0.1, 0.0, 0.0), max_range=8.0)
    assert not fov.full_circle and fov.width == pytest.approx(math.pi) and fov.range_max == 8.0
    robot = Pose2D(1.0, 1.0, math.pi / 2)             # facing +y
    assert fov.sees(robot, 1.0, 3.0) and fov.sees(robot, 2.0, 1.5) and fov.sees(robot, 0.0, 1.5)
    assert not fov.sees(robot, 1.0, 0.0) and not fov.sees(robot, 1.0, 9.5)
    assert fov.sees(robot, 2.0, 1.2) and not fov.sees(robot, 2.0, 1.2, margin=0.3)   # near the edge
    full = FieldOfView.of(sy.scan(sy.Scene(), ROBOT, sy.Laser(beams=360)), Pose2D(0.0, 0.0, 0.0), 8.0)
    assert full.full_circle and full.sees(robot, 1.0, 0.0) and not full.sees(robot, 1.0, -7.5)


@pytest.mark.parametrize("fields, message", [
    ((0.0, 0.0, [1.0], 0.0, 5.0), "angle_increment: 0.0 must be > 0"),
    ((math.nan, 0.01, [1.0], 0.0, 5.0), "angle_min: nan is not a finite number"),
    ((0.0, 0.01, [], 0.0, 5.0), "ranges: 0 beams"),
    ((0.0, 0.1, [1.0] * 100, 0.0, 5.0), "100 beams of 0.1 rad cover more than a full circle"),
    ((0.0, 0.01, [1.0], 5.0, 1.0), "range_min 5.0, range_max 1.0: must satisfy"),
    ((0.0, 0.01, ["a"], 0.0, 5.0), "ranges: not a sequence of numbers"),
    ((0.0, True, [1.0], 0.0, 5.0), "angle_increment: True is not a finite number"),
])
def test_a_malformed_scan_is_refused_naming_every_problem(fields: tuple, message: str) -> None:
    with pytest.raises(ScanError, match=message.replace("(", r"\(")):
        Scan.checked(*fields)


def test_a_scan_keeps_its_no_returns() -> None:
    scan = Scan.checked(-1.0, 0.5, [1.0, math.inf, math.nan, 0.01], 0.05, 5.0)
    assert scan.beams == 4 and scan.angle_max == 0.5 and not scan.full_circle
    assert not Detector().detect(scan, ROBOT).people


def test_bad_detector_parameters_are_refused_naming_each() -> None:
    with pytest.raises(PerceptionError) as info:
        DetectorParams(max_range=-1.0, leg_width=(0.3, 0.1), min_points=1)
    assert all(name in str(info.value) for name in ("max_range", "leg_width", "min_points"))


def test_the_benchmark_measures_a_scan() -> None:
    """The figure itself is for the report (python -m gidabot_navigation.perception.benchmark), not a test."""
    figures = benchmark(beams=(360,), scans=20)
    assert set(figures) == {360} and all(f["detect_ms"] > 0 and f["step_ms"] > 0 for f in figures.values())


def test_a_declared_field_of_view_is_checked_against_the_scans() -> None:
    front = sy.scan(sy.Scene(), ROBOT, sy.Laser(beams=541, fov=math.radians(270)))
    assert fov_mismatch(math.radians(270), front) == ""
    assert fov_mismatch(2 * math.pi, front) == ("the scans cover 270 deg, the building file declares 360 deg "
                                                "(sensors.laser.fov): the scans' angles are used")
    assert fov_mismatch(2 * math.pi, sy.scan(sy.Scene(), ROBOT, sy.Laser(beams=360))) == ""
