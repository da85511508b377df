"""A person in a robot's way (ROS-free): where to stand so that the robot is delayed, never stopped.

:func:`choose_obstacle` places a disc on the robot's planned path, a few metres ahead of it, where the planner
still finds a way around it for a robot wider than this one: the goal stays reachable (an unreachable goal is a
different outcome, which the visitor is told).
"""

from __future__ import annotations

import math

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import PlanningError


def choose_obstacle(building: Building, floor: float, pose: tuple[float, float], plan: list[tuple[float, float]],
                    robot_radius: float, ahead: tuple[float, float] = (3.0, 9.0), radius: float = 0.3,
                    margin: float = 0.2) -> tuple[float, float, float] | None:
    """(x, y, radius) of a disc on the robot's planned path, ``ahead`` m in front of it, such that a
    path around it still exists for a robot ``margin`` m wider than this one (it delays the robot; it
    never makes the goal impossible). None when no such place exists on this plan."""
    from gidabot_navigation.building.planning import Circle, GridPlanner

    if len(plan) < 2:
        return None
    dense = [plan[0]]
    for (x0, y0), (x1, y1) in zip(plan, plan[1:], strict=False):   # a point every 0.25 m at most
        n = max(1, math.ceil(math.hypot(x1 - x0, y1 - y0) / 0.25))
        dense += [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n) for k in range(1, n + 1)]
    plan = dense
    grid = building.floor(floor).map
    planner = GridPlanner(grid, robot_radius + 0.05 + margin, inflation_radius=robot_radius + 0.7)
    goal = plan[-1]
    # distance along the plan from its point nearest to the robot
    near = min(range(len(plan)), key=lambda i: math.hypot(plan[i][0] - pose[0], plan[i][1] - pose[1]))
    along, candidates = 0.0, []
    for i in range(near + 1, len(plan)):
        along += math.hypot(plan[i][0] - plan[i - 1][0], plan[i][1] - plan[i - 1][1])
        if ahead[0] <= along <= ahead[1]:
            candidates.append(i)
        if along > ahead[1]:
            break
    if math.hypot(goal[0] - pose[0], goal[1] - pose[1]) < ahead[0] + 2.0:
        return None
    for i in candidates[len(candidates) // 2:] + candidates[:len(candidates) // 2]:
        x, y = plan[i]
        nxt = plan[min(i + 1, len(plan) - 1)]
        dx, dy = nxt[0] - plan[i - 1][0], nxt[1] - plan[i - 1][1]
        norm = math.hypot(dx, dy) or 1.0
        nx, ny = -dy / norm, dx / norm
        for offset in (0.0, 0.25, -0.25):
            cx, cy = x + nx * offset, y + ny * offset
            if math.hypot(cx - goal[0], cy - goal[1]) < radius + robot_radius + 1.5:
                continue
            if math.hypot(cx - pose[0], cy - pose[1]) < radius + robot_radius + 1.0:
                continue
            planner.clear_obstacles()
            try:
                planner.add_obstacle("chaos", Circle(cx, cy, radius))
                path = planner.plan(pose, goal)
            except PlanningError:
                continue
            if math.isfinite(path.length):
                return (round(cx, 2), round(cy, 2), radius)
    return None
