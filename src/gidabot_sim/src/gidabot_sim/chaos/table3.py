"""Table 3 of a tour without faults (ROS-free): goal messages received and processed per robot.

A chaos run compares what its probes and bags counted with what the tour makes without faults: every goal
reaches every robot; a floor's robots process the goals with a leg on their floor. Robots sharing a floor are
one row (:func:`table3_rows`): which of them serves a leg is decided trip by trip.
"""

from __future__ import annotations

import math

from gidabot_navigation.building.model import Building
from gidabot_navigation.tours.tour_file import Tour


def tour_trips(tour: Tour, start_floor: float, building: Building) -> list[tuple[float, float]]:
    """(start floor, goal floor) of every goal of a tour run from ``start_floor``: a stop on a floor without
    robot that follows another such stop gets no goal (the visitor finds it alone, docs/guiding.md)."""
    return list(tour_step_trips(tour, start_floor, building).values())


def tour_step_trips(tour: Tour, start_floor: float, building: Building) -> dict[int, tuple[float, float]]:
    """:func:`tour_trips` by tour step (the steps that make a goal)."""
    trips, here = {}, start_floor
    for k, g in enumerate(tour.goals):
        if not (building.has_robot(here) or building.has_robot(g.floor)):
            here = g.floor
            continue
        trips[k] = (here, g.floor)
        here = g.floor
    return trips


def trips_with_retries(step_trips: dict[int, tuple[float, float]],
                       retried: dict[int, tuple[float, float]]) -> list[tuple[float, float]]:
    """The tour's trips, a step the system ended and the visitor asked for again counted as the trip that
    completed it: the person asks again where they are (e.g. upstairs, where the start robot had sent them
    before the goal floor's robot gave up), so that trip may start on another floor than the tour's."""
    return [retried.get(k, trip) for k, trip in step_trips.items()]


def table3_rows(building: Building) -> dict[str, list[str]]:
    """The rows of Table 3: a robot, or the robots of a floor together ("Kbot+Basajaun"): which of them serves
    a leg is decided trip by trip (docs/guiding.md, who serves a leg), only their sum is known in advance."""
    rows: dict[str, list[str]] = {}
    for f in building.floors:
        robots = [r.name for r in building.robots_on(f.id)]
        if robots:
            rows["+".join(robots)] = robots
    return rows


def fold_table3(building: Building, table: dict[str, tuple[int, int]]) -> dict[str, tuple[int, int]]:
    """A per-robot Table 3 in :func:`table3_rows`: received by each robot of the row, processed by all."""
    return {row: (min(table.get(r, (0, 0))[0] for r in robots), sum(table.get(r, (0, 0))[1] for r in robots))
            for row, robots in table3_rows(building).items()}


def expected_table3(building: Building, trips: list[tuple[float, float]]) -> dict[str, tuple[int, int]]:
    """Table 3 row -> (received, processed) without faults: every goal reaches every robot; a floor's robots
    process the goals with a leg on their floor: the start leg when the trip starts there, the goal leg
    when it ends there coming from another floor."""
    out = {}
    for row, robots in table3_rows(building).items():
        floor = building.robot(robots[0]).floor
        processed = sum(1 for a, b in trips if math.isclose(a, floor) or math.isclose(b, floor))
        out[row] = (len(trips), processed)
    return out
