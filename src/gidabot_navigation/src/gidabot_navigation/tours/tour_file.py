"""Tour files in the paper's format (section 5.2), ROS-free.

A tour file is UTF-8 text::

    Tour
    0, 014, Computer Technicians 1
    1, 101, Secretary's Office

The first line is the header ``Tour`` (optionally ``Tour: <display name>``);
every other line is ``floor, room number, room description`` (the description
may itself contain commas). What text editors and phones produce is accepted:
``\n``, ``\r\n`` or ``\r`` line endings, a UTF-8 byte-order mark, no newline
after the last line, trailing blank lines, spaces or tabs around the header's
parts and around columns, floors written ``0.0``, text in any Unicode
normalisation. Blank lines between goals, a second header, control characters
and everything else malformed are errors naming the line. :func:`format_tour`
writes the one canonical form (``", "`` between columns, ``0`` for floor 0.0,
``\n`` endings, NFC, no name when it equals the one derived from the file
name), so every variant of a tour gives the same canonical bytes and canonical
files round-trip byte for byte.

File names are checked by :func:`check_tour_file_name`: they come from other
robots and must never escape the tours directory.
"""

from __future__ import annotations

import math
import re
import unicodedata
from dataclasses import dataclass

from gidabot_navigation.building.model import Building, format_floor
from gidabot_navigation.errors import Problem, TourError, TourNameError

HEADER = "Tour"
TOUR_SUFFIX = ".tour"
MAX_TOUR_BYTES = 64 * 1024       # a tour is a few hundred bytes; anything bigger is hostile
MAX_GOALS = 100
MAX_DESCRIPTION = 200            # characters
MAX_NAME = 80                    # characters of the display name
MAX_FILE_NAME = 64               # bytes
_FILE_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]*(\.[A-Za-z0-9_-]+)*\Z")
_ROOM_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,31}\Z")
_HEADER_RE = re.compile(rf"^{HEADER}(?:\s*:(.*))?$")
_RESERVED = {"con", "prn", "aux", "nul", "com1", "com2", "com3", "com4", "lpt1", "lpt2", "lpt3"}


@dataclass(frozen=True)
class TourGoal:
    floor: float
    room: str
    description: str

    def line(self) -> str:
        """The goal as one line of a tour file (and of Tour.tour_goals_info)."""
        return f"{format_floor(self.floor)}, {self.room}, {self.description}"


@dataclass(frozen=True)
class Tour:
    file_name: str
    name: str                     # display name ("" = derived from the file name)
    goals: tuple[TourGoal, ...]

    @property
    def display_name(self) -> str:
        if self.name:
            return self.name
        stem = self.file_name[: -len(TOUR_SUFFIX)] if self.file_name.endswith(TOUR_SUFFIX) else self.file_name
        return stem.replace("_", " ").replace("-", " ").strip().capitalize()

    @property
    def floor(self) -> float:
        """Floor of the first goal (Tour.msg ``floor``)."""
        return self.goals[0].floor if self.goals else 0.0

    def goal_lines(self) -> list[str]:
        return [g.line() for g in self.goals]


def check_tour_file_name(name: object) -> str:
    """Return ``name`` if it is a safe tour file name, else raise :class:`TourNameError`.

    Safe: a plain name ending in ``.tour``, ASCII letters/digits/``_``/``-``/dots
    between parts, at most 64 bytes, not hidden, no path separators or ``..``,
    no NUL or control characters, not a device name.
    """
    if not isinstance(name, str):
        raise TourNameError(f"tour file name {name!r} must be a string")
    shown = repr(name) if len(name) <= 80 else repr(name[:77]) + "..."
    if not name:
        raise TourNameError("tour file name is empty; expected e.g. 'open_day.tour'")
    if "\x00" in name or any(unicodedata.category(ch) == "Cc" for ch in name):
        raise TourNameError(f"tour file name {shown} contains NUL or control characters")
    if "/" in name or "\\" in name:
        raise TourNameError(f"tour file name {shown} contains a path separator; expected a plain file name")
    if name in (".", "..") or name.startswith("."):
        raise TourNameError(f"tour file name {shown} is hidden or a directory reference")
    if len(name.encode("utf-8")) > MAX_FILE_NAME:
        raise TourNameError(f"tour file name {shown} is longer than {MAX_FILE_NAME} bytes")
    if not name.endswith(TOUR_SUFFIX) or name == TOUR_SUFFIX:
        raise TourNameError(f"tour file name {shown} must end with '{TOUR_SUFFIX}'")
    if not _FILE_NAME_RE.match(name):
        raise TourNameError(f"tour file name {shown} may only hold ASCII letters, digits, '_', '-' and "
                            "single dots, and must start with a letter or digit")
    if name.split(".")[0].lower() in _RESERVED:
        raise TourNameError(f"tour file name {shown} is a reserved device name")
    return name


def _parse_floor(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _control(text: str) -> str | None:
    """The first control character of ``text`` other than a tab, as U+XXXX, or None."""
    for ch in text:
        if ch != "\t" and unicodedata.category(ch) == "Cc":
            return f"U+{ord(ch):04X}"
    return None


def _decode(data: bytes | str, where_file: str) -> str:
    """The text of a tour file: size and encoding checked, BOM removed, line endings made ``\n``."""
    if isinstance(data, bytes):
        if len(data) > MAX_TOUR_BYTES:
            raise TourError([Problem(where_file, "file", f"{len(data)} bytes is more than the "
                                                        f"{MAX_TOUR_BYTES} a tour may have")])
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as err:
            line = data[: err.start].replace(b"\r\n", b"\n").replace(b"\r", b"\n").count(b"\n") + 1
            raise TourError([Problem(where_file, f"line {line}", f"bad encoding at byte {err.start}: tour files "
                                                                 f"must be UTF-8 ({err.reason})")]) from err
    else:
        text = data
        try:
            size = len(text.encode("utf-8"))
        except UnicodeEncodeError as err:
            line = text[: err.start].replace("\r\n", "\n").replace("\r", "\n").count("\n") + 1
            raise TourError([Problem(where_file, f"line {line}", f"character {err.start} is not valid "
                                                                 "UTF-8 text")]) from err
        if size > MAX_TOUR_BYTES:
            raise TourError([Problem(where_file, "file", f"more than the {MAX_TOUR_BYTES} bytes a tour may have")])
    if "\x00" in text:
        raise TourError([Problem(where_file, "file", "contains a NUL byte; tour files are plain text")])
    text = text.removeprefix("\ufeff")
    return unicodedata.normalize("NFC", text.replace("\r\n", "\n").replace("\r", "\n"))


def parse_tour(data: bytes | str, file_name: str, building: Building | None = None,
               source: str | None = None) -> Tour:
    """Parse a tour file's content; with ``building`` also check floors and rooms exist.

    ``source`` names the file in messages (default ``file_name``). Raises
    :class:`TourError` listing every problem with file and line number.
    """
    problems: list[Problem] = []
    where_file = source or file_name

    def bad(where: str, message: str) -> None:
        problems.append(Problem(where_file, where, message))

    lines = _decode(data, where_file).split("\n")
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise TourError([Problem(where_file, "file", "is empty; expected a 'Tour' header and at least one goal")])

    header = _HEADER_RE.match(lines[0].strip())
    name = ""
    if header is None:
        bad("line 1", f"expected the header 'Tour' (or 'Tour: <name>'), got {lines[0].strip()[:40]!r}")
    else:
        name = (header.group(1) or "").strip()
        if (code := _control(name)) is not None:
            bad("line 1", f"tour name holds the control character {code}")
        if len(name) > MAX_NAME:
            bad("line 1", f"tour name is {len(name)} characters; at most {MAX_NAME}")
        if name == _derived_name(file_name):
            name = ""            # the same display name either way: one canonical form

    goals: list[TourGoal] = []
    for number, line in enumerate(lines[1:], start=2):
        where = f"line {number}"
        if _HEADER_RE.match(line.strip()):
            bad(where, "duplicate 'Tour' header; a file holds one tour")
            continue
        if not line.strip():
            bad(where, "blank line between goals; every line after the header is "
                       "'floor, room number, room description'")
            continue
        if (code := _control(line)) is not None:
            bad(where, f"holds the control character {code}")
            continue
        parts = line.split(",", 2)
        if len(parts) != 3:
            bad(where, f"{len(parts)} column(s) in {line.strip()[:60]!r}; expected 3: floor, room number, "
                       "room description")
            continue
        floor_text, room, description = parts[0].strip(), parts[1].strip(), parts[2].strip()
        floor = _parse_floor(floor_text)
        if floor is None:
            bad(where, f"floor {floor_text!r} is not a number")
            continue
        if not _ROOM_RE.match(room):
            bad(where, f"room number {room!r} must be letters/digits such as '014'")
            continue
        if not description:
            bad(where, "room description is empty")
            continue
        if len(description) > MAX_DESCRIPTION:
            bad(where, f"room description is {len(description)} characters; at most {MAX_DESCRIPTION}")
            continue
        goal = TourGoal(floor, room, description)
        if building is not None:
            bfloor = building.find_floor(floor)
            if bfloor is None:
                bad(where, f"unknown floor {floor_text} (building {building.id} has floors "
                           f"{', '.join(f.label for f in building.floors)})")
                continue
            location = building.find_location(room)
            if location is None:
                bad(where, f"unknown room {room!r} for building {building.id}")
                continue
            if location.floor != bfloor.id:
                bad(where, f"room {room} is on floor {format_floor(location.floor)}, not {floor_text}")
                continue
            goal = TourGoal(bfloor.id, room, description)
        goals.append(goal)
    if not goals and not problems:
        bad("file", "empty tour: no goals after the header")
    if len(goals) > MAX_GOALS:
        bad("file", f"{len(goals)} goals; a tour may have at most {MAX_GOALS}")
    if problems:
        raise TourError(problems)
    return Tour(file_name=file_name, name=name, goals=tuple(goals))


def format_tour(tour: Tour) -> str:
    """The file content of ``tour`` (inverse of :func:`parse_tour`)."""
    header = f"{HEADER}: {tour.name}" if tour.name else HEADER
    return "\n".join([header, *tour.goal_lines()]) + "\n"


def tour_from_lines(file_name: str, name: str, goal_lines: list[str], building: Building | None = None) -> Tour:
    """Build a tour from Tour.msg fields, validated exactly like a file.

    The fields are single lines: a line break in the name or in a goal line is an error
    (it would add lines to the tour), not a tolerated variant.
    """
    check_tour_file_name(file_name)
    problems = [Problem(file_name, where, "holds a line break; each field is one line")
                for where, text in [("tour name", name)] + [(f"goal {i}", g) for i, g in enumerate(goal_lines, 1)]
                if "\n" in text or "\r" in text]
    if problems:
        raise TourError(problems)
    header = f"{HEADER}: {name}" if name.strip() else HEADER
    return parse_tour("\n".join([header, *goal_lines]) + "\n", file_name, building)


def _derived_name(file_name: str) -> str:
    return Tour(file_name, "", ()).display_name
