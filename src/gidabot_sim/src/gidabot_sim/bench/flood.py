"""``gidabot bench flood [--json]``: a valid request under a flood of invalid messages.

Every robot of the faculty gets its own master with its goal_manager, multirobot_navigation and
tour_store (the nodes a visitor's request and the hostile traffic reach; no relays: they carry
messages between masters, ``gidabot bench relay``). On every master one worker process plays
the visitor at the robot's screen: a REQUEST to a place on the robot's floor, timed until the
robot's own goal manager answers with ACCEPTED, then a CANCEL of that trip, one request after
the other. Side by side in one run:

1. *quiet*: ``--requests`` requests per robot, nothing else on the bus;
2. *flood*: the same while the worker publishes ``--rate`` (1000) invalid messages per second on
   its master: goals from robots that do not exist, to unknown places or with NaN floors,
   cancels and navigation events from robots that do not exist or with unknown phases, robot
   states with NaN poses, tours with traversal file names.

Printed per robot: answer time p50 / max (ms) quiet and flooded, the flood rate achieved (while
the requests were made), and the goal manager's state writes while the flood ran alone for
``FLOOD_ONLY_S`` before the flooded requests (its ``state_saves`` on ``/diagnostics``, counted from a
value that held still for ``SETTLE_S`` before the flood started: the quiet requests' writes are done).
Exit status 1 if a flooded answer takes more than 0.5 s (``LIMIT_S``), a state
file was written because of the flood, or a worker could not publish at 90 % of the rate (the
verdict would not mean anything).
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from gidabot_navigation.building.model import Building, load_building, relocate_building
from gidabot_navigation.resources import resource
from gidabot_sim.bench.workers import Worker, percentile
from gidabot_sim.runner.building_runner import node_executable
from gidabot_sim.runner.command_line import bench_arguments, progress_printer
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master, test_network

LIMIT_S = 0.5          # s: a valid request answered within this under the flood
MIN_RATE_SHARE = 0.9   # the flood must reach this share of --rate for the verdict to count
NODE = "gidabot_sim.bench.flood_node"     # the worker


def start_robot(group: ProcessGroup, building: Building, robot: str, tmp: Path) -> dict[str, str]:
    """The robot's master, goal_manager, multirobot_navigation and tour_store; returns its environment."""
    r = building.robot(robot)
    env = ros_env(r.master_uri, r.ip, log_dir=tmp / "ros" / robot)
    common = [f"_building:={building.path}", f"_robot:={robot}"]
    group.start(f"goal_manager_{robot}", [sys.executable, _node("goal_manager"), *common,
                                          f"_state_dir:={tmp / 'state' / robot}"], env)
    group.start(f"navigation_{robot}", [sys.executable, _node("multirobot_navigation"), *common,
                                        f"_state_dir:={tmp / 'state' / robot}"], env)
    group.start(f"tour_store_{robot}", [sys.executable, _node("tour_store"), *common,
                                        f"_tours_dir:={tmp / 'tours' / robot}", f"_seed_dir:={resource('tours')}"], env)
    return env


def _node(name: str) -> str:
    return node_executable("gidabot_navigation", name)


def run(tmp: Path, rate: float, requests: int, log) -> dict:
    net = test_network()
    faculty = load_building(resource("maps", "faculty"))
    with ProcessGroup(tmp / "logs") as group:
        uris = {r.name: start_master(group, f"master_{r.name}", robot_address(i, net))
                for i, r in enumerate(faculty.robots)}
        building = load_building(relocate_building(resource("maps", "faculty"), tmp / "building", uris))
        workers = []
        try:
            for r in building.robots:
                env = start_robot(group, building, r.name, tmp)
                workers.append(Worker(group, f"worker_{r.name}", env, NODE,
                                      ["--building", str(building.path), "--robot", r.name, "--rate", str(rate)]))
            for w in workers:
                w.expect("ready", 180)
            results: dict[str, dict] = {r.name: {} for r in building.robots}
            for phase in ("quiet", "flood"):
                log(f"  {phase}: {requests} requests per robot"
                    + (f", {rate:g} invalid messages/s on every master" if phase == "flood" else ""))
                for w in workers:
                    w.send(f"requests {requests}" + (" flood" if phase == "flood" else ""))
                for r, w in zip(building.robots, workers, strict=True):
                    results[r.name][phase] = w.expect("done", 60 + requests * 12)
        finally:
            for w in workers:
                w.close()
    rows = []
    for name, res in results.items():
        quiet, flood = res["quiet"]["ms"], res["flood"]["ms"]
        rows.append({"robot": name, "quiet_p50_ms": percentile(quiet, 50), "quiet_max_ms": max(quiet),
                     "flood_p50_ms": percentile(flood, 50), "flood_max_ms": max(flood),
                     "flood_rate_hz": res["flood"]["rate"], "state_writes_in_flood": res["flood"]["writes"]})
    return {"rate_hz": rate, "requests": requests, "limit_ms": LIMIT_S * 1000.0, "robots": rows}


def verdict(res: dict) -> list[str]:
    """What misses the targets (empty: passed)."""
    misses = []
    for row in res["robots"]:
        if not row["flood_max_ms"] <= res["limit_ms"]:
            misses.append(f"{row['robot']}: a request took {row['flood_max_ms']:.0f} ms under the flood "
                          f"(limit {res['limit_ms']:.0f} ms)")
        if row["state_writes_in_flood"] != 0:
            misses.append(f"{row['robot']}: {row['state_writes_in_flood']} state writes during the flood "
                          "(rejected messages must write nothing; -1: not measured)")
        if row["flood_rate_hz"] < MIN_RATE_SHARE * res["rate_hz"]:
            misses.append(f"{row['robot']}: the flood reached {row['flood_rate_hz']:.0f} msg/s only "
                          f"(< {MIN_RATE_SHARE:.0%} of {res['rate_hz']:g}): no verdict")
    return misses


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = bench_arguments("gidabot bench flood", __doc__)
    ap.add_argument("--rate", type=float, default=1000.0, help="invalid messages per second per master (1000)")
    ap.add_argument("--requests", type=int, default=15, help="timed requests per robot and phase (15)")
    args = ap.parse_args(argv)
    log = progress_printer(args.json)
    with tempfile.TemporaryDirectory(prefix="gidabot-bench-flood-") as tmpdir:
        log("flood benchmark: 4 masters, each robot's goal_manager, multirobot_navigation and tour_store")
        res = run(Path(tmpdir), args.rate, args.requests, log)
    misses = verdict(res)
    res["passed"], res["misses"] = not misses, misses
    if args.json:
        print(json.dumps(res, sort_keys=True))
    else:
        log(f"\n{'Robot':<12} {'quiet p50':>10} {'quiet max':>10} {'flood p50':>10} {'flood max':>10} "
            f"{'flood msg/s':>12} {'state writes':>13}")
        for r in res["robots"]:
            log(f"{r['robot']:<12} {r['quiet_p50_ms']:>8.1f}ms {r['quiet_max_ms']:>8.1f}ms {r['flood_p50_ms']:>8.1f}ms "
                f"{r['flood_max_ms']:>8.1f}ms {r['flood_rate_hz']:>12.0f} {r['state_writes_in_flood']:>13}")
        log("\n" + ("PASS: every request answered within "
                    f"{res['limit_ms']:.0f} ms under the flood, no state write" if not misses
                    else "FAIL:\n  " + "\n  ".join(misses)))
    return 0 if not misses else 1


if __name__ == "__main__":
    sys.exit(main())
