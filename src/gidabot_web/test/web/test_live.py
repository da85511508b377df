"""Live updates: each client gets the sections that changed, at most once per period (states coalesced, the latest
value wins), events pushed at once; ticks when nothing changes; a dead, slow or chatty client is dropped."""

from __future__ import annotations

import asyncio
import json
import time

from aiohttp import WSMsgType, web
from aiohttp.test_utils import TestClient, TestServer

from gidabot_web.web.limits import Counters
from gidabot_web.web.live import LiveHub


class Source:
    def __init__(self) -> None:
        self.values = {"robots": 0, "alerts": 0}
        self.v = {"robots": 1, "alerts": 1}
        self.rendered = 0

    def versions(self) -> dict[str, int]:
        return dict(self.v)

    def section_json(self, name: str) -> str:
        self.rendered += 1
        return json.dumps(self.values[name])

    def set(self, name: str, value: int) -> None:
        self.values[name] = value
        self.v[name] += 1


def run(test, **hub_args) -> None:
    async def main() -> None:
        source, counters = Source(), Counters()
        hub = LiveHub(source, counters, **hub_args)
        app = web.Application()

        async def handler(request: web.Request) -> web.StreamResponse:
            return await hub.handle(request, request.headers.get("X-Test-Address", "a"))
        app.router.add_get("/live", handler)
        app.on_startup.append(hub.start)
        app.on_shutdown.append(hub.stop)
        async with TestClient(TestServer(app)) as client:
            await test(hub, source, counters, client)
    asyncio.run(main())


async def until(cond, timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "condition not met in time"
        await asyncio.sleep(0.02)


def test_states_are_coalesced_per_client_and_the_latest_value_arrives() -> None:
    async def test(hub, source, counters, client) -> None:
        ws = await client.ws_connect("/live")
        first = await ws.receive_json(timeout=2.0)
        assert first["type"] == "update" and first["sections"] == {"robots": 0, "alerts": 0}
        got = []

        async def read() -> None:
            async for msg in ws:
                got.append(json.loads(msg.data))
        reader = asyncio.create_task(read())
        began = time.monotonic()
        for i in range(1, 201):                   # 200 changes in about 1 s
            source.set("robots", i)
            await asyncio.sleep(0.005)
        await until(lambda: any(m.get("sections", {}).get("robots") == 200 for m in got))
        spent = time.monotonic() - began
        updates = [m for m in got if m["type"] == "update"]
        assert len(updates) <= spent / 0.2 + 2                      # at most one message per period
        assert all(set(m["sections"]) == {"robots"} for m in updates)   # only what changed
        assert source.rendered <= len(updates) + 3                  # rendered once per version sent, not per client
        reader.cancel()
        await ws.close()
    run(test, period=0.2)


def test_an_event_goes_out_within_the_period_and_ticks_keep_a_quiet_page_alive() -> None:
    async def test(hub, source, counters, client) -> None:
        ws = await client.ws_connect("/live")
        await ws.receive_json(timeout=2.0)
        await asyncio.sleep(0.3)                  # past the first period: nothing else is due
        source.set("alerts", 7)
        t0 = time.monotonic()
        hub.notify()
        msg = await ws.receive_json(timeout=5.0)
        # pushed within its period, not with the next tick (4 s): the bound leaves room for a loaded machine
        assert msg["sections"] == {"alerts": 7} and time.monotonic() - t0 < 2.0
        tick = await ws.receive_json(timeout=10.0)
        assert tick["type"] == "tick" and abs(tick["now"] - time.time()) < 5
        await ws.close()
    run(test, period=0.25, tick_period=4.0)


def test_a_dead_client_is_dropped_within_one_and_a_half_heartbeats() -> None:
    async def test(hub, source, counters, client) -> None:
        ws = await client.ws_connect("/live", autoping=False)     # never reads: never answers a ping
        await until(lambda: len(hub.clients) == 1, 2.0)
        t0 = time.monotonic()
        await until(lambda: not hub.clients, 6.0)
        assert time.monotonic() - t0 < 1.0 * 1.5 + 1.0                # 1.5 heartbeats, and room for a loaded machine
        await ws.close()
        live = await client.ws_connect("/live")                   # a live client stays
        await live.receive_json(timeout=2.0)
        reader = asyncio.create_task(live.receive())
        await asyncio.sleep(3.0)                  # three heartbeats answered: still there
        assert len(hub.clients) == 1
        reader.cancel()
        await live.close()
    run(test, heartbeat=1.0)


def test_clients_are_bounded_per_address_and_may_not_talk() -> None:
    async def test(hub, source, counters, client) -> None:
        socks = [await client.ws_connect("/live", headers={"X-Test-Address": "x"}) for _ in range(3)]
        r = await client.get("/live", headers={"X-Test-Address": "x", "Connection": "Upgrade", "Upgrade": "websocket",
                                               "Sec-WebSocket-Version": "13", "Sec-WebSocket-Key": "x" * 24})
        assert r.status == 429 and counters["refused_too_many_clients"] == 1
        other = await client.ws_connect("/live", headers={"X-Test-Address": "y"})
        await other.receive_json(timeout=2.0)
        for i in range(10):
            await other.send_str(f"hello {i}")
        closed = None
        while closed is None:
            msg = await other.receive(timeout=2.0)
            if msg.type in (WSMsgType.CLOSE, WSMsgType.CLOSED, WSMsgType.CLOSING):
                closed = msg
        assert counters["refused_live_chatter"] == 1
        for s in socks:
            await s.close()
    run(test, max_per_address=3, client_rate=1.0, client_burst=5.0)
