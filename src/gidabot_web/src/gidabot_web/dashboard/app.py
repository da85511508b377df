"""The dashboard's web application (aiohttp, ROS-free): the page, its files, its API and its live updates, on the
web stack (:mod:`gidabot_web.web.app`). It renders and pushes what the core (:mod:`.dashboard`) holds and hands
staff actions to the core; what must go on the robots' topics goes to a :class:`Bus` (the node's publishers,
or a test's stand-in).

Routes (docs/dashboard.md, *API*):

==========================================  =========  =====================================================
``GET /``                                   anyone     the page
``GET /static/<name>``, ``/web/<name>``     anyone     the page's files, by the names the package ships
``GET /blueprints/<name>``                  anyone     a floor's blueprint, by the name the building section lists
``GET /i18n/<language>``                    anyone     the page's texts in eu, en or es (gidabot_gui's catalogs)
``GET /api/state``                          anyone     every section (what the live updates carry)
``GET /api/history/<day>``                  anyone     a day's sums (``YYYY-MM-DD``)
``GET /api/history/<day>/csv``              anyone     a day's trips as CSV
``GET /live``                               anyone     WebSocket: the sections as they change
``POST /api/trips/cancel``                  staff      ``{"trip": uid}``: cancel a trip on every robot
``POST /api/robots/service``                staff      ``{"robot": name, "out": bool, "reason": text}``
``POST /api/alerts/ack``                    staff      ``{"id": n}``
``POST /api/tours/save``                    admin      ``{"file_name", "text", "language"}``: create or edit
``POST /api/tours/delete``                  admin      ``{"file_name"}``
==========================================  =========  =====================================================

Tours go through the tour store (``tour_store/edit``), never to a file from here: the text is checked exactly
like a tour file first (:func:`~gidabot_navigation.tours.tour_file.parse_tour`: a hostile name or content is
refused with 400 and nothing is sent), then the store's answer (``tour_store/edit_result`` with the same uid)
is awaited and returned.
"""

from __future__ import annotations

import asyncio
import json
import re
import time
from collections.abc import Callable, Mapping
from importlib.resources import files
from pathlib import Path
from typing import Protocol

from aiohttp import web

from gidabot_navigation.errors import TourError, TourNameError
from gidabot_navigation.guiding.messages import CancelData, StaffCommandData
from gidabot_navigation.interface import DEFAULT_LANGUAGE, LANGUAGES
from gidabot_navigation.tours.tour_file import MAX_TOUR_BYTES, check_tour_file_name, parse_tour
from gidabot_navigation.tours.tour_store import EditResultData, TourMessage
from gidabot_web.dashboard.dashboard import DashboardCore, Section, blueprint_name
from gidabot_web.errors import Refused
from gidabot_web.web.app import WebApp, WebConfig
from gidabot_web.web.auth import ADMIN, STAFF, Session
from gidabot_web.web.files import NamedFiles
from gidabot_web.web.live import LiveHub

STATIC = Path(str(files("gidabot_web.dashboard") / "static"))     # the package's data (setup.py package_data)
WEB_STATIC = Path(str(files("gidabot_web.web") / "static"))
DAY_RE = re.compile(r"^\d{4}-\d{2}-\d{2}\Z")
EDIT_TIMEOUT = 5.0          # s to wait for the tour store's answer


class Bus(Protocol):
    """Where staff actions go (the node publishes them)."""

    def cancel(self, cancel: CancelData) -> None: ...

    def staff(self, command: StaffCommandData) -> None: ...

    def tour_edit(self, tour: TourMessage) -> None: ...


class DashboardApp:
    def __init__(self, core: DashboardCore, web_config: WebConfig, bus: Bus, texts: Mapping[str, Mapping[str, str]],
                 clock: Callable[[], float] = time.monotonic, push_period: float = 0.25, heartbeat: float = 4.0,
                 edit_timeout: float = EDIT_TIMEOUT) -> None:
        self.core, self.bus, self.texts, self.clock = core, bus, texts, clock
        self.edit_timeout = edit_timeout
        self.web = WebApp(web_config, clock)
        self.hub = LiveHub(self, self.web.counters, period=push_period, heartbeat=heartbeat, clock=clock)
        self._edits: dict[str, asyncio.Future] = {}
        blueprints = {blueprint_name(i, f.blueprint_file): f.blueprint_file
                      for i, f in enumerate(core.building.floors)}
        w = self.web
        w.page("/", NamedFiles.directory(STATIC), "index.html")
        w.files("/static", NamedFiles.directory(STATIC))
        w.files("/web", NamedFiles.directory(WEB_STATIC))
        w.files("/blueprints", NamedFiles(blueprints))
        w.read("/i18n/{language}", self._texts)
        w.read("/api/state", self._state)
        w.read("/api/history/{day}", self._history)
        w.read("/api/history/{day}/csv", self._csv)
        w.live("/live", self.hub)
        w.action("/api/trips/cancel", self._cancel, STAFF)
        w.action("/api/robots/service", self._service, STAFF)
        w.action("/api/alerts/ack", self._ack, STAFF)
        w.action("/api/tours/save", self._tour_save, ADMIN)
        w.action("/api/tours/delete", self._tour_delete, ADMIN)

    @property
    def app(self) -> web.Application:
        return self.web.app

    # -- the live source (LiveHub) -----------------------------------------------------------
    def versions(self) -> dict[str, int]:
        self.core.web_counters = self.web.counters
        self.core.clients = len(self.hub.clients)
        return self.core.versions()

    def section_json(self, name: str) -> str:
        return self.core.section_json(name)

    def changed(self) -> None:
        """The core changed something the page should see now (an alert, a trip)."""
        self.hub.notify()

    # -- reads ----------------------------------------------------------------------------
    async def _texts(self, request: web.Request) -> web.StreamResponse:
        language = request.match_info["language"]
        if language not in LANGUAGES:
            raise Refused(404, "not_found", "no such language")
        return web.json_response(self.texts.get(language, {}))

    async def _state(self, _request: web.Request) -> web.StreamResponse:
        self.versions()
        body = ",".join(f"{json.dumps(str(s))}:{self.core.section_json(s)}" for s in Section)
        return web.Response(text=f"{{{body}}}", content_type="application/json")

    def _day(self, request: web.Request) -> str:
        day = request.match_info["day"]
        if not DAY_RE.match(day) or self.core.history is None:
            raise Refused(404, "not_found", "no such day")
        return day

    async def _history(self, request: web.Request) -> web.StreamResponse:
        day = self._day(request)
        assert self.core.history is not None
        return web.json_response(self.core.history.summary(day))

    async def _csv(self, request: web.Request) -> web.StreamResponse:
        day = self._day(request)
        assert self.core.history is not None
        return web.Response(text=self.core.history.csv(day), content_type="text/csv", charset="utf-8", headers={
            "Content-Disposition": f'attachment; filename="gidabot-{self.core.me}-{day}.csv"'})

    # -- actions --------------------------------------------------------------------------
    async def _cancel(self, _request: web.Request, session: Session, body: dict) -> dict:
        cancel = self.core.cancel_trip(body.get("trip"), session.user, self.clock())
        self.bus.cancel(cancel)
        self.changed()
        return {"trip": cancel.goal_uid, "cancel": cancel.uid}

    async def _service(self, _request: web.Request, session: Session, body: dict) -> dict:
        out = body.get("out")
        if not isinstance(out, bool):
            raise Refused(400, "invalid", "out must be true or false")
        cmd = self.core.set_service(body.get("robot"), out, session.user, body.get("reason", ""), self.clock())
        self.bus.staff(cmd)
        self.changed()
        return {"robot": cmd.target_robot, "out": out, "uid": cmd.uid}

    async def _ack(self, _request: web.Request, session: Session, body: dict) -> dict:
        alert = self.core.ack_alert(body.get("id"), session.user, self.clock())
        self.changed()
        return alert.to_json()

    def _file_name(self, body: dict) -> str:
        name = body.get("file_name")
        try:
            return check_tour_file_name(name)
        except TourNameError as err:
            raise Refused(400, "invalid_name", str(err)) from err

    async def _tour_save(self, _request: web.Request, session: Session, body: dict) -> dict:
        name = self._file_name(body)
        text = body.get("text")
        language = body.get("language", DEFAULT_LANGUAGE)
        if not isinstance(text, str):
            raise Refused(400, "invalid", "text must be the tour file's text")
        if len(text.encode("utf-8", "surrogatepass")) > MAX_TOUR_BYTES:
            raise Refused(413, "too_large", f"a tour file has at most {MAX_TOUR_BYTES} bytes")
        if language not in LANGUAGES:
            raise Refused(400, "invalid", f"language must be one of {', '.join(LANGUAGES)}")
        try:
            tour = parse_tour(text.encode("utf-8", "replace"), name, self.core.building)
        except TourError as err:
            raise Refused(400, "invalid_tour", "; ".join(str(p) for p in err.problems)) from err
        tm = TourMessage(uid=self.core.uids.tour_edit(), origin_robot=self.core.me, editor_robot=self.core.me,
                         language=language, floor=tour.floor, tour_name=tour.name, file_name=tour.file_name,
                         tour_goals_info=tuple(tour.goal_lines()))
        return await self._edit(tm, session)

    async def _tour_delete(self, _request: web.Request, session: Session, body: dict) -> dict:
        name = self._file_name(body)
        tm = TourMessage(uid=self.core.uids.tour_edit(), origin_robot=self.core.me, editor_robot=self.core.me,
                         deleted=True, language=DEFAULT_LANGUAGE, file_name=name)
        return await self._edit(tm, session)

    async def _edit(self, tm: TourMessage, session: Session) -> dict:
        future: asyncio.Future = asyncio.get_running_loop().create_future()
        self._edits[tm.uid] = future
        self.core.count("tour_edits")
        try:
            self.bus.tour_edit(tm)
            result: EditResultData = await asyncio.wait_for(future, timeout=self.edit_timeout)
        except TimeoutError as err:
            raise Refused(504, "tour_store_silent", "the tour store did not answer") from err
        finally:
            self._edits.pop(tm.uid, None)
        if not result.ok:
            raise Refused(400 if result.reason != "io" else 500, f"tour_{result.reason or 'refused'}", result.error)
        return {"file_name": result.file_name, "deleted": result.deleted, "version": result.version,
                "user": session.user}

    def on_edit_result(self, result: EditResultData) -> None:
        """The tour store's answer to an edit (from the node's loop)."""
        future = self._edits.get(result.uid) if isinstance(result.uid, str) else None
        if future is not None and not future.done():
            future.set_result(result)
