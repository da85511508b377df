"""Several robots on one floor, each driven by its own move_base core (no ROS, no clock: driven by step()):
the obstacle layer marks the robots the laser sees and clears them, robots drive around each other, a
head-on meeting in a corridor too narrow to pass is resolved by a yield within a bound, an unresolvable
one is reported as a deadlock by the world and aborted by both robots naming the other."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from sim_support import ListLog

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.occupancy import FREE, OCCUPIED, OccupancyMap
from gidabot_navigation.building.planning import Rectangle
from gidabot_sim.navstack.move_base import (
    ABORTED,
    SUCCEEDED,
    MoveBaseCore,
    NavConfig,
    SensedRobot,
    State,
    StepResult,
)
from gidabot_sim.world.clock import Periodic
from gidabot_sim.world.kinematics import ZERO, Limits
from gidabot_sim.world.world import LaserSpec, RobotSpec, World

RES = 0.05
LIMITS = Limits(0.5, 1.0, 0.5, 1.5, "differential")
RADIUS = 0.3



def floor_map(width: float, height: float, free: list[tuple[float, float, float, float]]) -> OccupancyMap:
    """A map ``width`` x ``height`` m, solid but for the rectangles ``free`` (x0, y0, x1, y1 in m)."""
    cells = np.full((int(round(height / RES)), int(round(width / RES))), OCCUPIED, dtype=np.int8)
    for x0, y0, x1, y1 in free:
        cells[int(round(y0 / RES)):int(round(y1 / RES)), int(round(x0 / RES)):int(round(x1 / RES))] = FREE
    return OccupancyMap(cells, RES, 0.0, 0.0)


def two_rooms(corridor_width: float = 0.9) -> OccupancyMap:
    """Two 4 x 4 m rooms (x 0.5..4.5 and 10.5..14.5, y 0.5..4.5) joined by a 6 m corridor along y = 2.5."""
    half = corridor_width / 2
    return floor_map(15.0, 5.0, [(0.5, 0.5, 4.5, 4.5), (10.5, 0.5, 14.5, 4.5), (4.5, 2.5 - half, 10.5, 2.5 + half)])


class Floor:
    """Robots in one world, each with its move_base core; poses from the ground truth, the robots each laser
    sees fed to its core's obstacle layer at 10 Hz, control at 10 Hz (as the nodes do)."""

    def __init__(self, grid: OccupancyMap, poses: dict[str, Pose2D], deadlock_time: float = 30.0) -> None:
        self.world = World(grid, dt=0.02, deadlock_time=deadlock_time, rng=np.random.default_rng(1))
        self.logs = {name: ListLog() for name in poses}
        self.nav: list[MoveBaseCore] = []
        for name, pose in poses.items():
            self.world.add_robot(RobotSpec(name, RADIUS, LIMITS, LaserSpec(noise=0.0)), pose)
            self.nav.append(MoveBaseCore.for_robot(grid, RADIUS, LIMITS, log=self.logs[name], name=name))
        self.control_due = Periodic(10.0)
        self.results: dict[int, StepResult] = {}
        self.events: list = []
        self.min_gap = math.inf            # m, smallest gap seen between two robots' discs

    def sense(self) -> None:
        for i, nav in enumerate(self.nav):
            seen = [self.world.robots[j] for j in self.world.seen_robots(i)]
            nav.set_robots([SensedRobot(r.spec.name, r.pose.x, r.pose.y, r.spec.radius) for r in seen])

    def tick(self) -> None:
        w = self.world
        w.step()
        self.events += w.take_events()
        a, b = w.robots[:2]
        self.min_gap = min(self.min_gap, math.hypot(a.pose.x - b.pose.x, a.pose.y - b.pose.y) - 2 * RADIUS)
        if not self.control_due.due(w.time):
            return
        self.sense()
        for i, nav in enumerate(self.nav):
            robot = w.robots[i]
            nav.set_pose(robot.pose, robot.vel, w.time)
            result = nav.step(w.time)
            if result.cmd is not None:
                w.set_command(i, result.cmd.vx, result.cmd.vy, result.cmd.wz)
            if result.outcome is not None:
                self.results[i] = result
            w.set_active(i, nav.state is not State.IDLE)

    def run(self, goals: dict[int, Pose2D], timeout: float) -> float:
        """Send ``goals`` and step until all ended or ``timeout`` sim s; returns the sim s it took."""
        start = self.world.time
        for i, goal in goals.items():
            self.nav[i].set_goal(goal, start)
        while self.world.time - start < timeout and len(self.results) < len(goals):
            self.tick()
        return self.world.time - start


def test_the_obstacle_layer_marks_the_robots_the_laser_sees_and_clears_them() -> None:
    floor = Floor(two_rooms(), {"A": Pose2D(2.0, 2.5, 0.0), "B": Pose2D(13.0, 2.5, math.pi)})
    a, b = floor.nav
    floor.sense()
    planner = a.planner
    assert planner.lethal[planner.grid.world_to_cell(13.0, 2.5)]               # B, down the corridor
    assert planner.clearance(13.0, 2.5 + 0.45) < 0.25                          # its disc: 0.3 m
    assert b.planner.lethal[b.planner.grid.world_to_cell(2.0, 2.5)]
    floor.world.teleport(1, Pose2D(13.0, 4.0, math.pi))                          # out of A's line of sight
    floor.sense()
    assert not planner.lethal[planner.grid.world_to_cell(13.0, 2.5)]           # cleared
    assert not planner.lethal[planner.grid.world_to_cell(13.0, 4.0)]
    floor.world.teleport(1, Pose2D(13.0, 2.55, math.pi))                         # back, 5 cm off: re-marked
    assert a.set_robots([SensedRobot("B", 13.0, 2.55, RADIUS)])
    assert not a.set_robots([SensedRobot("B", 13.1, 2.55, RADIUS)])           # moved < robot_mark_step
    assert a.set_robots([SensedRobot("A", 5.0, 2.5, RADIUS), SensedRobot("C", math.nan, 0.0, 0.3)])   # B gone
    assert not planner.lethal[planner.grid.world_to_cell(13.0, 2.55)]
    assert not planner.lethal[planner.grid.world_to_cell(5.0, 2.5)]             # itself and a NaN: ignored
    a.set_pose(Pose2D(2.0, 2.5, 0.0), floor.world.robots[0].vel, 0.0)
    assert a.set_robots([SensedRobot("B", 1.0, 2.5, RADIUS)])
    assert not a.set_robots([])                          # B behind A, in the laser's blind sector: still marked
    assert planner.lethal[planner.grid.world_to_cell(1.0, 2.5)]
    a.set_pose(Pose2D(2.0, 2.5, math.pi), floor.world.robots[0].vel, 0.0)
    assert a.set_robots([])                              # A looks there and B is not: cleared
    assert not planner.lethal[planner.grid.world_to_cell(1.0, 2.5)]


def test_a_robot_drives_around_another_standing_in_its_way() -> None:
    hall = floor_map(12.0, 6.0, [(0.5, 0.5, 11.5, 5.5)])
    floor = Floor(hall, {"A": Pose2D(2.0, 3.0, 0.0), "B": Pose2D(6.0, 3.0, 0.0)})
    floor.run({0: Pose2D(10.0, 3.0, 0.0)}, timeout=60.0)
    assert floor.results[0].outcome == SUCCEEDED
    assert floor.world.robot_collisions == 0 and floor.world.robots[1].pose.x == 6.0
    assert floor.min_gap >= 0.3                          # driven around with room, not brushed past


def test_a_head_on_meeting_in_a_narrow_corridor_is_resolved_by_the_later_name_yielding() -> None:
    floor = Floor(two_rooms(0.9), {"A": Pose2D(1.5, 2.5, 0.0), "B": Pose2D(13.5, 2.5, math.pi)})
    took = floor.run({0: Pose2D(13.5, 1.5, 0.0), 1: Pose2D(1.5, 3.5, math.pi)}, timeout=240.0)
    assert {i: r.outcome for i, r in floor.results.items()} == {0: SUCCEEDED, 1: SUCCEEDED}, floor.logs["B"].lines
    assert took < 80.0                       # bound: 12 m at 0.5 m/s each, a yield and the wait
    assert floor.world.robot_collisions == 0 and floor.world.deadlocks == 0 and floor.min_gap > 0.0
    assert any("yielding to robot A: moving aside" in line for line in floor.logs["B"].lines)
    assert not any("yielding to robot B" in line for line in floor.logs["A"].lines)


def test_the_first_name_yields_when_the_other_has_no_room_to() -> None:
    # a dead end west of B: B cannot yield, A (priority) waits yield_timeout, then yields itself
    grid = floor_map(14.0, 5.0, [(0.5, 2.05, 8.5, 2.95), (8.5, 0.5, 13.5, 4.5)])
    floor = Floor(grid, {"A": Pose2D(6.0, 2.5, math.pi), "B": Pose2D(2.0, 2.5, 0.0)})
    took = floor.run({0: Pose2D(1.0, 2.5, math.pi), 1: Pose2D(12.0, 2.5, 0.0)}, timeout=300.0)
    assert {i: r.outcome for i, r in floor.results.items()} == {0: SUCCEEDED, 1: SUCCEEDED}, floor.logs["A"].lines
    assert took < 90.0
    assert any("no room to yield to robot A" in line for line in floor.logs["B"].lines)
    assert any("yielding to robot B: moving aside" in line for line in floor.logs["A"].lines)
    assert floor.world.robot_collisions == 0 and floor.world.deadlocks == 0     # yield_timeout < deadlock_time


def test_an_unresolvable_meeting_is_reported_as_a_deadlock_and_aborted() -> None:
    # one closed corridor, no room anywhere: neither robot can yield
    grid = floor_map(12.0, 3.0, [(0.5, 1.05, 11.5, 1.95)])
    floor = Floor(grid, {"A": Pose2D(2.0, 1.5, 0.0), "B": Pose2D(10.0, 1.5, math.pi)}, deadlock_time=30.0)
    took = floor.run({0: Pose2D(11.0, 1.5, 0.0), 1: Pose2D(1.0, 1.5, math.pi)}, timeout=300.0)
    for _ in range(5):
        floor.tick()
    assert {i: r.outcome for i, r in floor.results.items()} == {0: ABORTED, 1: ABORTED}
    assert "Blocked by robot B" in floor.results[0].text and "deadlock" in floor.results[0].text
    assert "Blocked by robot A" in floor.results[1].text
    assert took < 60.0 + 20.0                            # robot_patience after they met
    assert floor.world.deadlocks == 1
    [event] = [e for e in floor.events if e.kind == "deadlock"]
    assert event.robots == ("A", "B") and "robots A and B block each other" in event.text
    assert [e.kind for e in floor.events if e.kind != "collision"] == ["deadlock", "deadlock_resolved"]


@pytest.mark.parametrize("blocked", [False, True])
def test_a_door_closed_far_from_any_robot_still_aborts_after_the_planner_patience(blocked: bool) -> None:
    floor = Floor(two_rooms(1.4), {"A": Pose2D(1.5, 2.5, 0.0), "B": Pose2D(13.5, 4.0, math.pi)})
    if blocked:
        floor.world.add_obstacle("door", Rectangle(10.4, 2.5, 0.1, 1.4))
        floor.nav[0].set_obstacles(dict(floor.world.obstacles))
    took = floor.run({0: Pose2D(13.0, 1.5, 0.0)}, timeout=120.0)
    assert floor.results[0].outcome == (ABORTED if blocked else SUCCEEDED)
    assert took < (10.0 if blocked else 60.0)


def test_a_goal_where_another_robot_stands_is_reached_next_to_it() -> None:
    """B is parked on A's goal (a meeting point, or the screen where A's visitor asked): A stops next to it
    and succeeds there, without touching it; once B has left, the same goal is reached on the spot."""
    hall = floor_map(12.0, 6.0, [(0.5, 0.5, 11.5, 5.5)])
    floor = Floor(hall, {"A": Pose2D(2.0, 3.0, 0.0), "B": Pose2D(9.0, 3.0, 0.0)})
    took = floor.run({0: Pose2D(9.0, 3.0, 0.0)}, timeout=120.0)
    assert floor.results[0].outcome == SUCCEEDED, floor.logs["A"].lines
    a = floor.world.robots[0].pose
    assert 0.6 <= math.hypot(a.x - 9.0, a.y - 3.0) <= 1.2 and took < 40.0
    assert any("robot B stands at the goal; stopping next to it" in line for line in floor.logs["A"].lines)
    assert floor.world.robot_collisions == 0 and floor.world.deadlocks == 0 and floor.min_gap > 0.0
    floor.world.teleport(1, Pose2D(9.0, 5.0, 0.0))           # B leaves
    floor.results.clear()
    floor.run({0: Pose2D(9.0, 3.0, 0.0)}, timeout=60.0)
    a = floor.world.robots[0].pose
    assert floor.results[0].outcome == SUCCEEDED and math.hypot(a.x - 9.0, a.y - 3.0) <= 0.25


def _guide_past_parker(corridor: tuple[float, float, float, float], parker_y: float,
                       move_parker: Callable[[World], None], until: float) -> tuple[StepResult | None, float, ListLog,
                                                                                    World]:
    """Guide (0.35 m) drives from the west room along ``corridor`` (x0, y0, x1, y1; a doorway niche below it at
    x 18..19.5) to the east room, where Parker (0.33 m, idle) stands at (16, ``parker_y``); ``move_parker`` is
    called after every world step (it may teleport Parker). The result, when it came, and the time."""
    grid = floor_map(32.0, 10.0, [(1.0, 2.0, 6.0, 8.0), (26.0, 2.0, 31.0, 8.0), corridor,
                                  (18.0, 2.7, 19.5, corridor[1])])
    limits = Limits(0.7, 1.2, 0.6, 2.0, "differential")
    world = World(grid, dt=0.02, deadlock_time=30.0, rng=np.random.default_rng(1))
    world.add_robot(RobotSpec("Guide", 0.35, limits, LaserSpec(noise=0.0)), Pose2D(3.0, 5.0, 0.0))
    world.add_robot(RobotSpec("Parker", 0.33, limits, LaserSpec(noise=0.0)), Pose2D(16.0, parker_y, 0.0))
    log = ListLog()
    nav = MoveBaseCore.for_robot(grid, 0.35, limits, log=log, name="Guide")
    due = Periodic(10.0)
    nav.set_goal(Pose2D(29.0, 5.0, 0.0), 0.0)
    while world.time < until:
        world.step()
        move_parker(world)
        if not due.due(world.time):
            continue
        nav.set_robots([SensedRobot(r.spec.name, r.pose.x, r.pose.y, r.spec.radius)
                        for r in (world.robots[j] for j in world.seen_robots(0))])
        nav.set_pose(world.robots[0].pose, world.robots[0].vel, world.time)
        result = nav.step(world.time)
        if result.cmd is not None:
            world.set_command(0, result.cmd.vx, result.cmd.vy, result.cmd.wz)
        if result.outcome is not None:
            return result, world.time, log, world
    return None, world.time, log, world


def _pass_a_parked_robot(step_aside_at: float | None) -> tuple[StepResult | None, float, ListLog, World]:
    """A 0.35 m robot drives down a 2.6 m corridor where an idle 0.33 m robot stands in the middle (too close
    to squeeze past: no safe velocity beside it); the idle one steps into a doorway at ``step_aside_at``."""
    stepped = []

    def step_aside(world: World) -> None:
        if step_aside_at is not None and world.time >= step_aside_at and not stepped:
            world.teleport(1, Pose2D(18.75, 3.2, 0.0))
            stepped.append(world.time)

    return _guide_past_parker((6.0, 3.7, 26.0, 6.3), 5.0, step_aside, 200.0)


def test_a_robot_parked_in_a_narrow_corridor_is_waited_for_not_given_up_on_as_stuck() -> None:
    result, took, log, world = _pass_a_parked_robot(None)
    assert result is not None and result.outcome == ABORTED, log.lines[-5:]
    assert result.text == ("Blocked by robot Parker for 60 s: deadlock (robots Guide and Parker cannot pass each "
                           "other: it neither passed nor made way)")
    assert 60.0 + 15.0 < took < 100.0                 # reached it in ~20 s, waited robot_patience, not 15 s
    assert any("robot Parker is in the way, close: waiting for it to pass or make way" in line for line in log.lines)
    assert world.robot_collisions == 0


def test_a_robot_parked_in_a_narrow_corridor_that_makes_way_is_passed() -> None:
    result, took, log, world = _pass_a_parked_robot(40.0)     # it waited ~20 s beside it: longer than 15 s
    assert result is not None and result.outcome == SUCCEEDED, log.lines[-5:]
    assert took < 90.0 and world.robot_collisions == 0


def test_a_blocker_that_keeps_moving_but_never_opens_the_way_is_given_up_on_after_the_wait_budget() -> None:
    """In a 1.6 m corridor a robot stands across the way and every 20 s moves 0.6 m across it and back, never
    leaving room to pass: each move starts the wait anew (robot_patience is never reached), the goal's wait
    budget (180 s blocked in all) ends the livelock, naming the last blocker."""
    moves = [0]

    def shuffle(world: World) -> None:
        if world.time >= 20.0 * (moves[0] + 1):
            moves[0] += 1
            world.teleport(1, Pose2D(16.0, 4.7 + 0.6 * (moves[0] % 2), 0.0))

    result, took, log, world = _guide_past_parker((6.0, 4.2, 26.0, 5.8), 4.7, shuffle, 400.0)
    assert result is not None and result.outcome == ABORTED, log.lines[-5:]
    assert result.text.startswith("Blocked by robots or people for 180 s in all (last by robot Parker)"), result.text
    assert 180.0 < took < 180.0 + 40.0 and world.robot_collisions == 0


def _stand_still_with_a_goal(config: NavConfig, timeout: float) -> tuple[StepResult | None, float, ListLog]:
    """A robot in a hall whose commands the world never carries out (held by a body move_base does not know),
    while a door across the hall's far end opens and closes every 10 s (each change re-plans the goal)."""
    hall = floor_map(12.0, 6.0, [(0.5, 0.5, 11.5, 5.5)])
    log = ListLog()
    nav = MoveBaseCore.for_robot(hall, RADIUS, LIMITS, config, log=log, name="A")
    pose, t = Pose2D(2.0, 3.0, 0.0), 0.0
    nav.set_goal(Pose2D(8.0, 3.0, 0.0), t)
    while t < timeout:
        t = round(t + 0.1, 6)
        if t % 10.0 < 1e-6:
            nav.set_obstacles({} if int(t / 10.0) % 2 else {"door": Rectangle(11.0, 3.0, 0.2, 5.0)})
        nav.set_pose(pose, ZERO, t)
        result = nav.step(t)
        if result.outcome is not None:
            return result, t, log
    return None, t, log


def test_a_robot_that_does_not_move_with_a_goal_recovers_then_aborts_whatever_re_plans_it() -> None:
    """Each re-plan restarts the progress watchdog, so a robot that never moves while the costmap keeps changing
    held its goal for ever, silently; the stall watchdog clears the costmap and re-plans at 60 s (logged with the
    state it was in), and aborts at 120 s."""
    result, took, log = _stand_still_with_a_goal(NavConfig(), 400.0)
    assert result is not None and result.outcome == ABORTED, log.lines[-5:]
    assert result.text.startswith("Robot stalled: the robot has not moved for 60 s at (2.00, 3.00) (following"), \
        result.text
    assert 120.0 <= took < 121.0
    recovered = [line for line in log.lines if ": clearing the costmap" in line]
    assert len(recovered) == 1 and "has not moved for 60 s" in recovered[0]
    result, _, log = _stand_still_with_a_goal(NavConfig(stall_timeout=1e6), 400.0)
    assert result is None, result                 # without it: no abort, no word in the log
    assert not any("aborting" in line for line in log.lines)
