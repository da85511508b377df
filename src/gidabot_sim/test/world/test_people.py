"""People on a simulated floor (no ROS, no clock): a visitor's body follows its robot along the robot's path at its
own pace, pauses, wanders off, walks as a group, leaves; the laser sees bodies, move_base drives around a person
standing in its way without touching it, a robot driven into a person is stopped and the contact counted; the
floor simulator takes the visitor node's directives, lists the people each robot sees, counts its collisions;
bystanders walk between places; a body leaves one floor and appears on another."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from sim_support import ListLog

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.occupancy import FREE, OCCUPIED, OccupancyMap
from gidabot_navigation.interface import PERSON_ID_PREFIX
from gidabot_sim.navstack.move_base import SUCCEEDED, MoveBaseCore, SensedRobot
from gidabot_sim.visitor.behaviour import TIDY, Behaviour, Bystander
from gidabot_sim.world import floor_sim as fs
from gidabot_sim.world.kinematics import Limits
from gidabot_sim.world.people import FOLLOW, GONE, LEAVE, PERSON_RADIUS, Crowd, Directive, RobotDisc
from gidabot_sim.world.world import LaserSpec, RobotSpec, World

RES = 0.05
LIMITS = Limits(0.7, 1.0, 0.5, 1.5, "differential")
MAPS = Path(__file__).resolve().parents[4] / "maps"


def hall() -> OccupancyMap:
    """A 20 x 4 m hall (walls all round)."""
    cells = np.full((int(5 / RES), int(21 / RES)), OCCUPIED, dtype=np.int8)
    cells[int(0.5 / RES):int(4.5 / RES), int(0.5 / RES):int(20.5 / RES)] = FREE
    return OccupancyMap(cells, RES, 0.0, 0.0)


def drive(crowd: Crowd, world: World, t0: float, seconds: float, speed: float, on) -> float:
    """Drive robot 0 along +x at ``speed`` for ``seconds`` (stops every 0.1 s), the crowd stepping; ``on(t)`` after
    each stop."""
    t = t0
    for _ in range(int(round(seconds / 0.1))):
        robot = world.robots[0]
        robot.pose = Pose2D(robot.pose.x + speed * 0.1, robot.pose.y, 0.0)
        t += 0.1
        crowd.step(t, [RobotDisc("R", robot.pose.x, robot.pose.y, 0.3)])
        on(t)
    return t


def straight(a: tuple[float, float], b: tuple[float, float]) -> list[tuple[float, float]]:
    """A bystander's way from a to b in the hall: a straight line, 21 points."""
    return [(a[0] + (b[0] - a[0]) * k / 20, a[1] + (b[1] - a[1]) * k / 20) for k in range(21)]


def setup(behaviour: Behaviour = TIDY) -> tuple[Crowd, World]:
    world = World(hall(), rng=np.random.default_rng(1))
    world.add_robot(RobotSpec("R", 0.3, LIMITS, LaserSpec(noise=0.0, fov=2 * math.pi)), Pose2D(3.0, 2.5, 0.0))
    crowd = Crowd(world.clearance)
    crowd.step(1.0, [RobotDisc("R", 3.0, 2.5, 0.3)])
    crowd.direct(Directive("v1", FOLLOW, "R", math.nan, math.nan, behaviour, 1.0), [RobotDisc("R", 3.0, 2.5, 0.3)])
    return crowd, world


def test_a_body_appears_next_to_its_robot_and_follows_it_at_its_gap() -> None:
    crowd, world = setup(Behaviour(speed=1.0, gap=1.0))
    (body,) = crowd.bodies
    assert body.person_id == PERSON_ID_PREFIX + "v1"
    assert world.clearance(body.x, body.y) >= PERSON_RADIUS
    assert math.hypot(body.x - 3.0, body.y - 2.5) >= 0.3 + PERSON_RADIUS
    behind = []
    drive(crowd, world, 1.0, 20.0, 0.6, lambda t: behind.append(world.robots[0].pose.x - crowd.bodies[0].x))
    assert 1.2 <= behind[-1] <= 1.7            # robot radius + body radius + gap, along the path
    assert max(behind[50:]) < 1.8


def test_a_slow_body_falls_behind_and_a_pause_stands_still() -> None:
    crowd, world = setup(Behaviour(speed=0.5, gap=1.0, pauses=((3.0, 4.0),)))
    xs = []
    drive(crowd, world, 1.0, 14.0, 0.7, lambda t: xs.append((t, crowd.bodies[0].x)))
    during = [x for t, x in xs if 4.2 <= t <= 7.9]
    assert max(during) - min(during) < 1e-9                 # stood still 4 s
    assert world.robots[0].pose.x - xs[-1][1] > 4.0         # 0.5 m/s behind a 0.7 m/s robot


def test_a_group_walks_behind_one_another_and_a_wanderer_leaves_for_good() -> None:
    crowd, world = setup(Behaviour(speed=1.2, gap=1.0, group=3))
    drive(crowd, world, 1.0, 15.0, 0.6, lambda t: None)
    xs = sorted((b.x for b in crowd.bodies), reverse=True)
    assert len(xs) == 3 and xs[0] - xs[1] > 0.4 and xs[1] - xs[2] > 0.4
    crowd, world = setup(Behaviour(speed=1.2, wander_at=8.0))
    seen = []
    drive(crowd, world, 1.0, 40.0, 0.5, lambda t: seen.append((t, [b.x for b in crowd.bodies])))
    x_at = {round(t, 1): xs for t, xs in seen}
    assert x_at[9.0] and x_at[15.0] and x_at[15.0][0] < x_at[9.0][0]   # walks back along the path
    assert not crowd.bodies and not x_at[31.0]                          # and leaves the floor


def test_a_body_its_robot_turns_back_towards_steps_aside_off_the_robot_s_line() -> None:
    crowd, world = setup(Behaviour(speed=1.0, gap=1.0))
    t = drive(crowd, world, 1.0, 15.0, 0.6, lambda t: None)        # the body walks behind, on the robot's line
    robot = world.robots[0].pose
    (body,) = crowd.bodies
    assert abs(body.y - robot.y) < 0.1
    for _ in range(20):                                           # the robot stops, still facing away: no change
        t += 0.1
        crowd.step(t, [RobotDisc("R", robot.x, robot.y, 0.3, 0.0)])
    assert abs(crowd.bodies[0].y - robot.y) < 0.1
    for _ in range(30):                                           # it turns back: the body makes room
        t += 0.1
        crowd.step(t, [RobotDisc("R", robot.x, robot.y, 0.3, math.pi)])
    body = crowd.bodies[0]
    assert abs(body.y - robot.y) >= 0.3 + PERSON_RADIUS + 0.3 - 1e-6
    assert world.clearance(body.x, body.y) >= PERSON_RADIUS * 0.8
    x0 = body.x                                                   # and walks after it again once it has passed
    for k in range(60):
        t += 0.1
        crowd.step(t, [RobotDisc("R", robot.x - 0.06 * k, robot.y, 0.3, math.pi)])
    assert crowd.bodies[0].x < x0


def test_a_standing_body_makes_way_for_another_robot_facing_it_and_a_walking_one_walks_on() -> None:
    crowd, world = setup(Behaviour(speed=1.0, gap=1.0, pauses=((3.0, 60.0),)))
    t = drive(crowd, world, 1.0, 8.0, 0.6, lambda t: None)        # its robot R drives on; the body pauses
    (body,) = crowd.bodies
    bx, by = body.x, body.y
    robot = world.robots[0].pose
    r = RobotDisc("R", robot.x, robot.y, 0.3, 0.0)
    for _ in range(20):                           # Q, behind the body and facing away, or beyond 1.5 m: no change
        t += 0.1
        crowd.step(t, [r, RobotDisc("Q", bx - 1.0, by, 0.3, math.pi), RobotDisc("Q2", bx + 2.5, by, 0.3, math.pi)])
    assert (crowd.bodies[0].x, crowd.bodies[0].y) == (bx, by)
    for _ in range(20):                           # Q comes along the corridor, facing it: the body makes room
        t += 0.1
        crowd.step(t, [r, RobotDisc("Q", bx + 1.5, by, 0.3, math.pi)])
    body = crowd.bodies[0]
    assert abs(body.y - by) >= 0.3 + PERSON_RADIUS + 0.3 - 1e-6 and abs(body.x - bx) < 1e-9
    assert world.clearance(body.x, body.y) >= PERSON_RADIUS * 0.8
    # a bystander walking across the front of a robot standing there walks on
    crowd = Crowd(world.clearance, straight, [(2.0, 2.5), (18.0, 2.5)], [Bystander("b1", speed=1.0, route=3)])
    crowd.step(0.1, [])
    start = crowd.bodies[0].x
    ahead = 2.0 if start < 10.0 else -2.0                       # Q stands 1.5 m off its way, 2 m on, facing it
    for k in range(2, 40):
        crowd.step(k * 0.1, [RobotDisc("Q", start + ahead, 1.0, 0.3, math.pi / 2)])
    assert abs(crowd.bodies[0].x - start) > 3.0 and abs(crowd.bodies[0].y - 2.5) < 1e-9


def test_leave_and_gone() -> None:
    crowd, world = setup()
    crowd.direct(Directive("v1", LEAVE, "R", math.nan, math.nan), [])
    crowd.step(5.0, [])
    assert crowd.bodies
    crowd.step(11.5, [])
    assert not crowd.bodies
    crowd, world = setup()
    crowd.direct(Directive("v1", GONE), [])
    assert not crowd.bodies


def test_the_laser_sees_a_body_and_a_robot_driving_into_it_is_stopped_and_counted_once() -> None:
    world = World(hall(), rng=np.random.default_rng(1))
    world.add_robot(RobotSpec("R", 0.3, LIMITS, LaserSpec(noise=0.0)), Pose2D(3.0, 2.5, 0.0))
    world.set_people([("person/v1", 6.0, 2.5, PERSON_RADIUS)])
    ranges = world.scan(0, noisy=False)
    ahead = int(np.argmin(np.abs(world.robots[0].spec.laser.angles())))
    assert ranges[ahead] == pytest.approx(6.0 - 3.1 - PERSON_RADIUS, abs=0.01)
    assert world.seen_people(0) == [0]
    world.set_people([("person/v1", 6.0, 2.5, PERSON_RADIUS), ("person/v2", 8.0, 2.5, PERSON_RADIUS),
                      ("person/v3", 1.5, 2.5, PERSON_RADIUS)])
    assert world.seen_people(0) == [0]                  # the second hides behind the first, the third is behind
    assert world.seen_people(0, world.scan(0, noisy=False)) == [0]
    for _ in range(400):
        world.set_command(0, 0.7, 0.0, 0.0)
        world.step()
        world.set_people(world.people)
    assert world.robots[0].pose.x < 6.0 - 0.3 - PERSON_RADIUS + 1e-6
    assert world.people_collisions == 1


def test_move_base_drives_around_a_person_standing_in_its_way_without_touching_them() -> None:
    world = World(hall(), rng=np.random.default_rng(1))
    world.add_robot(RobotSpec("R", 0.3, LIMITS, LaserSpec(noise=0.0)), Pose2D(2.0, 2.5, 0.0))
    nav = MoveBaseCore.for_robot(world.grid, 0.3, LIMITS, log=ListLog(), name="R")
    world.set_people([("person/bystander1", 8.0, 2.5, PERSON_RADIUS)])
    nav.set_goal(Pose2D(15.0, 2.5, 0.0), 0.0)
    outcome, gap = None, math.inf
    for k in range(5 * 600):
        world.step()
        r = world.robots[0]
        gap = min(gap, math.hypot(r.pose.x - 8.0, r.pose.y - 2.5) - 0.3 - PERSON_RADIUS)
        if k % 5 == 4:
            nav.set_robots([SensedRobot(*world.people[j][:3], world.people[j][3]) for j in world.seen_people(0)])
            nav.set_pose(r.pose, r.vel, world.time)
            result = nav.step(world.time)
            if result.cmd is not None:
                world.set_command(0, result.cmd.vx, result.cmd.vy, result.cmd.wz)
            if result.outcome is not None:
                outcome = result.outcome
                break
    assert outcome == SUCCEEDED
    assert world.people_collisions == 0 and gap > 0.05


class Floor:
    def __init__(self, building, robots=("Kbot",), **kw) -> None:
        self.out: list = []
        kw.setdefault("speed", None)
        kw.setdefault("seed", 1)
        self.sim = fs.FloorSim(fs.SimConfig("building", robots, **kw), building, 100.0, self.out.append,
                               lambda topic, _i: True, lambda name: "/" + name, ListLog())

    def run(self, wall: float, ticks: int) -> float:
        for _ in range(ticks):
            wall += 0.001
            self.sim.tick(wall)
        return wall


@pytest.fixture(scope="module")
def faculty():
    return load_building(MAPS / "faculty")


def test_the_floor_takes_directives_lists_the_people_seen_and_counts_collisions(faculty) -> None:
    floor = Floor(faculty, laser=LaserSpec(fov=2 * math.pi))       # the body may stand right behind the robot
    wall = floor.run(100.0, 5)
    floor.sim.post(fs.VISITOR_BODY, -1, lambda: Directive("v1", FOLLOW, "Kbot", math.nan, math.nan, Behaviour(),
                                                          floor.sim.world.time))
    floor.out.clear()
    wall = floor.run(wall, 20)
    assert [p[0] for p in floor.sim.world.people] == ["person/v1"]
    seen = [o for o in floor.out if isinstance(o, fs.Seen)]
    assert seen and ("person/v1" in {name for name, _ in seen[-1].robots})
    diag = [o for o in floor.out if isinstance(o, fs.Diagnostics)]
    floor.run(wall + 2.0, 1)
    diag = [o for o in floor.out if isinstance(o, fs.Diagnostics)]
    values = dict(diag[-1].values)
    assert values["people_collisions"] == "0" and values["people"] == "1"
    pid, x, y = values["people_at"].split()
    (_, bx, by, _r), = floor.sim.world.people
    assert pid == "person/v1" and math.hypot(float(x) - bx, float(y) - by) < 2.0       # where it was a step ago
    floor.sim.post(fs.VISITOR_BODY, -1, lambda: Behaviour(speed=9.0))   # a bad one (converted) is rejected, counted
    floor.run(wall + 4.0, 2)
    assert floor.sim.rejected.counts.get(fs.VISITOR_BODY) == 1


def test_a_body_leaves_one_floor_and_appears_on_another(faculty) -> None:
    lower, upper = Floor(faculty, ("Kbot",)), Floor(faculty, ("Tartalo",))
    wall = lower.run(100.0, 5)
    wall = upper.run(wall, 5)
    d = Directive("v1", FOLLOW, "Kbot", math.nan, math.nan, Behaviour(), 0.0)
    lower.sim.post(fs.VISITOR_BODY, -1, lambda: d)
    wall = lower.run(wall, 5)
    assert lower.sim.world.people
    lower.sim.post(fs.VISITOR_BODY, -1, lambda: Directive("v1", LEAVE, "Kbot", math.nan, math.nan))
    wall = lower.run(wall, 150)
    assert not lower.sim.world.people
    upper.sim.post(fs.VISITOR_BODY, -1, lambda: Directive("v1", FOLLOW, "Tartalo", math.nan, math.nan))
    upper.run(wall, 5)
    tartalo = upper.sim.world.robots[0].pose
    ((_pid, x, y, _r),) = upper.sim.world.people
    assert math.hypot(x - tartalo.x, y - tartalo.y) < 2.5


def test_bystanders_walk_between_places_on_the_first_robot_s_floor(faculty) -> None:
    floor = Floor(faculty, people=3, people_seed=2)
    assert len(floor.sim.crowd.walkers) == 3
    floor.run(100.0, 600)
    assert len(floor.sim.world.people) == 3
    starts = {p[0]: p[1:3] for p in floor.sim.world.people}
    floor.run(200.0, 300)
    moved = [math.dist(starts[p[0]], p[1:3]) for p in floor.sim.world.people]
    assert max(moved) > 1.0
    assert all(floor.sim.world.clearance(x, y) >= PERSON_RADIUS * 0.8 for _pid, x, y, _r in floor.sim.world.people)


def test_a_standing_bystander_stops_at_the_narrowest_point_of_its_walk() -> None:
    world = World(hall(), rng=np.random.default_rng(1))
    crowd = Crowd(world.clearance, straight, [(2.0, 2.5), (18.0, 2.5)],
                  [Bystander("b1", speed=1.0, route=3, stand_s=10.0)])
    xs = []
    for k in range(1, 300):
        crowd.step(k * 0.1, [])
        xs.append(crowd.bodies[0].x if crowd.bodies else math.nan)
    stood = [k for k in range(1, len(xs)) if xs[k] == xs[k - 1]]
    assert len(stood) >= 90
