"""A run's report as text (ROS-free): the tables ``gidabot report`` prints, and the same in Markdown.

:func:`format_tables` prints Tables 3 and 5, the run's timing per floor (:func:`format_timing`), who served the
legs, robot contacts and notes on hostile or unreadable messages, and for many visitors their tables and the
verdict (:func:`format_crowd`). :func:`format_markdown` gives Tables 3 and 5, the timing and the CPU per kind of
process as docs/demo.md shows them.
"""

from __future__ import annotations

import json
from pathlib import Path

from gidabot_navigation.interface import Topic


def format_crowd(report: dict) -> list[str]:
    """The many-visitors tables: per robot, per visitor, overall, the verdict."""
    pop = report["population"]
    chosen = ", ".join(f"{k} {n}" for k, n in pop["intents"].items())
    lines = ["", f"Visitors: {report['visitors']} (seed {report.get('seed')}): {report['completed']} completed, "
                 f"{report['cancelled']} cancelled, {report['timed_out']} timed out, {report.get('left', 0)} left "
                 f"at the screen, {report['failed']} failed, {report['refused']} refused, "
                 f"{report.get('lost', 0)} lost, {report['unfinished']} unfinished; chosen: {chosen}"]
    pace = (report.get("pace") or {}).get("totals")
    if pace and pace.get("legs"):
        behind = "-" if pace["mean_behind_m"] is None else f"{pace['mean_behind_m']:.1f} m"
        worst = "-" if pace["worst_behind_m"] is None else f"{pace['worst_behind_m']:.1f} m"
        lines.append(f"The visitor's pace ({pace['legs']} guided legs): behind the robot mean {behind}, worst {worst}; "
                     f"waited {pace['waiting_s']:.0f} s; {pace['slowdowns']} slow-downs, {pace['waits']} waits, "
                     f"{pace['searches']} searches, {pace['lost']} lost, {pace['found_again']} found again")
    for lost in (report.get("pace") or {}).get("lost") or ():
        lines.append(f"  visitor lost by {lost['robot']} at {lost['t']:.0f} s ({lost['goal_uid']}): " + _where(lost))
    wait = "-" if report["wait_mean_s"] is None else f"{report['wait_mean_s']:.1f} s"
    p95 = "-" if report["wait_p95_s"] is None else f"{report['wait_p95_s']:.1f} s"
    lines.append(f"Wait before the first robot moved: mean {wait}, 95th percentile {p95}")
    head = f"{'Robot':<12} {'Legs':>5} {'Busy':>6} {'Queue max':>10} {'Queue mean':>11}"
    lines += ["", head, "-" * len(head)]
    lines += [f"{r['robot']:<12} {r['legs_served']:>5} {100 * r['busy_fraction']:>5.0f}% {r['queue_max']:>10} "
              f"{r['queue_mean']:>11.2f}" for r in pop["per_robot"]]
    head = f"{'Visitor':<11} {'At':<12} {'Target':<18} {'Way':<7} {'Chose':<9} {'Arrive':>7} {'Shown':>6} " \
           f"{'Patience':>8} {'Wait':>7} {'Trip':>7}  Outcome"
    lines += ["", head, "-" * len(head)]

    def s(value: float | None) -> str:
        return "-" if value is None else f"{value:.0f}"

    for v in pop["per_visitor"]:
        again = f" (asked again {v['asked_again']}x)" if v.get("asked_again") else ""
        lines.append(f"{v['visitor']:<11} {v['robot']:<12} {v['target']:<18} {v['way']:<7} {v['intent']:<9} "
                     f"{v['arrive_s']:>7.0f} {s(v.get('shown_wait_s')):>6} {s(v.get('patience_s')):>8} "
                     f"{s(v['wait_s']):>7} {s(v['trip_s']):>7}  {v['outcome']}{again}"
                     + ("" if v["as_chosen"] else "  <- not as chosen"))
    lines += ["", "Collisions (robot-robot): not measured" if report["collisions"] is None else
              f"Collisions (robot-robot): {report['collisions']} ({report['collisions_note']}); deadlocks "
              f"reported: {report.get('deadlocks', 0)}"]
    lines.append(f"Verdict: {report['verdict']}" + "".join(f"\n  {p}" for p in report["problems"]))
    return lines


def format_tables(report: dict) -> str:
    lines = ["Goal messages per robot (paper Table 3) and guiding data (paper Table 5)", ""]
    head = f"{'Robot':<12} {'Floor':>5} {'Received':>9} {'Processed':>10} {'Time (s)':>9} {'Dist. (m)':>10} " \
           f"{'Mean vel. (m/s)':>16}"
    lines += [head, "-" * len(head)]
    for r in report["robots"]:
        lines.append(f"{r['name']:<12} {r['floor']:>5g} {r['received']:>9} {r['processed']:>10} {r['time_s']:>9.1f} "
                     f"{r['distance_m']:>10.1f} {r['mean_velocity_mps']:>16.2f}")
    t = report["tour"]
    lines.append(f"{'Tour':<12} {'':>5} {'':>9} {'':>10} {t['time_s']:>9.1f} {t['distance_m']:>10.1f} "
                 f"{t['mean_velocity_mps']:>16.2f}")
    lines += ["", f"Goals completed: {t['completed']} of {t['goals']}"
                  f"   sim time {t['sim_s']:.0f} s, wall time {t['wall_s']:.0f} s "
                  f"(sim/wall {t['sim_to_wall']:.1f}x)"]
    lines += format_timing(report.get("timing") or {})
    legs = report.get("legs")
    if legs:
        verdict = "each served by exactly one robot" if not legs["double_served"] and not legs["unserved"] else \
            f"{len(legs['double_served'])} served by two robots or more, {len(legs['unserved'])} by none"
        lines.append(f"Legs: {legs['legs']}, {verdict} ("
                     + ", ".join(f"{r} {n}" for r, n in sorted(legs["served_by"].items())) + ")")
        lines += [f"  two robots on {uid} {leg}: {', '.join(robots)}" for uid, leg, robots in legs["double_served"]]
        lines += [f"  nobody on {uid} {leg}" for uid, leg in legs["unserved"]]
    contacts = report.get("contacts")
    if contacts and "population" not in report:
        lines.append("Robot-robot collisions: " + ("not measured" if contacts["collisions"] is None else
                                                   f"{contacts['collisions']}, deadlocks {contacts['deadlocks']}"))
    for robot, n in report.get("rejected_goals", {}).items():
        lines.append(f"note: {robot}: {n} message(s) on {Topic.GOALS} were not goals (hostile input), not counted")
    for where, n in report.get("unreadable_messages", {}).items():
        lines.append(f"warning: {where}: {n} message(s) in the bag could not be deserialised (skipped)")
    if "population" in report:
        lines += format_crowd(report)
    return "\n".join(lines)


def format_timing(timing: dict) -> list[str]:
    floors = timing.get("floors") or {}
    if not floors:
        return []
    def short(name: str) -> str:
        return name.rsplit("/", 1)[-1].split(" ")[0]

    nodes = sorted({short(n) for f in floors.values() for n in (*f["controllers"], *f["guiding"])})
    lines = ["", "Timing over the tour, per floor (docs/simulator.md): achieved sim/wall factor, wall time behind the "
                 "speed ceiling, rates against nominal (%)", ""]
    head = f"{'Robot':<12} {'sim/wall':>8} {'behind (s)':>10} {'behind %':>8} " + " ".join(
        f"{n[:12]:>12}" for n in nodes)
    lines += [head, "-" * len(head)]
    for robot, f in floors.items():
        rates = {short(n): r["rate_pct"] for kind in ("controllers", "guiding") for n, r in f[kind].items()}
        lines.append(f"{robot:<12} {f['achieved_factor']:>8.1f} {f['behind_s']:>10.2f} {f['behind_pct']:>8.2f} "
                     + " ".join(f"{rates[n]:>12.0f}" if n in rates else f"{'-':>12}" for n in nodes))
    drift = timing.get("max_drift_s")
    lines.append("")
    lines.append(("largest drift between floors: " + (f"{drift:.1f} s sim" if drift is not None else "not measured"))
                 + ("; DEGRADED: " + "; ".join(timing["reasons"]) if timing.get("degraded") else "; not degraded"))
    return lines


def format_markdown(report: dict, run: dict, folder: Path) -> str:
    """Tables 3 and 5, the timing per floor and (with ``cpu.json``) the CPU per kind of process, in Markdown."""
    t = report["tour"]
    speed = run.get("speed")
    lines = [f"`gidabot demo --tour {t['file']} --speed {speed}"
             + (f" --seed {run['seed']}`" if run.get("seed") is not None else "`")
             + f": {t['completed']} of {t['goals']} goals, tour sim {t['sim_s']:.0f} s, wall {t['wall_s']:.1f} s "
             f"(sim/wall {t['sim_to_wall']:.1f}x)", "",
             "| Robot | Floor | Received | Processed | Time (s) | Dist. (m) | Mean vel. (m/s) |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in report["robots"]:
        lines.append(f"| {r['name']} | {r['floor']:g} | {r['received']} | {r['processed']} | {r['time_s']:.1f} | "
                     f"{r['distance_m']:.1f} | {r['mean_velocity_mps']:.2f} |")
    lines.append(f"| Tour | | | | {t['time_s']:.1f} | {t['distance_m']:.1f} | {t['mean_velocity_mps']:.2f} |")
    timing = report.get("timing") or {}
    floors = timing.get("floors") or {}
    if floors:
        lines += ["", "| Floor's robot | sim/wall | behind (s) | waiting for controllers (s) | for floors (s) | "
                      "controllers (% of nominal) | guiding loops (% of nominal) |",
                  "|---|---:|---:|---:|---:|---|---|"]
        for robot, f in floors.items():
            ctl = ", ".join(f"{n.rsplit('/', 1)[-1]} {v['rate_pct']:.0f}" for n, v in f["controllers"].items())
            gui = ", ".join(f"{n.split(' ')[0]} {v['rate_pct']:.0f}" for n, v in f["guiding"].items())
            lines.append(f"| {robot} | {f['achieved_factor']:.1f} | {f['behind_s']:.2f} | "
                         f"{f['wait_controllers_s']:.2f} | {f['wait_floors_s']:.2f} | {ctl} | {gui} |")
        lines += ["", f"Largest drift between floors: {timing.get('max_drift_s')} s of sim time; "
                      + ("**degraded**: " + "; ".join(timing["reasons"]) if timing.get("degraded") else "not degraded")
                      + "."]
    cpu_file = folder / "cpu.json"
    if cpu_file.exists():
        cpu = json.loads(cpu_file.read_text(encoding="utf-8")).get("tour") or {}
        sim_s = float(t.get("sim_s") or 0.0)
        if cpu and sim_s > 0:
            lines += ["", f"CPU during the tour: {cpu['cpu_s']:.0f} s in {cpu['wall_s']:.0f} s of wall time "
                          f"({cpu['cores']:.2f} cores), {1000.0 * cpu['cpu_s'] / sim_s:.1f} ms per simulated second:",
                      "", "| process (all robots) | CPU s | ms per sim s | cores |", "|---|---:|---:|---:|"]
            for kind, sec in cpu["per_kind_cpu_s"].items():
                lines.append(f"| {kind} | {sec:.1f} | {1000.0 * sec / sim_s:.2f} | {sec / cpu['wall_s']:.3f} |")
    return "\n".join(lines)


def _where(lost: dict) -> str:
    """Where the robot and the lost visitor's body were (a row of ``where_lost``)."""
    robot = "robot at -" if lost["robot_at"] is None else "robot at ({:.1f}, {:.1f})".format(*lost["robot_at"])
    if lost["body_at"] is not None:
        body = "visitor at ({:.1f}, {:.1f}), {:.1f} m away".format(*lost["body_at"], lost["distance_m"] or 0.0)
    else:
        body = {None: "visitor's position not recorded", False: "visitor no longer on the floor"}[lost["on_floor"]]
    return f"{robot}, {body}"
