"""A run folder's whole report (ROS-free): what ``gidabot report`` writes and prints, and the demo after a run.

:func:`make_report` reads the run folder (:mod:`gidabot_sim.report.bags`), makes the tables
(:mod:`gidabot_sim.report.tables`), with many visitors their part (:func:`crowd_report`) and, unless told not
to, the path plots (:mod:`gidabot_sim.report.plots`); :func:`show_report` writes ``report.json`` and prints it
(tables, ``--json`` or ``--markdown``); :func:`report_run` does both, as ``gidabot report`` and the demo after
its run do, and returns the exit status: 1 when the folder cannot be read or the verdict of a run with many
visitors is FAILED.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from gidabot_sim.errors import ReportError, SimConfigError
from gidabot_sim.report.bags import load_run, run_building
from gidabot_sim.report.crowd import Crowd
from gidabot_sim.report.plots import plot_paths
from gidabot_sim.report.tables import analyse
from gidabot_sim.report.text import format_markdown, format_tables
from gidabot_sim.visitor.population import VisitorPlan, plans_from_list

PASSED_VERDICT, FAILED_VERDICT = "PASSED", "FAILED"
COLLISIONS_NOTE = ("robot-robot contacts counted by each robot's floor simulator (a contact in which both robots "
                   "drove counts for each)")


def crowd_report(folder: Path, run: dict, report: dict) -> dict:
    """The many-visitors part of a run's report (``gidabot demo --visitors``; docs/demo.md): per visitor and per
    robot from the monitor's records (:mod:`gidabot_sim.report.crowd`), the legs' audit from the bags, a verdict."""
    building = run_building(folder, run)
    try:
        plans = plans_from_list(run["population"], building) if building is not None else \
            tuple(VisitorPlan.from_dict(p) for p in run["population"])
    except SimConfigError as err:
        raise ReportError(f"{folder / 'run.json'}: population: {err}") from err
    crowd = Crowd(plans)
    monitor = folder / "monitor.jsonl"
    try:
        with open(monitor, encoding="utf-8") as lines:
            for line in lines:
                crowd.feed_line(line)
    except OSError as err:
        raise ReportError(f"{monitor}: cannot read ({err.strerror})") from err
    summary = crowd.summary([r["name"] for r in run.get("robots", [])])
    legs = report["legs"]
    problems = list(summary["problems"])
    problems += [f"leg {leg} of {uid} served by {', '.join(robots)}" for uid, leg, robots in legs["double_served"]]
    problems += [f"leg {leg} of {uid} served by nobody" for uid, leg in legs["unserved"]]
    contacts = report.get("contacts") or {"collisions": None, "deadlocks": 0, "per_robot": {}, "unmeasured": []}
    if contacts["collisions"] is None:
        problems.append("robot-robot collisions not measured (no count from the simulator of "
                        f"{', '.join(contacts['unmeasured']) or 'any robot'})")
    elif contacts["collisions"]:
        problems.append(f"{contacts['collisions']} robot-robot collision(s): "
                        + ", ".join(f"{r} {n}" for r, n in contacts["per_robot"].items() if n))
    if run.get("outcome") not in (None, "completed"):
        problems.append(f"the run did not finish: {run.get('outcome')}")
    return {"visitors": summary["visitors"], "completed": summary["completed"], "cancelled": summary["cancelled"],
            "timed_out": summary["timed_out"], "left": summary["left"], "failed": summary["failed"],
            "refused": summary["refused"], "unfinished": summary["unfinished"], "asked_again": summary["asked_again"],
            "collisions": contacts["collisions"], "collisions_note": COLLISIONS_NOTE,
            "deadlocks": contacts["deadlocks"],
            "legs_double_served": len(legs["double_served"]), "legs_unserved": len(legs["unserved"]),
            "wait_mean_s": summary["wait_mean_s"], "wait_p95_s": summary["wait_p95_s"], "seed": run.get("seed"),
            "population": summary, "problems": problems,
            "verdict": FAILED_VERDICT if problems else PASSED_VERDICT}


def make_report(folder: Path, plots: bool = True) -> tuple[dict, dict]:
    """(run.json, the report) of the run folder ``folder``; ReportError when it cannot be read."""
    run, records = load_run(folder)
    report = analyse(records, run)
    if run.get("population") is not None:
        report.update(crowd_report(folder, run, report))
    report["run_folder"] = str(folder.resolve())
    if plots:
        report["plots"] = [str(p) for p in plot_paths(folder, run, records)]
    return run, report


def show_report(folder: Path, run: dict, report: dict, json_out: bool = False, markdown: bool = False) -> int:
    """Write ``report.json`` into ``folder`` and print the report: one JSON object, Markdown, or the tables and
    the plots written. Returns 1 when the verdict is FAILED, else 0."""
    (folder / "report.json").write_text(json.dumps(report, indent=2), encoding="utf-8")
    if json_out:
        print(json.dumps(report))
    elif markdown:
        print(format_markdown(report, run, folder))
    else:
        print(format_tables(report))
        for p in report.get("plots", []):
            print(f"wrote {p}")
    return 1 if report.get("verdict") == FAILED_VERDICT else 0


def report_run(folder: Path, json_out: bool = False, markdown: bool = False, plots: bool = True) -> int:
    """The report of the run folder ``folder`` made, written and printed (``gidabot report``); its exit status:
    1 when the folder cannot be read (said on stderr) or the verdict is FAILED."""
    try:
        run, report = make_report(folder, plots)
    except ReportError as err:
        print(f"gidabot report: {err}", file=sys.stderr)
        return 1
    return show_report(folder, run, report, json_out, markdown)
