"""Places of the building (ROS-free): the nearest one to a position, their names, search by room or name."""

from __future__ import annotations

import math
import unicodedata
from dataclasses import dataclass

from gidabot_navigation.building.model import Building, Location

NEAR = 2.5   # m: closer than this the robot is "at" the place, else "near" it
TAP_RADIUS = 4.5   # m: a tap on the blueprint picks the nearest location this close (stop poses are at the doors)


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


def location_near(building: Building, floor: float, x: float, y: float, within: float = TAP_RADIUS) -> Location | None:
    """The location of ``floor`` nearest to (x, y), if closer than ``within`` m."""
    best, best_d = None, within
    for loc in building.locations:
        if loc.floor == floor:
            d = ((loc.pose.x - x) ** 2 + (loc.pose.y - y) ** 2) ** 0.5
            if d < best_d:
                best, best_d = loc, d
    return best


def fold(text: str) -> str:
    """Lower case without accents, for searching ("Reprografía" ~ "reprografia")."""
    decomposed = unicodedata.normalize("NFKD", text)
    return "".join(ch for ch in decomposed if not unicodedata.combining(ch)).casefold()


def find_locations(building: Building, query: str, language: str, floor: float | None = None) -> list[Location]:
    """The locations (of ``floor``, or of every floor) whose room number or name in any language holds
    ``query`` (accents and case ignored), by floor and room."""
    q = fold(query.strip())
    out = []
    for loc in building.locations:
        if floor is not None and loc.floor != floor:
            continue
        if q and q not in fold(loc.id) and q not in fold(loc.name(language)) and \
                not any(q in fold(n) for n in loc.names.values()):
            continue
        out.append(loc)
    return sorted(out, key=lambda loc: (loc.floor, loc.id))
