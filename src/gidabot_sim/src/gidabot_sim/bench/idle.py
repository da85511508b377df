"""``gidabot bench idle [--json]``: what a building at rest costs, per robot: CPU per wall second, no visitor, 1x.

Starts the simulated building (every robot's master and ``robot.launch sim:=true``: simulator, move_base and amcl
stand-ins, guiding, tour store, relay ends; no visitor, no recorder, no monitor) at 1x, the demo's launch
arguments otherwise, waits until every floor's clock runs and ``--settle`` more wall seconds (the start-up's last
processes), then reads every process's CPU time at the start and at the end of ``--seconds`` wall seconds. Each
process is counted in the process group it was started in (``robot_<R>``: the robot's roslaunch and every node
it started; ``master_<R>``: its master), so the figure per robot is its whole software at rest. Printed per robot
(ms of CPU per wall s, and its largest kinds of process) and in all; ``--json``: one object with ``robots``
(``name``, ``ms_per_wall_s``, ``per_kind_ms_per_wall_s``), ``per_kind_ms_per_wall_s`` (all robots),
``ms_per_wall_s_per_robot`` (their mean), ``calibration``. Target: none; the figure is compared before and after a
change, on one machine, back to back. Run it alone: ``flock /tmp/gidabot-heavy.lock bin/gidabot bench idle``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from tempfile import mkdtemp

from gidabot_navigation.building.model import load_building
from gidabot_navigation.resources import resource
from gidabot_sim.errors import DemoError, ProcessError
from gidabot_sim.runner.building_runner import SimulatedBuilding, clock_rate_for
from gidabot_sim.runner.calibration import Calibration, as_json, describe
from gidabot_sim.runner.command_line import bench_arguments, progress_printer
from gidabot_sim.runner.procs import robot_address

Row = dict[str, object]      # one process: owner (its process group's name), process (node / program), pid, cpu_s


def idle_cost(before: list[Row], after: list[Row], wall_s: float, robots: list[str]) -> dict:
    """CPU per wall second of each robot's process groups (``robot_<R>``, ``master_<R>``) between two readings of
    every process's CPU (a process absent from ``before`` counts from 0); per robot, per kind, and their mean."""
    if wall_s <= 0:
        raise ValueError(f"wall_s {wall_s}: expected > 0")
    start = {int(r["pid"]): float(r["cpu_s"]) for r in before}  # type: ignore[arg-type]
    per_robot: dict[str, dict[str, float]] = {r: {} for r in robots}
    for row in after:
        owner = str(row["owner"])
        kind, _, robot = owner.partition("_")
        if robot not in per_robot or kind not in ("robot", "master"):
            continue
        used = float(row["cpu_s"]) - start.get(int(row["pid"]), 0.0)  # type: ignore[arg-type]
        name = str(row["process"])
        per_robot[robot][name] = per_robot[robot].get(name, 0.0) + max(used, 0.0)
    rows, kinds = [], {}
    for robot in robots:
        cost = per_robot[robot]
        for name, cpu in cost.items():
            kinds[name] = kinds.get(name, 0.0) + cpu
        rows.append({"name": robot, "ms_per_wall_s": round(1000.0 * sum(cost.values()) / wall_s, 1),
                     "per_kind_ms_per_wall_s": {k: round(1000.0 * v / wall_s, 2)
                                                for k, v in sorted(cost.items(), key=lambda kv: -kv[1])}})
    return {"wall_s": round(wall_s, 1), "robots": rows,
            "ms_per_wall_s_per_robot": round(sum(r["ms_per_wall_s"] for r in rows) / max(len(rows), 1), 1),
            "per_kind_ms_per_wall_s": {k: round(1000.0 * v / wall_s, 2)
                                       for k, v in sorted(kinds.items(), key=lambda kv: -kv[1])}}


def format_text(result: dict) -> list[str]:
    lines = [f"a building at rest (1x, no visitor), {result['wall_s']:g} s of wall time: CPU per robot per wall "
             f"second (its roslaunch, every node of it, its master)"]
    for row in result["robots"]:
        top = ", ".join(f"{k} {v:.1f}" for k, v in list(row["per_kind_ms_per_wall_s"].items())[:6])
        lines.append(f"  {row['name']:<12} {row['ms_per_wall_s']:7.1f} ms/s  ({top})")
    lines.append(f"  mean per robot: {result['ms_per_wall_s_per_robot']:.1f} ms of CPU per wall s "
                 f"({result['ms_per_wall_s_per_robot'] / 10:.2f} % of a core)")
    lines.append("  per kind, all robots (ms/s): " + ", ".join(
        f"{k} {v:.1f}" for k, v in result["per_kind_ms_per_wall_s"].items()))
    return lines


def measure(building_dir: Path, seconds: float, settle: float, net: int | None, out: Path, clock_rate: float,
            say: object = print) -> dict:
    """Start the building at rest, wait for its clocks and ``settle``, measure ``seconds``; stop it."""
    building = load_building(building_dir)
    robots = [r.name for r in building.robots]
    addresses = [robot_address(i, net) for i in range(len(robots))] if net is not None else None
    run_dir = out / "idle"
    # at 1x the state topics' rates are guiding's defaults (state_rate_args); /clock at clock_rate
    sim = SimulatedBuilding(building_dir, run_dir, speed=1.0, seed=1, record=False, monitor=False, visitor=None,
                            addresses=addresses, common_args={"sim_clock_rate": f"{clock_rate:g}"})
    with sim:
        sim.start()
        deadline = time.monotonic() + 120.0
        while True:                              # every floor's clock runs (each robot's simulator is up)
            clocks = sim.clocks()
            if clocks and all(c.sim >= 1.0 for c in clocks.values()):
                break
            if time.monotonic() > deadline or sim.dead():
                raise DemoError(f"the floors' clocks did not start (dead: {sim.dead()})")
            time.sleep(0.5)
        say(f"every floor's clock runs; settling {settle:g} s, then measuring {seconds:g} s")  # type: ignore[operator]
        time.sleep(settle)
        before, began = sim.cpu_usage(), time.monotonic()
        time.sleep(seconds)
        after, wall = sim.cpu_usage(), time.monotonic() - began
        if sim.dead():
            raise DemoError(f"processes died while idle: {', '.join(sim.dead())}")
    return idle_cost(before, after, wall, robots)


def main(argv: list[str] | None = None) -> int:
    ap = bench_arguments("gidabot bench idle", __doc__)
    ap.add_argument("--building", type=Path, default=resource("maps", "faculty"), help="building (default: faculty)")
    ap.add_argument("--seconds", type=float, default=30.0, help="wall s measured (default 30)")
    ap.add_argument("--settle", type=float, default=10.0, help="wall s after the clocks run, before (default 10)")
    ap.add_argument("--net", type=int, default=None, help="masters on 127.N.0.x (as gidabot demo --net)")
    ap.add_argument("--out", type=Path, default=None, help="run folder (default: a new temporary folder)")
    ap.add_argument("--clock-rate", type=float, default=None, metavar="HZ",
                    help="/clock per wall second (default: gidabot demo's at 1x)")
    args = ap.parse_args(argv)
    say = progress_printer(args.json)
    clock_rate = args.clock_rate or clock_rate_for(1.0)
    out = args.out or Path(mkdtemp(prefix="gidabot-bench-idle-"))
    calibration = Calibration()
    calibration.measure()
    try:
        result = measure(args.building, args.seconds, args.settle, args.net, out, clock_rate, say)
    except (DemoError, ProcessError) as err:
        print(f"gidabot bench idle: {err}", file=sys.stderr)
        return 1
    calibration.measure()
    result["calibration"], result["out"], result["clock_rate"] = as_json(calibration), str(out), clock_rate
    if args.json:
        print(json.dumps(result))
    else:
        for line in format_text(result):
            print(line)
        print(describe(calibration))
    return 0


if __name__ == "__main__":
    sys.exit(main())
