"""Administrator tools (ROS-free): password check, Set location, tour drafts.

Admin mode exists only when the node is started with ``~admin: true`` and a
salted hash of the password in ``~admin_password_hash`` (``gidabot admin-passwd``
makes it: :mod:`gidabot_navigation.passwords`); it is never on by default. A wrong
password is refused, and after ``MAX_FAILURES`` wrong ones in a row the prompt is
locked for ``LOCKOUT`` seconds (wall time, passed in).
"""

from __future__ import annotations

import math
import re
import unicodedata
from dataclasses import dataclass

from gidabot_gui.core.model import InitialPose, TourEdit
from gidabot_gui.errors import ConfigError, TourEditError
from gidabot_navigation.building.geometry import BlueprintTransform
from gidabot_navigation.building.model import Building, format_floor
from gidabot_navigation.errors import PasswordHashError, TourError, TourNameError
from gidabot_navigation.passwords import parse_record
from gidabot_navigation.tours.tour_file import MAX_FILE_NAME, TOUR_SUFFIX, TourGoal, tour_from_lines

MAX_FAILURES = 5
LOCKOUT = 30.0          # s
MAX_PASSWORD = 256      # characters; longer input is refused without hashing
LEGACY_SHA256 = ("~admin_password_sha256 (an unsalted SHA-256) is no longer taken: make a salted hash with "
                 "'gidabot admin-passwd' and pass it as admin_password_hash")


class PasswordCheck:
    """Checks the administrator password against a configured salted hash record
    (``scrypt:<n>:<r>:<p>:<salt hex>:<hash hex>``)."""

    def __init__(self, record: str) -> None:
        try:
            self._hash = parse_record(record, "admin_password_hash")
        except PasswordHashError as err:
            raise ConfigError(str(err)) from err
        self.failures = 0
        self.locked_until = 0.0

    def locked_for(self, now: float) -> float:
        """Seconds until the prompt accepts passwords again (0 when open)."""
        return max(0.0, self.locked_until - now)

    def check(self, password: str, now: float) -> bool:
        """True if ``password`` is right (and the prompt is not locked)."""
        if self.locked_for(now) > 0:
            return False
        ok = isinstance(password, str) and len(password) <= MAX_PASSWORD and self._hash.matches(password)
        if ok:
            self.failures = 0
            return True
        self.failures += 1
        if self.failures >= MAX_FAILURES:
            self.failures = 0
            self.locked_until = now + LOCKOUT
        return False


def pose_from_drag(transform: BlueprintTransform, floor: float, press: tuple[float, float],
                   release: tuple[float, float], min_drag_px: float = 3.0,
                   default_yaw: float = 0.0) -> InitialPose:
    """The pose set by pressing at ``press`` and dragging to ``release`` (blueprint pixels).

    The position is the press point; the heading points from press to release
    (``default_yaw`` when the drag is shorter than ``min_drag_px``).
    """
    x, y = transform.to_map(*press)
    if math.hypot(release[0] - press[0], release[1] - press[1]) < min_drag_px:
        yaw = default_yaw
    else:
        x2, y2 = transform.to_map(*release)
        yaw = math.atan2(y2 - y, x2 - x)
    return InitialPose(floor, x, y, yaw)


def slug_file_name(name: str) -> str:
    """A tour file name derived from a display name ("Open day" -> "open_day.tour")."""
    text = unicodedata.normalize("NFKD", name)
    text = "".join(ch for ch in text if not unicodedata.combining(ch)).lower()
    text = re.sub(r"[^a-z0-9]+", "_", text).strip("_") or "tour"
    return text[: MAX_FILE_NAME - len(TOUR_SUFFIX)].rstrip("_") + TOUR_SUFFIX


@dataclass
class TourDraft:
    """A tour being created or edited in admin mode."""

    file_name: str
    name: str
    language: str
    goals: list[tuple[float, str, str]]   # (floor, room, description)
    existing: bool = False                # editing a tour of the catalog (file name fixed)

    def lines(self) -> list[str]:
        return [TourGoal(f, r, d.strip()).line() for f, r, d in self.goals]

    def validate(self, building: Building) -> None:
        """Raise :class:`TourEditError` naming the bad value, exactly as a tour file is checked."""
        if self.language not in ("eu", "en", "es"):
            raise TourEditError(f"language {self.language!r} is not one of eu, en, es")
        for i, (_f, _r, desc) in enumerate(self.goals, start=1):
            if "\n" in desc or "\r" in desc:
                raise TourEditError(f"stop {i}: the description may not hold a line break")
        try:
            tour_from_lines(self.file_name, self.name.strip(), self.lines(), building)
        except TourNameError as err:
            raise TourEditError(str(err)) from err
        except TourError as err:
            raise TourEditError("; ".join(str(p) for p in err.problems)) from err

    def to_edit(self, building: Building, uid: str) -> TourEdit:
        """The validated ``tour_store/edit`` message of this draft."""
        self.validate(building)
        return TourEdit(uid=uid, file_name=self.file_name, tour_name=self.name.strip(), language=self.language,
                        floor=self.goals[0][0], goal_lines=tuple(self.lines()))


def delete_edit(file_name: str, language: str, uid: str) -> TourEdit:
    return TourEdit(uid=uid, file_name=file_name, tour_name="", language=language, floor=0.0,
                    goal_lines=(), deleted=True)


def floor_text(floor: float) -> str:
    return format_floor(floor)
