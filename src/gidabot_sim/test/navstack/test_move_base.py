"""The move_base stand-in's core in closed loop with the simulated floor (no ROS): goals succeed, walls and
closed corridors abort, people are driven around, cancel stops, plans on demand."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from building_support import GLASS, faculty_with_keep_out
from sim_support import ListLog

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.planning import Circle, Rectangle
from gidabot_navigation.errors import PlanningError
from gidabot_sim.bench.closed_loop import FloorLoop
from gidabot_sim.errors import NavGoalRejected
from gidabot_sim.navstack.move_base import ABORTED, SUCCEEDED, MoveBaseCore, NavConfig, State
from gidabot_sim.world.kinematics import Limits

FACULTY = Path(__file__).resolve().parents[4] / "maps" / "faculty"



@pytest.fixture(scope="module")
def faculty():
    return load_building(FACULTY)


def loop(faculty, floor: float = 1, **kw) -> FloorLoop:
    return FloorLoop(faculty, floor, seed=3, laser_rate=0.0, log=ListLog(), **kw)


def assert_reached(sim: FloorLoop, goal: Pose2D, out) -> None:
    assert out.outcome == SUCCEEDED and out.text == "Goal reached.", out
    p = sim.pose
    assert math.hypot(p.x - goal.x, p.y - goal.y) <= 0.25 + 0.12      # tolerance + localisation error
    assert abs(math.remainder(p.yaw - goal.yaw, 2 * math.pi)) <= 0.2 + 0.08
    assert out.stalls == 0 and out.min_clearance >= sim.robot.radius


def test_a_goal_down_the_corridor_succeeds_at_full_speed(faculty) -> None:
    sim = loop(faculty)
    goal = faculty.location("120").pose if faculty.find_location("120") else Pose2D(45.0, 11.4, -math.pi / 2)
    out = sim.drive(goal, timeout=200)
    assert_reached(sim, goal, out)
    straight = math.hypot(goal.x - 30.0, goal.y - 12.0)
    assert out.duration < straight / sim.robot.max_linear + 12.0        # accelerate, brake, turn
    assert sim.state is State.IDLE and sim.nav.step(sim.world.time).cmd is None


def test_the_synchro_drive_robot_reaches_its_goals(faculty) -> None:
    sim = loop(faculty, floor=3)
    for goal in (Pose2D(10.0, 11.4, -math.pi / 2), Pose2D(35.5, 12.6, math.pi / 2)):
        assert_reached(sim, goal, sim.drive(goal, timeout=200))


@pytest.mark.parametrize("goal, text", [
    (Pose2D(30.0, 10.35, 0.0), "inside a wall"),      # the corridor's south wall
    (Pose2D(30.0, 40.0, 0.0), "outside the map"),
    (Pose2D(-0.9, 12.0, 0.0), "inside a wall or unknown space"),
])
def test_a_goal_into_a_wall_aborts_at_once(faculty, goal, text) -> None:
    sim = loop(faculty)
    sim.run(1.0)
    out = sim.drive(goal, timeout=30)
    assert out.outcome == ABORTED and text in out.text and out.duration < 0.5
    assert sim.world.robots[0].vel.is_zero()


def test_a_corridor_closed_while_driving_aborts_after_the_planner_patience(faculty) -> None:
    sim = loop(faculty)
    goal = Pose2D(60.0, 12.0, 0.0)
    sim.nav.set_goal(goal, sim.world.time)
    sim.run(8.0)
    assert sim.state is State.FOLLOWING and sim.world.robots[0].vel.speed > 0.3
    sim.add_obstacle("door", Rectangle(45.0, 12.0, 0.2, 3.4))          # across the whole corridor
    closed_at = sim.world.time
    result = None
    while result is None or result.outcome is None:
        result = sim.tick()
        assert sim.world.time - closed_at < 20
    assert result.outcome == ABORTED and "Failed to find a valid plan" in result.text
    assert 5.0 <= sim.world.time - closed_at <= 6.0                   # planner_patience
    sim.run(2.0)
    robot = sim.world.robots[0]
    assert robot.vel.is_zero() and robot.pose.x < 45.0 - 0.1 - robot.spec.radius and robot.stalls == 0
    # a goal behind the closed door is refused after the patience too (the door may open)
    out = sim.drive(goal, timeout=30)
    assert out.outcome == ABORTED and 5.0 <= out.duration <= 6.0


def test_a_door_that_opens_within_the_patience_lets_the_robot_through(faculty) -> None:
    sim = loop(faculty)
    sim.add_obstacle("door", Rectangle(40.0, 12.0, 0.2, 3.4))
    goal = Pose2D(50.0, 12.0, 0.0)
    sim.nav.set_goal(goal, sim.world.time)
    sim.run(3.0)
    assert sim.state is State.PLANNING and sim.world.robots[0].vel.is_zero()
    sim.remove_obstacle("door")                                       # a person opens it
    while sim.last.outcome is None and sim.world.time < 100:
        sim.tick()
    assert sim.last.outcome == SUCCEEDED


def test_a_person_stepping_into_the_path_is_driven_around(faculty) -> None:
    sim = loop(faculty)
    goal = Pose2D(55.0, 12.0, 0.0)
    sim.nav.set_goal(goal, sim.world.time)
    sim.run(6.0)
    plans = sim.nav.plans
    y = sim.pose.y
    sim.add_obstacle("person", Circle(42.0, y, 0.3))                  # right on the robot's line
    min_gap = math.inf
    while sim.last.outcome is None and sim.world.time < 150:
        sim.tick()
        min_gap = min(min_gap, math.hypot(sim.pose.x - 42.0, sim.pose.y - y))
    assert sim.last.outcome == SUCCEEDED and sim.nav.plans > plans
    assert min_gap >= 0.3 + sim.robot.radius and sim.world.robots[0].stalls == 0


def test_cancel_stops_the_robot_and_a_new_goal_replaces_the_old(faculty) -> None:
    sim = loop(faculty)
    sim.nav.set_goal(Pose2D(60.0, 12.0, 0.0), sim.world.time)
    sim.run(6.0)
    assert sim.world.robots[0].vel.speed > 0.3
    sim.nav.set_goal(Pose2D(20.0, 12.0, math.pi), sim.world.time)   # turn round
    assert sim.nav.goal == Pose2D(20.0, 12.0, pytest.approx(-math.pi))
    sim.run(8.0)
    assert sim.pose.x < 36.0
    sim.nav.cancel()
    assert sim.state is State.IDLE and sim.nav.step(sim.world.time).cmd is None
    sim.run(2.0)                                                      # no commands: the base stops
    assert sim.world.robots[0].vel.is_zero()


def test_relocation_during_a_goal_replans_from_the_new_place(faculty) -> None:
    sim = loop(faculty)
    goal = Pose2D(20.0, 12.0, math.pi)
    sim.nav.set_goal(goal, sim.world.time)
    sim.run(4.0)
    sim.world.teleport(0, Pose2D(50.0, 12.0, 0.0))                    # the admin's "Set location"
    while sim.last.outcome is None and sim.world.time < 200:
        sim.tick()
    assert sim.last.outcome == SUCCEEDED and math.hypot(sim.pose.x - 20.0, sim.pose.y - 12.0) < 0.4
    assert any("off the path" in line for line in sim.nav.log.lines) and sim.nav.replans >= 1


def test_make_plan_and_clear_costmaps(faculty) -> None:
    sim = loop(faculty)
    sim.run(1.0)
    path = sim.nav.make_plan(None, (50.0, 12.0))
    assert path.points[0] == pytest.approx((sim.pose.x, sim.pose.y), abs=0.15)
    assert path.length == pytest.approx(20.0, abs=0.5)
    assert sim.nav.make_plan((10.0, 12.0), (20.0, 12.0)).length == pytest.approx(10.0, abs=0.1)
    with pytest.raises(PlanningError, match="inside a wall"):
        sim.nav.make_plan(None, (30.0, 10.35))
    sim.add_obstacle("door", Rectangle(40.0, 12.0, 0.2, 3.4))
    with pytest.raises(PlanningError, match="not reachable"):
        sim.nav.make_plan(None, (50.0, 12.0))
    sim.nav.clear_costmaps()                       # the obstacle layer marks the door again
    with pytest.raises(PlanningError, match="not reachable"):
        sim.nav.make_plan(None, (50.0, 12.0))
    # a goal just too close to the wall moves within the tolerance (navfn's default_tolerance)
    near = sim.nav.make_plan(None, (30.0, 13.3), tolerance=0.6)
    assert near.goal != (30.0, 13.3) and math.hypot(near.goal[0] - 30.0, near.goal[1] - 13.3) <= 0.6


def test_no_pose_aborts_and_bad_goals_are_rejected(faculty) -> None:
    robot = faculty.robot("Kbot")
    core = MoveBaseCore.for_robot(faculty.floor(1).map, robot.radius, Limits.of_robot(robot), NavConfig())
    core.set_goal(Pose2D(40.0, 12.0, 0.0), 10.0)
    t = 10.0
    while t < 15.0:                                 # control cycles at 10 Hz, never a pose
        assert core.step(t).cmd.is_zero()
        t = round(t + 0.1, 3)
    result = core.step(15.1)
    assert result.outcome == ABORTED and "No robot pose" in result.text
    with pytest.raises(NavGoalRejected, match="not finite"):
        core.set_goal(Pose2D(math.nan, 12.0, 0.0), 20.0)
    with pytest.raises(Exception, match="controller_frequency"):
        NavConfig(controller_frequency=0.0)


def test_keep_out_zones_are_driven_around_and_goals_inside_abort(faculty, tmp_path: Path) -> None:
    """A keep-out zone of the building file (floor 1, the north half of the corridor at x 43..47) is lethal for
    move_base: the robot drives past it on the free side, and a goal inside it aborts at once."""
    building = load_building(faculty_with_keep_out(tmp_path / "faculty", 1, "glass", GLASS))
    zone = building.floor(1).keep_out[0].polygon
    sim = loop(building)
    goal = Pose2D(50.0, 12.0, 0.0)
    start, stalls = sim.world.time, sim.world.robots[0].stalls
    sim.nav.set_goal(goal, sim.world.time)
    while sim.world.time - start < 200:
        result = sim.tick()
        p = sim.pose
        assert not zone.contains_point(p.x, p.y) and sim.world.clearance(p.x, p.y) >= sim.robot.radius - 1e-6
        if result is not None and result.outcome is not None:
            break
    assert result.outcome == SUCCEEDED and sim.world.robots[0].stalls == stalls
    out = sim.drive(Pose2D(45.0, 12.8, 0.0), timeout=30)
    assert out.outcome == ABORTED and "inside keep-out zone glass" in out.text and out.duration < 0.5
