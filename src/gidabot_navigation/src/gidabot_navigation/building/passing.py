"""Can a robot pass another one parked at its home or at a meeting point? (ROS-free; warnings of ``gidabot check``.)

A robot waits at its home and at a connector's meeting point; another robot of the same floor must still be able
to drive past it. For each such pose the check finds the narrowest cross-section through it (the shortest chord
through the pose between walls, unknown space or keep-out zones, over every direction), takes the wider of its
two sides, less the parked robot's radius (its disc, centred on the pose), and compares that gap with what each
other robot of the floor needs: its diameter plus :data:`PASSING_MARGIN`. Too little is a *warning*, not an
error: the building works, but two robots may block each other there (park the robot against a wall, or in a
recess).

A home is parked on by its robot; a meeting point by any robot of the floor (each may wait there).
"""

from __future__ import annotations

import math

import numpy as np

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building, Floor, Robot, format_floor
from gidabot_navigation.building.occupancy import FREE
from gidabot_navigation.building.planning import cells_of, keep_out_mask
from gidabot_navigation.errors import Problem

PASSING_MARGIN = 0.4     # m beyond the passing robot's diameter: 0.2 m each side (safety padding, localisation)
DIRECTIONS = 180         # chords every 2 degrees (each direction and its opposite)
REACH = 6.0              # m: a side longer than this is wide enough for any robot


def passing_warnings(building: Building) -> list[Problem]:
    """One warning per home or meeting point where a robot parked there leaves too little room for another robot
    of the floor to pass (the widest of them that does not fit)."""
    warnings: list[Problem] = []
    for floor in building.floors:
        robots = building.robots_on(floor.id)
        if len(robots) < 2:
            continue
        blocked = (floor.map.cells != FREE) | keep_out_mask(floor.map, floor.keep_out_zones.values())
        poses: list[tuple[str, Pose2D, list[Robot]]] = [(f"robot {r.name}", r.home, [r]) for r in robots]
        poses += [(f"connector {c.id} (meeting point on floor {floor.label})", c.meeting[floor.id], robots)
                  for c in building.connectors if floor.id in c.meeting]
        for where, pose, parked in poses:
            problem = _pose_warning(building, floor, blocked, where, pose, parked, robots)
            if problem is not None:
                warnings.append(problem)
    return warnings


def side_gaps(floor: Floor, blocked: np.ndarray, x: float, y: float) -> tuple[float, float, float]:
    """(width of the narrowest cross-section through (x, y), its wider side, the angle of that side (rad)), m."""
    grid = floor.map
    angles = np.arange(DIRECTIONS) * (2.0 * math.pi / DIRECTIONS)
    step = grid.resolution / 4.0
    t = np.arange(1, int(REACH / step) + 1) * step
    xs = x + np.outer(np.cos(angles), t)
    ys = y + np.outer(np.sin(angles), t)
    rows, cols = cells_of(grid, xs, ys)
    inside = (rows >= 0) & (rows < grid.height) & (cols >= 0) & (cols < grid.width)
    hit = ~inside
    hit[inside] = blocked[rows[inside], cols[inside]]
    first = np.where(hit.any(axis=1), hit.argmax(axis=1), len(t))
    reach = np.where(first < len(t), t[np.minimum(first, len(t) - 1)] - step / 2, REACH)
    half = DIRECTIONS // 2
    chords = reach[:half] + reach[half:]
    k = int(np.argmin(chords))
    wide = k if reach[k] >= reach[k + half] else k + half
    return float(chords[k]), float(reach[wide]), float(angles[wide])


def _pose_warning(building: Building, floor: Floor, blocked: np.ndarray, where: str, pose: Pose2D,
                  parked: list[Robot], robots: list[Robot]) -> Problem | None:
    width, side, angle = side_gaps(floor, blocked, pose.x, pose.y)
    worst: tuple[float, Robot, Robot] | None = None
    for robot in parked:
        gap = side - robot.radius
        for other in robots:
            need = 2.0 * other.radius + PASSING_MARGIN
            if other is not robot and gap < need and (worst is None or need - gap > worst[0]):
                worst = (need - gap, robot, other)
    if worst is None:
        return None
    _, robot, other = worst
    gap = side - robot.radius
    mid = robot.radius + gap / 2.0
    gx, gy = pose.x + mid * math.cos(angle), pose.y + mid * math.sin(angle)
    return Problem(str(building.path), where,
                   f"({pose.x:g}, {pose.y:g}) on floor {format_floor(floor.id)}: {robot.name} (radius "
                   f"{robot.radius:g} m) parked there leaves {max(gap, 0.0):.2f} m beside it (the way is "
                   f"{width:.2f} m wide there); {other.name} needs {2 * other.radius + PASSING_MARGIN:.2f} m to pass "
                   f"(its diameter + {PASSING_MARGIN:g} m): park it against a wall or in a recess",
                   floor.id, ((pose.x, pose.y, "place"), (gx, gy, "narrow")))
