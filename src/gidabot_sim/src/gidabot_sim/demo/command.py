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
    bin/gidabot demo --goal 012 --walk speed=0.5,pause=20:60   # a slow visitor who stops a minute
    bin/gidabot demo --gui                             # open each robot's GUI too
    bin/gidabot demo --dashboard                       # every robot's staff dashboard; prints their URLs
    bin/gidabot demo --visitors 20 --seed 1            # many visitors at random robots
    bin/gidabot demo --speed max --trace               # which processes use the CPU while the floors fall behind

``--trace``: every look at the floors' clocks (every 0.2 s of wall time) also samples every process's CPU into
trace.jsonl in the run folder; at the end the demo prints which processes used the CPU while the floors fell
behind their ceiling (gidabot_sim.demo.trace, kept in run.json under "trace"). The sampling itself costs CPU (it
reads /proc for every process of the run five times a second), printed too.
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from gidabot_navigation.building.model import Building, load_building
from gidabot_navigation.errors import BuildingError, TourError, TourNameError
from gidabot_navigation.interface import WAY_STAIRS, WAYS
from gidabot_navigation.resources import resource
from gidabot_navigation.tours.tour_file import parse_tour
from gidabot_sim.demo.run import DEFAULT_SPEED, LOOK_PERIOD, MAX_SPEED_GUESS, DemoPlan, run_demo
from gidabot_sim.demo.trace import TRACE_FILE
from gidabot_sim.errors import DemoError, SimConfigError
from gidabot_sim.runner.building_runner import CLOCK_MAX_HZ, CLOCK_MIN_HZ
from gidabot_sim.runner.command_line import RUNS, check_network, load_tour, run_command
from gidabot_sim.visitor.behaviour import parse_walk
from gidabot_sim.visitor.population import PATIENCE_S, VisitorPlan, make_population

START_STOP_S, SIM_S_PER_GOAL = 120.0, 300.0   # the default --timeout
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
    p.add_argument("--people", type=int, default=0, metavar="N",
                   help="N bystanders on every floor with a robot, walking between its places (some standing a while "
                        "in a corridor), nobody's visitor (deterministic from --seed; default 0)")
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
    p.add_argument("--clock-rate", type=float, default=None, metavar="HZ",
                   help="/clock messages per wall second at most, on every floor (default: one per second of sim "
                        f"time at the speed, {CLOCK_MIN_HZ:g} to {CLOCK_MAX_HZ:g}: the CPU of the building's nodes "
                        "receiving it against the sim-time resolution of their clocks)")
    p.add_argument("--way", choices=WAYS, default=WAY_STAIRS, help="how the visitor changes floors")
    p.add_argument("--walk", default=None, metavar="KEY=VALUE,...",
                   help="how the visitor's body walks (default: tidy, 1.1 m/s, 1 m behind its robot, no pauses): "
                        "speed=M/S (0.5-1.4), gap=M (0.3-5, behind its robot), pause=START:DURATION (s after the "
                        "visit started; may repeat), group=N (1-4 bodies walking as one visitor), wander_at=S "
                        "(walks off for good then), e.g. 'speed=0.5,pause=20:60,group=3,wander_at=40' "
                        "(docs/simulator.md, People); not with --visitors (each draws its own)")
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


def _visit(args: argparse.Namespace, building: Building) -> tuple[str, int, str, float, frozenset[int]]:
    """(label, number of goals, tour file name, start floor, tour steps on floors without robot) of what the
    visitor does."""
    if args.goal:
        if building.find_location(args.goal) is None:
            raise DemoError(f"--goal {args.goal!r} is not a location of {building.id}")
        start = args.start_floor if args.start_floor is not None else building.robots[0].floor
        return f"goal-{args.goal}", 1, "", float(start), frozenset()
    tour = load_tour(args.tour, building)
    start = args.start_floor if args.start_floor is not None else tour.goals[0].floor
    alone = frozenset(k for k, g in enumerate(tour.goals) if not building.has_robot(g.floor))
    return args.tour.stem, len(tour.goals), args.tour.name, float(start), alone


def _validate(args: argparse.Namespace, building: Building, start_floor: float) -> None:
    if args.speed is not None and not (math.isfinite(args.speed) and 0 < args.speed <= 200):
        raise DemoError(f"--speed {args.speed:g}: expected a factor in (0, 200], or max")
    if args.clock_rate is not None and not (math.isfinite(args.clock_rate) and 1 <= args.clock_rate <= 1000):
        raise DemoError(f"--clock-rate {args.clock_rate:g}: expected 1..1000 messages per wall second")
    if not 0 <= args.people <= 100:
        raise DemoError(f"--people {args.people}: expected 0..100 bystanders per floor")
    if not (math.isfinite(args.visit_time) and args.visit_time >= 0):
        raise DemoError(f"--visit-time {args.visit_time:g}: expected sim seconds >= 0")
    if args.timeout is not None and not (math.isfinite(args.timeout) and args.timeout > 0):
        raise DemoError(f"--timeout {args.timeout:g}: expected wall seconds > 0")
    if not building.has_robot(start_floor):
        raise DemoError(f"start floor {start_floor:g} has no robot (robots: "
                        f"{', '.join(f'{r.name} {r.floor:g}' for r in building.robots)})")
    if args.secret is not None and not args.secret.is_file():
        raise DemoError(f"--secret {args.secret}: not a file")
    check_network(args.net, args.machines)
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


def plan(args: argparse.Namespace) -> DemoPlan:
    """What the arguments ask the demo to run, checked (DemoError, BuildingError: one of them is wrong); a
    default ``--timeout`` (None) is set from it."""
    building = load_building(args.building)
    if args.walk is not None:     # checked here (every bad key or value named); the visitor nodes parse it again
        if args.visitors is not None:
            raise DemoError("--walk is the one visitor's; with --visitors each visitor draws how it walks from --seed")
        try:
            parse_walk(args.walk)
        except SimConfigError as err:
            raise DemoError(f"--walk: {err}") from err
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
    return DemoPlan(building, label, total, tour_name, start_floor, alone, skips, plans)


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    return run_command("demo", args.json, lambda out, stop: run_demo(args, plan(args), out, stop),
                       (DemoError, BuildingError))
