"""The history: the rules the core applies (outcomes, waits, legs, refusals), idempotent per event uid, in SQLite
(WAL) that survives a restart of the dashboard; a day as CSV, safe to open in a spreadsheet."""

from __future__ import annotations

import csv
import io
from dataclasses import replace
from pathlib import Path

from dashboard_support import WALL0, cancel, cross_trip, event, local_trip, make_core

from gidabot_navigation.interface import Phase
from gidabot_web.dashboard.history import CSV_COLUMNS, History, day_of, safe_cell

DAY = day_of(WALL0)


def run_day(core) -> tuple[list, str]:
    """A day of the faculty seen from Kbot: one cross-floor trip completed, one local trip cancelled, one timed out,
    one refused at once, one cancelled by its origin for being unreachable. Returns the events and the trips' uids."""
    evs = []
    trip = cross_trip(stamp=100.0)
    core.on_goal(trip, "Tartalo", 1.0)
    for robot, phase, leg, stamp, now in (("Tartalo", Phase.ON_THE_WAY, "start", 112.0, 2.0),
                                          ("MariSorgin", Phase.GOING_TO_MEETING, "goal", 0.0, 2.5),
                                          ("Tartalo", Phase.GO_TO_FLOOR, "start", 0.0, 30.0),
                                          ("MariSorgin", Phase.GOAL_REACHED, "goal", 0.0, 90.0)):
        ev = event(robot, phase, trip.uid, leg=leg, stamp=stamp)
        evs.append((ev, robot, now))
        core.on_event(ev, robot, now)
    local = local_trip("Kbot/v2/gm.b.1", goal="113")
    core.on_goal(local, "Kbot", 100.0)
    for phase, now in ((Phase.ON_THE_WAY, 103.0), (Phase.CANCELLED_HERE, 110.0), (Phase.GOAL_REACHED, 111.0)):
        ev = event("Kbot", phase, local.uid, stamp=0.0)
        evs.append((ev, "Kbot", now))
        core.on_event(ev, "Kbot", now)
    late = local_trip("Kbot/v3/gm.b.2", goal="113")
    core.on_goal(late, "Kbot", 120.0)
    ev = event("Kbot", Phase.TIMEOUT, late.uid)
    evs.append((ev, "Kbot", 500.0))
    core.on_event(ev, "Kbot", 500.0)
    refused = event("Kbot", Phase.PARTNER_OFFLINE, "", leg="", location_id="305")
    evs.append((refused, "Kbot", 600.0))
    core.on_event(refused, "Kbot", 600.0)
    lost = cross_trip("Tartalo/v4/gm.a.9")
    core.on_goal(lost, "Tartalo", 700.0)
    core.on_cancel(cancel("Tartalo", lost.uid, reason="unreachable"), "Tartalo", 710.0)
    core.step(711.0, WALL0 + 711.0)
    return evs, [trip.uid, local.uid, late.uid, refused.uid, lost.uid]


def test_the_days_sums(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    _, uids = run_day(core)
    s = core.history.summary(DAY)
    assert {k: s[k] for k in ("trips", "completed", "cancelled", "timed_out", "refused", "failed", "open")} == {
        "trips": 5, "completed": 1, "cancelled": 1, "timed_out": 1, "refused": 1, "failed": 1, "open": 0}
    # the cross-floor trip: Tartalo served its own start leg, so its own stamps (112 - 100); the local one: arrival here
    assert (s["waits"], s["wait_mean_s"], s["wait_max_s"]) == (2, 7.5, 12.0)
    assert s["places"] == [{"id": "305", "trips": 3}, {"id": "113", "trips": 2}]
    assert s["robots"] == [
        {"robot": "Kbot", "originated": 3, "legs": 1, "wait_mean_s": 3.0},
        {"robot": "MariSorgin", "originated": 0, "legs": 1, "wait_mean_s": None},
        {"robot": "Tartalo", "originated": 2, "legs": 1, "wait_mean_s": 12.0}]
    rows = {r[0]: r for r in core.history.rows(DAY)}
    assert rows[uids[1]][8] == "cancelled"                  # the first ending event stands (then GOAL_REACHED)
    assert rows[uids[3]][8] == "refused" and rows[uids[3]][4] == "305"
    assert rows[uids[4]][8] == "failed"                     # a cancel of its origin (unreachable): its reason
    assert core.history.days() == [DAY]


def test_events_seen_again_change_nothing_also_after_a_restart(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    evs, uids = run_day(core)
    before = core.history.summary(DAY), core.history.rows(DAY)
    for ev, robot, now in evs:                              # the relays' re-sends, the publishers' replays
        core.on_event(ev, robot, now + 1000.0)
    core.step(2000.0, WALL0 + 2000.0)
    assert (core.history.summary(DAY), core.history.rows(DAY)) == before
    core.history.close()
    again = make_core(faculty, tmp_path, now=5000.0)       # the dashboard node restarted: replays arrive again
    for ev, robot, _ in evs:
        again.on_goal(cross_trip(), "Tartalo", 5001.0)
        again.on_event(ev, robot, 5002.0)
    again.step(5003.0, WALL0 + 5003.0)
    assert (again.history.summary(DAY), again.history.rows(DAY)) == before
    assert again.section("history")["trips"] == 5


def test_the_database_is_sqlite_in_wal_mode_and_survives_reopening(tmp_path: Path) -> None:
    h = History(tmp_path / "h.sqlite")
    assert h.db.execute("PRAGMA journal_mode").fetchone() == ("wal",)
    h.trip("Kbot/v/1", "2027-01-15", WALL0, "Kbot", "113", 1.0, 1.0)
    assert h.first_time("Kbot/event/1", WALL0) and not h.first_time("Kbot/event/1", WALL0)
    assert h.outcome("Kbot/v/1", "completed", WALL0 + 60) and not h.outcome("Kbot/v/1", "cancelled", WALL0 + 70)
    assert h.wait("Kbot/v/1", 4.0) and not h.wait("Kbot/v/1", 9.0)
    h.commit()
    h.close()
    h = History(tmp_path / "h.sqlite")
    assert h.rows("2027-01-15")[0][8:11] == ("completed", WALL0 + 60, 4.0)
    assert not h.first_time("Kbot/event/1", WALL0)


def test_a_days_csv_is_safe_in_a_spreadsheet(tmp_path: Path) -> None:
    h = History(tmp_path / "h.sqlite")
    h.trip("-2+3/v/1", "2027-01-15", WALL0, "=cmd|'/C calc'!A0", "@SUM(1)", 0.0, 3.0, "+x.tour", 2)
    h.outcome("-2+3/v/1", "timed_out", WALL0 + 30)
    h.trip("Kbot/v/2", "2027-01-15", WALL0 + 5, "Kbot", "113", 1.0, 1.0)
    text = h.csv("2027-01-15")
    rows = list(csv.reader(io.StringIO(text)))
    assert tuple(rows[0]) == CSV_COLUMNS
    assert rows[1][:3] == ["'-2+3/v/1", rows[1][1], "'=cmd|'/C calc'!A0"] and rows[1][4] == "'@SUM(1)"
    assert rows[1][6:9] == ["'+x.tour", "2", "timed_out"] and rows[2][8] == "open"
    assert all(not cell.startswith(("=", "+", "-", "@", "\t", "\r")) for row in rows for cell in row)
    assert text.endswith("\r\n") and len(rows) == 3
    assert [safe_cell(v) for v in ("=1", "\tx", "ok", 3, -1.5)] == ["'=1", "'\tx", "ok", 3, -1.5]


def test_a_trip_first_known_by_its_events_gets_its_goal_later(faculty, tmp_path: Path) -> None:
    core = make_core(faculty, tmp_path)
    trip = cross_trip()
    core.on_event(event("Tartalo", Phase.ON_THE_WAY, trip.uid, stamp=0.0), "Tartalo", 1.0)
    core.on_goal(replace(trip, attempt=3), "Tartalo", 2.0)
    core.step(3.0, WALL0 + 3.0)
    [row] = core.history.rows(DAY)
    assert (row[0], row[2], row[4], row[5], row[11], row[12]) == (trip.uid, "Tartalo", "305", 3.0, "Tartalo",
                                                                  "MariSorgin")
