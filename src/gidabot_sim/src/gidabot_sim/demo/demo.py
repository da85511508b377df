"""``gidabot demo``: the simulated Faculty of Informatics (or any building) running a tour, unattended.

Starts one master per robot (the faculty: Tartalo floor 0, Kbot 1, Galtxagorri 2,
MariSorgin 3), a relay per pair of robots (HMAC secret file), a simulator per robot,
every robot's nodes and the simulated visitor (one node per robot's screen); runs the
tour (default: the paper's real-world tour, Table 4); shows progress; records one
rosbag per robot; then prints the paper's tables (3 and 5), sim time, wall time and
where it wrote everything. Ctrl-C (or SIGTERM) stops everything cleanly and keeps the
bags of the partial run.

    bin/gidabot demo                                   # Table 4 tour, headless
    bin/gidabot demo --tour tours/long_tour.tour       # Table 2, 15 goals
    bin/gidabot demo --goal 305 --way lift             # one target
    bin/gidabot demo --gui                             # open each robot's GUI too
    bin/gidabot demo --visitors 20 --seed 1            # many visitors at random robots (issue 18)
    bin/gidabot demo --speed max --trace               # which processes use the CPU while the floors fall behind
    bin/gidabot demo --dashboard                       # every robot's staff dashboard; prints their URLs

``--trace``: every look at the floors' clocks (every 0.2 s of wall time) also samples every process's CPU into
trace.jsonl in the run folder; at the end the demo prints which processes used the CPU while the floors fell
behind their ceiling (gidabot_sim.demo.trace, kept in run.json under "trace"). The sampling itself costs CPU (it
reads /proc for every process of the run five times a second), printed too.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TextIO

from gidabot_navigation.building.model import Building, load_building
from gidabot_navigation.errors import BuildingError, TourError, TourNameError
from gidabot_navigation.interface import WAY_STAIRS, WAYS
from gidabot_navigation.resources import resource
from gidabot_navigation.tours.tour_file import check_tour_file_name, parse_tour
from gidabot_sim.demo import report
from gidabot_sim.demo.crowd import UNFINISHED, Crowd
from gidabot_sim.demo.governor import SpeedGovernor
from gidabot_sim.demo.progress import Progress, Visit
from gidabot_sim.demo.timing import RunTiming
from gidabot_sim.demo.trace import TRACE_FILE, TraceWriter, format_summary, load, summarize
from gidabot_sim.errors import DemoError, ProcessError, SimConfigError
from gidabot_sim.runner.building_runner import RUNS, SimulatedBuilding
from gidabot_sim.runner.procs import robot_address
from gidabot_sim.visitor.population import PATIENCE_S, VisitorPlan, make_population

DEFAULT_SPEED = 20.0
# Wall-time rates of the state topics, whatever the speed. Guiding publishes them at rates in ROS (sim)
# time (2 Hz status, 5 Hz poses by default): at 20x that would be 40 + 100 messages per wall second per
# robot, every one of them handled by three relay ends and the recorder on each master (they cost more
# CPU than the rest of the building together). The relays forward at most 10 per second anyway; Table 5
# distances come from each robot's own /amcl_pose (a sample every 0.1 m), not from /gidabot/poses.
STATUS_WALL_HZ, POSE_WALL_HZ = 2.0, 5.0
START_STOP_S, SIM_S_PER_GOAL = 120.0, 300.0   # the default --timeout
STATUS_RATE, POSE_RATE = 2.0, 5.0       # guiding's defaults (Hz of ROS time), used up to 1x
# /clock messages per wall second at most (each floor's simulator; docs/demo.md, "Speed"): every node of a master
# receives every one (about 0.6 % of a core per node at 100 Hz, more with timers); at 100 Hz they were half the
# building's CPU at 50x (`bench demo`: 1.39 cores at 100 Hz, 1.12 at 50 Hz). At 50 Hz a /clock carries
# speed / 50 sim s: 0.2 s at 10x, 1 s at 50x.
CLOCK_WALL_HZ = 50.0
MAX_SPEED_GUESS = 50.0    # --speed max: the factor the rates above and the default --timeout assume
# wall s from every robot being up to the visit's start (the visitor's ~start_delay, in sim s at the speed): the
# start-up's last processes keep both cores of a 2-core machine busy for a second or two after the last robot
# reports (measured with /proc/stat); a tour starting then starts with its floors starved (one --speed max run:
# 0.1 s behind its ceiling in the tour's first 1.4 s, of 0.22 s in the whole tour, and it backed off on them)
START_SETTLE_WALL_S = 3.0
LOOK_PERIOD = 0.2         # wall s between two looks at the floors' clocks
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
MAX_TOUR_STOPS = 8        # --visitors: the longest tour a visitor may take
TOUR_STOPS_GUESS = 8      # --visitors: goals a tour visitor counts for in the default --timeout


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="gidabot demo", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--building", type=Path, default=resource("maps", "faculty"), help="building directory")
    p.add_argument("--tour", type=Path, default=resource("tours", "real_world.tour"),
                   help="tour file to run (default: tours/real_world.tour, the paper's Table 4)")
    p.add_argument("--goal", help="run one target (a location id, e.g. 305) instead of a tour")
    p.add_argument("--visitors", type=int, default=None, metavar="K",
                   help="K visitors instead of one: random arrival times, robots, targets or tours, stairs or lift, "
                        "some cancelling, some never turning up (deterministic from --seed); --tour, --goal, "
                        "--start-floor, --way and --skip are then not used")
    p.add_argument("--seed", type=int, default=1,
                   help="seed of the simulated sensor and localisation noise (robot i: SEED + i) and, with --visitors, "
                        "of the population (default 1)")
    p.add_argument("--mean-gap", type=float, default=30.0, metavar="S",
                   help="with --visitors: mean sim seconds between two arrivals (default 30)")
    p.add_argument("--patience", type=_patience, default=PATIENCE_S, metavar="LOW-HIGH",
                   help="with --visitors: each visitor's patience, uniform between LOW and HIGH sim s (default "
                        f"{PATIENCE_S[0]:g}-{PATIENCE_S[1]:g}): shown a longer wait before confirming, it leaves; "
                        "'none': every visitor confirms whatever the wait")
    p.add_argument("--start-floor", type=float, default=None,
                   help="floor where the visitor starts (default: the tour's first floor, else 0)")
    p.add_argument("--speed", type=_speed, default=DEFAULT_SPEED,
                   help=f"ceiling of sim seconds per wall second, the same on every floor (default "
                        f"{DEFAULT_SPEED:g}); 'max': as fast as this machine sustains")
    p.add_argument("--clock-rate", type=float, default=CLOCK_WALL_HZ, metavar="HZ",
                   help=f"/clock messages per wall second at most, on every floor (default {CLOCK_WALL_HZ:g}: the "
                        "CPU of the building's nodes receiving it against the sim-time resolution of their clocks)")
    p.add_argument("--way", choices=WAYS, default=WAY_STAIRS, help="how the visitor changes floors")
    p.add_argument("--visit-time", type=float, default=60.0, metavar="S",
                   help="sim seconds the visitor spends at a tour stop on a floor without robot (default 60)")
    p.add_argument("--skip", action="append", default=[], metavar="K:M",
                   help="after tour step K (1-based) go to step M (may repeat)")
    p.add_argument("--out", type=Path, default=RUNS,
                   help="output folder; the run goes to OUT/<date>-<time>-<tour>/ (default: runs/)")
    p.add_argument("--gui", action="store_true", help="open every robot's GUI (needs a display)")
    p.add_argument("--timeout", type=float, default=None,
                   help="wall seconds before giving up (default: 120 + 300 s of sim time per goal / speed)")
    p.add_argument("--secret", type=Path, default=None,
                   help="FILE with the relays' shared secret (default: a fresh random one in the run folder)")
    p.add_argument("--json", action="store_true",
                   help="print the final report as one JSON object on stdout (progress goes to stderr)")
    p.add_argument("--cpu", action="store_true",
                   help="print the CPU seconds each process of the run used (also written to cpu.json)")
    p.add_argument("--trace", action="store_true",
                   help=f"every look at the floors' clocks ({LOOK_PERIOD:g} s of wall time) also samples every "
                        f"process's CPU into {TRACE_FILE} in the run folder; at the end the demo prints which "
                        "processes used the CPU while the floors fell behind (gidabot_sim.demo.trace; run.json: "
                        "trace); the sampling itself costs CPU, printed too")
    p.add_argument("--net", type=int, default=None, metavar="N",
                   help="run the masters on 127.N.0.11, .12, ... (default: the building file's addresses)")
    p.add_argument("--dashboard", action="store_true",
                   help="every robot serves its staff web dashboard (docs/dashboard.md), on its own address; the "
                        "demo prints each robot's URL")
    p.add_argument("--machines", action="store_true",
                   help="every robot a separate machine: its own network namespace, address, master and firewall "
                        "(needs root; docs/deploy.md)")
    return p.parse_args(argv)


def _patience(text: str) -> tuple[float, float] | None:
    """``--patience``: ``LOW-HIGH`` sim s, or ``none``."""
    if text == "none":
        return None
    try:
        low, high = (float(v) for v in text.split("-"))
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"{text!r}: expected LOW-HIGH (sim s) or 'none'") from err
    if not (0 <= low <= high < float("inf")):
        raise argparse.ArgumentTypeError(f"{text!r}: expected 0 <= LOW <= HIGH")
    return low, high


def _speed(text: str) -> float | None:
    """``--speed``: a factor, or ``max`` (None: no fixed ceiling)."""
    if text == "max":
        return None
    try:
        return float(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a factor (sim s per wall s) or 'max'") from err


def speed_label(speed: float | None) -> str:
    return "max" if speed is None else f"{speed:g}x"


def _skips(values: list[str], goals: int) -> list[list[int]]:
    out = []
    for v in values:
        try:
            k, m = (int(x) for x in v.split(":"))
        except ValueError as err:
            raise DemoError(f"--skip {v!r}: expected K:M, two step numbers") from err
        if not (1 <= k < m <= goals):
            raise DemoError(f"--skip {v!r}: need 1 <= K < M <= {goals}")
        out.append([k - 1, m - 1])
    return out


class Signals:
    """SIGINT/SIGTERM set a flag (checked at safe points) instead of raising anywhere."""

    def __init__(self, log: Callable[[str], None]) -> None:
        self.received: str = ""
        self._log = log
        self._old: dict[int, object] = {}

    def __enter__(self) -> Signals:
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)  # type: ignore[arg-type]

    def _handle(self, signum: int, _frame: object) -> None:
        name = signal.Signals(signum).name
        if self.received:
            self._log(f"gidabot demo: {name} again: still stopping everything, please wait")
            return
        self.received = name
        self._log(f"\ngidabot demo: {name}: stopping everything (bags are closed first)")

    def __bool__(self) -> bool:
        return bool(self.received)


def _visit(args: argparse.Namespace, building: Building) -> tuple[str, int, str, float, frozenset[int]]:
    """(label, number of goals, tour file name, start floor, tour steps on floors without robot) of what the
    visitor does."""
    if args.goal:
        if building.find_location(args.goal) is None:
            raise DemoError(f"--goal {args.goal!r} is not a location of {building.id}")
        start = args.start_floor if args.start_floor is not None else building.robots[0].floor
        return f"goal-{args.goal}", 1, "", float(start), frozenset()
    try:
        check_tour_file_name(args.tour.name)
        tour = parse_tour(args.tour.read_bytes(), args.tour.name, building, source=str(args.tour))
    except (OSError, TourError, TourNameError) as err:
        raise DemoError(f"{args.tour}: {err}") from err
    start = args.start_floor if args.start_floor is not None else tour.goals[0].floor
    alone = frozenset(k for k, g in enumerate(tour.goals) if not building.has_robot(g.floor))
    return args.tour.stem, len(tour.goals), args.tour.name, float(start), alone


def _validate(args: argparse.Namespace, building: Building, start_floor: float) -> None:
    if args.speed is not None and not (math.isfinite(args.speed) and 0 < args.speed <= 200):
        raise DemoError(f"--speed {args.speed:g}: expected a factor in (0, 200], or max")
    if not (math.isfinite(args.clock_rate) and 1 <= args.clock_rate <= 1000):
        raise DemoError(f"--clock-rate {args.clock_rate:g}: expected 1..1000 messages per wall second")
    if not (math.isfinite(args.visit_time) and args.visit_time >= 0):
        raise DemoError(f"--visit-time {args.visit_time:g}: expected sim seconds >= 0")
    if args.timeout is not None and not (math.isfinite(args.timeout) and args.timeout > 0):
        raise DemoError(f"--timeout {args.timeout:g}: expected wall seconds > 0")
    if not building.has_robot(start_floor):
        raise DemoError(f"start floor {start_floor:g} has no robot (robots: "
                        f"{', '.join(f'{r.name} {r.floor:g}' for r in building.robots)})")
    if args.secret is not None and not args.secret.is_file():
        raise DemoError(f"--secret {args.secret}: not a file")
    if args.net is not None and not 1 <= args.net <= 254:
        raise DemoError(f"--net {args.net}: expected 1..254")
    if args.net is not None and args.machines:
        raise DemoError("--net and --machines exclude each other (separate machines have addresses of their own)")
    if args.gui and not os.environ.get("DISPLAY") and os.environ.get("QT_QPA_PLATFORM") != "offscreen":
        raise DemoError("--gui needs a display (DISPLAY is not set)")


def _population(args: argparse.Namespace, building: Building) -> tuple[VisitorPlan, ...]:
    """The visitors of ``--visitors``: the tours they may take are the tours shipped for every building that
    are valid for this one, up to MAX_TOUR_STOPS stops."""
    tours = {}
    for path in sorted(resource("tours").glob("*.tour")):
        try:
            tour = parse_tour(path.read_bytes(), path.name, building, source=str(path))
        except (OSError, TourError, TourNameError):
            continue
        if len(tour.goals) <= MAX_TOUR_STOPS:
            tours[path.name] = len(tour.goals)
    try:
        return make_population(building, args.visitors, args.seed, tours, mean_gap_s=args.mean_gap,
                               patience_s=args.patience)
    except SimConfigError as err:
        raise DemoError(str(err)) from err


def run_demo(args: argparse.Namespace, out: TextIO, stop: Signals) -> int:
    building = load_building(args.building)
    plans = _population(args, building) if args.visitors is not None else ()
    if plans:
        label, total, tour_name, start_floor, alone = f"visitors{len(plans)}-seed{args.seed}", len(plans), "", \
            building.robots[0].floor, frozenset()
    else:
        label, total, tour_name, start_floor, alone = _visit(args, building)
    _validate(args, building, start_floor)
    skips = _skips(args.skip, total) if not plans else []
    speed = args.speed or MAX_SPEED_GUESS   # what the wall-time rates and the timeout assume
    if args.timeout is None:   # a goal takes 60-150 s of sim time: three times that, plus start and stop
        stops = sum(TOUR_STOPS_GUESS if p.tour_file else 1 for p in plans) or total
        last_arrival = max((p.arrive_s for p in plans), default=0.0)
        args.timeout = START_STOP_S + (last_arrival + SIM_S_PER_GOAL * stops) / min(speed, DEFAULT_SPEED)

    wall_begin, machine_begin = time.time(), machine_busy_s()
    run_dir = args.out.resolve() / f"{datetime.now():%Y%m%d-%H%M%S}-{label}"
    seed = run_dir / "seed_tours"
    shutil.copytree(resource("tours"), seed, dirs_exist_ok=True)
    if tour_name:
        shutil.copy(args.tour, seed / tour_name)
    launch_args = {"gui_fullscreen": "false",
                   "status_rate": f"{min(STATUS_RATE, STATUS_WALL_HZ / speed):.4g}",
                   "pose_rate": f"{min(POSE_RATE, POSE_WALL_HZ / speed):.4g}",
                   "sim_clock_rate": f"{args.clock_rate:g}"}
    start_delay = round(START_SETTLE_WALL_S * speed, 3)
    visitor = {"tour_file": tour_name, "goal_id": args.goal or "", "way": args.way, "skips": skips,
               "start_floor": start_floor, "visit_time": args.visit_time, "start_delay": start_delay}
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
          f"{what} ({total} goals), visitor from floor {start_floor:g} by the {args.way}, "
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
            _cpu_table(sim, wall_begin, machine_begin, tour_cpu[0] if tour_cpu else None, out)
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
        "clock_rate": args.clock_rate,
        "way": args.way, "start_floor": start_floor, "skips": skips,
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
        code = report.main([str(run_dir)] + (["--json"] if args.json else []))
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


def machine_busy_s() -> float | None:
    """CPU seconds every core of this machine has been busy since boot (``/proc/stat``: all but idle and iowait),
    None where there is no /proc/stat."""
    try:
        with open("/proc/stat", encoding="ascii") as f:
            fields = f.readline().split()
    except OSError:
        return None
    if not fields or fields[0] != "cpu":
        return None
    ticks = [int(v) for v in fields[1:9]]            # user nice system idle iowait irq softirq steal
    return (sum(ticks) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")


@dataclass
class CpuSnapshot:
    wall: float
    rows: list[dict[str, object]]
    machine_s: float | None = field(default_factory=machine_busy_s)   # the whole machine's busy CPU s so far
    own_s: float = field(default_factory=lambda: sum(os.times()[:2]))  # this demo process's own CPU s so far


def _per_kind(rows: list[dict[str, object]], before: dict[int, float] | None = None) -> dict[str, float]:
    """CPU seconds per kind of process (node name / program), all robots together; minus ``before`` (pid ->
    CPU s at an earlier snapshot) when given."""
    kinds: dict[str, float] = {}
    for r in rows:
        cpu = float(r["cpu_s"]) - (before or {}).get(int(r["pid"]), 0.0)  # type: ignore[arg-type]
        kinds[str(r["process"])] = kinds.get(str(r["process"]), 0.0) + cpu
    return kinds


def _cpu_table(sim: SimulatedBuilding, begin: float, begin_machine: float | None, tour_start: CpuSnapshot | None,
               out: TextIO) -> None:
    """Print and save (cpu.json) what each kind of process cost: start-up, then the tour alone."""
    end = CpuSnapshot(time.time(), sim.cpu_usage())
    start = CpuSnapshot(begin, [], begin_machine, 0.0)
    if tour_start is None:
        phases = [("whole run", start, end, end.rows, None)]
    else:
        first = {int(r["pid"]): float(r["cpu_s"]) for r in tour_start.rows}  # type: ignore[arg-type]
        phases = [("start-up", start, tour_start, tour_start.rows, None), ("tour", tour_start, end, end.rows, first)]
    saved: dict[str, object] = {"processes": end.rows}
    for name, a, b, rows, before in phases:
        t0, t1 = a.wall, b.wall
        wall = max(t1 - t0, 1e-9)
        kinds = sorted(_per_kind(rows, before).items(), key=lambda kv: -kv[1])
        total = sum(cpu for _, cpu in kinds)
        # the whole machine over the same span: what the run's processes took, and what everything else did
        machine = b.machine_s - a.machine_s if a.machine_s is not None and b.machine_s is not None else None
        others = None if machine is None else max(0.0, machine - total - (b.own_s - a.own_s))
        saved[name] = {"wall_s": round(wall, 1), "cpu_s": round(total, 1), "cores": round(total / wall, 2),
                       "other_processes_cores": None if others is None else round(others / wall, 2),
                       "per_kind_cpu_s": {k: round(v, 1) for k, v in kinds}}
        beside = "" if others is None else f"; every other process of the machine: {others / wall:.2f} cores"
        print(f"\nCPU of the run's processes, {name}: {total:.0f} s in {wall:.0f} s of wall time "
              f"({total / wall:.2f} of {os.cpu_count()} cores{beside}); per kind of process (all robots together):",
              file=out)
        for kind, cpu in kinds:
            print(f"  {kind:<26} {cpu:7.1f} s  {100 * cpu / max(total, 1e-9):5.1f} %  {cpu / wall:5.2f} cores",
                  file=out)
    (sim.run_dir / "cpu.json").write_text(json.dumps(saved, indent=2), encoding="utf-8")


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    out = sys.stderr if args.json else sys.stdout
    with Signals(lambda text: print(text, file=out, flush=True)) as stop:
        try:
            return run_demo(args, out, stop)
        except (DemoError, BuildingError) as err:
            print(f"gidabot demo: {err}", file=sys.stderr)
            return EXIT_USAGE
