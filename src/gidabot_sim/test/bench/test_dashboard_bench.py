"""bench dashboard: one run reads the demo's whole stderr itself (the dashboards' addresses, the log), its report
from stdout, and the CPU of the process serving the robot's dashboard while it runs, on a stand-in for
``gidabot demo`` (the runs themselves are system-level)."""

from __future__ import annotations

import argparse
import asyncio
import sys
import time
from pathlib import Path

from aiohttp import web
from aiohttp.test_utils import TestServer

from gidabot_sim.bench import dashboard
from gidabot_sim.bench.dashboard import TOUR_DONE, Clients, judge, run_one

ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")
NOISE = 400          # progress lines after the addresses, as the demo prints them

# A demo that serves one "dashboard" (a listening socket), says where every robot's is, talks, runs until the
# bench has read its CPU time twice (the file ``seen``: at most 60 s), then reports and exits.
DEMO = f"""
import json, os, socket, sys, time
seen = sys.argv[1]
s = socket.socket(); s.bind(("127.0.0.1", 0)); s.listen()
port = s.getsockname()[1]
print("GidaBot demo: a stand-in", file=sys.stderr)
print("staff dashboards:", file=sys.stderr)
for i, name in enumerate({ROBOTS!r}):
    print(f"  {{name:<12}} http://127.0.0.{{i + 10}}:{{port}}/", file=sys.stderr)
for i in range({NOISE}):
    print(f"[{{i:6.1f}} s] goal 1 of 15, 0 done", file=sys.stderr)
sys.stderr.flush()
deadline = time.monotonic() + 60
while not os.path.exists(seen) and time.monotonic() < deadline:
    time.sleep(0.05)
robots = [{{"name": n, "processed": p}} for n, p in zip({ROBOTS!r}, (7, 8, 8, 6))]
print(json.dumps({{"robots": robots, "tour": {{"goals": 15, "completed": 15}}, "degraded": False}}))
"""


def test_a_run_reads_every_line_of_the_demos_stderr_and_the_cpu_of_the_robots_dashboard(tmp_path: Path,
                                                                                        monkeypatch) -> None:
    seen = tmp_path / "seen"
    monkeypatch.setattr(dashboard, "DEMO", (sys.executable, "-c", DEMO, str(seen)))
    read = []
    real = dashboard.cpu_seconds

    def cpu_seconds(pid: int | None) -> float | None:
        got = real(pid)
        if got is not None:
            read.append(got)
            if len(read) >= 2:
                seen.touch()
        return got
    monkeypatch.setattr(dashboard, "cpu_seconds", cpu_seconds)
    args = argparse.Namespace(tour=tmp_path / "x.tour", seed=1, robot="Kbot", clients=0, max_p95_ms=1000.0)
    log = tmp_path / "demo.log"
    row = run_one(args, tmp_path, 0, log)
    assert len(log.read_text(encoding="utf-8").splitlines()) == 2 + len(ROBOTS) + NOISE     # all of stderr, here
    assert row["dashboard_url"] is not None and row["dashboard_url"].startswith("http://127.0.0.11:")
    assert row["dashboard_cpu_percent"] is not None and row["dashboard_cpu_percent"] >= 0.0
    assert row["exit_status"] == 0 and row["table3"] == [7, 8, 8, 6] and row["completed"] == 15
    assert judge([row], args) == []


def test_a_client_counts_a_socket_closed_during_the_tour_as_dropped_not_one_closed_after_it() -> None:

    async def scenario(tour_over_first: bool) -> Clients:
        closing = asyncio.Event()

        async def live(request: web.Request) -> web.WebSocketResponse:
            ws = web.WebSocketResponse()
            await ws.prepare(request)
            await ws.send_json({"type": "update", "sections": {"robots": [{"name": "Kbot", "rx": time.time()}]}})
            await closing.wait()
            await ws.close()                           # the dashboard stops (or dies)
            return ws

        app = web.Application()
        app.router.add_get("/live", live)
        async with TestServer(app) as server:
            clients = Clients(str(server.make_url("/")), 2)
            task = asyncio.ensure_future(clients._all())
            deadline = time.monotonic() + 30
            while clients.messages < 2 and time.monotonic() < deadline:
                await asyncio.sleep(0.05)
            if tour_over_first:
                clients.stop.set()
            closing.set()
            await asyncio.wait_for(task, 30)
        return clients

    during = asyncio.run(scenario(tour_over_first=False))
    assert (during.connected, during.messages, during.dropped, len(during.delays)) == (2, 2, 2, 2)
    after = asyncio.run(scenario(tour_over_first=True))
    assert (after.connected, after.messages, after.dropped, after.errors) == (2, 2, 0, [])


def test_the_end_of_the_tour_is_the_progress_line_with_every_goal_done() -> None:
    assert TOUR_DONE.search("[  96.5 s] goal 15 of 15 (001 1->0), 15 done | Tartalo: tour finished | sim/wall 20")
    assert not TOUR_DONE.search("[  94.6 s] goal 15 of 15 (001 1->0), 14 done | Kbot: go to floor | sim/wall 20")
    assert not TOUR_DONE.search("[  24.9 s] goal 1 of 15 (005 0->0), 1 done | Tartalo: tour step done")
