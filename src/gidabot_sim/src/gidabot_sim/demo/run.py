"""One run of ``gidabot demo`` (ROS-free): the simulated building started, followed to the visit's end, stopped,
reported.

:func:`run_demo` starts the building (:class:`~gidabot_sim.runner.building_runner.SimulatedBuilding`) for what
the arguments asked (:class:`DemoPlan`, from :func:`gidabot_sim.demo.command.plan`), shows the visit's progress
from the monitor's records (:mod:`gidabot_sim.demo.progress`, or :class:`~gidabot_sim.report.crowd.Crowd` for
many visitors) while looking at the floors' clocks (:mod:`gidabot_sim.demo.timing`; with ``--speed max``
:mod:`gidabot_sim.demo.governor` sets their ceiling; with ``--trace`` :mod:`gidabot_sim.demo.trace` samples
every process's CPU), stops everything, writes ``run.json`` and prints the run's report
(:mod:`gidabot_sim.report.run_report`).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from typing import TextIO

from gidabot_navigation.building.model import Building
from gidabot_sim.demo.cpu import CpuSnapshot, cpu_table
from gidabot_sim.demo.governor import SpeedGovernor
from gidabot_sim.demo.progress import Progress, Visit
from gidabot_sim.demo.timing import RunTiming
from gidabot_sim.demo.trace import TRACE_FILE, TraceWriter, format_summary, load, summarize
from gidabot_sim.errors import DemoError, ProcessError
from gidabot_sim.report.crowd import UNFINISHED, Crowd
from gidabot_sim.report.run_report import report_run
from gidabot_sim.runner.building_runner import SimulatedBuilding, clock_rate_for, state_rate_args
from gidabot_sim.runner.command_line import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, Signals, run_folder, seed_tours
from gidabot_sim.runner.proc_info import machine_busy_s
from gidabot_sim.runner.procs import robot_address
from gidabot_sim.visitor.population import VisitorPlan

DEFAULT_SPEED = 20.0
MAX_SPEED_GUESS = 50.0    # --speed max: the factor the state topics' rates and the default --timeout assume
# wall s from every robot being up to the visit's start (the visitor's ~start_delay, in sim s at the speed): the
# start-up's last processes keep both cores of a 2-core machine busy for a second or two after the last robot
# reports (measured with /proc/stat); a tour starting then starts with its floors starved
START_SETTLE_WALL_S = 3.0
LOOK_PERIOD = 0.2         # wall s between two looks at the floors' clocks


@dataclass(frozen=True)
class DemoPlan:
    """What a demo runs, from its arguments, checked."""

    building: Building
    label: str                        # the run folder's name after its date and time
    total: int                        # goals of the one visitor, or visitors
    tour_name: str                    # the visitor's tour file ("": one target, or many visitors)
    start_floor: float
    alone: frozenset[int]             # tour steps on floors without robot
    skips: list[list[int]]            # --skip: [step, step it goes to], 0-based
    plans: tuple[VisitorPlan, ...]    # --visitors: every visitor


def speed_label(speed: float | None) -> str:
    return "max" if speed is None else f"{speed:g}x"


def run_demo(args: argparse.Namespace, demo: DemoPlan, out: TextIO, stop: Signals) -> int:
    """Run the building through ``demo``; the exit status (EXIT_OK: the visit completed and its report passed)."""
    building, label, total, tour_name = demo.building, demo.label, demo.total, demo.tour_name
    start_floor, alone, skips, plans = demo.start_floor, demo.alone, demo.skips, demo.plans
    speed = args.speed or MAX_SPEED_GUESS   # what the wall-time rates and the timeout assume
    wall_begin, machine_begin = time.time(), machine_busy_s()
    run_dir = run_folder(args.out, label)
    seed = seed_tours(run_dir, args.tour if tour_name else None, tour_name)
    clock_rate = args.clock_rate or clock_rate_for(speed)     # /clock per wall s (docs/demo.md, "Speed")
    launch_args = {"gui_fullscreen": "false", **state_rate_args(speed), "sim_clock_rate": f"{clock_rate:g}",
                   "sim_people": str(args.people), "sim_people_seed": str(1 if args.seed is None else args.seed)}
    start_delay = round(START_SETTLE_WALL_S * speed, 3)
    visitor = {"tour_file": tour_name, "goal_id": args.goal or "", "way": args.way, "skips": skips,
               "start_floor": start_floor, "visit_time": args.visit_time, "start_delay": start_delay,
               "walk": args.walk or ""}
    if plans:
        # what each visitor chose at the screen (asked, or left: a wait shown was too long) goes to the monitor's file
        visitor = {"population": [p.to_dict() for p in plans], "visit_time": args.visit_time,
                   "record": str(run_dir / "monitor.jsonl"), "start_delay": start_delay}
    what = f"tour {tour_name}" if tour_name else f"goal {args.goal}"
    if plans:
        patience = "any wait" if args.patience is None else f"{args.patience[0]:g}-{args.patience[1]:g} s"
        what = f"{len(plans)} visitors (seed {args.seed}, one every {args.mean_gap:g} s on average, patience " \
               f"{patience})"
    print(f"GidaBot demo: {building.name}: {len(building.robots)} robots "
          f"({', '.join(f'{r.name} {r.floor:g}' for r in building.robots)}), {len(building.relay_pairs())} relays; "
          f"{what} ({total} goals), visitor from floor {start_floor:g} by the {args.way}"
          f"{f', walking {args.walk}' if args.walk and not plans else ''}, "
          f"speed {speed_label(args.speed)}{'' if args.seed is None else f', seed {args.seed}'}"
          f"{', GUIs' if args.gui else ', headless'}"
          f"{', one machine (network namespace) per robot' if args.machines else ''}\nrun folder: {run_dir}",
          file=out, flush=True)

    addresses = ([robot_address(i, args.net) for i in range(len(building.robots))] if args.net is not None
                 else None)
    visit = Visit(building, building.robots[0].name, tour_name, args.goal or "", start_floor)   # monitor: robot 0
    progress: Progress | Crowd = Crowd(plans) if plans else \
        Progress(total_goals=total, visit=visit, robots_total=len(building.robots), alone=alone)
    governor = SpeedGovernor(start=MAX_SPEED_GUESS) if args.speed is None else None     # --speed max
    sim = SimulatedBuilding(args.building, run_dir, speed=governor.start if governor else args.speed,
                            seed=args.seed, gui=args.gui, relay_secret=args.secret, seed_tours=seed,
                            addresses=addresses, common_args=launch_args, visitor=visitor, machines=args.machines,
                            dashboard=args.dashboard)
    timing = RunTiming([r.name for r in building.robots], sim.peer_timeout)
    failure = ""
    tour_cpu: list[CpuSnapshot] = []   # --cpu: every process's CPU when the first goal appeared
    trace: TraceWriter | None = None    # --trace
    try:
        trace = TraceWriter(run_dir / TRACE_FILE) if args.trace else None
        sim.start(cancelled=lambda: bool(stop))
        if args.dashboard:
            _print_dashboards(sim, out)
        failure = _follow(sim, progress, timing, governor, args, wall_begin, out, stop,
                          tour_cpu if args.cpu else None, trace)
        if not stop and progress.finished:
            time.sleep(2.0)  # the last poses and events reach the recorders
        if args.cpu:
            cpu_table(sim, wall_begin, machine_begin, tour_cpu[0] if tour_cpu else None, out)
    except (DemoError, ProcessError, OSError) as err:   # a process that cannot start, a full disk...
        failure = str(err)
        print(f"gidabot demo: {err}", file=sys.stderr)
    finally:
        if trace is not None:
            trace.close()
        stop_begin = time.time()
        sim.stop()
        print(f"stopped every process in {time.time() - stop_begin:.1f} s"
              + (f"; ignored SIGINT: {', '.join(sim.forced)}" if sim.forced else "")
              + (f"; left by their parents and killed: {', '.join(sim.killed_leftovers)}"
                 if sim.killed_leftovers else ""), file=out, flush=True)
    total_wall = time.time() - wall_begin
    ended = "completed" if isinstance(progress, Crowd) and progress.finished else ""
    outcome = f"interrupted ({stop.received})" if stop else failure or ended or getattr(progress, "outcome", "") \
        or "not finished"
    what_ran = f"{len(plans)} visitors" if plans else tour_name or f"goal {args.goal}"
    done = sum(progress.visit_end(v)[0] != UNFINISHED for v in progress.plans) if isinstance(progress, Crowd) \
        else progress.done
    run = {
        "building": "building/building.yaml", "tour": what_ran, "goals": len(progress.goals) if plans else total,
        "completed": done, "stops_alone": sorted(alone) if tour_name else None, "outcome": outcome,
        "sim_s": progress.sim_seconds(), "wall_s": progress.wall_seconds(), "total_wall_s": round(total_wall, 1),
        "speed": "max" if args.speed is None else args.speed, "seed": args.seed, "timing": timing.summary(),
        "governor": governor.summary() if governor else None,
        "status_rate": float(launch_args["status_rate"]), "pose_rate": float(launch_args["pose_rate"]),
        "clock_rate": clock_rate,
        "way": args.way, "start_floor": start_floor, "skips": skips, "walk": None if plans else args.walk,
        "robots": [{"name": r.name, "floor": r.floor, "bag": f"{r.name}.bag"} for r in building.robots],
    }
    run["trace"] = _trace_summary(trace, timing) if trace is not None else None
    if plans:
        run.update(visitors=len(plans), population=[p.to_dict() for p in plans])
    (run_dir / "run.json").write_text(json.dumps(run, indent=2), encoding="utf-8")
    ratio = run["sim_s"] / run["wall_s"] if run["wall_s"] > 0 else 0.0
    counted = "visits ended; visitors:" if plans else "goals done; tour:"
    print(f"\nOutcome: {outcome}; {run['completed']} of {total} {counted} sim {run['sim_s']:.0f} s, "
          f"wall {run['wall_s']:.0f} s, sim/wall {ratio:.1f}x; whole demo {total_wall:.0f} s wall "
          f"(start-up and shut-down included)\n", file=out, flush=True)
    if run["trace"] is not None:
        print("\n".join(format_summary(run["trace"])) + "\n", file=out, flush=True)
    code = EXIT_FAILED
    if all((run_dir / f"{r.name}.bag").exists() for r in building.robots):
        code = report_run(run_dir, json_out=args.json)
    else:
        print(f"gidabot demo: no bags in {run_dir} (the run did not get that far)", file=out)
    print(f"\nrun folder: {run_dir}  (bags, run.json, report.json, paths_floor*.png, logs/)", file=out, flush=True)
    if stop:
        return EXIT_INTERRUPTED
    return EXIT_OK if code == 0 and (ended if plans else progress.outcome) == "completed" else EXIT_FAILED


def _print_dashboards(sim: SimulatedBuilding, out: TextIO) -> None:
    """Each robot's dashboard: its address (on the robot's own address; with separate machines, reached from this
    host through the staff machine) and how to give staff a password."""
    assert sim.building is not None
    print("staff dashboards:", file=out)
    for r in sim.building.robots:
        url, here = sim.dashboard_url(r.name), sim.staff_url(r.name)
        print(f"  {r.name:<12} {url}" + (f"  (from this host: {here})" if here != url else ""), file=out)
    print(f"  staff users: bin/gidabot dashboard-passwd {sim.run_dir / 'dashboard' / '<ROBOT>'} USER "
          "[--role admin]", file=out, flush=True)


def _trace_summary(trace: TraceWriter, timing: RunTiming) -> dict | None:
    """``--trace``: the trace summarised over the tour (its first goal to its end, or the last look at the clocks),
    the whole trace if the tour never started; None if the trace cannot be read (said on stderr)."""
    try:
        samples = load(trace.path)
    except OSError as err:
        print(f"gidabot demo: {err}", file=sys.stderr)
        return None
    if timing.first_wall is None:
        return summarize(samples)
    return summarize(samples, start_wall=timing.first_wall, end_wall=timing.latest_wall)


def clocks_line(timing: RunTiming) -> str:
    """The floors' achieved factors since the tour started, and their time behind the ceiling."""
    summary = timing.summary()["floors"]
    if not summary:
        return ""
    factors = " ".join(f"{f['achieved_factor']:.0f}" for f in summary.values())
    behind = max(f["behind_s"] for f in summary.values())
    return f" | sim/wall {factors}, behind {behind:.1f} s, drift {timing.max_drift:.1f} s"


def _follow(sim: SimulatedBuilding, progress: Progress | Crowd, timing: RunTiming, governor: SpeedGovernor | None,
            args: argparse.Namespace, wall_begin: float, out: TextIO, stop: Signals,
            tour_cpu: list[CpuSnapshot] | None = None, trace: TraceWriter | None = None) -> str:
    """Show progress until the visit ends, a process dies, the timeout, or a signal. Returns a failure or "".
    ``governor`` (``--speed max``): sets every floor's ceiling from the floors' clocks; ``trace`` (``--trace``):
    gets the clocks and every process's CPU at every look."""
    assert sim.monitor_file is not None
    shown = ""
    deadline = wall_begin + args.timeout
    next_track = next_look = 0.0
    with open(sim.monitor_file, encoding="utf-8") as feed:
        while not progress.finished and not stop:
            if time.monotonic() >= next_look:
                clocks, now = sim.clocks(), time.time()
                timing.look(clocks, now, bool(progress.goals))
                ceiling = governor.look(clocks, now, bool(progress.goals)) if governor else None
                if ceiling is not None:
                    sim.set_ceiling(ceiling)
                if trace is not None:
                    cost_from = time.process_time()    # reading /proc is the trace's cost too
                    trace.sample(now, clocks, sim.cpu_usage(), cost_from)
                next_look = time.monotonic() + LOOK_PERIOD
            line = feed.readline()
            if line:
                if progress.feed_line(line):
                    if tour_cpu is not None and not tour_cpu and progress.goals:
                        tour_cpu.append(CpuSnapshot(time.time(), sim.cpu_usage()))
                    if progress.goals and not timing.first or progress.finished:
                        timing.look(sim.clocks(), time.time(), True)    # the tour's start and end, exactly
                    text = progress.line()
                    if text != shown:
                        held = f", ceiling {governor.ceiling:g}x" if governor else ""
                        print(f"[{time.time() - wall_begin:6.1f} s] {text}{clocks_line(timing)}{held}", file=out,
                              flush=True)
                        shown = text
                continue
            if time.monotonic() >= next_track:   # know every node, so that stop() finds them all
                sim.track()
                next_track = time.monotonic() + 5.0
            dead = sim.dead()
            if dead:
                return f"{', '.join(dead)} stopped unexpectedly (see {sim.run_dir / 'logs'})"
            if time.time() > deadline:
                return f"timed out after {args.timeout:.0f} s of wall time ({progress.line()})"
            time.sleep(0.2)
    return ""

