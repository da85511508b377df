"""Tour mode (ROS-free): the tours a robot knows and the tours waiting for the visitor's Continue.

A tour is run as a sequence of single targets (paper section 3.2). The robot that
finishes step k of a tour reports TOUR_STEP_DONE and keeps a :class:`TourWait`; the
visitor's Continue there issues step k+1 from that robot's floor and pose, a Skip
issues the step the visitor picked, Start tour (again) issues step 0, Cancel ends it.
The tours come from the tour store's catalog (``tour_store/catalog``), identical on
every robot (tour sharing).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import dataclass

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import TourError, TourNameError
from gidabot_navigation.tours.tour_file import Tour, tour_from_lines
from gidabot_navigation.tours.tour_store import TourMessage


class TourBook:
    """The tours of this robot's catalog, parsed and checked against the building."""

    def __init__(self, building: Building) -> None:
        self.building = building
        self._tours: dict[str, Tour] = {}

    def update(self, entries: Iterable[TourMessage]) -> list[str]:
        """Replace the known tours by the tours of a new catalog; return one problem line per invalid one."""
        tours: dict[str, Tour] = {}
        problems: list[str] = []
        for e in entries:
            try:
                tours[e.file_name] = tour_from_lines(e.file_name, e.tour_name, list(e.tour_goals_info), self.building)
            except (TourError, TourNameError, TypeError, AttributeError) as err:
                problems.append(f"tour {str(e.file_name)[:64]!r} in the catalog is invalid: {err}")
        self._tours = tours
        return problems

    def get(self, file_name: str) -> Tour | None:
        return self._tours.get(file_name)

    def length(self, file_name: str) -> int | None:
        tour = self._tours.get(file_name)
        return len(tour.goals) if tour else None

    def __len__(self) -> int:
        return len(self._tours)


def next_robot_stop(tour: Tour, building: Building, step: int) -> int | None:
    """The first step after ``step`` on a floor with a robot (None: the tour ends on floors without robot).

    The steps in between are on floors without robot: the visitor finds them alone, and the robot that
    sends the visitor there announces them all at once (docs/guiding.md, *Tour mode*)."""
    return next((k for k in range(step + 1, len(tour.goals)) if building.has_robot(tour.goals[k].floor)), None)


@dataclass(frozen=True)
class TourWait:
    """Step ``step`` of ``tour_file`` was done here (goal ``goal_uid``); waiting for Continue or Skip."""

    goal_uid: str
    tour_file: str
    step: int
    way: str
    language: str
    visitor_id: str
    since: float          # s, ROS time


class TourWaits:
    """The tour steps done at this robot whose next step the visitor has not asked for yet (bounded)."""

    def __init__(self, limit: int = 32) -> None:
        self.limit = limit
        self._waits: OrderedDict[str, TourWait] = OrderedDict()

    def add(self, wait: TourWait) -> None:
        # one visitor follows one tour: a newer step of the same tour and visitor replaces older ones
        for uid in [u for u, w in self._waits.items()
                    if w.tour_file == wait.tour_file and w.visitor_id == wait.visitor_id]:
            del self._waits[uid]
        self._waits[wait.goal_uid] = wait
        while len(self._waits) > self.limit:
            self._waits.popitem(last=False)

    def get(self, goal_uid: str) -> TourWait | None:
        return self._waits.get(goal_uid)

    def latest(self) -> TourWait | None:
        return next(reversed(self._waits.values()), None)

    def all(self) -> list[TourWait]:
        """Every wait, oldest first."""
        return list(self._waits.values())

    def pop(self, goal_uid: str) -> TourWait | None:
        return self._waits.pop(goal_uid, None)

    def clear_tour(self, tour_file: str, visitor_id: str | None = None) -> None:
        for uid in [u for u, w in self._waits.items()
                    if w.tour_file == tour_file and (visitor_id is None or w.visitor_id == visitor_id)]:
            del self._waits[uid]

    def __len__(self) -> int:
        return len(self._waits)
