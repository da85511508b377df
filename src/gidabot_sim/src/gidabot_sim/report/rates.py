"""Can a run's sim time be trusted (ROS-free): each floor's timing over the tour, and the verdict.

Per floor over the tour: its achieved factor and the wall time its clock was behind its speed ceiling
(``run.json``'s ``timing``, from the floors' timeline), each lockstep controller's answers against the steps
it owed (move_base, amcl: its rate in sim time against nominal) and each guiding node's loop rate against
nominal (the floor's ``/diagnostics`` in its bag), the largest drift between floors. The run is *degraded*
when a floor was behind for more than ``MAX_BEHIND_PCT`` % of the tour or a rate fell below ``MIN_RATE_PCT`` %
of nominal.
"""

from __future__ import annotations

import json
import math

from gidabot_sim.report.bags import SIM_STATUS, DiagSample, RobotRecord

MAX_BEHIND_PCT = 1.0          # a floor behind its ceiling for more of the tour's wall time: degraded
MIN_RATE_PCT = 80.0           # a controller or guiding loop below this share of its nominal rate: degraded


def _bracket(samples: list[DiagSample], start: float, end: float) -> tuple[DiagSample, DiagSample] | None:
    """The samples around [start, end] (sim time): the last at or before ``start`` (else the first), the first at
    or after ``end`` (else the last)."""
    if len(samples) < 2:
        return None
    a = next((d for d in reversed(samples) if d.t <= start), samples[0])
    b = next((d for d in samples if d.t >= end), samples[-1])
    return (a, b) if b.t > a.t else None


def controller_rates(samples: list[DiagSample], start: float, end: float) -> dict[str, dict]:
    """Each lockstep participant of the floor's simulator over [start, end]: the steps it owed and answered in time
    (its achieved rate against its nominal one), the times the world stopped waiting for it."""
    pair = _bracket([d for d in samples if d.name.startswith(SIM_STATUS)], start, end)
    if pair is None:
        return {}
    out = {}
    for key, text in pair[1].values:
        if not key.startswith("participant "):
            continue
        try:
            after, before = json.loads(text), json.loads(pair[0].get(key, "{}"))
        except json.JSONDecodeError:
            continue
        delta = {k: after.get(k, 0) - before.get(k, 0) for k in ("owed", "answered", "timeouts", "waited_s")}
        owed = delta["owed"]
        out[key[len("participant "):]] = {"owed": owed, "answered": delta["answered"],
                                          "rate_pct": round(100.0 * delta["answered"] / owed, 1) if owed else 100.0,
                                          "timeouts": delta["timeouts"], "waited_s": round(delta["waited_s"], 3)}
    return out


def loop_rates(samples: list[DiagSample], start: float, end: float) -> dict[str, dict]:
    """Each guiding node's main loop over [start, end]: iterations per sim second, against its nominal rate (it
    wakes at least ``loop_nominal_hz`` times per wall second: at the floor's achieved factor, that many per sim
    second divided by it), and the longest wall gap between two iterations so far."""
    names = sorted({d.name for d in samples if d.name.startswith("guiding: ")})
    out = {}
    for name in names:
        pair = _bracket([d for d in samples if d.name == name], start, end)
        if pair is None:
            continue
        a, b = pair
        count = b.number("loop_count") - a.number("loop_count")
        ros = b.number("loop_ros") - a.number("loop_ros")
        wall = b.number("loop_wall") - a.number("loop_wall")
        nominal = b.number("loop_nominal_hz")
        if not all(math.isfinite(v) for v in (count, ros, wall, nominal)) or ros <= 0 or wall <= 0:
            continue
        out[name[len("guiding: "):]] = {
            "loops": int(count), "hz_sim": round(count / ros, 3), "nominal_hz_sim": round(nominal * wall / ros, 3),
            "rate_pct": round(100.0 * count / (nominal * wall), 1),
            "max_gap_wall_s": round(b.number("loop_max_gap_wall_s"), 3)}
    return out


def timing_report(records: list[RobotRecord], run: dict) -> dict:
    """Per floor over the tour (``run.json``'s ``timing``, from the timeline): achieved factor, wall time behind
    the speed ceiling and waiting; from the bags: its controllers' and guiding loops' rates. ``degraded``: a floor
    behind for more than ``MAX_BEHIND_PCT`` % of the tour, or a rate below ``MIN_RATE_PCT`` % of nominal (None:
    the run has no timing)."""
    timing = run.get("timing") or {}
    floors: dict[str, dict] = {}
    reasons = []
    for rec in records:
        floor = dict((timing.get("floors") or {}).get(rec.name) or {})
        if not floor:
            continue
        start, end = float(floor.get("sim_start", 0.0)), float(floor.get("sim_end", math.inf))
        floor["controllers"] = controller_rates(rec.diagnostics, start, end)
        floor["guiding"] = loop_rates(rec.diagnostics, start, end)
        floors[rec.name] = floor
        if floor.get("behind_pct", 0.0) > MAX_BEHIND_PCT:
            reasons.append(f"{rec.name}'s clock was behind its speed ceiling for {floor['behind_s']:.1f} s "
                           f"({floor['behind_pct']:.1f} % of the tour)")
        for kind in ("controllers", "guiding"):
            for node, rate in floor[kind].items():
                if rate["rate_pct"] < MIN_RATE_PCT:
                    reasons.append(f"{rec.name}'s {node} ran at {rate['rate_pct']:.0f} % of its nominal rate")
    return {"floors": floors, "max_drift_s": timing.get("max_drift_s"), "degraded": bool(reasons) if floors else None,
            "reasons": reasons}

