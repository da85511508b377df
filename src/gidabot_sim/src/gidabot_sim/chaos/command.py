"""``gidabot chaos``: the simulated building runs a tour while faults are injected.

Starts the simulated Faculty as ``gidabot demo`` does (four masters, six relays, every
robot's nodes, the simulated visitor, one rosbag per robot) plus a chaos probe on every
master, waits for the tour to start, then injects the faults of a seeded schedule one
after the other (:func:`gidabot_sim.chaos.schedule.make_schedule`): link cuts between two
robots (iptables between their addresses, a relay end stopped, a relay supervisor
killed), a restart of every robot's master, node restarts, process freezes, people
standing in corridors, hostile messages on any master, and overlapping faults (two
masters down at once, a link cut during a master restart, a partition longer than
``partner_timeout``). With ``--machines`` every robot is a separate machine (a network
namespace of its own, :mod:`gidabot_sim.runner.machines`) whose clock is off by up to 5
minutes, and the faults of a real network are added: a robot partitioned, every link
flapping, one-way loss, a lossy link, a robot's machine gone for 5 minutes. It measures
every recovery, waits for the tour to end, stops everything, and prints a table: faults by
kind, recovery times, what became of every request of the visitor, goals accepted /
completed / lost / duplicated, the paper's Table 3 (expected, from the probes, from the
bags), every hostile message and the node that counted it, crashed nodes, the tour
directories. Definitions and measured runs: docs/chaos.md.

    bin/gidabot chaos                          # Table 2 tour, seed 1, every kind of fault (~29)
    bin/gidabot chaos --machines --seed 7 --json   # separate machines; one JSON object on stdout
    bin/gidabot chaos --profile quick --tour tours/real_world.tour

Needs root (iptables, network namespaces). Exit status: 0 every target met, 1 a target
missed, 2 bad arguments, 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import time
from pathlib import Path
from typing import TextIO

from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import BuildingError
from gidabot_navigation.interface import WAY_STAIRS, WAYS
from gidabot_navigation.resources import resource
from gidabot_sim.chaos.bookkeeping import Bookkeeping
from gidabot_sim.chaos.injectors import Injector
from gidabot_sim.chaos.result import ChaosResult
from gidabot_sim.chaos.run import ChaosRun
from gidabot_sim.chaos.schedule import KINDS, PROFILES
from gidabot_sim.chaos.table3 import expected_table3, fold_table3, trips_with_retries
from gidabot_sim.errors import ChaosError, DemoError, ProcessError, ReportError
from gidabot_sim.report.bags import load_run
from gidabot_sim.report.tables import analyse
from gidabot_sim.runner.command_line import (
    EXIT_FAILED,
    EXIT_OK,
    RUNS,
    Signals,
    check_network,
    load_tour,
    run_command,
)

DEFAULT_SEED = 1


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="gidabot chaos", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"fault schedule seed (default {DEFAULT_SEED})")
    p.add_argument("--tour", type=Path, default=resource("tours", "long_tour.tour"),
                   help="tour to run (default: tours/long_tour.tour, the paper's Table 2)")
    p.add_argument("--profile", choices=sorted(PROFILES), default="full",
                   help="how many faults: full = every kind, several of most (about 26), quick = one or two of "
                        "each kind")
    p.add_argument("--speed", type=float, default=None,
                   help="sim seconds per wall second (default: slow enough for the tour to outlast the faults)")
    p.add_argument("--way", choices=WAYS, default=WAY_STAIRS)
    p.add_argument("--start-floor", type=float, default=None, help="default: the tour's first floor")
    p.add_argument("--building", type=Path, default=resource("maps", "faculty"))
    p.add_argument("--out", type=Path, default=RUNS,
                   help="output folder; the run goes to OUT/<date>-<time>-chaos-<tour>-seed<N>/")
    p.add_argument("--timeout", type=float, default=None, help="wall seconds before giving up")
    p.add_argument("--net", type=int, default=None, metavar="N", help="masters on 127.N.0.11... (tests)")
    p.add_argument("--machines", action="store_true",
                   help="every robot a separate machine (network namespace, firewall, clock off by up to 5 "
                        "minutes) and the faults of a real network between them")
    p.add_argument("--json", action="store_true", help="print the result as one JSON object (progress on stderr)")
    return p.parse_args(argv)


def run_chaos(args: argparse.Namespace, out: TextIO, stop: Signals) -> int:
    building = load_building(args.building)
    tour = load_tour(args.tour, building)
    if args.start_floor is None:
        args.start_floor = tour.goals[0].floor
    if not building.has_robot(args.start_floor):
        raise ChaosError(f"start floor {args.start_floor:g} has no robot")
    if args.speed is not None and not (math.isfinite(args.speed) and 0 < args.speed <= 50):
        raise ChaosError(f"--speed {args.speed:g}: expected a factor in (0, 50]")
    check_network(args.net, args.machines)
    if shutil.which("iptables") is None:
        raise ChaosError("iptables is not installed (make setup installs it): link cuts need it")
    run = ChaosRun(args, building, tour, out, lambda: bool(stop))
    injector = Injector(run)
    counts = {k: sum(1 for f in run.schedule if f.kind == k) for k in KINDS}
    print(f"GidaBot chaos: seed {args.seed}, tour {tour.file_name} ({len(tour.goals)} goals), speed {args.speed:g}x, "
          f"{len(run.schedule)} faults ({', '.join(f'{k} {v}' for k, v in counts.items() if v)})"
          + (f"; separate machines, clocks {', '.join(f'{r} {o:+g} s' for r, o in run.clock_offsets.items())}"
             if args.machines else "") + f"\nrun folder: {run.run_dir}", file=out, flush=True)
    error = ""
    try:
        run.start()
        run.say("building started; waiting for every robot on every master")
        run.wait_ready()
        run.tours_before = run.tour_dirs()
        run.say("ready; waiting for the tour's first goal")
        while not run.watch.goals and not run.over():
            run.pause(0.5)
            run.check_alive()
        run.say(f"tour started; injecting {len(run.schedule)} faults")
        injector.run_faults()
        run.wait_for_tour()
        run.say(f"tour: {run.outcome()}")
        run.pause(2.0)    # the last events reach every probe and recorder
    except (ChaosError, DemoError, ProcessError, OSError) as err:
        error = str(err)
        print(f"gidabot chaos: {err}", file=sys.stderr)
    finally:
        injector.clear_network_faults()
        hostile = run.hostile_counters() if run.probes and not error else {}
        relays = run.relay_counters() if run.probes and not error else {}
        run.mark_logs()
        began = time.monotonic()
        for p in run.probes.values():
            p.close()
        if run.sim is not None:
            run.sim.stop()
            run.say(f"stopped every process in {time.monotonic() - began:.1f} s"
                    + (f"; ignored SIGINT: {', '.join(run.sim.forced)}" if run.sim.forced else ""))
    if run.sim is None or run.sim.building is None:
        return EXIT_FAILED
    return finish(run, hostile, relays, error, out)


def finish(run: ChaosRun, hostile: dict[str, int], relays: dict[str, int], error: str, out: TextIO) -> int:
    args = run.args
    assert run.sim is not None and run.sim.building is not None
    records = [rec for p in run.probes.values() for rec in p.records()]
    book = Bookkeeping(run.building, records)
    fates = book.fates()
    crashes, tbs = run.crashes()
    if run.sim.forced:
        crashes += [f"ignored SIGINT at shutdown: {n}" for n in run.sim.forced]
    lost, answered, _ = book.partner_notices()
    outcome = error or run.outcome()
    # the tour's length on one clock (the host's, as the probes saw it): the robots' clocks may disagree
    events = [r for r in records if r.get("k") == "event" and r.get("tour_file") == run.tour.file_name
              and r.get("m") == r.get("robot")]
    walls = [float(e.get("w", 0.0)) for e in events]
    wall_s = max(walls) - min(walls) if walls else 0.0
    sim_s = wall_s * float(args.speed)
    run_json = {"building": "building/building.yaml", "tour": run.tour.file_name, "goals": len(run.tour.goals),
                "completed": run.watch.last_step_done + 1, "outcome": outcome, "speed": args.speed, "seed": args.seed,
                "sim_s": round(sim_s, 1), "wall_s": round(wall_s, 1),
                "robots": [{"name": r.name, "floor": r.floor, "bag": f"{r.name}.bag",
                            "bags": [p.name for p in run.sim.recorders.bags.get(r.name, [])]} for r in run.base.robots],
                "bag_parts_never_recorded": run.sim.recorders.never_recorded}
    (run.run_dir / "run.json").write_text(json.dumps(run_json, indent=2), encoding="utf-8")
    bags: dict[str, tuple[int, int]] = {}
    bags_error = ""
    try:
        rep_run, rep_records = load_run(run.run_dir)
        rep = analyse(rep_records, rep_run)
        bags = {r["name"]: (r["received"], r["processed"]) for r in rep["robots"]}
        bad = {f"{r.name} {topic}": n for r in rep_records for topic, n in r.bad.items() if n}
        if bad:
            bags_error = "unreadable messages: " + ", ".join(f"{k} {v}" for k, v in bad.items())
        (run.run_dir / "report.json").write_text(json.dumps(rep, indent=2), encoding="utf-8")
    except ReportError as err:
        bags_error = str(err)
    steps = book.visit(fates, run.tour.file_name, len(run.tour.goals))
    # the tour's Table 3; a step the system ended counts as the trip of the retry that completed it
    expected = expected_table3(run.building, trips_with_retries(run.step_trips, book.retried_routes(steps)))
    result = ChaosResult(
        seed=args.seed, tour=run.tour.file_name, speed=args.speed, faults=run.results, fates=fates,
        duplicated_cancels=book.duplicated_cancels(), republished_cancels=book.duplicated_cancels(republished=True),
        table3_expected=expected,
        table3_measured=fold_table3(run.building, book.table3(fates)),
        table3_bags=fold_table3(run.building, bags) if bags else {}, tours_intact=False, tours_problems=[],
        crashes=crashes, tracebacks=tbs, hostile_rejected=hostile, partner_lost=lost, partner_answered=answered,
        tour_completed=book.tour_finished(run.tour.file_name, len(run.tour.goals) - 1), outcome=outcome,
        run_folder=str(run.run_dir), wall_s=wall_s, sim_s=sim_s, steps=steps,
        table3_bags_expected=book.table3_with(expected, fates, book.retried_goals(steps)), bags_error=bags_error,
        machines=bool(args.machines), relay_counters=relays,
        table3_tour=expected_table3(run.building, run.trips))
    problems = run.tours_problems() if run.tours_before else ["the tour directories were never read"]
    result.tours_intact, result.tours_problems = not problems, problems
    doc = result.to_json()
    (run.run_dir / "chaos.json").write_text(json.dumps(doc, indent=2), encoding="utf-8")
    print("\n" + result.format(), file=out, flush=True)
    print(f"\nrun folder: {run.run_dir}  (chaos.json, chaos/<robot>.jsonl, bags, logs/)", file=out, flush=True)
    if args.json:
        print(json.dumps(doc))
    return EXIT_OK if not result.failures() else EXIT_FAILED


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    return run_command("chaos", args.json, lambda out, stop: run_chaos(args, out, stop), (DemoError, BuildingError))
