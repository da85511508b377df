"""The web stack's application (aiohttp, ROS-free): every request goes through the same guard.

:class:`WebApp` owns an ``aiohttp.web.Application`` and adds to the routes an application registers:

- **every request**: a ``Host`` this server answers to (an address, ``localhost``, a name in
  :attr:`WebConfig.hosts` or of :attr:`WebConfig.origins`; else ``403``: a page of another site whose name was
  made to resolve to the robot, DNS rebinding, would otherwise be same-origin with itself and read the
  building), a rate limit per address (``429``), a body size limit (``client_max_size``: ``413``),
  security headers on every answer, errors included (a Content-Security-Policy without inline script or
  style, ``X-Frame-Options: DENY``, ``nosniff``, no referrer, ``Cache-Control: no-store`` for the API);
- **reads** (:meth:`WebApp.page`, :meth:`WebApp.read`): GET only, they change nothing;
- **actions** (:meth:`WebApp.action`): POST only (a GET on their path is ``405``), each checked in this
  order: same origin (``Origin``, else ``Referer``, must be this server: ``403``), a logged-in session
  (``401``), its CSRF token in ``X-CSRF-Token`` (``403``), the role (``403``), a rate limit per session
  (``429``), a JSON object body (``400``). The handler gets the session and the body;
- **files** (:meth:`WebApp.files`): served only by the names a :class:`~gidabot_web.web.files.NamedFiles`
  lists (``404`` otherwise);
- **the session API**: ``GET /api/session`` (who is logged in, and the CSRF token: before login, the token of
  the login form, bound to a pre-session cookie), ``POST /api/login`` (same origin, the login form's token,
  failed logins limited per address: ``401``, then ``429`` while locked out), ``POST /api/logout``;
- **live**: ``GET /live`` (WebSocket, same origin) hands the client to a :class:`~gidabot_web.web.live.LiveHub`.

Every refusal is counted by reason in :attr:`WebApp.counters` (``refused_<reason>``). The client address is
the TCP peer; ``X-Forwarded-For`` counts only from the ``trusted_proxies`` (a reverse proxy for HTTPS).
"""

from __future__ import annotations

import hmac
import ipaddress
import json
import secrets
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from aiohttp import web

from gidabot_web.errors import Refused
from gidabot_web.web.auth import STAFF, LoginLimiter, PasswordFile, Session, Sessions, allows
from gidabot_web.web.files import NamedFiles
from gidabot_web.web.limits import Counters, TokenBuckets
from gidabot_web.web.live import LiveHub

SESSION_COOKIE = "gidabot_session"
PRE_COOKIE = "gidabot_pre"
CSRF_HEADER = "X-CSRF-Token"
CSP = ("default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self'; connect-src 'self'; "
       "font-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'")
SECURITY_HEADERS = {
    "Content-Security-Policy": CSP,
    "X-Frame-Options": "DENY",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "same-origin",
    "Cross-Origin-Opener-Policy": "same-origin",
    "Cross-Origin-Resource-Policy": "same-origin",
    "Permissions-Policy": "camera=(), microphone=(), geolocation=()",
}
STATUS_REASONS = {400: "invalid", 401: "unauthenticated", 403: "forbidden", 404: "not_found", 405: "method",
                  413: "too_large", 429: "rate_limited"}

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]
ActionHandler = Callable[[web.Request, Session, dict], Awaitable[Any]]


@dataclass(frozen=True)
class WebConfig:
    users_file: Path
    max_body: int = 128 * 1024                # bytes of a request body
    address_rate: float = 30.0                # requests per second per address (all kinds) ...
    address_burst: float = 120.0              # ... and at once
    session_rate: float = 2.0                 # actions per second per session ...
    session_burst: float = 20.0               # ... and at once
    login_failures: int = 5                   # failed logins per address within login_window s ...
    login_window: float = 60.0
    login_lockout: float = 60.0               # ... lock it out this long
    session_idle: float = 8 * 3600.0          # s
    secure_cookies: bool = False              # Secure cookies (the page is served over HTTPS by a proxy)
    trusted_proxies: frozenset[str] = field(default_factory=frozenset)
    origins: frozenset[str] = field(default_factory=frozenset)   # more origins the page may be served from
    hosts: frozenset[str] = field(default_factory=frozenset)     # names (no port) staff reach this server by


class WebApp:
    def __init__(self, config: WebConfig, clock: Callable[[], float] = time.monotonic) -> None:
        self.config, self.clock = config, clock
        self.counters = Counters()
        self.passwords = PasswordFile(config.users_file)
        self.sessions = Sessions(config.session_idle, clock=clock)
        self.logins = LoginLimiter(config.login_failures, config.login_window, config.login_lockout)
        self._per_address = TokenBuckets(config.address_rate, config.address_burst)
        self._per_session = TokenBuckets(config.session_rate, config.session_burst)
        self.app = web.Application(middlewares=[self._guard], client_max_size=config.max_body)
        self.app.on_response_prepare.append(self._headers)
        self.read("/api/session", self._session)
        self.app.router.add_post("/api/login", self._login)
        self.action("/api/logout", self._logout)

    # -- registering routes --------------------------------------------------------------
    def page(self, path: str, files: NamedFiles, name: str) -> None:
        """GET ``path`` serves file ``name`` of ``files``."""
        async def handler(_request: web.Request) -> web.StreamResponse:
            return self._file(files, name)
        self.app.router.add_get(path, handler)

    def files(self, prefix: str, files: NamedFiles) -> None:
        """GET ``<prefix>/<name>`` serves the file listed as ``name``."""
        async def handler(request: web.Request) -> web.StreamResponse:
            return self._file(files, request.match_info["name"])
        self.app.router.add_get(prefix + "/{name}", handler)

    def read(self, path: str, handler: Handler) -> None:
        """GET ``path`` (it must change nothing)."""
        self.app.router.add_get(path, handler)

    def action(self, path: str, handler: ActionHandler, role: str = STAFF) -> None:
        """POST ``path``, for a session of ``role``: the checks of the module docstring, then
        ``handler(request, session, body)``; its result is answered as JSON."""
        async def guarded(request: web.Request) -> web.StreamResponse:
            self.same_origin(request)
            session = self.sessions.get(request.cookies.get(SESSION_COOKIE))
            if session is None:
                raise Refused(401, "unauthenticated", "log in first")
            token = request.headers.get(CSRF_HEADER, "")
            if not hmac.compare_digest(token.encode(), session.csrf.encode()):
                raise Refused(403, "csrf", "missing or wrong CSRF token")
            if not allows(session.role, role):
                raise Refused(403, "role", f"this needs the {role} role")
            if not self._per_session.take(session.id, self.clock()):
                raise Refused(429, "session_rate", "too many actions; wait a moment")
            body = await self.json_body(request)
            return web.json_response(await handler(request, session, body))
        self.app.router.add_post(path, guarded)

    def live(self, path: str, hub: LiveHub) -> None:
        async def handler(request: web.Request) -> web.StreamResponse:
            self.same_origin(request, require=False)
            return await hub.handle(request, self.address(request))
        self.app.router.add_get(path, handler)
        self.app.on_startup.append(hub.start)
        self.app.on_shutdown.append(hub.stop)

    # -- checks --------------------------------------------------------------------------
    def address(self, request: web.Request) -> str:
        peer = request.remote or "?"
        if peer in self.config.trusted_proxies:
            forwarded = request.headers.get("X-Forwarded-For", "")
            if forwarded:
                return forwarded.split(",")[-1].strip()[:64] or peer
        return peer

    def host_allowed(self, host: str) -> bool:
        """Whether a request's ``Host`` (name or address, and port) is one this server answers to: an IP address,
        ``localhost``, a name in :attr:`WebConfig.hosts`, or the name of one of :attr:`WebConfig.origins`. A name
        not listed is refused: DNS rebinding needs one."""
        try:
            name = urlsplit("//" + host).hostname if host else None
        except ValueError:                      # "[::1" and the like
            return False
        if not name:
            return False
        try:
            ipaddress.ip_address(name)
            return True
        except ValueError:
            pass
        named = {h.lower() for h in self.config.hosts} | {urlsplit(o).hostname or "" for o in self.config.origins}
        return name == "localhost" or name in named

    def origins(self, request: web.Request) -> set[str]:
        host = request.host
        return {f"http://{host}", f"https://{host}", *self.config.origins}

    def same_origin(self, request: web.Request, require: bool = True) -> None:
        """Refuse (403) a request whose ``Origin`` (else ``Referer``) is not this server; with ``require``, also
        one that has neither."""
        allowed = self.origins(request)
        origin = request.headers.get("Origin")
        if origin is not None:
            if origin not in allowed:
                raise Refused(403, "origin", f"origin {origin[:80]!r} is not this server")
            return
        referer = request.headers.get("Referer")
        if referer is not None:
            if not any(referer == o or referer.startswith(o + "/") for o in allowed):
                raise Refused(403, "origin", "referer is not this server")
            return
        if require:
            raise Refused(403, "origin", "no Origin or Referer header")

    async def json_body(self, request: web.Request) -> dict:
        if request.content_type != "application/json":
            raise Refused(400, "invalid", "expected an application/json body")
        raw = await request.read()
        try:
            body = json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as err:
            raise Refused(400, "invalid", f"not JSON: {err}") from err
        if not isinstance(body, dict):
            raise Refused(400, "invalid", "expected a JSON object")
        return body

    # -- the guard and the headers ---------------------------------------------------------
    @web.middleware
    async def _guard(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        self.counters.inc("requests")
        try:
            if not self._per_address.take(self.address(request), self.clock()):
                raise Refused(429, "rate_limited", "too many requests; slow down")
            if not self.host_allowed(request.host):
                raise Refused(403, "host", f"host {request.host[:80]!r} is not a name of this server "
                                           "(the dashboard's ~hosts lists the names staff use)")
            return await handler(request)
        except Refused as err:
            self.counters.inc(f"refused_{err.reason}")
            return web.json_response({"error": err.reason, "message": str(err)}, status=err.status)
        except web.HTTPException as err:
            if err.status >= 400:
                self.counters.inc(f"refused_{STATUS_REASONS.get(err.status, str(err.status))}")
                return web.json_response({"error": STATUS_REASONS.get(err.status, "error"), "message": err.reason},
                                         status=err.status, headers={k: v for k, v in err.headers.items()
                                                                     if k.lower() == "allow"})
            raise

    async def _headers(self, request: web.Request, response: web.StreamResponse) -> None:
        for key, value in SECURITY_HEADERS.items():
            response.headers.setdefault(key, value)
        if request.path.startswith("/api/"):
            response.headers["Cache-Control"] = "no-store"
        else:
            response.headers.setdefault("Cache-Control", "no-cache")

    def _file(self, files: NamedFiles, name: str) -> web.Response:
        served = files.read(name)
        if served is None:
            raise Refused(404, "not_found", "no such file")
        return web.Response(body=served.body, headers={"Content-Type": served.content_type})

    # -- the session API -----------------------------------------------------------------
    def _set_cookie(self, response: web.StreamResponse, name: str, value: str, max_age: int | None = None) -> None:
        response.set_cookie(name, value, httponly=True, samesite="Strict", secure=self.config.secure_cookies,
                            path="/", max_age=max_age)

    async def _session(self, request: web.Request) -> web.StreamResponse:
        session = self.sessions.get(request.cookies.get(SESSION_COOKIE))
        if session is not None:
            return web.json_response({"user": session.user, "role": session.role, "csrf": session.csrf})
        nonce = request.cookies.get(PRE_COOKIE, "")
        fresh = not (isinstance(nonce, str) and 16 <= len(nonce) <= 128)
        if fresh:
            nonce = secrets.token_urlsafe(24)
        response = web.json_response({"user": None, "role": None, "csrf": self.sessions.pre_token(nonce)})
        if fresh:
            self._set_cookie(response, PRE_COOKIE, nonce)
        return response

    async def _login(self, request: web.Request) -> web.StreamResponse:
        self.same_origin(request)
        address = self.address(request)
        now = self.clock()
        if self.logins.locked(address, now):
            raise Refused(429, "login_locked", "too many failed logins from this address; try again later")
        if not self.sessions.check_pre_token(request.cookies.get(PRE_COOKIE), request.headers.get(CSRF_HEADER)):
            raise Refused(403, "csrf", "missing or wrong CSRF token")
        body = await self.json_body(request)
        user = self.passwords.verify(body.get("user"), body.get("password"))
        if user is None:
            self.logins.failed(address, now)
            raise Refused(401, "login_failed", "wrong user or password")
        self.logins.succeeded(address)
        session = self.sessions.create(user.name, user.role)
        self.counters.inc("logins")
        response = web.json_response({"user": session.user, "role": session.role, "csrf": session.csrf})
        self._set_cookie(response, SESSION_COOKIE, session.id)
        response.del_cookie(PRE_COOKIE, path="/")
        return response

    async def _logout(self, request: web.Request, session: Session, _body: dict) -> dict:
        self.sessions.end(session.id)
        return {"user": None}
