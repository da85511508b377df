"""``gidabot bench flood [--json]``: a valid request under a flood of invalid messages (issue 19.7).

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
Exit status 1 if a flooded answer takes more than 0.5 s (``LIMIT_S``, the issue's bound), a state
file was written because of the flood, or a worker could not publish at 90 % of the rate (the
verdict would not mean anything).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import select
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from pathlib import Path

from gidabot_navigation.building.model import Building, load_building, relocate_building
from gidabot_navigation.resources import resource
from gidabot_sim.bench.relay import Worker, percentile
from gidabot_sim.runner.building_runner import node_executable
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master, test_network

LIMIT_S = 0.5          # s: a valid request answered within this under the flood (issue 19.7)
MIN_RATE_SHARE = 0.9   # the flood must reach this share of --rate for the verdict to count
FLOOD_ONLY_S = 4.0     # s of flood without requests, in which the goal manager's state writes are counted
SETTLE_S = 2.5         # s without a state write (1 s soft interval, 1 Hz diagnostics) before the flood starts


# -- the worker: the visitor at one robot's screen, and the flood on its master -------------------------
def worker(argv: Sequence[str]) -> int:
    """``bench_flood worker --building B --robot R --rate HZ``; stdin/stdout line protocol: prints
    ``{"event": "ready"}`` once the goal manager listens; ``requests N [flood]`` makes N timed requests
    (flood: after the flood ran alone for a while) and prints ``{"event": "done", "ms": [...], "rate": hz,
    "writes": n}`` (n: the goal manager's state writes while the flood ran alone); ``quit``."""
    import genpy
    import rospy
    from diagnostic_msgs.msg import DiagnosticArray

    from gidabot_msgs.msg import Cancel, Goal, NavEvent, RobotStatus, Tour, VisitorCommand
    from gidabot_navigation.interface import Cmd, Node, Phase, RobotState, Topic, global_name

    ap = argparse.ArgumentParser(prog="bench_flood worker")
    ap.add_argument("--building", required=True)
    ap.add_argument("--robot", required=True)
    ap.add_argument("--rate", type=float, default=1000.0)
    args = ap.parse_args(list(argv))
    out = os.fdopen(os.dup(sys.stdout.fileno()), "w", buffering=1)
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())          # rospy's log lines stay off the protocol
    building = load_building(args.building)
    me = building.robot(args.robot)
    places = [loc.id for loc in building.locations if loc.floor == me.floor][:6]
    if len(places) < 2:
        raise SystemExit(f"bench_flood worker: floor {me.floor:g} of {args.robot} has fewer than 2 places")
    rospy.init_node(f"bench_flood_{args.robot}", disable_signals=True, disable_rostime=True)

    answered = threading.Event()
    answer: dict[str, str] = {}
    saves = [-1]

    def on_event(m: NavEvent) -> None:
        sender = (m._connection_header or {}).get("callerid", "")
        if m.robot == args.robot and m.phase == Phase.ACCEPTED and sender == global_name(Node.GOAL_MANAGER) and \
                m.location_id == answer.get("want"):
            answer["goal_uid"] = m.goal_uid
            answered.set()

    def on_diag(m: DiagnosticArray) -> None:
        for st in m.status:
            if st.name == f"guiding: goal_manager {args.robot}":
                saves[0] = int(next((kv.value for kv in st.values if kv.key == "state_saves"), -1))

    rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, on_event, queue_size=None, tcp_nodelay=True)
    rospy.Subscriber(Topic.DIAGNOSTICS, DiagnosticArray, on_diag, queue_size=10)
    command = rospy.Publisher(Topic.VISITOR_COMMAND, VisitorCommand, queue_size=10)
    hostile = {Topic.GOALS: Goal, Topic.CANCELS: Cancel, Topic.NAV_EVENTS: NavEvent,
               Topic.STATUS: RobotStatus, Topic.TOURS: Tour}
    pubs = {topic: rospy.Publisher(topic, cls, queue_size=10000) for topic, cls in hostile.items()}

    def invalid(k: int) -> tuple[str, genpy.Message]:
        """The k-th hostile message: a new uid every time (nothing is dropped as a duplicate)."""
        kind = k % 8
        if kind < 3:
            g = Goal(uid=f"Mallory/x/{k}", origin_robot="Mallory" if kind == 0 else args.robot,
                     goal_id="nowhere" if kind == 1 else places[0], initial_floor=me.floor,
                     goal_floor=math.nan if kind == 2 else me.floor, language="en")
            g.goal_pose.orientation.w = 1.0
            return Topic.GOALS, g
        if kind == 3:
            return Topic.CANCELS, Cancel(uid=f"Mallory/cancel/{k}", goal_uid=f"{args.robot}/v/{k}",
                                              origin_robot="Mallory", reason="visitor")
        if kind == 4:
            return Topic.NAV_EVENTS, NavEvent(uid=f"Mallory/event/{k}", robot="Mallory", phase=Phase.UNREACHABLE,
                                                   goal_uid=f"{args.robot}/v/{k}")
        if kind == 5:
            return Topic.NAV_EVENTS, NavEvent(uid=f"Mallory/event/{k}", robot=args.robot, phase=250,
                                                   goal_uid=f"{args.robot}/v/{k}")
        if kind == 6:
            s = RobotStatus(robot="Mallory", floor=math.nan, state=RobotState.GUIDING)
            s.nav_pose.position.x = math.nan
            return Topic.STATUS, s
        return Topic.TOURS, Tour(uid=f"Mallory/tour/{k}", file_name=f"../../escape{k}.tour",
                                      editor_robot=args.robot, version=1, language="en",
                                      tour_goals_info=[f"{me.floor:g}, {places[0]}, x"])

    flooding = threading.Event()
    sent = [0]

    def flood() -> None:
        step = 0.01                                   # publish in 10 ms batches
        per_step = args.rate * step
        due = time.monotonic()
        owed = 0.0
        while flooding.is_set():
            owed += per_step
            while owed >= 1.0:
                topic, msg = invalid(sent[0])
                pubs[topic].publish(msg)
                sent[0] += 1
                owed -= 1.0
            due += step
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            else:
                due = time.monotonic()

    def request(place: str, n: int) -> float:
        answered.clear()
        answer.clear()
        answer["want"] = place
        cmd = VisitorCommand(uid=f"{args.robot}/bench/cmd/{n}", visitor_id="bench", command=Cmd.REQUEST,
                             goal_id=place, way="stairs", language="en")
        cmd.header.stamp = rospy.Time.now()
        t0 = time.monotonic()
        command.publish(cmd)
        if not answered.wait(10.0):
            return math.inf
        took = time.monotonic() - t0
        cancel = VisitorCommand(uid=f"{args.robot}/bench/cmd/{n}c", visitor_id="bench", command=Cmd.CANCEL,
                                goal_uid=answer.get("goal_uid", ""), language="en")
        cancel.header.stamp = rospy.Time.now()
        command.publish(cancel)
        return took

    def settled_saves() -> int:
        """The goal manager's state writes once the count has not changed over SETTLE_S (its writes of the last
        request, within its 1 s soft interval, are done); -1 if /diagnostics never told it."""
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            seen = saves[0]
            time.sleep(SETTLE_S)
            if seen >= 0 and saves[0] == seen:
                return seen
        return -1

    deadline = time.monotonic() + 120
    while command.get_num_connections() < 1 or any(p.get_num_connections() < 1 for p in pubs.values()):
        if time.monotonic() > deadline:
            out.write(json.dumps({"event": "error", "error": "the robot's nodes did not subscribe"}) + "\n")
            return 1
        time.sleep(0.05)
    n = 0
    while request(places[0], n) == math.inf:         # warm up: the goal manager plans its first leg
        n += 1
        if n == 5:
            out.write(json.dumps({"event": "error", "error": f"{args.robot} accepts no request to {places[0]}"})
                      + "\n")
            return 1
    out.write(json.dumps({"event": "ready"}) + "\n")
    while True:
        ready, _, _ = select.select([sys.stdin], [], [], 0.5)
        if not ready:
            continue
        line = sys.stdin.readline().split()
        if not line or line[0] == "quit":
            break
        if line[0] != "requests":
            continue
        count, flooded = int(line[1]), "flood" in line[2:]
        writes = 0
        if flooded:
            before = settled_saves()   # the last request's writes done: what is written now is the flood's
            flooding.set()
            threading.Thread(target=flood, daemon=True).start()
            time.sleep(FLOOD_ONLY_S)   # the flood alone; /diagnostics (1 Hz) then reports at least 3 s of it
            writes = saves[0] - before if before >= 0 else -1
        sent_before, t_begin = sent[0], time.monotonic()
        times = []
        for k in range(count):
            n += 1
            times.append(request(places[1 + k % (len(places) - 1)], n))
            time.sleep(0.2)
        flooding.clear()
        elapsed = time.monotonic() - t_begin
        out.write(json.dumps({"event": "done", "ms": [t * 1000.0 for t in times],
                              "rate": (sent[0] - sent_before) / elapsed if flooded else 0.0,
                              "writes": writes}) + "\n")
    rospy.signal_shutdown("bench done")
    return 0


# -- the orchestrator -------------------------------------------------------------------------------
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
                workers.append(Worker(group, f"worker_{r.name}", env,
                                      ["--building", str(building.path), "--robot", r.name, "--rate", str(rate)],
                                      module="gidabot_sim.bench.flood"))
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
    if argv and argv[0] == "worker":
        return worker(argv[1:])
    ap = argparse.ArgumentParser(prog="gidabot bench flood", description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--rate", type=float, default=1000.0, help="invalid messages per second per master (1000)")
    ap.add_argument("--requests", type=int, default=15, help="timed requests per robot and phase (15)")
    args = ap.parse_args(argv)

    def log(msg: str) -> None:
        if not args.json:
            print(msg, flush=True)

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
