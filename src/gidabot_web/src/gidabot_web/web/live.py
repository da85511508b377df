"""Live updates over WebSocket (aiohttp, ROS-free).

An application's state is a set of named *sections* (:class:`LiveSource`), each with a version that grows on
every change and a JSON text rendered once per version. :class:`LiveHub` sends every client, at most once per
``period`` (the per-client rate limit), one message holding the sections that changed since it last sent
that client anything: states are coalesced, whatever their rate. :meth:`LiveHub.notify` wakes the hub at once
(an alert is pushed as it happens, within the client's period). Every client gets a ``tick`` at least every
``tick_period`` s, so a page knows the server is there; the server pings every ``heartbeat`` s and drops a
client that does not answer within ``heartbeat / 2`` s (a dead client is gone within 1.5 heartbeats), one
whose sends do not complete within ``send_timeout`` s (a stalled reader), and one that talks too much
(clients only listen). Connections are bounded in number, in total and per address.

Messages, server to client (JSON): ``{"type": "update", "sections": {name: value, ...}, "now": wall s}``,
``{"type": "tick", "now": wall s}``.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

from aiohttp import WSMsgType, web

from gidabot_web.web.limits import Counters, TokenBuckets


class LiveSource(Protocol):
    def versions(self) -> Mapping[str, int]:
        """Every section's current version."""

    def section_json(self, name: str) -> str:
        """Section ``name`` as JSON text (rendered once per version)."""


@dataclass(eq=False)
class Client:
    ws: web.WebSocketResponse
    address: str
    sent: dict[str, int] = field(default_factory=dict)
    last_send: float = -1e9
    messages: int = 0


class LiveHub:
    def __init__(self, source: LiveSource, counters: Counters, period: float = 0.25, heartbeat: float = 4.0,
                 tick_period: float = 2.0, send_timeout: float = 3.0, max_clients: int = 200,
                 max_per_address: int = 50, client_rate: float = 2.0, client_burst: float = 20.0,
                 clock: Callable[[], float] = time.monotonic, wall: Callable[[], float] = time.time) -> None:
        self.source, self.counters = source, counters
        self.period, self.heartbeat, self.tick_period = period, heartbeat, tick_period
        self.send_timeout = send_timeout
        self.max_clients, self.max_per_address = max_clients, max_per_address
        self.clock, self.wall = clock, wall
        self.clients: set[Client] = set()
        self._talk = TokenBuckets(client_rate, client_burst)
        self._wake = asyncio.Event()
        self._task: asyncio.Task | None = None
        self.sent_messages = 0

    # -- life cycle ----------------------------------------------------------------------
    async def start(self, _app: web.Application | None = None) -> None:
        self._task = asyncio.get_running_loop().create_task(self._run())

    async def stop(self, _app: web.Application | None = None) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        for c in list(self.clients):
            with contextlib.suppress(Exception):
                await c.ws.close()

    def notify(self) -> None:
        """Something changed that should go out now (each client still at most once per period)."""
        self._wake.set()

    # -- one client ----------------------------------------------------------------------
    async def handle(self, request: web.Request, address: str) -> web.StreamResponse:
        """The WebSocket of one client (the caller checked its origin)."""
        if len(self.clients) >= self.max_clients or \
                sum(c.address == address for c in self.clients) >= self.max_per_address:
            self.counters.inc("refused_too_many_clients")
            raise web.HTTPTooManyRequests(text="too many live clients")
        ws = web.WebSocketResponse(heartbeat=self.heartbeat, max_msg_size=4096, autoping=True)
        await ws.prepare(request)
        client = Client(ws, address)
        self.clients.add(client)
        self.counters.inc("live_clients_total")
        self.notify()
        try:
            async for msg in ws:
                client.messages += 1
                if msg.type in (WSMsgType.ERROR, WSMsgType.CLOSE):
                    break
                if not self._talk.take(str(id(client)), self.clock()):
                    self.counters.inc("refused_live_chatter")
                    await ws.close(code=1008, message=b"clients only listen")
                    break
        finally:
            self.clients.discard(client)
        return ws

    # -- the push loop -------------------------------------------------------------------
    async def _run(self) -> None:
        while True:
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(self._wake.wait(), timeout=self.period)
            self._wake.clear()
            if not self.clients:
                continue
            now = self.clock()
            versions = dict(self.source.versions())
            rendered: dict[str, str] = {}
            sends = []
            later = False
            for c in list(self.clients):
                if c.ws.closed:
                    self.clients.discard(c)
                    continue
                changed = [n for n, v in versions.items() if c.sent.get(n) != v]
                if changed and now - c.last_send < self.period:
                    later = True       # this client's period is not over: the next round sends it
                    continue
                if changed:
                    for n in changed:
                        if n not in rendered:
                            rendered[n] = self.source.section_json(n)
                    body = ",".join(f"{json.dumps(n)}:{rendered[n]}" for n in changed)
                    text = f'{{"type":"update","now":{self.wall():.3f},"sections":{{{body}}}}}'
                    c.sent.update({n: versions[n] for n in changed})
                elif now - c.last_send >= self.tick_period:
                    text = f'{{"type":"tick","now":{self.wall():.3f}}}'
                else:
                    continue
                c.last_send = now
                sends.append(self._send(c, text))
            if sends:
                await asyncio.gather(*sends)
            if later:
                self._wake.set()
                await asyncio.sleep(min(self.period / 4, 0.05))

    async def _send(self, c: Client, text: str) -> None:
        try:
            await asyncio.wait_for(c.ws.send_str(text), timeout=self.send_timeout)
            self.sent_messages += 1
        except (TimeoutError, ConnectionError, RuntimeError):
            self.counters.inc("live_clients_dropped")
            self.clients.discard(c)
            with contextlib.suppress(Exception):
                await c.ws.close(code=1011, message=b"too slow")
