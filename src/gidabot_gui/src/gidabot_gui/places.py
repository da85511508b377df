"""Names of places on a floor (ROS-free): the nearest location or connector to a position."""

from __future__ import annotations

import math
from dataclasses import dataclass

from gidabot_navigation.building.model import Building

NEAR = 2.5   # m: closer than this the robot is "at" the place, else "near" it


@dataclass(frozen=True)
class Place:
    kind: str        # "location" or "connector"
    id: str
    distance: float  # m

    @property
    def at(self) -> bool:
        return self.distance <= NEAR


def nearest_place(building: Building, floor: float, x: float, y: float) -> Place | None:
    """The location or connector meeting point of ``floor`` nearest to (x, y), or None."""
    f = building.find_floor(floor)
    if f is None or not (math.isfinite(x) and math.isfinite(y)):
        return None
    best: Place | None = None
    for loc in building.locations:
        if loc.floor == f.id:
            d = math.hypot(loc.pose.x - x, loc.pose.y - y)
            if best is None or d < best.distance:
                best = Place("location", loc.id, d)
    for con in building.connectors:
        pose = con.meeting.get(f.id)
        if pose is not None:
            d = math.hypot(pose.x - x, pose.y - y)
            if best is None or d < best.distance:
                best = Place("connector", con.id, d)
    return best


def place_name(building: Building, place_id: str, language: str) -> str:
    """Display name of a location or connector id in ``language`` ("" if unknown)."""
    loc = building.find_location(place_id)
    if loc is not None:
        return loc.name(language)
    con = building.find_connector(place_id)
    if con is not None:
        return con.name(language)
    return ""


def floor_name(building: Building, floor: float, language: str) -> str:
    """Display name of a floor ("" if unknown)."""
    f = building.find_floor(floor)
    if f is None:
        return ""
    return f.names.get(language) or f.names["en"]
