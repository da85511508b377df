"""The floor world: commands and timeouts, collisions (walls, obstacles, robots), teleports, obstacles,
laser, battery, odometry, time catch-up; several robots on one floor."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from building_support import GLASS, faculty_with_keep_out

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.occupancy import FREE, OCCUPIED, OccupancyMap
from gidabot_navigation.building.planning import Circle, Rectangle
from gidabot_sim.errors import CommandRejected, ObstacleRejected, PoseRejected, SimConfigError
from gidabot_sim.world.kinematics import Limits
from gidabot_sim.world.world import MAX_OBSTACLES, BatteryModel, LaserSpec, RobotSpec, World

RES = 0.05
FACULTY = Path(__file__).resolve().parents[4] / "maps" / "faculty"
DIFF = Limits(0.6, 1.0, 0.5, 1.5, "differential")
SYNC = Limits(0.5, 0.9, 0.4, 1.2, "synchro")


def hall(width_m: float = 10.0, height_m: float = 6.0) -> OccupancyMap:
    """A walled rectangle, origin (0, 0): free inside x 0.05..w-0.05, y 0.05..h-0.05."""
    cells = np.full((int(round(height_m / RES)), int(round(width_m / RES))), FREE, dtype=np.int8)
    cells[0, :] = cells[-1, :] = cells[:, 0] = cells[:, -1] = OCCUPIED
    return OccupancyMap(cells, RES, 0.0, 0.0)


def spec(name: str = "R", radius: float = 0.3, limits: Limits = DIFF, **kw) -> RobotSpec:
    return RobotSpec(name, radius, limits, LaserSpec(beams=361, noise=0.0), **kw)   # beam 180 looks ahead


def drive(world: World, index: int, vx: float, vy: float, wz: float, seconds: float) -> None:
    """Keep commanding (as a controller at 10 Hz would) for ``seconds``."""
    end = world.time + seconds
    while world.time < end - 1e-9:
        world.set_command(index, vx, vy, wz)
        world.advance_to(world.time + 0.1)


def test_commands_ramp_at_the_limits_and_time_out() -> None:
    world = World(hall(), dt=0.02)
    world.add_robot(spec(), Pose2D(2.0, 3.0, 0.0))
    world.set_command(0, 1.0, 0.0, 0.0)                 # clamped to 0.6
    world.advance_to(0.2)
    robot = world.robots[0]
    assert robot.vel.vx == pytest.approx(0.1)            # 0.5 m/s^2 for 0.2 s
    world.advance_to(5.0)                                 # no new command after 0.2 s: brakes and stops
    assert robot.vel.is_zero()
    assert robot.pose.x < 2.0 + 0.2                       # moved only while the command was fresh
    drive(world, 0, 0.6, 0.0, 0.0, 3.0)
    assert robot.vel.vx == pytest.approx(0.6)
    assert robot.pose.y == pytest.approx(3.0) and robot.pose.yaw == pytest.approx(0.0)
    with pytest.raises(CommandRejected):
        world.set_command(0, math.nan, 0.0, 0.0)
    assert robot.cmd.vx == pytest.approx(0.6)             # the last good command stays


def test_a_robot_never_enters_a_wall() -> None:
    world = World(hall(), dt=0.02)
    world.add_robot(spec(), Pose2D(8.0, 3.0, 0.0))
    drive(world, 0, 0.6, 0.0, 0.0, 10.0)                  # straight at the east wall (inner face x 9.95)
    robot = world.robots[0]
    assert robot.stalled and robot.stalls >= 1 and robot.vel.is_zero()
    assert 9.95 - 0.3 - 0.02 <= robot.pose.x <= 9.95 - 0.3 + 1e-9    # touching, never overlapping
    assert world.clearance(robot.pose.x, robot.pose.y) >= 0.3
    drive(world, 0, -0.3, 0.0, 0.0, 1.0)                  # backing out is allowed
    assert not robot.stalled and robot.pose.x < 9.5


def test_two_robots_collide_and_see_each_other() -> None:
    world = World(hall(), dt=0.02)
    a = world.add_robot(spec("A"), Pose2D(2.0, 3.0, 0.0))
    b = world.add_robot(spec("B", radius=0.25, limits=SYNC), Pose2D(6.0, 3.0, math.pi))
    assert world.scan(a)[180] == pytest.approx(6.0 - 0.25 - 2.0 - 0.1, abs=1e-6)
    for _ in range(100):                                   # head-on
        world.set_command(a, 0.6, 0.0, 0.0)
        world.set_command(b, 0.5, 0.0, 0.0)
        world.advance_to(world.time + 0.1)
    ra, rb = world.robots
    gap = math.hypot(ra.pose.x - rb.pose.x, ra.pose.y - rb.pose.y)
    assert 0.55 - 1e-9 <= gap <= 0.55 + 0.05
    assert ra.stalls >= 1 and rb.stalls >= 1
    # B is holonomic: it can slide sideways out of the way, A then passes
    drive(world, b, 0.0, 0.5, 0.0, 3.0)
    assert rb.pose.y < 3.0 - 1.0                           # B faces -x: its left is -y
    drive(world, a, 0.6, 0.0, 0.0, 5.0)
    assert ra.pose.x > rb.pose.x + 1.0
    with pytest.raises(PoseRejected, match="overlaps robot A"):
        world.teleport(b, Pose2D(ra.pose.x + 0.3, ra.pose.y, 0.0))


def test_teleport_checks_and_nudges() -> None:
    world = World(hall(), dt=0.02)
    world.add_robot(spec(), Pose2D(2.0, 3.0, 0.0))
    world.set_command(0, 0.5, 0.0, 0.0)
    world.advance_to(0.1)
    odom_before = world.robots[0].odom
    placed = world.teleport(0, Pose2D(5.0, 2.0, 7.0))
    assert placed == Pose2D(5.0, 2.0, pytest.approx(7.0 - 2 * math.pi))
    assert world.robots[0].vel.is_zero() and world.robots[0].odom == odom_before   # odometry does not jump
    nudged = world.teleport(0, Pose2D(9.8, 3.0, 0.0))         # 0.15 m from the wall: moved clear of it
    assert world.clearance(nudged.x, nudged.y) >= 0.3 and abs(nudged.x - 9.8) <= 0.5
    for bad, message in [(Pose2D(math.nan, 1.0, 0.0), "not finite"), (Pose2D(1.0, 1.0, math.inf), "not finite"),
                         (Pose2D(-3.0, 1.0, 0.0), "outside the map"), (Pose2D(9.97, 3.0, 0.0), "inside a wall"),
                         (Pose2D(5.0, 6.5, 0.0), "outside the map")]:
        with pytest.raises(PoseRejected, match=message):
            world.teleport(0, bad)
    assert world.robots[0].pose == nudged
    with pytest.raises(PoseRejected, match="does not fit"):
        World(hall(1.0, 1.0)).add_robot(spec(radius=0.6), Pose2D(0.5, 0.5, 0.0))


def test_obstacles_block_robots_and_the_laser() -> None:
    world = World(hall(), dt=0.02)
    world.add_robot(spec(), Pose2D(2.0, 3.0, 0.0))
    ahead = 180
    assert world.scan(0)[ahead] == pytest.approx(9.95 - 2.1, abs=1e-6)
    world.add_obstacle("door", Rectangle(6.0, 3.0, 0.1, 6.0))      # a closed door across the hall
    version = world.obstacle_version
    assert world.scan(0)[ahead] == pytest.approx(5.95 - 2.1, abs=0.06)   # rasterised within half a cell
    drive(world, 0, 0.6, 0.0, 0.0, 15.0)
    assert world.robots[0].pose.x <= 5.90 - 0.3 + 1e-9 and world.robots[0].stalls >= 1
    world.add_obstacle("person", Circle(3.0, 1.0, 0.25))
    with pytest.raises(ObstacleRejected, match="overlap robot R"):
        world.add_obstacle("onto", Circle(world.robots[0].pose.x + 0.4, 3.0, 0.2))
    with pytest.raises(ObstacleRejected, match="id"):
        world.add_obstacle("bad id!", Circle(3.0, 5.0, 0.2))
    assert world.remove_obstacle("door") and not world.remove_obstacle("door")
    assert world.obstacle_version > version
    assert world.scan(0)[ahead] == pytest.approx(9.95 - world.laser_pose(0).x, abs=1e-6)
    assert world.clear_obstacles() == 1 and world.obstacles == {}
    for k in range(MAX_OBSTACLES):
        world.add_obstacle(f"o{k}", Circle(9.0, 0.5 + 0.02 * k, 0.01))
    with pytest.raises(ObstacleRejected, match="already"):
        world.add_obstacle("one-more", Circle(9.0, 5.0, 0.01))
    world.add_obstacle("o0", Circle(9.0, 5.0, 0.02))                # replacing is fine


def test_a_burst_of_obstacle_changes_updates_the_world_once() -> None:
    world = World(hall(), dt=0.02)
    world.add_robot(spec(), Pose2D(2.0, 3.0, 0.0))
    version = world.obstacle_version
    for k in range(20):
        world.add_obstacle(f"p{k}", Circle(4.0 + 0.2 * k, 5.0, 0.05), rebuild=False)
    world.add_obstacle("door", Rectangle(6.0, 3.0, 0.1, 6.0), rebuild=False)
    assert world.remove_obstacle("p0", rebuild=False)
    assert world.scan(0)[180] == pytest.approx(9.95 - 2.1, abs=1e-6)   # not applied yet
    assert world.rebuild() and not world.rebuild()
    assert world.obstacle_version == version + 1
    assert world.scan(0)[180] < 4.0
    assert world.clear_obstacles(rebuild=False) == 20 and world.rebuild()


def test_laser_noise_limits_and_geometry() -> None:
    world = World(hall(), dt=0.02, rng=np.random.default_rng(3))
    laser = LaserSpec(beams=181, fov=math.pi, noise=0.02, range_max=4.0)
    world.add_robot(RobotSpec("R", 0.3, DIFF, laser), Pose2D(2.0, 3.0, 0.0))
    ranges = world.scan(0)
    assert ranges.shape == (181,) and laser.angle_increment == pytest.approx(math.pi / 180)
    assert ranges[0] == pytest.approx(2.95, abs=0.1) and ranges[-1] == pytest.approx(2.95, abs=0.1)  # right, left
    assert ranges[90] == math.inf                                 # 7.85 m ahead > range_max 4 m
    clean = world.scan(0, noisy=False)
    finite = np.isfinite(clean)
    noise = ranges[finite] - clean[finite]
    assert 0.01 < noise.std() < 0.03
    assert LaserSpec(beams=4, fov=2 * math.pi).angles().tolist() == pytest.approx(
        [-math.pi, -math.pi / 2, 0.0, math.pi / 2])
    with pytest.raises(SimConfigError, match="beams"):
        LaserSpec(beams=0)


def test_battery_drains_with_time_and_distance() -> None:
    model = BatteryModel(start=0.9, idle_per_hour=0.1, per_km=0.5)
    world = World(hall(30.0, 6.0), dt=0.05)
    world.add_robot(spec(battery=model), Pose2D(2.0, 3.0, 0.0))
    world.advance_to(3600.0 / 10)                      # 6 minutes at rest
    robot = world.robots[0]
    assert robot.battery == pytest.approx(0.9 - 0.01, abs=1e-6)
    drive(world, 0, 0.6, 0.0, 0.0, 40.0)
    assert robot.odometer > 20.0
    idle = 0.1 * 40.0 / 3600.0
    assert robot.battery == pytest.approx(0.89 - idle - 0.5 * robot.odometer / 1000.0, abs=1e-6)
    assert model.voltage(1.0) == 12.7 and model.voltage(0.0) == 11.0
    with pytest.raises(SimConfigError, match="start"):
        BatteryModel(start=1.5)


def test_time_advances_only_by_steps_without_rounding_drift() -> None:
    world = World(hall(), dt=0.02)
    world.add_robot(spec(), Pose2D(2.0, 3.0, 0.0))
    world.start_at(100.0)
    assert world.advance_to(101.0) == 50 and world.time == pytest.approx(101.0)
    for _ in range(100_000):
        world.step()
    assert world.time == 101.0 + 100_000 * 0.02               # exact multiple: no accumulated rounding
    assert world.advance_to(world.time + 0.5) == 25            # a far target is stepped through, never skipped
    with pytest.raises(ValueError):
        world.advance_to(math.nan)
    with pytest.raises(ValueError):
        world.start_at(math.inf)


def test_the_faculty_robots_fit_at_home_and_the_synchro_robot_turns_while_sliding() -> None:
    faculty = load_building(FACULTY)
    for floor in faculty.floors:
        [robot] = faculty.robots_on(floor.id)
        world = World(floor.map)
        world.add_robot(RobotSpec(robot.name, robot.radius, Limits.of_robot(robot)), robot.home)
        assert world.clearance(robot.home.x, robot.home.y) >= robot.radius
    mari = faculty.robot("MariSorgin")
    world = World(faculty.floor(3).map, dt=0.02)
    world.add_robot(RobotSpec(mari.name, mari.radius, Limits.of_robot(mari)), mari.home)
    drive(world, 0, 0.4, 0.0, 0.5, 4.0)
    pose = world.robots[0].pose
    assert pose.yaw > 1.0 and world.robots[0].stalls == 0


def test_a_robot_sees_the_others_it_has_a_line_of_sight_to() -> None:
    world = World(hall(), dt=0.02)
    a = world.add_robot(spec("A"), Pose2D(2.0, 3.0, 0.0))
    b = world.add_robot(spec("B"), Pose2D(5.0, 3.0, 0.0))
    c = world.add_robot(spec("C"), Pose2D(8.0, 3.0, 0.0))
    assert world.seen_robots(a) == [b]                          # C is hidden behind B (same size, farther)
    assert world.seen_robots(b) == [c]                          # A is in the blind 90 degrees behind B
    world.teleport(c, Pose2D(8.0, 5.0, 0.0))
    assert world.seen_robots(a) == [b, c]
    assert world.seen_robots(c) == []                           # C looks +x: A and B are in its blind sector
    world.teleport(c, Pose2D(8.0, 5.0, math.pi))
    assert world.seen_robots(c) == [a, b]
    world.add_obstacle("wall", Rectangle(6.5, 4.0, 0.2, 4.0))
    assert world.seen_robots(a) == [b]                          # C is behind the new wall


def test_a_collision_between_robots_is_counted_once_per_contact() -> None:
    world = World(hall(), dt=0.02)
    a = world.add_robot(spec("B"), Pose2D(2.0, 3.0, 0.0))
    b = world.add_robot(spec("A"), Pose2D(5.0, 3.0, math.pi))
    drive(world, a, 0.6, 0.0, 0.0, 10.0)                   # into A (parked), pushing for seconds: one contact
    ra, rb = world.robots
    assert ra.stalled and rb.pose.x == 5.0                 # stopped as against a wall; A not pushed
    assert world.robot_collisions == 1
    [event] = world.take_events()
    assert (event.kind, event.robots) == ("collision", ("A", "B")) and "B ran into robot A" in event.text
    drive(world, a, -0.3, 0.0, 0.0, 1.0)                   # parts...
    drive(world, a, 0.6, 0.0, 0.0, 3.0)                    # ...and hits again: a second contact
    assert world.robot_collisions == 2 and len(world.take_events()) == 1
    drive(world, b, -0.3, 0.0, 0.0, 0.1)                   # A backs off a little, B drives on: still counted once
    drive(world, a, 0.6, 0.0, 0.0, 3.0)
    assert world.robot_collisions == 2                      # never parted by 0.05 m: the same contact
    assert world.deadlocks == 0                            # nobody had a goal


def test_two_robots_blocking_each_other_are_reported_as_a_deadlock_once() -> None:
    world = World(hall(), dt=0.02, deadlock_time=20.0)
    a = world.add_robot(spec("A"), Pose2D(2.0, 3.0, 0.0))
    b = world.add_robot(spec("B"), Pose2D(3.2, 3.0, math.pi))
    world.set_active(a, True)
    world.set_active(b, True)
    drive(world, a, 0.0, 0.0, 0.3, 19.0)                   # turning on the spot is no progress
    assert world.deadlocks == 0 and world.deadlocked == []
    drive(world, a, 0.0, 0.0, 0.3, 2.0)
    assert world.deadlocks == 1 and world.deadlocked == [("A", "B")]
    [event] = world.take_events()
    assert event.kind == "deadlock" and event.robots == ("A", "B") and "robots A and B block each other" in event.text
    drive(world, a, 0.0, 0.0, 0.3, 30.0)
    assert world.deadlocks == 1 and world.take_events() == []       # reported once
    world.teleport(a, Pose2D(1.0, 3.0, math.pi))
    world.step()
    assert world.deadlocked == [] and [e.kind for e in world.take_events()] == ["deadlock_resolved"]
    drive(world, a, 0.0, 0.0, 0.3, 5.0)                    # the new standoff starts from zero
    world.set_active(a, False)
    world.set_active(b, False)
    drive(world, a, 0.0, 0.0, 0.3, 60.0)                   # parked robots side by side are no deadlock
    assert world.deadlocks == 1


def test_two_worlds_of_one_floor_share_it_through_their_mates() -> None:
    """A and B share a floor but not a simulator: each world moves its own robot and carries the other along
    what its world wrote (pose, velocity, time). A drives east into B, B drives west into A: each sees the other
    in its laser, each is stopped by the other, never overlapping it; each world counts the contact its own
    robot had (both drove: one in each)."""
    wa, wb = World(hall(), dt=0.02), World(hall(), dt=0.02)
    a, a_mate = wa.add_robot(spec("A"), Pose2D(2.0, 3.0, 0.0)), wa.add_mate(spec("B"), Pose2D(8.0, 3.0, math.pi))
    b, b_mate = wb.add_robot(spec("B"), Pose2D(8.0, 3.0, math.pi)), wb.add_mate(spec("A"), Pose2D(2.0, 3.0, 0.0))
    assert wa.own == [a] and wb.own == [b]
    assert wa.seen_robots(a) == [a_mate] and wb.seen_robots(b) == [b_mate]
    scan = wa.scan(a, noisy=False)
    assert abs(scan[180] - (8.0 - 2.1 - 0.3)) < 0.05             # the beam ahead ends on B's disc

    def share(src: World, i: int, dst: World, j: int) -> None:
        r = src.robots[i]
        c, s_ = math.cos(r.pose.yaw), math.sin(r.pose.yaw)
        dst.set_mate(j, r.pose, r.vel.vx * c - r.vel.vy * s_, r.vel.vx * s_ + r.vel.vy * c, src.time, True)

    for _ in range(150):                                          # 15 s, 0.1 s steps, the two worlds in turn
        wa.set_command(a, 0.6, 0.0, 0.0)
        wb.set_command(b, 0.6, 0.0, 0.0)
        wa.advance_to(wa.time + 0.1)
        share(wa, a, wb, b_mate)
        wb.advance_to(wb.time + 0.1)
        share(wb, b, wa, a_mate)
        gap = math.dist((wa.robots[a].pose.x, wa.robots[a].pose.y), (wb.robots[b].pose.x, wb.robots[b].pose.y))
        assert gap >= 0.6 - 0.06                                 # never overlapping (one step of the other's drive)
    assert wa.robots[a].stalled and wb.robots[b].stalled
    assert (wa.robot_collisions, wb.robot_collisions) == (1, 1)
    assert [e.robots for e in wa.take_events() if e.kind == "collision"] == [("A", "B")]
    with pytest.raises(ValueError, match="not a mate"):
        wa.set_mate(a, Pose2D(0, 0, 0), 0, 0, 0, False)
    # a mate is carried along its velocity for at most 0.5 s past its last known time
    wc = World(hall(), dt=0.02)
    wc.add_robot(spec("C"), Pose2D(1.0, 1.0, 0.0))
    m = wc.add_mate(spec("D"), Pose2D(5.0, 3.0, 0.0))
    wc.set_mate(m, Pose2D(5.0, 3.0, 0.0), 0.5, 0.0, -0.2, True)
    assert math.isclose(wc.robots[m].pose.x, 5.1)
    wc.advance_to(2.0)
    assert math.isclose(wc.robots[m].pose.x, 5.25) and wc.robots[m].active


def test_the_mates_file_holds_each_robots_latest_motion(tmp_path) -> None:
    from gidabot_sim.world.mates import NEVER, Mates, MateState, mate_motion

    with Mates.create(tmp_path / "mates", [Pose2D(1.0, 2.0, 0.0), Pose2D(3.0, 4.0, 1.0)]) as created:
        with Mates.open(tmp_path / "mates") as sim:
            home = sim.read(1)
            assert (home.sim, home.x, home.y, home.yaw) == (NEVER, 3.0, 4.0, 1.0)
            assert mate_motion(home, 100.0, 5.0) == (Pose2D(3.0, 4.0, 1.0), 0.0, 0.0, NEVER, False)
            sim.write(1, MateState(12.5, 100.0, 3.5, 4.0, 0.0, 0.4, 0.0, 1.0))
            state = created.read(1)
            assert mate_motion(state, 101.0, 5.0) == (Pose2D(3.5, 4.0, 0.0), 0.4, 0.0, 12.5, True)
            assert mate_motion(state, 106.0, 5.0)[1:] == (0.0, 0.0, 12.5, False)     # its simulator stopped
        with pytest.raises(SimConfigError, match="slot"):
            created.read(2)
    (tmp_path / "junk").write_bytes(b"x" * 100)
    with pytest.raises(SimConfigError, match="not a mates file"):
        Mates.open(tmp_path / "junk")
    with pytest.raises(SimConfigError, match="cannot open"):
        Mates.open(tmp_path / "none")


def test_keep_out_zones_stop_bodies_but_not_the_laser() -> None:
    """A keep-out zone (a glass wall, the top of a staircase) is solid for robots and invisible to the laser."""
    from gidabot_navigation.building.geometry import Polygon

    glass = Polygon(((6.0, 0.0), (6.2, 0.0), (6.2, 6.0), (6.0, 6.0)))
    world = World(hall(), dt=0.02, keep_out={"glass": glass})
    world.add_robot(spec(), Pose2D(4.0, 3.0, 0.0))
    ranges = world.scan(0, noisy=False)
    assert ranges[180] == pytest.approx(10.0 - 0.05 - 4.0 - 0.1, abs=0.06)   # the far wall, through the zone
    drive(world, 0, 0.6, 0.0, 0.0, 8.0)
    robot = world.robots[0]
    assert robot.stalled and 5.6 <= robot.pose.x + 0.3 <= 6.0 + 1e-6       # stopped at the zone's edge
    assert world.clearance(5.0, 3.0) == pytest.approx(0.95, abs=0.03)       # rasterised with half a cell more
    with pytest.raises(PoseRejected, match="keep-out zone"):
        world.teleport(0, Pose2D(6.1, 3.0, 0.0))
    world.add_obstacle("box", Circle(2.0, 1.0, 0.3))                     # a rebuild keeps the zone solid
    assert world.clearance(5.0, 3.0) == pytest.approx(0.95, abs=0.03)       # rasterised with half a cell more
    assert World(hall()).clearance(5.0, 3.0) == pytest.approx(2.95, abs=0.03)   # no zone: only the walls


def test_a_floors_world_and_move_base_hold_its_keep_out_zones(tmp_path: Path) -> None:
    """What the simulator and move_base nodes build from the building file: the floor's map with its keep-out
    zones (solid for the robots, lethal for the planner)."""
    from gidabot_sim.navstack.move_base import MoveBaseCore

    floor = load_building(faculty_with_keep_out(tmp_path / "faculty", 1, "glass", GLASS)).floor(1)
    world = World.of_floor(floor, dt=0.02)
    assert world.grid is floor.map
    world.add_robot(spec(), Pose2D(40.0, 12.0, 0.0))
    with pytest.raises(PoseRejected, match="keep-out zone"):
        world.teleport(0, Pose2D(45.0, 12.8, 0.0))
    core = MoveBaseCore.for_floor(floor, 0.3, DIFF)
    assert list(core.planner.keep_out) == ["glass"] and core.planner.keep_out_at(45.0, 12.8) == "glass"
    assert World.of_floor(load_building(FACULTY).floor(1)).clearance(45.0, 12.8) > 0.3      # no zone, no wall
