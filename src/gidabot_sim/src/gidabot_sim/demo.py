"""``gidabot demo``: the simulated Faculty of Informatics running a tour, unattended.

Starts four masters (Tartalo floor 0, Kbot 1, Galtxagorri 2, MariSorgin 3), the six
relays, a simulator per floor, every robot's nodes and a simulated visitor per
floor; runs the tour (default: the paper's real-world tour, Table 4); shows
progress; records one rosbag per robot; then prints the paper's tables and where
it wrote them. Ctrl-C stops everything cleanly.

    bin/gidabot demo                                   # Table 4 tour, headless
    bin/gidabot demo --tour tours/long_tour.tour       # Table 2, 15 goals
    bin/gidabot demo --goal 305 --way lift             # one target
    bin/gidabot demo --gui                             # open each robot's GUI too
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import sys
import time
from datetime import datetime
from pathlib import Path

from gidabot_navigation.building import load_building
from gidabot_navigation.errors import BuildingError, TourError, TourNameError
from gidabot_navigation.tours import check_tour_file_name, parse_tour
from gidabot_sim import report
from gidabot_sim.building_runner import REPO, SimulatedBuilding
from gidabot_sim.progress import Progress


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="gidabot demo", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--building", type=Path, default=REPO / "maps" / "faculty")
    p.add_argument("--tour", type=Path, default=REPO / "tours" / "real_world.tour", help="tour file to run")
    p.add_argument("--goal", help="run one target (a location id, e.g. 305) instead of a tour")
    p.add_argument("--speed", type=float, default=10.0, help="sim seconds per wall second (default 10)")
    p.add_argument("--way", choices=("stairs", "lift"), default="stairs", help="how the visitor changes floors")
    p.add_argument("--skip", action="append", default=[], metavar="K:M",
                   help="after tour step K (1-based) go to step M (may repeat)")
    p.add_argument("--out", type=Path, default=REPO / "runs", help="output folder (a run folder is made inside)")
    p.add_argument("--gui", action="store_true", help="open every robot's GUI (needs a display)")
    p.add_argument("--timeout", type=float, default=900.0, help="wall seconds before giving up")
    p.add_argument("--secret", default="gidabot-demo", help="relay shared secret (HMAC)")
    p.add_argument("--json", action="store_true", help="print the final report as JSON")
    return p.parse_args(argv)


def _skips(values: list[str], goals: int) -> list[list[int]]:
    out = []
    for v in values:
        try:
            k, m = (int(x) for x in v.split(":"))
        except ValueError as err:
            raise SystemExit(f"gidabot demo: --skip {v!r}: expected K:M, two step numbers") from err
        if not (1 <= k < m <= goals):
            raise SystemExit(f"gidabot demo: --skip {v!r}: need 1 <= K < M <= {goals}")
        out.append([k - 1, m - 1])
    return out


def _interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    try:
        building = load_building(args.building)
    except BuildingError as err:
        print(f"gidabot demo: {err}", file=sys.stderr)
        return 2
    if args.gui and not os.environ.get("DISPLAY") and os.environ.get("QT_QPA_PLATFORM") != "offscreen":
        print("gidabot demo: --gui needs a display (DISPLAY is not set)", file=sys.stderr)
        return 2
    if args.goal:
        if building.find_location(args.goal) is None:
            print(f"gidabot demo: --goal {args.goal!r} is not a location of {building.id}", file=sys.stderr)
            return 2
        label, total, tour_name = f"goal-{args.goal}", 1, ""
    else:
        try:
            check_tour_file_name(args.tour.name)
            tour = parse_tour(args.tour.read_bytes(), args.tour.name, building, source=str(args.tour))
        except (OSError, TourError, TourNameError) as err:
            print(f"gidabot demo: {args.tour}: {err}", file=sys.stderr)
            return 2
        label, total, tour_name = args.tour.stem, len(tour.goals), args.tour.name
    skips = _skips(args.skip, total)

    run_dir = args.out / f"{datetime.now():%Y%m%d-%H%M%S}-{label}"
    seed = run_dir / "seed_tours"
    shutil.copytree(REPO / "tours", seed, dirs_exist_ok=True)
    if tour_name and not (seed / tour_name).exists():
        shutil.copy(args.tour, seed / tour_name)
    start_floor = building.robots[0].floor
    visitor = {"visitor": "true", "visitor_tour": tour_name, "visitor_goal": args.goal or "",
               "visitor_way": args.way, "visitor_skips": json.dumps(skips)}
    print(f"GidaBot demo: {building.name}: {len(building.robots)} robots, {len(building.relay_pairs())} relays; "
          f"{'tour ' + tour_name if tour_name else 'goal ' + str(args.goal)} ({total} goals), "
          f"speed {args.speed:g}x, by the {args.way}; output {run_dir}")

    signal.signal(signal.SIGTERM, _interrupt)
    progress = Progress(total_goals=total, tour_mode=bool(tour_name))
    wall_start = time.time()
    sim = SimulatedBuilding(args.building, run_dir, speed=args.speed, gui=args.gui, relay_secret=args.secret,
                            seed_tours=seed, common_args=visitor)
    interrupted = False
    try:
        sim.start()
        assert sim.monitor_file is not None
        with open(sim.monitor_file, encoding="utf-8") as feed:
            shown = ""
            deadline = wall_start + args.timeout
            while not progress.finished and time.time() < deadline:
                line = feed.readline()
                if not line:
                    time.sleep(0.2)
                    continue
                if progress.feed_line(line):
                    text = progress.line()
                    if text != shown:
                        print(f"[{time.time() - wall_start:6.1f} s] {text}", flush=True)
                        shown = text
        if not progress.finished:
            progress.outcome = f"timed out after {args.timeout:g} s of wall time"
        time.sleep(2.0)  # let the last messages reach the recorders
    except KeyboardInterrupt:
        interrupted = True
        print("\ngidabot demo: interrupted; stopping everything", flush=True)
    finally:
        sim.stop()
    run = {
        "building": str(sim.building_file or args.building), "tour": tour_name or f"goal {args.goal}",
        "goals": total, "completed": len(progress.completed), "outcome": progress.outcome or "interrupted",
        "sim_s": progress.sim_seconds(), "wall_s": progress.wall_seconds(), "speed": args.speed, "way": args.way,
        "robots": [{"name": r.name, "floor": r.floor, "bag": f"{r.name}.bag"} for r in building.robots],
        "start_floor": start_floor,
    }
    (run_dir / "run.json").write_text(json.dumps(run, indent=2), encoding="utf-8")
    if interrupted:
        print(f"partial run in {run_dir}")
        return 130
    print(f"\nOutcome: {run['outcome']}; {run['completed']} of {total} goals; sim {run['sim_s']:.0f} s, "
          f"wall {run['wall_s']:.0f} s, ratio {run['sim_s'] / max(run['wall_s'], 1e-9):.1f}x\n")
    code = report.main([str(run_dir)] + (["--json"] if args.json else []))
    print(f"\nrun folder: {run_dir} (bags, report.json, paths_floor*.png, logs/)")
    return 0 if code == 0 and progress.outcome == "completed" else 1
