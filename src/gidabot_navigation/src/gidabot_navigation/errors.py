"""The exception hierarchy of gidabot_navigation (ROS-free).

Every error message names the bad value and what was expected; loaders that can
find several problems at once collect them as :class:`Problem` records and raise
one error listing all of them.
"""

from __future__ import annotations

from dataclasses import dataclass


class GidaBotError(Exception):
    """Base class of every error raised by gidabot_navigation."""


@dataclass(frozen=True)
class Problem:
    """One problem found in a data file: where (file, key or line) and what.

    ``floor`` and ``marks`` place it on a floor's map when it has a place there (the building editor shows it):
    each mark is (x, y, what) in that floor's map metres, ``what`` one of :data:`MARKS`.
    """

    file: str
    where: str
    message: str
    floor: float | None = None
    marks: tuple[tuple[float, float, str], ...] = ()

    def __str__(self) -> str:
        return f"{self.file}: {self.where}: {self.message}"


MARKS = ("place", "closed", "reached", "narrow", "zone")   # the place, where the way closes, the last point reached,
#                                                          the narrowest point, a keep-out zone


class ProblemsError(GidaBotError):
    """A data file has one or more problems; ``problems`` lists all of them."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = list(problems)
        lines = "\n".join(f"  - {p}" for p in self.problems)
        super().__init__(f"{len(self.problems)} problem(s):\n{lines}")


class MapError(GidaBotError):
    """An occupancy map (map_server YAML + image) cannot be loaded."""


class BuildingError(ProblemsError):
    """A building description is invalid."""


class TourError(ProblemsError):
    """A tour file is invalid."""


class TourNameError(GidaBotError):
    """A tour file name is unsafe or malformed."""


class AlignmentError(GidaBotError):
    """Matching points do not determine an alignment (too few, all at one spot, a mirror image)."""


class PlanningError(GidaBotError):
    """A path cannot be planned (start or goal blocked, no path)."""


class ObstacleError(PlanningError):
    """An obstacle's shape is invalid (not finite, not positive, absurdly large)."""


class TourStoreError(GidaBotError):
    """The tour store cannot do what was asked (directory unusable, a file in the way, unknown tour)."""


class TourRejected(TourStoreError):
    """A tour message (local edit or from another robot) is invalid; nothing stored was touched.

    ``reason`` is a short category used for counters (e.g. ``"file_name"``, ``"content"``,
    ``"oversized"``); the message names the bad value and what was expected.
    """

    def __init__(self, reason: str, message: str) -> None:
        self.reason = reason
        super().__init__(message)


class GuidingError(GidaBotError):
    """Guiding (goal_manager / multirobot_navigation) cannot do what was asked."""


class GoalRejected(GuidingError):
    """A goal, cancel, event or visitor command is invalid; it was not acted upon.

    ``reason`` is a short category used for counters (e.g. ``"floor"``, ``"location"``,
    ``"not_finite"``, ``"too_long"``); the message names the bad value and what was expected.
    """

    def __init__(self, reason: str, message: str) -> None:
        self.reason = reason
        super().__init__(message)


class NoRouteError(GuidingError):
    """No connector or no path joins the start and the goal of a trip."""


class GuidingStateError(GuidingError):
    """A guiding state file cannot be read or written."""


# -- perception (people detection and tracking) ----------------------------------------------
class PerceptionError(GidaBotError):
    """The people detector or tracker cannot do what was asked (a bad parameter)."""


class ScanError(PerceptionError):
    """A laser scan is malformed (non-finite angles, no beams, a negative increment...); it was not used."""


# -- relay -----------------------------------------------------------------------------------
class RelayConfigError(GidaBotError):
    """The relay's configuration (shared topics, link parameters, secret) is invalid."""


class FrameRejected(GidaBotError):
    """A frame (or a message inside one) is refused; ``reason`` is auth, oversize, malformed or type."""

    def __init__(self, reason: str, message: str) -> None:
        self.reason = reason
        super().__init__(message)


class JournalError(GidaBotError):
    """The journal cannot be opened, locked or written."""


# -- ROS infrastructure (gidabot_navigation.ros) ---------------------------------------------
class ParamError(GidaBotError):
    """A node's ~parameter is missing or invalid."""


class MasterWatchError(GidaBotError):
    """Re-registration with the master failed (the master refused a registration or went away)."""


class ExitGuardError(GidaBotError):
    """The exit guard cannot be installed (a bad grace time, not called from the main thread)."""


class ResourceError(GidaBotError):
    """A file the packages ship (launch file, map, tour, config) is not found: the workspace is not built
    or not sourced (:mod:`gidabot_navigation.resources`)."""


class PasswordHashError(GidaBotError):
    """A salted password hash record that is malformed or out of range (:mod:`gidabot_navigation.passwords`)."""
