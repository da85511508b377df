"""``gidabot bench relay [--machines] [--json]``: relay latency against direct delivery, and 4/8-robot meshes.

1. Side by side in one run: one publisher on master A sends gidabot_msgs/Goal at 100 Hz;
   a subscriber on A (direct: same master) and one on B (relayed by /gidabot_relay_A_B)
   time every message (wall clock stamped at publication). Prints p50/p99 of both and
   their difference.
2. Meshes of 4 and 8 robots (6 and 28 relays, each robot's ends started as its relay
   supervisor starts them, HMAC on): every robot publishes goals at 10 Hz and records
   everyone else's; prints CPU per relay (both end processes, % of one core, while
   publishing and idle), delivery latency p50/p99/max (max = the worst stall), lost and
   duplicated deliveries.

Each robot has its own master: on loopback addresses 127.N.0.x (see procs.robot_address), or
with ``--machines`` each robot a separate machine (a network namespace of its own on a
bridge, :mod:`gidabot_sim.runner.machines`), so relayed messages cross a network hop. The
ends write their journals to a temporary directory. Exit status 1 when a target is missed:
the relay adds at most ``--max-added-p50`` ms at p50 and stays under ``--max-relayed-p99`` ms
at p99; every mesh delivers every message once, with no stall over ``--max-stall`` ms.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from gidabot_navigation.building.model import DEFAULT_RELAY_PORT
from gidabot_navigation.relay.supervisor import EndOptions, EndSpec, RelaySupervisor, end_argv
from gidabot_sim.bench.workers import Worker, percentile
from gidabot_sim.runner.command_line import bench_arguments, progress_printer
from gidabot_sim.runner.machines import Machines
from gidabot_sim.runner.proc_info import cpu_seconds
from gidabot_sim.runner.procs import (
    ProcessGroup,
    free_port_run,
    master_pid,
    robot_address,
    ros_env,
    start_master,
    wait_until,
)

SECRET = "bench-relay-secret-0123456789"
NODE = "gidabot_sim.bench.relay_node"     # the worker


@dataclass
class Robots:
    names: list[str]
    uris: list[str]
    ips: list[str]
    relay_ports: list[int]                 # relay_port of each robot (robot k listens on relay_port .. + k - 1)
    net: Machines | None = None            # separate machines, or all on this host's loopback

    def command(self, k: int) -> list[str]:
        """What runs a command line on robot k's machine."""
        return self.net.wrap(self.names[k], []) if self.net else []


def start_robots(group: ProcessGroup, n: int, net: Machines | None = None) -> Robots:
    names = [f"R{i}" for i in range(n)]
    if net is None:
        ips = [robot_address(i) for i in range(n)]
        uris = [start_master(group, f"master_{names[i]}", ips[i]) for i in range(n)]
        return Robots(names, uris, ips, [free_port_run(ips[k], max(k, 1)) for k in range(n)])
    ips = [net.address(name) for name in names]
    uris = [f"http://{ip}:11311/" for ip in ips]
    for k, name in enumerate(names):
        group.start(f"master_{name}", net.wrap(name, ["rosmaster", "--core", "-p", "11311", "-w", "3"]),
                    ros_env(uris[k], ips[k], log_dir=group.log_dir / f"master_{name}" if group.log_dir else None))
    for k, name in enumerate(names):
        wait_until(lambda k=k, name=name: net.call(name, master_pid, uris[k]) is not None, 30.0, f"master {name}")
    ports = [DEFAULT_RELAY_PORT] * n
    for k, name in enumerate(names):
        net.firewall(name, range(ports[k], ports[k] + k))
    return Robots(names, uris, ips, ports, net)


def mesh_ends(robots: Robots) -> list[EndSpec]:
    """Every robot's ends, as relay_supervisor.plan_relays gives them (on its own master; for a pair (i, j),
    i < j, j's end listens on its address, port relay_port(j) + i)."""
    ends = []
    n = len(robots.names)
    for i in range(n):
        for j in range(i + 1, n):
            port = robots.relay_ports[j] + i
            a, b = robots.names[i], robots.names[j]
            ends.append(EndSpec(a, b, "a", robots.uris[i], robots.ips[i], robots.ips[j], port, robots.ips[i]))
            ends.append(EndSpec(a, b, "b", robots.uris[j], robots.ips[j], robots.ips[j], port, robots.ips[i]))
    return ends


def start_relays(robots: Robots, state_dir: Path, secret_file: Path, log_dir: Path) -> RelaySupervisor:
    """Every end of the mesh, each on its robot's machine (one supervisor here stands for every robot's)."""
    opts = EndOptions(state_dir=str(state_dir), secret_file=str(secret_file))
    env = dict(os.environ)
    env["ROS_LOG_DIR"] = env["ROS_HOME"] = str(log_dir)
    log_dir.mkdir(parents=True, exist_ok=True)

    def argv_for(spec: EndSpec, options: EndOptions) -> list[str]:
        robot = robots.names.index(spec.robot_a if spec.side == "a" else spec.robot_b)
        return [*robots.command(robot), *end_argv(spec, options)]

    sup = RelaySupervisor(mesh_ends(robots), opts, lambda level, msg: None, base_env=env, output_dir=log_dir,
                          argv_for=argv_for)
    sup.step(time.monotonic())
    return sup


def wait_warm(workers: list[Worker], timeout: float) -> None:
    for w in workers:
        w.expect("warm_ok", timeout)


def side_by_side(tmp: Path, rate: float, count: int, log, machines: bool = False) -> dict:
    with _machines(machines, 2) as net, ProcessGroup(tmp / "logs_pair") as group:
        robots = start_robots(group, 2, net)
        sup = start_relays(robots, tmp / "state_pair", tmp / "secret", tmp / "logs_pair")
        try:
            env_a = ros_env(robots.uris[0], robots.ips[0], log_dir=tmp / "logs_pair" / "A")
            env_b = ros_env(robots.uris[1], robots.ips[1], log_dir=tmp / "logs_pair" / "B")
            direct = Worker(group, "direct_sub", env_a, NODE, ["--robot", "A", "--role", "sub", "--expect", "R0"],
                            robots.command(0))
            relayed = Worker(group, "relayed_sub", env_b, NODE, ["--robot", "B", "--role", "sub", "--expect", "R0"],
                             robots.command(1))
            # subscribers: the direct one, and end a of the relay (which forwards to B)
            pub = Worker(group, "pub", env_a, NODE, ["--robot", "R0", "--role", "pub", "--subs", "2",
                                                     "--rate", str(rate), "--count", str(count)], robots.command(0))
            workers = [direct, relayed, pub]
            try:
                wait_warm(workers, 120)
                log(f"  publishing {count} goals at {rate:g} Hz ...")
                for w in workers:
                    w.send("go")
                pub.expect("sent", count / rate + 60)
                time.sleep(1.0)
                res = {}
                for name, w in (("direct", direct), ("relayed", relayed)):
                    w.send("report")
                    recv = w.expect("report", 30)["recv"].get("R0", [])
                    res[name] = [lat for _, lat in recv]
                    res[name + "_n"] = len(recv)
            finally:
                for w in workers:
                    w.close()
        finally:
            sup.stop()
    d, r = res["direct"], res["relayed"]
    out = {"rate_hz": rate, "messages": count, "direct_received": res["direct_n"], "relayed_received": res["relayed_n"],
           "direct_p50_ms": percentile(d, 50), "direct_p99_ms": percentile(d, 99),
           "relayed_p50_ms": percentile(r, 50), "relayed_p99_ms": percentile(r, 99)}
    out["added_p50_ms"] = out["relayed_p50_ms"] - out["direct_p50_ms"]
    out["added_p99_ms"] = out["relayed_p99_ms"] - out["direct_p99_ms"]
    return out


def mesh(tmp: Path, n: int, rate: float, seconds: float, idle: float, log, machines: bool = False) -> dict:
    tag = f"mesh{n}"
    count = int(rate * seconds)
    with _machines(machines, n) as net, ProcessGroup(tmp / f"logs_{tag}") as group:
        t0 = time.monotonic()
        robots = start_robots(group, n, net)
        sup = start_relays(robots, tmp / f"state_{tag}", tmp / "secret", tmp / f"logs_{tag}")
        ends = [c.spec for c in sup.children]
        workers: list[Worker] = []
        try:
            for i, name in enumerate(robots.names):
                env = ros_env(robots.uris[i], robots.ips[i], log_dir=tmp / f"logs_{tag}" / name)
                others = ",".join(x for x in robots.names if x != name)
                workers.append(Worker(group, f"worker_{name}", env, NODE,
                                      ["--robot", name, "--role", "both", "--expect", others, "--subs", str(n),
                                       "--rate", str(rate), "--count", str(count), "--phase", str(i / n / rate)],
                                      robots.command(i)))
            wait_warm(workers, 300)
            startup = time.monotonic() - t0
            pids = [c.pid for c in sup.children if c.pid]
            if len(pids) != len(ends):
                raise RuntimeError(f"{len(ends) - len(pids)} relay end(s) not running")
            log(f"  {n} robots, {len(ends) // 2} relays up in {startup:.1f} s; idle {idle:g} s ...")
            c0, w0 = cpu_seconds(pids), time.monotonic()
            time.sleep(idle)
            c1, w1 = cpu_seconds(pids), time.monotonic()
            log(f"  every robot publishes {count} goals at {rate:g} Hz ...")
            for w in workers:
                w.send("go")
            for w in workers:
                w.expect("sent", seconds + 120)
            time.sleep(2.0)
            c2, w2 = cpu_seconds(pids), time.monotonic()
            reports = {}
            for name, w in zip(robots.names, workers, strict=True):
                w.send("report")
                reports[name] = w.expect("report", 60)["recv"]
            sup.step(time.monotonic())
            restarts = sum(c.restarts for c in sup.children)
        finally:
            for w in workers:
                w.close()
            sup.stop()
    relays = len(ends) // 2
    lat: list[float] = []
    lost = dup = 0
    for receiver, recv in reports.items():
        for origin in robots.names:
            if origin == receiver:
                continue
            got = recv.get(origin, [])
            ks = [k for k, _ in got]
            lost += count - len(set(ks))
            dup += len(ks) - len(set(ks))
            lat += [x for _, x in got]
    return {"robots": n, "relays": relays, "messages_per_robot": count, "rate_hz": rate,
            "deliveries": len(lat), "startup_s": round(startup, 1),
            "cpu_percent_per_relay": 100.0 * (c2 - c1) / (w2 - w1) / relays,
            "idle_cpu_percent_per_relay": 100.0 * (c1 - c0) / (w1 - w0) / relays,
            "p50_ms": percentile(lat, 50), "p99_ms": percentile(lat, 99), "max_ms": max(lat) if lat else float("nan"),
            "lost": lost, "duplicated": dup, "end_restarts": restarts}


@contextlib.contextmanager
def _machines(machines: bool, n: int) -> Iterator[Machines | None]:
    """n separate machines for a run (removed afterwards), or None: every robot on this host's loopback."""
    if not machines:
        yield None
        return
    with Machines([f"R{i}" for i in range(n)]) as net:
        yield net


def targets_missed(res: dict, max_added_p50: float, max_relayed_p99: float, max_stall: float) -> list[str]:
    """Every target the measurements miss (empty: all met)."""
    missed = []
    if not res["added_p50_ms"] <= max_added_p50:
        missed.append(f"the relay adds {res['added_p50_ms']:.3f} ms at p50 (target <= {max_added_p50:g} ms)")
    if not res["relayed_p99_ms"] < max_relayed_p99:
        missed.append(f"relayed p99 {res['relayed_p99_ms']:.3f} ms (target < {max_relayed_p99:g} ms)")
    if res["relayed_received"] != res["messages"]:
        missed.append(f"{res['messages'] - res['relayed_received']} relayed message(s) lost")
    for m in res["mesh"]:
        if m["lost"] or m["duplicated"]:
            missed.append(f"mesh of {m['robots']}: {m['lost']} lost, {m['duplicated']} duplicated")
        if not m["max_ms"] < max_stall:
            missed.append(f"mesh of {m['robots']}: a delivery took {m['max_ms']:.0f} ms (stall target < "
                          f"{max_stall:g} ms)")
    return missed


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    ap = bench_arguments("gidabot bench relay", __doc__)
    ap.add_argument("--machines", action="store_true",
                    help="every robot a separate machine (network namespace): relayed messages cross a network hop")
    ap.add_argument("--max-added-p50", type=float, default=1.0, help="target: ms the relay adds at p50 (1)")
    ap.add_argument("--max-relayed-p99", type=float, default=5.0, help="target: relayed p99 in ms (5)")
    ap.add_argument("--max-stall", type=float, default=1000.0, help="target: slowest mesh delivery in ms (1000)")
    ap.add_argument("--rate", type=float, default=100.0, help="Hz of the side-by-side run (default 100)")
    ap.add_argument("--count", type=int, default=1000, help="messages of the side-by-side run (default 1000)")
    ap.add_argument("--mesh", default="4,8", help="robot counts of the mesh runs (default 4,8; '' = none)")
    ap.add_argument("--mesh-rate", type=float, default=10.0, help="Hz per robot in the meshes (default 10)")
    ap.add_argument("--mesh-seconds", type=float, default=10.0, help="publishing time of a mesh run (default 10)")
    ap.add_argument("--idle", type=float, default=5.0, help="s of idle CPU measurement per mesh (default 5)")
    args = ap.parse_args(argv)
    log = progress_printer(args.json)
    with tempfile.TemporaryDirectory(prefix="gidabot-bench-relay-") as tmpdir:
        tmp = Path(tmpdir)
        (tmp / "secret").write_text(SECRET)
        where = "separate machines (a network namespace per robot)" if args.machines else "loopback"
        log(f"relay benchmark: {where}, one master per robot, HMAC-SHA256, journals on {tmp}")
        res = side_by_side(tmp, args.rate, args.count, log, args.machines)
        res["machines"] = args.machines
        log(f"  direct  (same master):  p50 {res['direct_p50_ms']:.3f} ms  p99 {res['direct_p99_ms']:.3f} ms  "
            f"({res['direct_received']}/{args.count} received)")
        log(f"  relayed (A -> B):       p50 {res['relayed_p50_ms']:.3f} ms  p99 {res['relayed_p99_ms']:.3f} ms  "
            f"({res['relayed_received']}/{args.count} received)")
        log(f"  relay adds:             p50 {res['added_p50_ms']:+.3f} ms  p99 {res['added_p99_ms']:+.3f} ms  "
            "(target: <= 1 ms at p50, < 5 ms at p99)")
        res["mesh"] = []
        for n in [int(x) for x in args.mesh.split(",") if x.strip()]:
            m = mesh(tmp, n, args.mesh_rate, args.mesh_seconds, args.idle, log, args.machines)
            res["mesh"].append(m)
            log(f"  mesh {m['robots']} robots / {m['relays']} relays: cpu {m['cpu_percent_per_relay']:.2f} %/relay "
                f"(idle {m['idle_cpu_percent_per_relay']:.2f}), latency p50 {m['p50_ms']:.2f} ms p99 "
                f"{m['p99_ms']:.2f} ms max {m['max_ms']:.1f} ms, lost {m['lost']}, duplicated {m['duplicated']} "
                f"of {m['deliveries']} deliveries")
    res["targets_missed"] = targets_missed(res, args.max_added_p50, args.max_relayed_p99, args.max_stall)
    log("targets: " + ("all met" if not res["targets_missed"] else "MISSED: " + "; ".join(res["targets_missed"])))
    if args.json:
        print(json.dumps(res, sort_keys=True))
    return 1 if res["targets_missed"] else 0


if __name__ == "__main__":
    sys.exit(main())
