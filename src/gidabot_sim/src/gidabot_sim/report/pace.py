"""The visitor's pace per trip and robot (ROS-free): how far behind the visitor walked, how long the robot waited.

Two sources, each a robot's own:

* the phases its navigation sent (:func:`pace_from_events`, records with ``robot``, ``goal_uid``, ``phase`` and a
  time): waits (``WAITING_FOR_YOU``), searches (``SEARCHING_VISITOR``), visitors lost (``VISITOR_LOST``), found
  again (a ``FOLLOW_ME`` after a search), and the time waiting: from a wait or a search to the ``FOLLOW_ME``
  or the end of the robot's part that follows it;
* the ``guiding: pace <robot>`` status its navigation publishes on ``/diagnostics`` when a guided leg ends
  (:func:`pace_from_diagnostics`): the visitor's mean and worst distance behind (m, while seen), the time waiting,
  slow-downs, waits, searches, lost, found again, as the robot counted them.

:func:`merge` puts both together (the diagnostics' numbers where there are some) and :func:`totals` sums them.
:func:`where_lost` says, for each visitor a robot declared lost, where the robot was and where the visitor's body
truly was then (the simulator's ``people_at``): a person reading the report tells a visitor who walked off from
one the robot did not see.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections.abc import Iterable, Sequence

from gidabot_navigation.interface import FINAL_PHASES, PACE_PHASES, PERSON_ID_PREFIX, Phase

PACE_STATUS = "guiding: pace "
COUNTS = ("slowdowns", "waits", "searches", "lost", "found_again")
LOOK_S = 30.0         # s: a position sampled further than this from a loss is not where it was then


def people_at(value: str) -> dict[str, tuple[float, float]]:
    """The simulator's ``people_at`` diagnostics value (``<id> <x> <y>; ...``) -> id -> (x, y); a part that does
    not read is skipped."""
    out: dict[str, tuple[float, float]] = {}
    for part in value.split(";"):
        words = part.split()
        if len(words) != 3:
            continue
        try:
            x, y = float(words[1]), float(words[2])
        except ValueError:
            continue
        if math.isfinite(x) and math.isfinite(y):
            out[words[0]] = (x, y)
    return out


def _nearest(samples: Sequence[tuple[float, object]], t: float) -> object | None:
    """The value of the time-ordered ``samples`` (t, value) nearest ``t``, within :data:`LOOK_S`."""
    k = bisect_left([s[0] for s in samples], t)
    best = min((samples[j] for j in (k - 1, k) if 0 <= j < len(samples)), key=lambda s: abs(s[0] - t), default=None)
    return best[1] if best is not None and abs(best[0] - t) <= LOOK_S else None


def where_lost(losses: Iterable[tuple[float, str, str]], tracks: dict[str, Sequence[tuple[float, float, float]]],
               bodies: dict[str, Sequence[tuple[float, dict[str, tuple[float, float]]]]]) -> list[dict]:
    """(time s, robot, goal uid) of each VISITOR_LOST; each robot's track (t, x, y) and its floor's bodies (t,
    id -> (x, y)), both time-ordered -> a row per loss: where the robot was, where the visitor's body was (the
    visitor id is the goal uid's second part, ``<robot>/<visitor>/...``; a group's first body), and the distance
    between them (None where not recorded; no body: it had left the floor)."""
    rows = []
    for t, robot, goal_uid in sorted(losses):
        parts = goal_uid.split("/")
        person = PERSON_ID_PREFIX + parts[1] if len(parts) >= 3 else ""
        pose = _nearest([(p[0], (p[1], p[2])) for p in tracks.get(robot, ())], t)
        seen = _nearest(bodies.get(robot, ()), t)
        body = seen.get(person) if isinstance(seen, dict) else None
        rows.append({"t": round(t, 1), "robot": robot, "goal_uid": goal_uid,
                     "robot_at": None if pose is None else [round(v, 2) for v in pose],
                     "body_at": None if body is None else [round(v, 2) for v in body],
                     "on_floor": None if seen is None else body is not None,
                     "distance_m": None if pose is None or body is None else round(math.dist(pose, body), 2)})
    return rows


def _row(goal_uid: str, robot: str) -> dict:
    return {"goal_uid": goal_uid, "robot": robot, "mean_behind_m": None, "worst_behind_m": None,
            "waiting_s": 0.0, "slowdowns": None, "waits": 0, "searches": 0, "lost": 0, "found_again": 0}


def pace_from_events(events: Iterable[tuple[float, str, str, int]]) -> dict[tuple[str, str], dict]:
    """(time s, robot, goal uid, phase) of every event -> a row per (goal uid, robot) that paced a visitor."""
    rows: dict[tuple[str, str], dict] = {}
    waiting_since: dict[tuple[str, str], float] = {}
    searched: set[tuple[str, str]] = set()
    for t, robot, goal_uid, phase in sorted(events, key=lambda e: e[0]):
        key = (goal_uid, robot)
        if not goal_uid or (phase not in PACE_PHASES and key not in rows):
            continue
        row = rows.setdefault(key, _row(goal_uid, robot))
        if phase in (Phase.WAITING_FOR_YOU, Phase.SEARCHING_VISITOR):
            row["waits" if phase == Phase.WAITING_FOR_YOU else "searches"] += 1
            waiting_since.setdefault(key, t)
            if phase == Phase.SEARCHING_VISITOR:
                searched.add(key)
        elif phase == Phase.FOLLOW_ME or phase in FINAL_PHASES:
            since = waiting_since.pop(key, None)
            if since is not None and math.isfinite(t) and t >= since:
                row["waiting_s"] = round(row["waiting_s"] + t - since, 1)
            if phase == Phase.FOLLOW_ME and key in searched:
                row["found_again"] += 1
                searched.discard(key)
            if phase == Phase.VISITOR_LOST:
                row["lost"] += 1
    return rows


def pace_from_diagnostics(statuses: Iterable[tuple[str, dict[str, str]]]) -> dict[tuple[str, str], dict]:
    """(status name, its values) of ``/diagnostics`` -> a row per (goal uid, robot) from the robots' own counts."""
    rows: dict[tuple[str, str], dict] = {}
    for name, values in statuses:
        if not name.startswith(PACE_STATUS) or not values.get("goal_uid"):
            continue
        robot = name[len(PACE_STATUS):]
        key = (values["goal_uid"], robot)
        row = rows.setdefault(key, _row(key[0], robot))
        row["_samples"] = row.get("_samples", 0) + _num(values.get("samples"))
        for field, out in (("mean_behind", "mean_behind_m"), ("worst_behind", "worst_behind_m")):
            value = _num(values.get(field), math.nan)
            if math.isfinite(value) and _num(values.get("samples")) > 0:
                row[out] = value if row[out] is None or field == "mean_behind" else max(row[out], value)
        row["waiting_s"] = round(row["waiting_s"] + _num(values.get("waiting")), 1)
        for count in COUNTS:
            row[count] = (row[count] or 0) + int(_num(values.get(count)))
    for row in rows.values():
        row.pop("_samples", None)
    return rows


def merge(from_events: dict[tuple[str, str], dict], from_diagnostics: dict[tuple[str, str], dict]) -> list[dict]:
    """One row per (goal uid, robot): the robot's own counts where it published them, else the events'."""
    keys = sorted(set(from_events) | set(from_diagnostics))
    return [from_diagnostics.get(k) or from_events[k] for k in keys]


def totals(rows: Sequence[dict]) -> dict:
    """Sums over the rows, and the mean of the trips' mean distance behind (m; None: never measured)."""
    behind = [r["mean_behind_m"] for r in rows if r.get("mean_behind_m") is not None]
    worst = [r["worst_behind_m"] for r in rows if r.get("worst_behind_m") is not None]
    out = {"legs": len(rows), "mean_behind_m": round(sum(behind) / len(behind), 2) if behind else None,
           "worst_behind_m": round(max(worst), 2) if worst else None,
           "waiting_s": round(sum(r.get("waiting_s") or 0.0 for r in rows), 1)}
    for count in COUNTS:
        out[count] = sum(r.get(count) or 0 for r in rows)
    return out


def _num(value: object, default: float = 0.0) -> float:
    try:
        out = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return default
    return out if math.isfinite(out) else default
