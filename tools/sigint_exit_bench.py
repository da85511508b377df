"""How long the sim, move_base and amcl stand-ins take to exit on SIGINT (gidabot_navigation.ros.exit_guard).

Starts them on one master (plus two probe subscribers), SIGINTs all three at once as roslaunch does,
under a chosen condition (plain, a frozen subscriber, a restarted or a frozen master), and prints
every exit time, the hangs (> 3 s; the sim's threads are dumped) and the median / max. Run it with
`source tools/env.sh; python tools/sigint_exit_bench.py -n 20 --mode mixed` (it holds no lock: run
it alone, it uses the session's loopback network 127.N.0.x)."""
from __future__ import annotations

import argparse
import os
import random
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

from gidabot_navigation.interface import Node, Topic

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
from probe import Probe  # noqa: E402

from gidabot_navigation.building.model import load_building, relocate_building  # noqa: E402
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master, wait_until  # noqa: E402

FACULTY = REPO / "maps" / "faculty"
NODES = REPO / "src" / "gidabot_sim" / "nodes"
WRAP = ("import faulthandler, signal, sys, runpy; faulthandler.register(signal.SIGUSR1, all_threads=True); "
        "sys.argv = sys.argv[1:]; runpy.run_path(sys.argv[0], run_name='__main__')")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("-n", type=int, default=20)
    ap.add_argument("--speed", default="20")
    ap.add_argument("--mode", default="plain", choices=["plain", "stop_sub", "restart_master", "stop_master", "mixed"])
    ap.add_argument("--budget", type=float, default=280.0)
    ap.add_argument("--out", default=str(Path(tempfile.gettempdir()) / "gidabot-sigint-exit"))
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    robot = "Kbot"
    index = [r.name for r in load_building(FACULTY).robots].index(robot)
    ip = robot_address(index)
    times: list[float] = []
    hangs = 0
    began = time.monotonic()
    with ProcessGroup(out / "logs") as procs:
        uri = start_master(procs, "master", ip)
        building = relocate_building(FACULTY, out / "building", {robot: uri})
        env = ros_env(uri, ip, log_dir=out / "ros")
        for it in range(a.n):
            if time.monotonic() - began > a.budget:
                print(f"budget reached after {it} iterations", flush=True)
                break
            modes = ["plain", "stop_sub", "restart_master", "stop_master"]
            mode = random.choice(modes) if a.mode == "mixed" else a.mode
            if mode == "restart_master" and it > 0:
                procs.stop("master", grace=3.0)
                uri = start_master(procs, "master", ip, port=int(uri.rsplit(":", 1)[1].strip("/")))
            if not procs.alive("master"):
                procs.signal("master", signal.SIGCONT)
            procs.start("sim", [sys.executable, "-c", WRAP, str(NODES / "world"), f"__name:={Node.SIM}",
                                f"_building:={building}", f"_robot:={robot}", f"_speed:={a.speed}",
                                "_use_sim_time:=true"], env)
            procs.start("move_base", [sys.executable, str(NODES / "move_base"), f"__name:={Node.MOVE_BASE}",
                                      f"_building:={building}", f"_robot:={robot}"], env)
            procs.start("amcl", [sys.executable, str(NODES / "amcl"), f"__name:={Node.AMCL}"], env)
            probes = [Probe(env, out / f"probe{i}.log") for i in range(2)]
            try:
                for p in probes:
                    for topic, type_ in ((Topic.CLOCK, "rosgraph_msgs/Clock"), (Topic.ODOM, "nav_msgs/Odometry"),
                                         (Topic.BASE_POSE_GROUND_TRUTH, "nav_msgs/Odometry"),
                                         (Topic.BASE_SCAN, "sensor_msgs/LaserScan"), (Topic.TF, "tf2_msgs/TFMessage"),
                                         (Topic.BATTERY, "sensor_msgs/BatteryState")):
                        p.sub(topic, type_)
                probes[0].wait(Topic.ODOM, lambda m: True, 60, "odom")
                time.sleep(random.uniform(0.2, 1.5))    # a random moment of the run
                if mode == "stop_sub":
                    os.killpg(probes[1].proc.pid, signal.SIGSTOP)
                    time.sleep(random.uniform(0.5, 2.0))
                elif mode == "restart_master":
                    procs.stop("master", grace=3.0)
                    uri = start_master(procs, "master", ip, port=int(uri.rsplit(":", 1)[1].strip("/")))
                    time.sleep(random.uniform(0.5, 2.0))
                elif mode == "stop_master":
                    procs.signal("master", signal.SIGSTOP)
                    time.sleep(random.uniform(0.5, 1.5))
                t0 = time.monotonic()
                for name in ("sim", "move_base", "amcl"):     # roslaunch: SIGINT to every node at once
                    procs.signal(name, signal.SIGINT)
                try:
                    wait_until(lambda: not procs.alive("sim"), 3.0, "sim exit", interval=0.01)
                    dt = time.monotonic() - t0
                except Exception:  # noqa: BLE001
                    dt = float("inf")
                    hangs += 1
                    procs.signal("sim", signal.SIGUSR1)
                    time.sleep(0.5)
                    log = procs.get("sim").log_path
                    (out / f"hang_{it}.txt").write_text(log.read_text(errors="replace")[-20000:])
                others = {}
                for name in ("move_base", "amcl"):
                    try:
                        wait_until(lambda n=name: not procs.alive(n), 3.0, name, interval=0.01)
                        others[name] = round(time.monotonic() - t0, 2)
                    except Exception:  # noqa: BLE001
                        others[name] = "HANG"
                times.append(dt)
                print(f"{it:3d} {mode:15s} sim exit {dt:6.2f} s  {others}", flush=True)
            finally:
                if mode == "stop_master" or not procs.alive("master"):
                    procs.signal("master", signal.SIGCONT)
                for p in probes:
                    os.killpg(p.proc.pid, signal.SIGCONT)
                    p.close()
                for name in ("sim", "move_base", "amcl"):
                    procs.stop(name, grace=1.0)
    ok = [t for t in times if t != float("inf")]
    print(f"iterations {len(times)}, hangs (>3 s) {hangs}, exit s: median {statistics.median(ok) if ok else 0:.2f} "
          f"max {max(ok) if ok else 0:.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
