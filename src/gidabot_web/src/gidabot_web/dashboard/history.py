"""The dashboard's history on the robot: SQLite (stdlib ``sqlite3``, WAL mode), ROS-free.

What the rules of :mod:`gidabot_web.dashboard.dashboard` decide is written here; this module only stores
and sums. Every write is idempotent, so an event the node sees again (a replay after a restart, a relay's
re-send) changes nothing:

- ``seen(uid)``: the uid of every event, cancel and staff command applied (the history's de-duplication);
- ``trips``: one row per trip (``uid`` = the goal's uid; a request refused at once: its answer's uid) with its
  day, origin, goal, floors, tour step, outcome (set once: the first one stands), when it ended and the
  visitor's wait before the first robot moved (set once);
- ``legs``: which robot started serving each leg of each trip (set once);
- ``alerts`` (the alert list, acknowledgements included) and ``service`` (the newest staff command about
  each robot): what the page shows after a restart.

Writes are committed by :meth:`History.commit` (the node's loop: twice a second); a crash loses at most the
uncommitted ones, which the replays of the last 60 s bring back. ``day`` is the robot's local date of the
trip's first sighting. :meth:`History.csv` is one day's trips, CSV-injection safe (a text cell that a
spreadsheet would read as a formula gets a leading ``'``).
"""

from __future__ import annotations

import csv
import io
import json
import sqlite3
import time
from pathlib import Path

from gidabot_web.errors import HistoryError

OUTCOMES = ("completed", "cancelled", "timed_out", "refused", "failed")
FORMULA_START = ("=", "+", "-", "@", "\t", "\r")
CSV_COLUMNS = ("trip", "created", "origin", "start_floor", "goal", "goal_floor", "tour", "tour_step", "outcome",
               "ended", "wait_s", "start_robot", "goal_robot")
SCHEMA = """
CREATE TABLE IF NOT EXISTS seen(uid TEXT PRIMARY KEY, wall REAL NOT NULL);
CREATE TABLE IF NOT EXISTS trips(uid TEXT PRIMARY KEY, day TEXT NOT NULL, created REAL NOT NULL, origin TEXT,
    goal_id TEXT, start_floor REAL, goal_floor REAL, tour_file TEXT, tour_step INTEGER, outcome TEXT, ended REAL,
    wait_s REAL, start_robot TEXT, goal_robot TEXT);
CREATE INDEX IF NOT EXISTS trips_day ON trips(day);
CREATE TABLE IF NOT EXISTS legs(goal_uid TEXT, leg TEXT, robot TEXT NOT NULL, day TEXT NOT NULL, wall REAL,
    PRIMARY KEY(goal_uid, leg));
CREATE INDEX IF NOT EXISTS legs_day ON legs(day);
CREATE TABLE IF NOT EXISTS alerts(id INTEGER PRIMARY KEY, body TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS service(target TEXT PRIMARY KEY, body TEXT NOT NULL);
"""


def day_of(wall: float) -> str:
    """The robot's local date of wall time ``wall`` (s since the epoch), ``YYYY-MM-DD``."""
    return time.strftime("%Y-%m-%d", time.localtime(wall))


def iso(wall: float | None) -> str:
    return "" if wall is None else time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(wall))


def safe_cell(value: object) -> object:
    """A CSV cell a spreadsheet shows as text: a string starting like a formula gets a leading ``'``."""
    if isinstance(value, str) and value.startswith(FORMULA_START):
        return "'" + value
    return value


class History:
    def __init__(self, path: str | Path) -> None:
        self.path = str(path)
        try:
            self.db = sqlite3.connect(self.path, isolation_level="DEFERRED", check_same_thread=False)
            self.db.execute("PRAGMA journal_mode=WAL")
            self.db.execute("PRAGMA synchronous=NORMAL")
            self.db.executescript(SCHEMA)
            self.db.commit()
        except sqlite3.Error as err:
            raise HistoryError(f"history database {self.path}: {err}") from err
        self.writes = 0

    def close(self) -> None:
        try:
            self.db.commit()
        finally:
            self.db.close()

    def commit(self) -> None:
        try:
            self.db.commit()
        except sqlite3.Error as err:
            raise HistoryError(f"history database {self.path}: {err}") from err

    def _exec(self, sql: str, args: tuple = ()) -> int:
        try:
            cur = self.db.execute(sql, args)
        except sqlite3.Error as err:
            raise HistoryError(f"history database {self.path}: {err}") from err
        self.writes += cur.rowcount > 0
        return cur.rowcount

    # -- writes (idempotent) ---------------------------------------------------------------
    def first_time(self, uid: str, wall: float) -> bool:
        """Record ``uid`` as applied; True if it was not before."""
        return self._exec("INSERT OR IGNORE INTO seen(uid, wall) VALUES (?, ?)", (uid, wall)) > 0

    def trip(self, uid: str, day: str, wall: float, origin: str, goal_id: str = "", start_floor: float | None = None,
             goal_floor: float | None = None, tour_file: str = "", tour_step: int = -1, start_robot: str = "",
             goal_robot: str = "") -> None:
        """A trip seen: its row made, or its unknown fields filled (a trip first known by an event)."""
        self._exec("INSERT OR IGNORE INTO trips(uid, day, created, origin) VALUES (?, ?, ?, ?)",
                   (uid, day, wall, origin))
        self._exec("UPDATE trips SET goal_id = COALESCE(NULLIF(goal_id, ''), ?), "
                   "start_floor = COALESCE(start_floor, ?), goal_floor = COALESCE(goal_floor, ?), "
                   "tour_file = COALESCE(NULLIF(tour_file, ''), ?), "
                   "tour_step = CASE WHEN tour_step IS NULL OR tour_step < 0 THEN ? ELSE tour_step END, "
                   "start_robot = COALESCE(NULLIF(?, ''), start_robot), "
                   "goal_robot = COALESCE(NULLIF(?, ''), goal_robot) WHERE uid = ?",
                   (goal_id, start_floor, goal_floor, tour_file, tour_step, start_robot, goal_robot, uid))

    def outcome(self, uid: str, outcome: str, wall: float) -> bool:
        """The trip's outcome, if it has none yet; True if set now."""
        if outcome not in OUTCOMES:
            raise ValueError(f"outcome {outcome!r}: expected one of {OUTCOMES}")
        return self._exec("UPDATE trips SET outcome = ?, ended = ? WHERE uid = ? AND outcome IS NULL",
                          (outcome, wall, uid)) > 0

    def wait(self, uid: str, wait_s: float) -> bool:
        return self._exec("UPDATE trips SET wait_s = ? WHERE uid = ? AND wait_s IS NULL", (max(0.0, wait_s), uid)) > 0

    def leg(self, goal_uid: str, leg: str, robot: str, day: str, wall: float) -> bool:
        return self._exec("INSERT OR IGNORE INTO legs(goal_uid, leg, robot, day, wall) VALUES (?, ?, ?, ?, ?)",
                          (goal_uid, leg, robot, day, wall)) > 0

    def save_alert(self, alert_id: int, body: dict) -> None:
        self._exec("INSERT OR REPLACE INTO alerts(id, body) VALUES (?, ?)", (alert_id, json.dumps(body)))

    def drop_alerts_below(self, alert_id: int) -> None:
        self._exec("DELETE FROM alerts WHERE id < ?", (alert_id,))

    def save_service(self, target: str, body: dict) -> None:
        self._exec("INSERT OR REPLACE INTO service(target, body) VALUES (?, ?)", (target, json.dumps(body)))

    # -- reads -----------------------------------------------------------------------------
    def alerts(self) -> list[dict]:
        return [json.loads(b) for (b,) in self.db.execute("SELECT body FROM alerts ORDER BY id")]

    def service(self) -> dict[str, dict]:
        return {t: json.loads(b) for t, b in self.db.execute("SELECT target, body FROM service")}

    def days(self, limit: int = 90) -> list[str]:
        return [d for (d,) in self.db.execute("SELECT DISTINCT day FROM trips ORDER BY day DESC LIMIT ?", (limit,))]

    def summary(self, day: str) -> dict:
        """One day: trips by outcome, the visitors' mean and worst wait, the busiest places, per robot."""
        q = self.db.execute
        counts = dict(q("SELECT COALESCE(outcome, 'open'), COUNT(*) FROM trips WHERE day = ? GROUP BY 1", (day,)))
        n, mean, worst = q("SELECT COUNT(wait_s), AVG(wait_s), MAX(wait_s) FROM trips WHERE day = ? AND "
                           "wait_s IS NOT NULL", (day,)).fetchone()
        places = [{"id": g, "trips": c} for g, c in
                  q("SELECT goal_id, COUNT(*) FROM trips WHERE day = ? AND COALESCE(goal_id, '') != '' "
                    "GROUP BY goal_id ORDER BY 2 DESC, 1 LIMIT 5", (day,))]
        robots: dict[str, dict] = {}
        for robot, made, waited in q("SELECT origin, COUNT(*), AVG(wait_s) FROM trips WHERE day = ? GROUP BY origin",
                                     (day,)):
            robots.setdefault(robot, {})["originated"] = made
            robots[robot]["wait_mean_s"] = None if waited is None else round(waited, 1)
        for robot, legs in q("SELECT robot, COUNT(*) FROM legs WHERE day = ? GROUP BY robot", (day,)):
            robots.setdefault(robot, {})["legs"] = legs
        return {"day": day, "trips": sum(counts.values()),
                **{o: counts.get(o, 0) for o in (*OUTCOMES, "open")},
                "waits": n, "wait_mean_s": None if mean is None else round(mean, 1),
                "wait_max_s": None if worst is None else round(worst, 1), "places": places,
                "robots": [{"robot": r, "originated": v.get("originated", 0), "legs": v.get("legs", 0),
                            "wait_mean_s": v.get("wait_mean_s")} for r, v in sorted(robots.items())]}

    def rows(self, day: str) -> list[tuple]:
        return list(self.db.execute(
            "SELECT uid, created, origin, start_floor, goal_id, goal_floor, tour_file, tour_step, outcome, ended, "
            "wait_s, start_robot, goal_robot FROM trips WHERE day = ? ORDER BY created, uid", (day,)))

    def csv(self, day: str) -> str:
        out = io.StringIO()
        w = csv.writer(out, lineterminator="\r\n")
        w.writerow(CSV_COLUMNS)
        for (uid, created, origin, sf, goal, gf, tour, step, outcome, ended, wait_s, sr, gr) in self.rows(day):
            w.writerow([safe_cell(v) for v in (uid, iso(created), origin or "", "" if sf is None else f"{sf:g}",
                                               goal or "", "" if gf is None else f"{gf:g}", tour or "",
                                               "" if step is None or step < 0 else step, outcome or "open",
                                               iso(ended), "" if wait_s is None else f"{wait_s:.1f}", sr or "",
                                               gr or "")])
        return out.getvalue()
