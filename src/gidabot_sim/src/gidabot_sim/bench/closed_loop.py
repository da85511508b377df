"""One simulated floor in one process, without ROS (for tests and the benchmark).

Wires the same cores the three nodes run: :class:`~gidabot_sim.world.world.World` (the
simulator), :class:`~gidabot_sim.navstack.amcl.AmclCore` (amcl) and
:class:`~gidabot_sim.navstack.move_base.MoveBaseCore` with a
:class:`~gidabot_sim.navstack.amcl.PoseTracker` (move_base), exchanging what the
topics carry at the rates the nodes use: physics every ``dt``, odometry and
ground truth at ``odom_rate``, the laser at ``laser_rate``, control at the
controller frequency.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building
from gidabot_navigation.building.planning import Shape
from gidabot_navigation.logs import Logger
from gidabot_sim.navstack.amcl import AmclConfig, AmclCore, PoseTracker
from gidabot_sim.navstack.move_base import MoveBaseCore, NavConfig, State, StepResult
from gidabot_sim.world.clock import Periodic
from gidabot_sim.world.kinematics import Limits
from gidabot_sim.world.world import LaserSpec, RobotSpec, World


@dataclass
class LegResult:
    outcome: str | None       # "succeeded", "aborted", None (timed out / still running)
    text: str
    duration: float           # sim seconds
    min_clearance: float      # m, smallest distance of the robot's centre to a wall/obstacle on the way
    stalls: int               # moves the simulator refused (collisions) during the goal


class FloorLoop:
    """The robot of ``floor`` in its world, driven by the move_base core (sim time starts at 0)."""

    def __init__(self, building: Building, floor: float, seed: int = 0, laser_rate: float = 10.0,
                 odom_rate: float = 20.0, laser: LaserSpec | None = None, nav: NavConfig | None = None,
                 amcl: AmclConfig | None = None, start: Pose2D | None = None, log: Logger | None = None) -> None:
        self.floor = building.floor(floor)
        robot = next(iter(building.robots_on(self.floor.id)), None)
        if robot is None:
            raise ValueError(f"floor {self.floor.label} has no robot")
        self.robot = robot
        rng = np.random.default_rng(seed)
        self.world = World.of_floor(self.floor, rng=rng)
        self.world.add_robot(RobotSpec(robot.name, robot.radius, Limits.of_robot(robot), laser or LaserSpec()),
                             start or robot.home)
        self.amcl = AmclCore(amcl or AmclConfig(), rng)
        self.tracker = PoseTracker()
        self.nav = MoveBaseCore.for_floor(self.floor, robot.radius, Limits.of_robot(robot), nav, log)
        self.odom_due = Periodic(odom_rate)
        self.laser_due = Periodic(laser_rate) if laser_rate > 0 else None
        self.control_due = Periodic(self.nav.config.controller_frequency)
        self.scans = 0
        self.last: StepResult = StepResult(None)

    @property
    def state(self) -> State:
        return self.nav.state

    @property
    def pose(self) -> Pose2D:
        return self.world.robots[0].pose

    def add_obstacle(self, obstacle_id: str, shape: Shape) -> None:
        """Add an obstacle to the world; the move_base core learns it (as from ``/sim/obstacles``)."""
        self.world.add_obstacle(obstacle_id, shape)
        self.nav.set_obstacles(dict(self.world.obstacles))

    def remove_obstacle(self, obstacle_id: str) -> None:
        self.world.remove_obstacle(obstacle_id)
        self.nav.set_obstacles(dict(self.world.obstacles))

    def tick(self) -> StepResult | None:
        """One physics step and whatever is due after it; the control result when control ran."""
        w = self.world
        w.step()
        t = w.time
        robot = w.robots[0]
        if self.odom_due.due(t):
            self.amcl.on_odom(t, robot.odom)
            self.tracker.on_odom(t, robot.odom, robot.vel)
            estimate = self.amcl.on_truth(t, robot.pose)
            if estimate is not None:
                self.tracker.on_estimate(estimate.stamp, estimate.pose)
        if self.laser_due is not None and self.laser_due.due(t):
            w.scan(0)
            self.scans += 1
        if not self.control_due.due(t):
            return None
        pose = self.tracker.pose()
        if pose is not None and self.tracker.stamp is not None:
            self.nav.set_pose(pose, self.tracker.velocity, self.tracker.stamp)
        result = self.nav.step(t)
        if result.cmd is not None:
            w.set_command(0, result.cmd.vx, result.cmd.vy, result.cmd.wz)
        self.last = result
        return result

    def run(self, duration: float) -> None:
        """Simulate ``duration`` sim seconds."""
        end = self.world.time + duration
        while self.world.time < end - 1e-9:
            self.tick()

    def drive(self, goal: Pose2D, timeout: float = 600.0) -> LegResult:
        """Send ``goal`` and simulate until it ends or ``timeout`` sim seconds pass."""
        w = self.world
        start, stalls = w.time, w.robots[0].stalls
        self.nav.set_goal(goal, w.time)
        min_clear = math.inf
        while w.time - start < timeout:
            result = self.tick()
            p = w.robots[0].pose
            min_clear = min(min_clear, w.clearance(p.x, p.y))
            if result is not None and result.outcome is not None:
                return LegResult(result.outcome, result.text, w.time - start, min_clear, w.robots[0].stalls - stalls)
        return LegResult(None, "timed out", w.time - start, min_clear, w.robots[0].stalls - stalls)
