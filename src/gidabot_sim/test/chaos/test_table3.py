"""Table 3 of a tour without faults, and the rows of robots sharing a floor."""

from __future__ import annotations

from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_navigation.tours.tour_file import parse_tour
from gidabot_sim.chaos.table3 import expected_table3, fold_table3, tour_trips

REPO = Path(__file__).resolve().parents[4]


@pytest.fixture(scope="module")
def faculty():
    return load_building(REPO / "maps" / "faculty")


def test_expected_table3_of_the_long_tour_is_the_papers(faculty) -> None:
    tour = parse_tour((REPO / "tours" / "long_tour.tour").read_bytes(), "long_tour.tour", faculty)
    table = expected_table3(faculty, tour_trips(tour, 0.0, faculty))
    assert table == {"Tartalo": (15, 7), "Kbot": (15, 8), "Galtxagorri": (15, 8), "MariSorgin": (15, 6)}


def test_expected_table3_with_two_robots_on_a_floor_and_a_floor_without() -> None:
    """Table 4 on faculty3: 223 and 274 (floor 2, no robot) make one goal; on faculty6 the robots of a floor
    share one row."""
    three, six = (load_building(REPO / "maps" / name) for name in ("faculty3", "faculty6"))
    tour = parse_tour((REPO / "tours" / "real_world.tour").read_bytes(), "real_world.tour", three)
    assert tour_trips(tour, 0.0, three) == [(0, 0), (0, 0), (0, 1), (1, 1), (1, 2), (2, 3), (3, 3)]
    assert expected_table3(three, tour_trips(tour, 0.0, three)) == {
        "Tartalo": (7, 3), "Kbot": (7, 3), "MariSorgin": (7, 2)}
    six_table = expected_table3(six, tour_trips(tour, 0.0, six))
    assert six_table == {"Tartalo": (8, 3), "Kbot+Basajaun": (8, 3), "Galtxagorri+Lamia": (8, 3), "MariSorgin": (8, 2)}
    measured = {"Tartalo": (8, 3), "Kbot": (8, 3), "Basajaun": (8, 0), "Galtxagorri": (8, 1), "Lamia": (8, 2),
                "MariSorgin": (8, 2)}
    assert fold_table3(six, measured) == six_table
