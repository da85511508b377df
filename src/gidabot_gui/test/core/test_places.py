"""Places of the building (core.places): nearest place, a tap on the blueprint, search by room or name."""

from __future__ import annotations

import math

from gidabot_gui.core.places import find_locations, location_near, nearest_place


def test_nearest_place_at_or_near(faculty) -> None:
    here = nearest_place(faculty, 1, 30.0, 12.0)                   # Kbot's home
    assert (here.kind, here.id, here.at) == ("location", "104", True)
    assert nearest_place(faculty, 1, math.nan, 12.0) is None
    assert nearest_place(faculty, 9, 30.0, 12.0) is None           # no such floor


def test_a_tap_picks_the_location_within_reach(faculty) -> None:
    door = faculty.location("223").pose
    assert location_near(faculty, 2, door.x + 1.0, door.y).id == "223"
    assert location_near(faculty, 1, door.x + 1.0, door.y).floor == 1      # only the floor tapped
    assert location_near(faculty, 2, -0.5, 25.0) is None                   # outside the building


def test_search_ignores_accents_and_case_and_knows_every_language(faculty) -> None:
    assert [loc.id for loc in find_locations(faculty, "REPROGRAFIA", "en")] == ["001"]
    assert [loc.id for loc in find_locations(faculty, "secretaría", "en", floor=1)] == ["101"]
    assert [loc.id for loc in find_locations(faculty, " 22", "en", floor=2)][:2] == ["223", "225"]
    assert len(find_locations(faculty, "", "en")) == len(faculty.locations)
    assert find_locations(faculty, "22", "en", floor=0) == [loc for loc in find_locations(faculty, "22", "en")
                                                               if loc.floor == 0]
