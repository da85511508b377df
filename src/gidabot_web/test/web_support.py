"""The dashboard's web application on a test server (aiohttp.test_utils, no master): the faculty seen from Kbot, a
real tour store (ROS-free) behind the ``tour_store/edit`` the application publishes on, two users (staff and
admin), and helpers to log in and to send requests as a browser would (or would not)."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path

from aiohttp.test_utils import TestClient, TestServer
from dashboard_support import cross_trip, make_core, status
from yarl import URL

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import TourRejected
from gidabot_navigation.interface import Node, global_name
from gidabot_navigation.resources import resource
from gidabot_navigation.tours.tour_store import EditResultData, TourMessage, TourStore
from gidabot_web.dashboard.app import DashboardApp
from gidabot_web.dashboard.texts import catalogs
from gidabot_web.web.app import CSRF_HEADER, WebConfig
from gidabot_web.web.auth import ADMIN, STAFF, make_user, save_users

STAFF_USER, STAFF_PASSWORD = "sara", "staff-password-1"
ADMIN_USER, ADMIN_PASSWORD = "ada", "admin-password-1"
ADDRESS = "10.1.0.5"          # the test browser's address (X-Forwarded-For from the trusted proxy: the test client)


class QuietLog:
    def info(self, msg: str) -> None:
        pass

    warning = error = info


@dataclass
class Bus:
    """What the application publishes; tour edits go to a real tour store, whose answer comes back as on ROS."""

    store: TourStore
    app: DashboardApp | None = None
    cancels: list = field(default_factory=list)
    commands: list = field(default_factory=list)
    edits: list = field(default_factory=list)

    def cancel(self, c: object) -> None:
        self.cancels.append(c)

    def staff(self, c: object) -> None:
        self.commands.append(c)

    def tour_edit(self, tm: TourMessage) -> None:
        self.edits.append(tm)
        try:
            rec = self.store.edit(tm, sender=global_name(Node.DASHBOARD))     # the dashboard node publishes it
            result = EditResultData(tm.uid, tm.file_name, tm.deleted, True, rec.version)
        except TourRejected as err:
            result = EditResultData(tm.uid, tm.file_name, tm.deleted, False, 0, err.reason, str(err))
        asyncio.get_running_loop().call_soon(self.app.on_edit_result, result)

    @property
    def sent(self) -> int:
        return len(self.cancels) + len(self.commands) + len(self.edits)


@dataclass
class Site:
    app: DashboardApp
    bus: Bus
    client: TestClient
    tours_dir: Path

    @property
    def origin(self) -> str:
        return str(self.client.make_url("")).rstrip("/")

    def headers(self, address: str = ADDRESS, origin: str | None = "", csrf: str | None = None,
                **more: str) -> dict[str, str]:
        h = {"X-Forwarded-For": address, **more}
        if origin is not None:
            h["Origin"] = origin or self.origin
        if csrf is not None:
            h[CSRF_HEADER] = csrf
        return h

    async def session(self, address: str = ADDRESS) -> dict:
        r = await self.client.get("/api/session", headers=self.headers(address, origin=None))
        return await r.json()

    async def login(self, user: str = STAFF_USER, password: str = STAFF_PASSWORD, address: str = ADDRESS) -> str:
        """Log in; the session's CSRF token."""
        pre = await self.session(address)
        r = await self.client.post("/api/login", json={"user": user, "password": password},
                                   headers=self.headers(address, csrf=pre["csrf"]))
        assert r.status == 200, await r.text()
        return (await r.json())["csrf"]

    async def post(self, path: str, body: object, csrf: str | None, address: str = ADDRESS,
                   origin: str | None = "", **more: str):
        return await self.client.post(path, json=body, headers=self.headers(address, origin, csrf, **more))

    async def raw(self, method: str, raw_path: str, address: str = ADDRESS, **kw: object):
        """A request whose path is sent exactly as written (not normalised by the client)."""
        url = URL(self.origin + raw_path, encoded=True)
        return await self.client.session.request(method, url, headers=self.headers(address, origin=None), **kw)

    def tour_files(self) -> dict[str, bytes]:
        """Every file of the tours directory and of its parent (what a hostile upload could have written)."""
        out = {}
        for d in (self.tours_dir, self.tours_dir.parent):
            for p in sorted(d.iterdir()):
                if p.is_file():
                    out[str(p)] = p.read_bytes()
        return out


def run_site(building: Building, tmp: Path, test: Callable[[Site], Awaitable[None]], **config: object) -> None:
    """Run ``test(site)`` against a fresh application (an event loop of its own)."""
    async def main() -> None:
        core = make_core(building, tmp, now=time.monotonic())
        for r in building.robots:
            core.on_status(status(building, r.name), r.name, time.monotonic())
        core.on_goal(cross_trip(), "Tartalo", time.monotonic())
        core.on_status(status(building, "Galtxagorri", battery=0.05), "Galtxagorri", time.monotonic())   # an alert
        users = tmp / "users.json"
        save_users(users, {STAFF_USER: make_user(STAFF_USER, STAFF_PASSWORD, STAFF),
                           ADMIN_USER: make_user(ADMIN_USER, ADMIN_PASSWORD, ADMIN)})
        tours = tmp / "robot" / "tours"
        store = TourStore(tours, building, core.me, wall_ns=time.time_ns, log=QuietLog(), seed_dir=resource("tours"))
        store.open()
        bus = Bus(store)
        cfg = {"users_file": users, "trusted_proxies": frozenset({"127.0.0.1"}), **config}
        app = DashboardApp(core, WebConfig(**cfg), bus, catalogs())   # type: ignore[arg-type]
        bus.app = app
        async with TestClient(TestServer(app.app)) as client:
            await test(Site(app, bus, client, tours))
        store.close()
        core.history.close()

    asyncio.run(main())
