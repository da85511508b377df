"""``gidabot bench dashboard [--json]``: 20 live clients on one robot's staff dashboard during the Table 2 tour.

Runs ``gidabot demo --dashboard`` twice on the same tour (default: the paper's Table 2 tour, ``tours/long_tour.tour``)
with the same ``--seed``, at the demo's default speed, one after the other: first with no client, then with
``--clients`` WebSocket clients (default 20) on ``--robot``'s dashboard (default Kbot) from when it serves until every
goal of the tour is done (then the demo stops every process: a socket closed after that is not dropped). Each client
reads every update; for every robot status it gets, the delay from the dashboard's receipt of that
``/gidabot/status`` message (the ``rx`` it carries, wall clock) to the client is recorded. Prints per run: the
outcome, Table 3, whether the run is degraded, the dashboard's CPU (that robot's dashboard process, % of one core
from when it listens until it was last seen running, sampled every 0.5 s); with clients also the messages received
and the delay's p50 / p95 / max; and, as every benchmark, the time of a fixed workload on this machine at its start
and end (:mod:`gidabot_sim.runner.calibration`).

Targets (exit status 1 when one is missed): both runs complete the tour with Table 3 = 7, 8, 8, 6 and are not
degraded; the robot's dashboard is found serving (its CPU measured); every client stays connected to the end; the
p95 delay is at most ``--max-p95-ms`` (1000: the page is at most 1 s behind the robot's own topics). Run it alone:
``flock /tmp/gidabot-heavy.lock bin/gidabot bench dashboard``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import re
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from tempfile import mkdtemp

import aiohttp

from gidabot_navigation.resources import resource
from gidabot_sim.runner.calibration import Calibration, as_json, describe

DEMO = (sys.executable, "-m", "gidabot_sim.cli", "demo")
TABLE3 = [7, 8, 8, 6]
URL_LINE = re.compile(r"^\s+(\w+)\s+(http://\S+)(?:\s+\(from this host: (http://\S+)\))?")
TOUR_DONE = re.compile(r"\bgoal (\d+) of \1 \(.*\), \1 done \|")     # the demo's progress line once every goal is done


@dataclass
class Clients:
    """The live clients of one run: what they received and when. ``stop``: the tour is over (the demo then stops
    every process, its dashboards too: a socket closed after that is no drop)."""

    url: str
    count: int
    delays: list[float] = field(default_factory=list)       # s
    messages: int = 0
    connected: int = 0
    dropped: int = 0
    errors: list[str] = field(default_factory=list)
    stop: threading.Event = field(default_factory=threading.Event)

    async def _one(self, session: aiohttp.ClientSession, n: int) -> None:
        origin = self.url.rstrip("/")
        seen: dict[str, float] = {}
        try:
            async with session.ws_connect(origin + "/live", headers={"Origin": origin}, heartbeat=None) as ws:
                self.connected += 1
                while not self.stop.is_set():
                    try:
                        msg = await ws.receive(timeout=0.5)
                    except TimeoutError:
                        continue
                    now = time.time()
                    if msg.type != aiohttp.WSMsgType.TEXT:
                        if not self.stop.is_set():
                            self.dropped += 1
                        return
                    self.messages += 1
                    data = json.loads(msg.data)
                    for robot in (data.get("sections") or {}).get("robots") or []:
                        rx = robot.get("rx") or 0.0
                        if rx and seen.get(robot["name"]) != rx:
                            seen[robot["name"]] = rx
                            self.delays.append(now - rx)
        except (aiohttp.ClientError, OSError) as err:
            if not self.stop.is_set():
                self.errors.append(f"client {n}: {err}")

    async def _all(self) -> None:
        async with aiohttp.ClientSession() as session:
            await asyncio.gather(*(self._one(session, n) for n in range(self.count)))

    def run(self) -> threading.Thread:
        thread = threading.Thread(target=lambda: asyncio.run(self._all()), name="bench-clients", daemon=True)
        thread.start()
        return thread


def pid_listening(port: int) -> int | None:
    """The process listening on TCP ``port`` (this host's network namespace), from /proc."""
    inodes = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            f = line.split()
            if f[3] == "0A" and int(f[1].rsplit(":", 1)[1], 16) == port:
                inodes.add(f[9])
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            for fd in os.scandir(f"/proc/{entry.name}/fd"):
                target = os.readlink(fd.path)
                if target.startswith("socket:[") and target[8:-1] in inodes:
                    return int(entry.name)
        except OSError:
            continue
    return None


def cpu_seconds(pid: int | None) -> float | None:
    if pid is None:
        return None
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def percentile(values: list[float], q: float) -> float | None:
    if not values:
        return None
    s = sorted(values)
    return s[min(len(s) - 1, max(0, round(q / 100 * (len(s) - 1))))]


def run_one(args: argparse.Namespace, out: Path, clients: int, log: Path) -> dict:
    """One demo run with ``clients`` live clients on the robot's dashboard; its report and the measurements."""
    argv = [*DEMO, "--tour", str(args.tour), "--seed", str(args.seed), "--out", str(out), "--json", "--dashboard"]
    began = time.monotonic()
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    state: dict = {"url": None, "pid": None, "cpu0": None, "t0": None, "cpu1": None, "t1": None, "clients": None,
                   "thread": None, "watcher": None}
    over = threading.Event()                  # the demo said every goal is done

    def watch(port: int) -> None:
        """Find the process listening on the dashboard's port (the demo says where it will be before it starts),
        start the clients, then read its CPU time every 0.5 s while it runs: the demo stops it before it exits, so
        the last figure is the last one read while it lived."""
        deadline = time.monotonic() + 60
        while state["pid"] is None and time.monotonic() < deadline and proc.poll() is None:
            state["pid"] = pid_listening(port)
            if state["pid"] is None:
                time.sleep(0.2)
        state["cpu0"], state["t0"] = cpu_seconds(state["pid"]), time.monotonic()
        if clients and not over.is_set():
            c = Clients(state["url"], clients, stop=over)
            state["clients"], state["thread"] = c, c.run()
        while state["cpu0"] is not None and proc.poll() is None:
            cpu = cpu_seconds(state["pid"])
            if cpu is None:
                return
            state["cpu1"], state["t1"] = cpu, time.monotonic()
            time.sleep(0.5)

    def follow() -> None:
        """The demo's stderr, every line to the log (this thread alone reads it: the demo never waits on a full
        pipe); the robot's dashboard address, watched by a thread of its own."""
        with open(log, "w", encoding="utf-8") as f:
            for line in proc.stderr:          # type: ignore[union-attr]
                f.write(line)
                f.flush()
                if TOUR_DONE.search(line):
                    over.set()
                m = URL_LINE.match(line)
                if m and m.group(1) == args.robot and state["url"] is None:
                    state["url"] = m.group(3) or m.group(2)
                    port = int(m.group(2).rsplit(":", 1)[1].strip("/"))
                    state["watcher"] = threading.Thread(target=watch, args=(port,), daemon=True)
                    state["watcher"].start()

    reader = threading.Thread(target=follow, daemon=True)
    reader.start()
    stdout = proc.stdout.read()               # type: ignore[union-attr]
    proc.wait()
    reader.join(timeout=30)
    if state["watcher"] is not None:
        state["watcher"].join(timeout=10)
    cpu1, t1 = state["cpu1"], state["t1"]
    over.set()
    c: Clients | None = state["clients"]
    if c is not None:
        state["thread"].join(timeout=10)
    try:
        report = json.loads(stdout.strip().splitlines()[-1]) if stdout.strip() else {}
    except json.JSONDecodeError:
        report = {}
    robots = {r["name"]: r for r in report.get("robots", [])}
    names = [r["name"] for r in report.get("robots", [])]
    cpu = None
    if state["cpu0"] is not None and cpu1 is not None and t1 > state["t0"]:
        cpu = round(100.0 * (cpu1 - state["cpu0"]) / (t1 - state["t0"]), 2)
    row = {"clients": clients, "exit_status": proc.returncode, "wall_s": round(time.monotonic() - began, 1),
           "completed": (report.get("tour") or {}).get("completed"), "goals": (report.get("tour") or {}).get("goals"),
           "table3": [robots[n]["processed"] for n in names] if names else None, "degraded": report.get("degraded"),
           "dashboard_url": state["url"], "dashboard_cpu_percent": cpu}
    if c is not None:
        ms = [1000.0 * d for d in c.delays]
        row.update(connected=c.connected, dropped=c.dropped, client_errors=c.errors[:5], messages=c.messages,
                   delays=len(ms), delay_p50_ms=_r(percentile(ms, 50)), delay_p95_ms=_r(percentile(ms, 95)),
                   delay_max_ms=_r(max(ms) if ms else None))
    return row


def _r(v: float | None) -> float | None:
    return None if v is None else round(v, 1)


def judge(rows: list[dict], args: argparse.Namespace) -> list[str]:
    missed = []
    for row in rows:
        what = f"run with {row['clients']} clients"
        if row["exit_status"] != 0 or row["completed"] != row["goals"] or not row["goals"]:
            missed.append(f"{what}: the tour did not complete ({row['completed']} of {row['goals']} goals, exit "
                          f"{row['exit_status']})")
        if row["table3"] != TABLE3:
            missed.append(f"{what}: Table 3 {row['table3']}, expected {TABLE3}")
        if row["degraded"]:
            missed.append(f"{what}: degraded")
        if row["dashboard_url"] is None:
            missed.append(f"{what}: no dashboard URL printed for {args.robot}")
        elif row["dashboard_cpu_percent"] is None:
            missed.append(f"{what}: no process seen serving {args.robot}'s dashboard (its CPU not measured)")
        if row["clients"]:
            if row.get("connected") != row["clients"] or row.get("dropped") or row.get("client_errors"):
                missed.append(f"{what}: {row.get('connected')} connected, {row.get('dropped')} dropped, "
                              f"errors {row.get('client_errors')}")
            p95 = row.get("delay_p95_ms")
            if p95 is None or p95 > args.max_p95_ms:
                missed.append(f"{what}: p95 delay {p95} ms, target at most {args.max_p95_ms:g} ms")
    return missed


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="gidabot bench dashboard", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--tour", type=Path, default=resource("tours", "long_tour.tour"))
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--robot", default="Kbot", help="the robot whose dashboard the clients open")
    p.add_argument("--clients", type=int, default=20)
    p.add_argument("--max-p95-ms", type=float, default=1000.0)
    p.add_argument("--out", type=Path, default=None, help="folder of the runs (default: a temporary one)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args(argv)
    out = args.out or Path(mkdtemp(prefix="gidabot-bench-dashboard-"))
    out.mkdir(parents=True, exist_ok=True)
    calibration = Calibration()
    calibration.measure()
    print(describe(calibration), file=sys.stderr, flush=True)
    rows = []
    for clients in (0, args.clients):
        print(f"bench dashboard: Table 2 tour with {clients} clients on {args.robot}'s dashboard "
              f"(log: {out / f'demo-{clients}.log'})", file=sys.stderr, flush=True)
        rows.append(run_one(args, out, clients, out / f"demo-{clients}.log"))
    calibration.measure()
    missed = judge(rows, args)
    result = {"runs": rows, "targets_missed": missed, "calibration": as_json(calibration), "out": str(out)}
    if args.json:
        print(json.dumps(result))
    else:
        for row in rows:
            line = (f"{row['clients']:>2} clients: {row['completed']}/{row['goals']} goals, Table 3 {row['table3']}, "
                    f"{'degraded' if row['degraded'] else 'not degraded'}, {row['wall_s']} s wall; {args.robot}'s "
                    f"dashboard {row['dashboard_cpu_percent']} % of a core")
            if row["clients"]:
                line += (f"; {row.get('connected')} clients connected, {row.get('messages')} messages, "
                         f"{row.get('delays')} statuses, delay from the dashboard's receipt to the client p50 "
                         f"{row.get('delay_p50_ms')} ms, p95 {row.get('delay_p95_ms')} ms, "
                         f"max {row.get('delay_max_ms')} ms")
            print(line)
        print(describe(calibration))
        print("targets: " + ("all met" if not missed else "MISSED: " + "; ".join(missed)))
    return 1 if missed else 0
