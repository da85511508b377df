"""Tour files: the paper's tours parse; round trip is exact; malformed files and names are named."""

from __future__ import annotations

from pathlib import Path

import pytest

from gidabot_navigation.errors import TourError, TourNameError
from gidabot_navigation.tours.tour_file import (
    MAX_TOUR_BYTES,
    Tour,
    TourGoal,
    check_tour_file_name,
    format_tour,
    parse_tour,
    tour_from_lines,
)

TOURS = Path(__file__).resolve().parents[4] / "tours"

TABLE2 = [(0, "Student Council"), (3, "IXA Lab"), (2, "C. Rodriguez's Office"), (1, "Dean's Office"),
          (2, "J. Abascal's Office"), (3, "B. Sierra's Office"), (0, "Computer Technicians 1"),
          (1, "Ada Lovelace Auditorium"), (2, "Seminar Room 2.3"), (0, "Wi-Fi Room"), (1, "Laboratory 1.3"),
          (3, "RSAIT Lab"), (2, "O. Arbelaitz's Office"), (1, "Secretary's Office"), (0, "Copy Shop")]
TABLE4 = [(0, "Technicians' Lab"), (0, "Caretakers' Office"), (1, "Secretary's Office"),
          (1, "Ada Lovelace Auditorium"), (2, "M. Larrea's Office"), (2, "K. Sarasola's Office"),
          (3, "I. Irigoien's Office"), (3, "RSAIT Lab")]


@pytest.mark.parametrize("name, table", [("long_tour.tour", TABLE2), ("real_world.tour", TABLE4)])
def test_paper_tables(faculty, name: str, table: list) -> None:
    tour = parse_tour((TOURS / name).read_bytes(), name, faculty)
    assert [(g.floor, g.description) for g in tour.goals] == table


def test_section_5_2_example_verbatim(faculty) -> None:
    text = (TOURS / "paper_example.tour").read_text()
    assert text.splitlines()[:3] == ["Tour", "0, 014, Computer Technicians 1", "0, 008, Caretaker's Office"]
    tour = parse_tour(text, "paper_example.tour", faculty)
    assert [g.room for g in tour.goals] == ["014", "008", "101", "104", "223", "274", "325", "305"]
    assert tour.display_name == "Paper example"


@pytest.mark.parametrize("path", sorted(TOURS.glob("*.tour")), ids=lambda p: p.name)
def test_round_trip_exact(faculty, path: Path) -> None:
    data = path.read_bytes()
    tour = parse_tour(data, path.name, faculty)
    assert format_tour(tour).encode("utf-8") == data
    assert parse_tour(format_tour(tour), path.name, faculty) == tour


def test_descriptions_may_hold_commas_and_accents(faculty) -> None:
    tour = parse_tour("Tour: Bisita\n1, 101, Idazkaritza, Secretaría\n0.0, 014, Técnicos\n", "x.tour", faculty)
    assert tour.goals[0] == TourGoal(1.0, "101", "Idazkaritza, Secretaría")
    assert tour.name == "Bisita"
    assert format_tour(tour) == "Tour: Bisita\n1, 101, Idazkaritza, Secretaría\n0, 014, Técnicos\n"


def test_sloppy_spacing_is_normalised(faculty) -> None:
    tour = parse_tour("Tour\n0,014,Lab  \n", "x.tour", faculty)
    assert format_tour(tour) == "Tour\n0, 014, Lab\n"


def test_from_message_fields(faculty) -> None:
    tour = tour_from_lines("visit.tour", "My visit", ["0, 014, Lab", "3, 305, RSAIT"], faculty)
    assert format_tour(tour) == "Tour: My visit\n0, 014, Lab\n3, 305, RSAIT\n"
    assert tour.floor == 0 and tour.goal_lines()[1] == "3, 305, RSAIT"
    with pytest.raises(TourNameError):
        tour_from_lines("../evil.tour", "x", ["0, 014, Lab"], faculty)


GOOD = "Tour\n0, 014, Computer Technicians 1\n"
MALFORMED: list[tuple[str, bytes, str]] = [
    ("wrong column count", b"Tour\n0, 014\n", "line 2: 2 column(s) in '0, 014'; expected 3"),
    ("one column", b"Tour\n0\n", "line 2: 1 column(s)"),
    ("unknown floor", b"Tour\n7, 014, Lab\n", "line 2: unknown floor 7"),
    ("floor not a number", b"Tour\nground, 014, Lab\n", "line 2: floor 'ground' is not a number"),
    ("NaN floor", b"Tour\nnan, 014, Lab\n", "line 2: floor 'nan' is not a number"),
    ("unknown room", b"Tour\n0, 999, Nowhere\n", "line 2: unknown room '999' for building faculty"),
    ("room on another floor", b"Tour\n1, 014, Lab\n", "line 2: room 014 is on floor 0, not 1"),
    ("empty tour", b"Tour\n", "empty tour: no goals after the header"),
    ("empty file", b"", "is empty; expected a 'Tour' header"),
    ("duplicate header", b"Tour\n0, 014, Lab\nTour\n", "line 3: duplicate 'Tour' header"),
    ("bad encoding", b"Tour\n0, 014, T\xe9cnicos\n", "line 2: bad encoding at byte 14: tour files must be UTF-8"),
    ("missing header", b"0, 014, Lab\n", "line 1: expected the header 'Tour'"),
    ("blank line", b"Tour\n\n0, 014, Lab\n", "line 2: blank line between goals"),
    ("blank line between goals, CRLF", b"Tour\r\n0, 014, Lab\r\n\r\n0, 008, Office\r\n", "line 3: blank line"),
    ("blank line in a CR file", b"Tour\r0, 014, Lab\r \r0, 008, Office\r", "line 3: blank line"),
    ("control character", b"Tour\n0, 014, L\x1bab\n", "line 2: holds the control character U+001B"),
    ("control character in the name", b"Tour: A\x07B\n0, 014, Lab\n", "line 1: tour name holds the control"),
    ("header without colon", b"Tour Open day\n0, 014, Lab\n", "line 1: expected the header 'Tour'"),
    ("BOM and a bad line", b"\xef\xbb\xbfTour\r\n0, 014\r\n", "line 2: 2 column(s) in '0, 014'"),
    ("only blank lines", b"\xef\xbb\xbf\r\n \r\n", "is empty; expected a 'Tour' header"),
    ("bad encoding after CRLF lines", b"Tour\r\n0, 014, Lab\r\n0, 008, Caf\xe9\r\n", "line 3: bad encoding"),
    ("empty description", b"Tour\n0, 014, \n", "line 2: room description is empty"),
    ("NUL byte", b"Tour\n0, 014, L\x00ab\n", "contains a NUL byte"),
    ("too big", b"Tour\n" + b"0, 014, Lab\n" * (MAX_TOUR_BYTES // 10), f"more than the {MAX_TOUR_BYTES} a tour"),
    ("hostile room", b"Tour\n0, ../../etc, Lab\n", "room number '../../etc' must be letters/digits"),
]


@pytest.mark.parametrize("label, data, expected", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_tours(faculty, label: str, data: bytes, expected: str) -> None:
    with pytest.raises(TourError) as info:
        parse_tour(data, "bad.tour", faculty, source="tours/bad.tour")
    text = str(info.value)
    assert "tours/bad.tour" in text and expected in text, text


CANONICAL = "Tour: Open day at the faculty\n0, 014, Computer Technicians 1\n1, 101, Secretary's Office\n"
TOLERATED: list[tuple[str, bytes]] = [
    ("CRLF (Windows editors)", CANONICAL.replace("\n", "\r\n").encode()),
    ("CR (old Mac editors)", CANONICAL.replace("\n", "\r").encode()),
    ("UTF-8 BOM (Notepad)", b"\xef\xbb\xbf" + CANONICAL.encode()),
    ("BOM and CRLF", b"\xef\xbb\xbf" + CANONICAL.replace("\n", "\r\n").encode()),
    ("no newline at the end", CANONICAL.rstrip("\n").encode()),
    ("trailing blank lines", (CANONICAL + "\n\n  \n\t\n").encode()),
    ("trailing blank lines, CRLF", (CANONICAL + "\n\n").replace("\n", "\r\n").encode()),
    ("spaces around fields", b"  Tour :  Open day at the faculty  \n 0 ,014 ,  Computer Technicians 1 \n"
                             b"\t1,\t101,\tSecretary's Office\t\n"),
    ("header without space", b"Tour:Open day at the faculty\n0,014,Computer Technicians 1\n1,101,Secretary's Office"),
    ("floors written 0.0 and 1.00", CANONICAL.replace("\n0,", "\n0.0,").replace("\n1,", "\n1.00,").encode()),
    ("mixed line endings", CANONICAL.replace("\n", "\r\n", 1).replace("Office\n", "Office\r").encode()),
]


@pytest.mark.parametrize("label, data", TOLERATED, ids=[t[0] for t in TOLERATED])
def test_what_editors_and_phones_write_is_accepted_and_canonicalised(faculty, label: str, data: bytes) -> None:
    tour = parse_tour(data, "open_day.tour", faculty)
    assert tour == parse_tour(CANONICAL, "open_day.tour", faculty)
    assert format_tour(tour) == CANONICAL


def test_unicode_normalisation_is_canonicalised(faculty) -> None:
    decomposed = "Tour\n0, 014, Te\u0301cnicos\n"           # e + combining acute (macOS, some phones)
    assert format_tour(parse_tour(decomposed, "x.tour", faculty)) == "Tour\n0, 014, T\u00e9cnicos\n"


def test_a_name_equal_to_the_derived_one_has_one_canonical_form(faculty) -> None:
    """"Tour: Open day" in open_day.tour and "Tour" show the same name: both are written "Tour", so
    a robot that read the file and one that received the tour's fields hold the same bytes."""
    from_file = parse_tour("Tour: Open day\n0, 014, Lab\n", "open_day.tour", faculty)
    from_fields = tour_from_lines("open_day.tour", from_file.display_name, from_file.goal_lines(), faculty)
    assert from_file == from_fields and format_tour(from_file) == "Tour\n0, 014, Lab\n"
    assert from_file.display_name == "Open day"


def test_canonical_form_is_a_fixed_point(faculty) -> None:
    for _, data in TOLERATED:
        once = format_tour(parse_tour(data, "open_day.tour", faculty))
        assert format_tour(parse_tour(once, "open_day.tour", faculty)) == once


@pytest.mark.parametrize("name, lines, where", [
    ("x", ["0, 014, Lab\n0, 008, Injected"], "goal 1"),
    ("x", ["0, 014, Lab", "0, 008, Lab\r0, 008, Injected"], "goal 2"),
    ("x\n0, 008, Injected", ["0, 014, Lab"], "tour name"),
])
def test_fields_with_line_breaks_are_not_a_variant(faculty, name: str, lines: list[str], where: str) -> None:
    """CR is a line ending in a file, but a message field holding one would add lines to the tour."""
    with pytest.raises(TourError, match=f"{where}: holds a line break"):
        tour_from_lines("visit.tour", name, lines, faculty)


def test_every_problem_is_listed(faculty) -> None:
    with pytest.raises(TourError) as info:
        parse_tour("Tour\n7, 014, A\n0, 999, B\n0, 014\n", "bad.tour", faculty)
    assert [p.where for p in info.value.problems] == ["line 2", "line 3", "line 4"]


def test_without_building_rooms_are_not_checked() -> None:
    assert parse_tour("Tour\n9, 999, Somewhere\n", "x.tour").goals[0].room == "999"


@pytest.mark.parametrize("name", ["open_day.tour", "Tour-2.v2.tour", "a.tour", "x" * 59 + ".tour"])
def test_good_file_names(name: str) -> None:
    assert check_tour_file_name(name) == name


@pytest.mark.parametrize("name, expected", [
    ("../escape.tour", "path separator"),
    ("/etc/passwd", "path separator"),
    ("..", "hidden or a directory reference"),
    (".hidden.tour", "hidden"),
    ("a\x00b.tour", "NUL or control"),
    ("x" * 61 + ".tour", "longer than 64 bytes"),
    ("notes.txt", "must end with '.tour'"),
    (".tour", "hidden"),
    ("con.tour", "reserved device name"),
    ("sp ace.tour", "may only hold ASCII letters"),
    ("a..b.tour", "may only hold ASCII letters"),
    ("ñandú.tour", "may only hold ASCII letters"),
    ("dir\\x.tour", "path separator"),
    ("", "is empty"),
    (None, "must be a string"),
])
def test_hostile_file_names(name: object, expected: str) -> None:
    with pytest.raises(TourNameError, match=expected):
        check_tour_file_name(name)


def test_display_name() -> None:
    assert Tour("open_day.tour", "", ()).display_name == "Open day"
    assert Tour("x.tour", "Named", ()).display_name == "Named"
