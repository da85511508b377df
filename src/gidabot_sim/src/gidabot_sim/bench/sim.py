"""``gidabot bench sim [--json]``: planner time per faculty floor and the simulator's real-time factor.

Measured side by side in one run:

1. **Planner**: on every floor of the building, plans between every pair of places
   (locations, meeting points, the robot's home) with the move_base stand-in's planner
   (A* on the inflated costmap at the map's resolution, string pulling); median and
   worst time per plan. Targets: median <= 50 ms, worst <= 200 ms at 0.05 m (C++ navfn
   takes about 150 ms on a 75 m path).
2. **Real-time factor** of one floor (ROS-free, one process, as fast as it goes): the
   floor's robot with a 360-beam laser at 10 Hz, odometry, the amcl stand-in and the
   move_base stand-in driving a tour of the floor; sim seconds per wall second.
   Target: >= 10.
3. **The floor under ROS** (unless ``--no-ros``): ``launch/sim_floor.launch`` on its own
   master at ``--speed`` (10x), a subscriber on ``base_scan`` (so the laser runs) and a
   move_base action client driving the same tour; CPU time (% of one core) of the
   ``/sim``, ``/move_base`` and ``/amcl`` processes while driving, and the achieved
   clock factor.
4. **The floor with its whole stack** (unless ``--no-ros``): ``sim_floor.launch`` and
   ``guiding.launch`` (goal_manager, multirobot_navigation) with no speed ceiling (``speed:=max``:
   as fast as the lockstep allows), a visitor's requests of three places of the floor one after
   the other; the clock factor achieved, the CPU of each node per simulated second, the
   controllers' rates (steps answered / owed) and the guiding loops' rates against nominal.
   Targets: every goal reached, the factor >= ``stack_factor``, every rate >= 80 % of nominal.

Exit status 1 when a target is missed.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import select
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from tempfile import TemporaryDirectory

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building, Robot, load_building, relocate_building
from gidabot_navigation.interface import GUIDING_NODES, Node, global_name
from gidabot_navigation.resources import resource
from gidabot_sim.bench.closed_loop import FloorLoop
from gidabot_sim.errors import ProcessError
from gidabot_sim.navstack.move_base import MoveBaseCore
from gidabot_sim.runner.calibration import Calibration, as_json, describe
from gidabot_sim.runner.command_line import bench_arguments, print_verdict
from gidabot_sim.runner.proc_info import cpu_seconds
from gidabot_sim.runner.procs import ProcessGroup, node_pid, robot_address, ros_env, start_master, wait_until
from gidabot_sim.world.kinematics import Limits
from gidabot_sim.world.world import LaserSpec

TARGETS = {"planner_median_ms": 50.0, "planner_max_ms": 200.0, "real_time_factor": 10.0, "stack_factor": 100.0,
           "stack_rate_pct": 80.0}
STACK_NODES = tuple(global_name(n) for n in (Node.SIM, Node.MOVE_BASE, Node.AMCL, *GUIDING_NODES))
FLOOR_NODES = tuple(global_name(n) for n in (Node.SIM, Node.MOVE_BASE, Node.AMCL))
TOUR_FLOOR = 1.0
PHASES = ("laser", "no_laser", "idle")      # of the floor under ROS (sim_node's ros-driver)


def places(building: Building, floor: float) -> list[Pose2D]:
    f = building.floor(floor)
    out = [loc.pose for loc in building.locations_on(f.id)]
    out += [c.meeting[f.id] for c in building.connectors if f.id in c.meeting]
    out += [r.home for r in building.robots_on(f.id)]
    return out


def bench_planner(building: Building) -> list[dict]:
    """Time per plan between every pair of places, per floor."""
    rows = []
    for floor in building.floors:
        robot = next(iter(building.robots_on(floor.id)), None)
        radius = robot.radius if robot else 0.3
        limits = Limits.of_robot(robot) if robot else Limits(0.5, 1.0, 0.5, 1.0)
        core = MoveBaseCore.for_robot(floor.map, radius, limits, keep_out=floor.keep_out_zones)
        times, lengths = [], []
        for a, b in itertools.combinations(places(building, floor.id), 2):
            start = time.perf_counter()
            path = core.make_plan((a.x, a.y), (b.x, b.y))
            times.append((time.perf_counter() - start) * 1000.0)
            lengths.append(path.length)
        longest = max(range(len(lengths)), key=lengths.__getitem__)
        rows.append({"floor": floor.label, "plans": len(times), "median_ms": round(statistics.median(times), 2),
                     "max_ms": round(max(times), 2), "longest_path_m": round(lengths[longest], 1),
                     "longest_path_ms": round(times[longest], 2), "resolution_m": floor.map.resolution})
    return rows


def tour(building: Building, floor: float) -> list[Pose2D]:
    """East staircase, west staircase, lift: the floor's long trips."""
    f = building.floor(floor)
    meets = {c.id: c.meeting[f.id] for c in building.connectors if f.id in c.meeting}
    order = [k for k in ("stairs_east", "stairs_west", "lift") if k in meets] or list(meets)
    return [meets[k] for k in order]


def bench_rtf(building: Building, floor: float = TOUR_FLOOR) -> dict:
    """Sim seconds per wall second of one floor in one process (laser 360 beams at 10 Hz, driving)."""
    loop = FloorLoop(building, floor, seed=1, laser_rate=10.0, laser=LaserSpec(beams=360))
    goals = tour(building, floor)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    outcomes = [loop.drive(goal, timeout=400.0).outcome for goal in goals]
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    sim = loop.world.time
    return {"floor": building.floor(floor).label, "robot": loop.robot.name, "sim_s": round(sim, 1),
            "wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "real_time_factor": round(sim / wall, 1),
            "laser_beams": 360, "laser_scans": loop.scans, "laser_hz": round(loop.scans / sim, 2),
            "driven_m": round(loop.world.robots[0].odometer, 1), "goals": outcomes}


# -- the floor under ROS ------------------------------------------------------------------

@dataclass(frozen=True)
class FloorMaster:
    """The robot of one floor with a master of its own, in a temporary folder."""

    base: Building          # the building as given
    robot: Robot
    tmp: Path
    procs: ProcessGroup
    uri: str                # its master
    ip: str
    building: Path          # the building relocated to that master

    def env(self) -> dict[str, str]:
        return ros_env(self.uri, self.ip, log_dir=self.tmp / "ros")


@contextlib.contextmanager
def floor_master(building_dir: Path, floor: float, prefix: str) -> Iterator[FloorMaster]:
    """The robot of ``floor`` and its master, for the block; everything stopped and removed after."""
    base = load_building(building_dir)
    robot = next(iter(base.robots_on(floor)), None)
    if robot is None:
        raise ProcessError(f"floor {floor:g} has no robot")
    with TemporaryDirectory(prefix=prefix) as tmp, ProcessGroup(Path(tmp) / "logs") as procs:
        ip = robot_address(base.robots.index(robot))
        uri = start_master(procs, "master", ip)
        path = relocate_building(building_dir, Path(tmp) / "building", {robot.name: uri})
        yield FloorMaster(base, robot, Path(tmp), procs, uri, ip, path)


def node_pids(uri: str, nodes: tuple[str, ...], timeout: float) -> dict[str, int]:
    """node -> pid of every one of ``nodes`` once all are registered on the master at ``uri``."""
    pids: dict[str, int] = {}

    def found() -> bool:
        for node in nodes:
            pid = pids.get(node) or node_pid(uri, node, "/bench")
            if pid:
                pids[node] = pid
        return len(pids) == len(nodes)

    wait_until(found, timeout, "the floor's nodes")
    return pids


@contextlib.contextmanager
def driver(kind: str, spec: object, env: dict[str, str]) -> Iterator[subprocess.Popen]:
    """A driver of :mod:`gidabot_sim.bench.sim_node` (``kind``: ros-driver, stack-driver) on the floor's master,
    for the block; killed after if it still runs."""
    proc = subprocess.Popen([sys.executable, "-m", "gidabot_sim.bench.sim_node", kind, json.dumps(spec)],
                            env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=10)


def bench_ros(building_dir: Path, speed: float, floor: float = TOUR_FLOOR, timeout: float = 240.0) -> dict:
    """Launch one floor at ``speed`` and drive the tour through the ROS interfaces; CPU of the three nodes."""
    with floor_master(building_dir, floor, "gidabot-bench-") as fm:
        robot, tmp = fm.robot, fm.tmp
        env = fm.env()
        fm.procs.start("floor", ["roslaunch", "--skip-log-check", str(resource("launch", "sim_floor.launch")),
                                 f"building:={fm.building}", f"robot:={robot.name}", f"speed:={speed:g}", "seed:=1"],
                       env)
        pids = node_pids(fm.uri, FLOOR_NODES, 60.0)
        goals = [[g.x, g.y, g.yaw] for g in tour(load_building(fm.building), floor)]
        phases = {}
        with driver("ros-driver", goals, env) as proc:
            ready = proc.stdout.readline()
            if not ready.startswith("READY"):
                raise ProcessError(f"bench driver did not get ready: {ready!r} (logs in {tmp})")
            for _ in PHASES:
                cpu0 = {n: cpu_seconds([p]) for n, p in pids.items()}
                wall0 = time.monotonic()
                proc.stdin.write("GO\n")
                proc.stdin.flush()
                line = _read_line(proc, timeout)
                wall = time.monotonic() - wall0
                cpu = {n: cpu_seconds([p]) - cpu0[n] for n, p in pids.items()}
                result = json.loads(line)
                percent = {n.strip("/"): round(100.0 * c / wall, 1) for n, c in cpu.items()}
                percent["total"] = round(sum(100.0 * c / wall for c in cpu.values()), 1)
                phases[result["phase"]] = {
                    "wall_s": round(wall, 2), "sim_s": round(result["sim_s"], 1),
                    "achieved_factor": round(result["sim_s"] / result["wall_s"], 2), "goals": result["outcomes"],
                    "laser_hz_sim": round(result["scans"] / max(result["sim_s"], 1e-9), 2),
                    "cpu_percent_of_one_core": percent}
    laser_cpu = phases.get("laser", {}).get("cpu_percent_of_one_core", {}).get("total", 0.0)
    # extrapolation, not a measurement: the speed at which the three nodes would fill one core
    capacity = round(speed * 100.0 / laser_cpu, 1) if laser_cpu > 0 else None
    return {"speed": speed, "robot": robot.name, **phases, "one_core_capacity_factor_estimate": capacity}


def stack_places(building: Building, floor: float) -> list[str]:
    """Three places of the floor for a visitor's requests: the farthest from the robot's home, the farthest from
    that one, then the nearest to home (long trips both ways)."""
    robot = next(iter(building.robots_on(floor)), None)
    locs = building.locations_on(floor)
    if robot is None or len(locs) < 3:
        raise ProcessError(f"floor {floor:g} needs a robot and three places")

    def dist(a: Pose2D, b: Pose2D) -> float:
        return ((a.x - b.x) ** 2 + (a.y - b.y) ** 2) ** 0.5

    first = max(locs, key=lambda loc: dist(loc.pose, robot.home))
    second = max(locs, key=lambda loc: dist(loc.pose, first.pose))
    third = min((loc for loc in locs if loc not in (first, second)), key=lambda loc: dist(loc.pose, robot.home))
    return [first.id, second.id, third.id]


def bench_stack(building_dir: Path, floor: float = TOUR_FLOOR, timeout: float = 240.0) -> dict:
    """One floor with its simulator, stand-ins and guiding nodes, no speed ceiling: a visitor's three requests.

    Nobody walks behind the robot here (the requests come from a driver, not a visitor in the world), so the robot
    guides without watching for its visitor (``pace:=false``): with pacing it would wait for, then search for,
    a visitor who is not there."""
    with floor_master(building_dir, floor, "gidabot-bench-stack-") as fm:
        robot, tmp = fm.robot, fm.tmp
        launch = tmp / "stack.launch"
        launch.write_text(f"""<launch>
  <param name="/use_sim_time" value="true"/>
  <include file="{resource("launch", "sim_floor.launch")}">
    <arg name="building" value="{fm.building}"/> <arg name="robot" value="{robot.name}"/>
    <arg name="speed" value="max"/> <arg name="seed" value="1"/>
  </include>
  <include file="{resource("launch", "guiding.launch")}">
    <arg name="building" value="{fm.building}"/> <arg name="robot" value="{robot.name}"/>
    <arg name="status_rate" value="0.02"/> <arg name="pose_rate" value="0.05"/>
    <arg name="state_dir" value="{tmp / 'guiding'}"/> <arg name="pace" value="false"/>
  </include>
</launch>
""", encoding="utf-8")
        env = fm.env()
        fm.procs.start("stack", ["roslaunch", "--skip-log-check", str(launch)], env)
        pids = node_pids(fm.uri, STACK_NODES, 90.0)
        with driver("stack-driver", {"robot": robot.name, "goals": stack_places(fm.base, floor)}, env) as proc:
            ready = _read_line(proc, 90.0)
            if not ready.startswith("READY"):
                raise ProcessError(f"bench driver did not get ready: {ready!r} (logs in {tmp})")
            cpu0 = {n: cpu_seconds([p]) for n, p in pids.items()}
            wall0 = time.monotonic()
            proc.stdin.write("GO\n")
            proc.stdin.flush()
            done = _read_line(proc, timeout)          # at the end of the drive: the CPU over it
            cpu = {n.strip("/"): cpu_seconds([p]) - cpu0[n] for n, p in pids.items()}
            cpu_wall = time.monotonic() - wall0
            if not done.startswith("DONE"):
                raise ProcessError(f"bench driver: {done!r} (logs in {tmp})")
            result = json.loads(_read_line(proc, 30.0))
    sim_s, wall_s = result["sim_s"], result["wall_s"]
    guide_sim, guide_wall = result["guiding_sim_s"], result["guiding_wall_s"]
    return {"robot": robot.name, "goals": result["outcomes"], "places": result["places"], "sim_s": round(sim_s, 1),
            "wall_s": round(wall_s, 2), "achieved_factor": round(sim_s / wall_s, 1) if wall_s > 0 else 0.0,
            # while the robot guided (ON_THE_WAY to GOAL_REACHED: move_base in lockstep at every step); the rest of
            # the drive is mostly a floor at rest, which runs as fast as its loop goes
            "guiding_sim_s": round(guide_sim, 1), "guiding_wall_s": round(guide_wall, 2),
            "guiding_factor": round(guide_sim / guide_wall, 1) if guide_wall > 0 else 0.0,
            "cpu_ms_per_sim_s": {n: round(1000.0 * c / sim_s, 2) for n, c in cpu.items()} if sim_s > 0 else {},
            "cpu_cores": round(sum(cpu.values()) / cpu_wall, 2) if cpu_wall > 0 else 0.0,
            "rates_pct": result["rates_pct"]}


def _read_line(proc: subprocess.Popen, timeout: float) -> str:
    ready, _, _ = select.select([proc.stdout], [], [], timeout)
    line = proc.stdout.readline() if ready else ""
    if not line:
        raise ProcessError(f"bench driver gave no result within {timeout:g} s")
    return line


def main(argv: list[str] | None = None) -> int:
    parser = bench_arguments("gidabot bench sim", __doc__)
    parser.add_argument("--building", default=str(resource("maps", "faculty")),
                        help="building directory (default: the faculty)")
    parser.add_argument("--speed", type=float, default=10.0, help="speed factor of the ROS run (default 10)")
    parser.add_argument("--no-ros", action="store_true", help="skip the run under ROS")
    args = parser.parse_args(argv)
    building = load_building(args.building)
    calibration = Calibration()
    calibration.measure()
    planner = bench_planner(building)
    rtf = bench_rtf(building, TOUR_FLOOR if building.find_floor(TOUR_FLOOR) else building.floors[0].id)
    report: dict = {"planner": planner, "real_time_factor": rtf["real_time_factor"], "rtf_run": rtf,
                    "targets": TARGETS}
    if not args.no_ros:
        report["ros"] = bench_ros(Path(args.building), args.speed)
        report["stack"] = bench_stack(Path(args.building))
    missed = []
    for r in planner:
        if r["median_ms"] > TARGETS["planner_median_ms"] or r["max_ms"] > TARGETS["planner_max_ms"]:
            missed.append(f"planner on floor {r['floor']}: median {r['median_ms']} ms, max {r['max_ms']} ms")
    if rtf["real_time_factor"] < TARGETS["real_time_factor"]:
        missed.append(f"real-time factor {rtf['real_time_factor']}x")
    stack = report.get("stack")
    if stack is not None:
        if any(g != "reached" for g in stack["goals"]):
            missed.append(f"whole stack: goals {stack['goals']}")
        if stack["achieved_factor"] < TARGETS["stack_factor"]:
            missed.append(f"whole stack: {stack['achieved_factor']}x (target >= {TARGETS['stack_factor']:g}x)")
        low = {n: v for n, v in stack["rates_pct"].items() if v < TARGETS["stack_rate_pct"]}
        if low or not stack["rates_pct"]:
            missed.append(f"whole stack: rates below {TARGETS['stack_rate_pct']:g} % of nominal: "
                          f"{low or 'none measured'}")
    calibration.measure()
    report["missed"], report["pass"], report["calibration"] = missed, not missed, as_json(calibration)
    if args.json:
        print(json.dumps(report))
        return 0 if report["pass"] else 1
    print("planner (A* on the inflated costmap, string pulling), time per plan between every pair of places:")
    for r in planner:
        print(f"  floor {r['floor']}: {r['plans']:4d} plans, median {r['median_ms']:6.2f} ms, "
              f"max {r['max_ms']:6.2f} ms, longest path {r['longest_path_m']:.1f} m in {r['longest_path_ms']:.2f} ms "
              f"(res {r['resolution_m']:g} m)")
    print(f"  targets: median <= {TARGETS['planner_median_ms']:g} ms, max <= {TARGETS['planner_max_ms']:g} ms "
          "(navfn ~150 ms on a 75 m path)")
    print(f"real-time factor, floor {rtf['floor']} ({rtf['robot']}), {rtf['laser_beams']}-beam laser at "
          f"{rtf['laser_hz']:g} Hz, move_base driving {rtf['driven_m']} m ({', '.join(rtf['goals'])}):")
    print(f"  {rtf['sim_s']} sim s in {rtf['wall_s']} wall s -> {rtf['real_time_factor']}x "
          f"(target >= {TARGETS['real_time_factor']:g}x)")
    if "ros" in report:
        ros = report["ros"]
        print(f"under ROS at {ros['speed']:g}x (sim_floor.launch on its own master, move_base action goals), "
              "CPU in % of one core while driving:")
        for phase, text in (("laser", "driving, base_scan subscribed"), ("no_laser", "driving, no base_scan"),
                            ("idle", "parked, no base_scan")):
            r = ros[phase]
            cpu = r["cpu_percent_of_one_core"]
            print(f"  {text:30s}: sim {cpu['sim']:5.1f}, move_base {cpu['move_base']:5.1f}, amcl {cpu['amcl']:5.1f}, "
                  f"total {cpu['total']:5.1f} (clock factor {r['achieved_factor']}, laser {r['laser_hz_sim']} Hz"
                  + (f", goals {', '.join(r['goals'])})" if r["goals"] else ")"))
        if ros.get("one_core_capacity_factor_estimate"):
            print(f"  -> one core would carry this floor with its laser up to about "
                  f"{ros['one_core_capacity_factor_estimate']}x (extrapolated from the CPU at {ros['speed']:g}x)")
    if stack is not None:
        print(f"the whole stack of floor {TOUR_FLOOR:g} ({stack['robot']}: simulator, move_base, amcl, goal_manager, "
              f"multirobot_navigation), no speed ceiling, a visitor's requests {', '.join(stack['places'])}:")
        print(f"  {stack['sim_s']} sim s in {stack['wall_s']} wall s -> {stack['achieved_factor']}x "
              f"(target >= {TARGETS['stack_factor']:g}x), {stack['cpu_cores']} cores; "
              f"goals {', '.join(stack['goals'])}")
        print(f"  while guiding (move_base in step at every 0.1 s): {stack['guiding_sim_s']} sim s in "
              f"{stack['guiding_wall_s']} wall s -> {stack['guiding_factor']}x")
        print("  CPU per sim s: " + ", ".join(f"{n} {v} ms" for n, v in stack["cpu_ms_per_sim_s"].items()))
        print("  rates (% of nominal): " + ", ".join(f"{n} {v:.0f}" for n, v in stack["rates_pct"].items()))
    print(describe(calibration))
    print_verdict(missed)
    return 0 if report["pass"] else 1


if __name__ == "__main__":
    sys.exit(main())
