"""The building editor's live checks (ROS-free, web-free): ``gidabot check``'s own checks on the building being
edited, after every change.

The document is checked as the nodes load a building file (:func:`~gidabot_navigation.building.model.building_from_doc`:
every rule of docs/building-format.md), then, when that passes, as ``gidabot check`` goes on: every place and
meeting point reachable from each robot's home for its radius (:mod:`~gidabot_navigation.building.reachability`)
and the warnings about robots parked where another cannot pass (:mod:`~gidabot_navigation.building.passing`). The
building *would be accepted* when there is no problem (warnings do not count): exactly when ``gidabot check``
passes it once saved. A draft mark (``draft: true``) is the editor's own business and not a problem here.

Each problem goes to the page with what it is about (``item``: the floor, place, connector, robot or keep-out
zone, by list and index or id) and, when it has a place on a floor, that floor and its marks (the place; where
the way closes and the last point reached; the narrowest point). Maps and blueprints are read again only when
they change on disk, and the costmaps are kept (:class:`~gidabot_navigation.building.reachability.PlannerCache`),
so a check of the faculty takes a fraction of a second.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from pathlib import Path

from gidabot_navigation.building.model import FloorFiles, building_from_doc
from gidabot_navigation.building.passing import passing_warnings
from gidabot_navigation.building.reachability import PlannerCache, reachability_problems
from gidabot_navigation.errors import BuildingError, Problem

_LISTED = re.compile(r"^(floors|locations|connectors|robots)\[(\d+)\](?:\.keep_out\[(\d+)\])?")
_NAMED = re.compile(r"^(location|connector|robot) (\S+)")
_NAMED_LIST = {"location": "locations", "connector": "connectors", "robot": "robots"}


@dataclass
class CheckResult:
    revision: int                            # of the document checked
    accepted: bool                           # gidabot check would pass it (no problem; warnings allowed)
    problems: list[dict] = field(default_factory=list)
    warnings: list[dict] = field(default_factory=list)
    seconds: float = 0.0
    summary: str = ""

    def to_json(self) -> dict:
        return {"revision": self.revision, "accepted": self.accepted, "problems": self.problems,
                "warnings": self.warnings, "seconds": round(self.seconds, 3), "summary": self.summary}


def item_of(where: str) -> dict | None:
    """What a problem's ``where`` is about: ``{"list": "locations", "index": 3}`` (a key path), ``{"list":
    "floors", "index": 1, "zone": 0}`` (a keep-out zone), ``{"list": "robots", "id": "Kbot"}`` (reachability
    and passing name places by id); None for the building as a whole."""
    m = _LISTED.match(where)
    if m:
        out: dict = {"list": m.group(1), "index": int(m.group(2))}
        if m.group(3) is not None:
            out["zone"] = int(m.group(3))
        return out
    m = _NAMED.match(where)
    if m:
        return {"list": _NAMED_LIST[m.group(1)], "id": m.group(2)}
    return None


def problem_json(p: Problem) -> dict:
    return {"where": p.where, "message": p.message, "item": item_of(p.where), "floor": p.floor,
            "marks": [[x, y, what] for x, y, what in p.marks]}


class LiveChecker:
    """Checks documents of one building folder, keeping what the checks read in between."""

    def __init__(self) -> None:
        self.files = FloorFiles(cache=True)
        self.planners = PlannerCache()

    def check(self, data: dict, path: Path, revision: int) -> CheckResult:
        """Check the plain document ``data`` of building file ``path`` (files relative to its folder)."""
        start = time.monotonic()
        try:
            building = building_from_doc(data, path, allow_draft=True, files=self.files)
        except BuildingError as err:
            problems = [problem_json(p) for p in err.problems]
            return CheckResult(revision, False, problems, [], time.monotonic() - start,
                               f"{len(problems)} problem(s) in the building file")
        problems = [problem_json(p) for p in reachability_problems(building, self.planners)]
        warnings = [problem_json(p) for p in passing_warnings(building)]
        summary = (f"{len(problems)} place(s) not reachable" if problems else
                   f"{len(building.floors)} floors, {len(building.locations)} locations, "
                   f"{len(building.connectors)} connectors, {len(building.robots)} robots, "
                   f"{len(building.relay_pairs())} relays")
        if warnings:
            summary += f", {len(warnings)} warning(s)"
        return CheckResult(revision, not problems, problems, warnings, time.monotonic() - start, summary)
