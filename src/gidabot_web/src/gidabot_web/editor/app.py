"""``gidabot edit DIR``: the building editor's web server (aiohttp; ROS-free: a preview's robots come from the
pose reader's file, :mod:`gidabot_web.editor.preview`).

It serves one page (``static/``, shipped with the package, no CDN: it works offline) and a small JSON API over
one building folder: the document (:mod:`~gidabot_web.editor.document`), its live checks
(:mod:`~gidabot_web.editor.checks`, run in a worker thread after every change, the latest revision only), the
alignment fits (:mod:`gidabot_navigation.building.alignment`), saving (:mod:`gidabot_navigation.building.building_file`)
and the preview.

Security (as the staff dashboard's web stack; docs/building-format.md, *With the editor*):

- bound to 127.0.0.1 unless ``--host`` says otherwise; on a loopback address a request naming another host
  (``Host``) is refused (DNS rebinding);
- a random token in the printed address (``#token=...``: the part after ``#`` never reaches a server or a log).
  The page trades it (``POST /api/session``, header ``X-Editor-Token``) for a session cookie (HttpOnly,
  SameSite=Strict) and a CSRF token. Every ``/api/`` and ``/files/`` request needs the session;
- every change is a ``POST`` (a ``GET`` changes nothing) checked for the same origin (``Origin``, else
  ``Referer``), the session, its CSRF token (``X-CSRF-Token``) and a JSON body of at most ``MAX_BODY`` bytes;
- files are served only by plain names of image files of the building folder; the document refuses a file name
  outside it; requests per address are rate-limited; every answer carries the security headers
  (Content-Security-Policy without inline script or style, no framing, no sniffing, no referrer).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import hmac
import importlib.resources
import io
import ipaddress
import json
import math
import secrets
import signal
import sys
import time
from collections.abc import Awaitable, Callable
from pathlib import Path

from aiohttp import web

from gidabot_navigation.building import building_file
from gidabot_navigation.building.alignment import fit_blueprint, fit_floors
from gidabot_navigation.building.model import building_from_doc
from gidabot_navigation.building.yaml_text import load_yaml
from gidabot_navigation.errors import AlignmentError, BuildingError, ResourceError
from gidabot_web.editor.checks import CheckResult, LiveChecker
from gidabot_web.editor.document import BuildingDocument, folder_file, folder_images, folder_maps, left_out
from gidabot_web.editor.floors import removal_edits, renumber_edits
from gidabot_web.editor.preview import FEATURED, Preview, fitting_tours
from gidabot_web.errors import EditError, PreviewError, Refused

STATIC = importlib.resources.files("gidabot_web.editor") / "static"    # package data (devel and install space)
STATIC_FILES = {"index.html": "text/html; charset=utf-8", "editor.js": "text/javascript; charset=utf-8",
                "editor.css": "text/css; charset=utf-8", "favicon.svg": "image/svg+xml"}
IMAGE_TYPES = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".gif": "image/gif",
               ".webp": "image/webp"}
SESSION_COOKIE = "gidabot_editor"
TOKEN_HEADER = "X-Editor-Token"
CSRF_HEADER = "X-CSRF-Token"
MAX_BODY = 256 * 1024
MAX_IMAGE = 64 * 1024 * 1024
RATE, BURST = 40.0, 200.0              # requests per second per address, and at once
CHECK_DEBOUNCE = 0.1                   # s after a change before its check starts
CSP = ("default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob:; connect-src 'self'; "
       "base-uri 'none'; form-action 'none'; frame-ancestors 'none'")
SECURITY_HEADERS = {"Content-Security-Policy": CSP, "X-Frame-Options": "DENY", "X-Content-Type-Options": "nosniff",
                    "Referrer-Policy": "no-referrer", "Cross-Origin-Opener-Policy": "same-origin",
                    "Cross-Origin-Resource-Policy": "same-origin"}

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


class Buckets:
    """Requests per address: ``burst`` at once, ``rate`` per second on average."""

    def __init__(self, rate: float = RATE, burst: float = BURST, max_keys: int = 1000) -> None:
        self.rate, self.burst, self.max_keys = rate, burst, max_keys
        self._b: dict[str, tuple[float, float]] = {}

    def take(self, key: str, now: float) -> bool:
        tokens, at = self._b.pop(key, (self.burst, now))
        tokens = min(self.burst, tokens + max(0.0, now - at) * self.rate)
        ok = tokens >= 1.0
        self._b[key] = (tokens - 1.0 if ok else tokens, now)
        while len(self._b) > self.max_keys:
            self._b.pop(next(iter(self._b)))
        return ok


class EditorServer:
    """The editor of one building folder (see the module docstring)."""

    def __init__(self, directory: Path, token: str | None = None, preview: Preview | None = None,
                 host: str = "127.0.0.1") -> None:
        self.document = BuildingDocument.open(directory)
        self.directory = self.document.directory
        self.token = token or secrets.token_urlsafe(32)
        self.host = host
        self.checker = LiveChecker()
        self.preview = preview or Preview(tours_dir=_tours_dir())
        self.sessions: dict[str, str] = {}          # session id -> its CSRF token
        self.buckets = Buckets()
        self.check: CheckResult | None = None
        self._check_lock = asyncio.Lock()
        self._changed = asyncio.Event()
        self._images: dict[tuple, bytes] = {}
        self.app = web.Application(middlewares=[self._guard], client_max_size=MAX_BODY)
        self.app.on_response_prepare.append(self._headers)
        self.app.on_startup.append(self._start)
        self.app.on_cleanup.append(self._cleanup)
        r = self.app.router
        r.add_get("/", self._static("index.html"))
        for name in STATIC_FILES:
            r.add_get(f"/static/{name}", self._static(name))
        r.add_post("/api/session", self._login)
        r.add_get("/api/session", self._session_info)
        r.add_get("/api/state", self._read(self._state))
        r.add_get("/api/tours", self._read(self._tours))
        r.add_get("/files/{name}", self._read(self._file))
        for path, handler in (("/api/edit", self._edit), ("/api/undo", self._undo), ("/api/redo", self._redo),
                              ("/api/align/blueprint", self._align_blueprint),
                              ("/api/align/floor", self._align_floor), ("/api/floor/id", self._floor_id),
                              ("/api/floor/remove", self._floor_remove), ("/api/save", self._save),
                              ("/api/preview/start", self._preview_start), ("/api/preview/stop", self._preview_stop)):
            r.add_post(path, self._action(handler))
        self._task: asyncio.Task | None = None

    # -- life cycle ----------------------------------------------------------------------------------------------
    async def _start(self, _app: web.Application) -> None:
        self._task = asyncio.create_task(self._check_loop())
        self._changed.set()

    async def _cleanup(self, _app: web.Application) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        await asyncio.to_thread(self.preview.stop)

    async def _check_loop(self) -> None:
        """Check the document after every change (the latest revision; a change during a check starts another)."""
        while True:
            await self._changed.wait()
            await asyncio.sleep(CHECK_DEBOUNCE)
            self._changed.clear()
            await self.run_check()

    async def run_check(self) -> CheckResult:
        """The check of the document's current revision (made now unless it is already known)."""
        async with self._check_lock:
            doc = self.document
            if self.check is not None and self.check.revision == doc.revision:
                return self.check
            revision, data = doc.revision, doc.plain()
            result = await asyncio.to_thread(self.checker.check, data, doc.path, revision)
            if revision == doc.revision or self.check is None or self.check.revision < revision:
                self.check = result
            return result

    def changed(self) -> None:
        self._changed.set()

    # -- the guard -----------------------------------------------------------------------------------------------
    @web.middleware
    async def _guard(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        try:
            if not self.buckets.take(request.remote or "?", time.monotonic()):
                raise Refused(429, "rate_limited", "too many requests; slow down")
            self._check_host(request)
            return await handler(request)
        except Refused as err:
            return web.json_response({"error": err.reason, "message": str(err)}, status=err.status)
        except web.HTTPException as err:
            if err.status >= 400:
                return web.json_response({"error": "http", "message": err.reason}, status=err.status)
            raise

    def _check_host(self, request: web.Request) -> None:
        """On a loopback address, refuse a request for another host name (DNS rebinding)."""
        try:
            loopback = ipaddress.ip_address(self.host).is_loopback
        except ValueError:
            loopback = self.host == "localhost"
        if not loopback:
            return
        name = request.host.rsplit(":", 1)[0].strip("[]") if request.host else ""
        if name not in ("127.0.0.1", "localhost", "::1", self.host):
            raise Refused(403, "host", f"host {request.host[:80]!r} is not this editor")

    async def _headers(self, request: web.Request, response: web.StreamResponse) -> None:
        for key, value in SECURITY_HEADERS.items():
            response.headers.setdefault(key, value)
        response.headers["Cache-Control"] = "no-store" if request.path.startswith(("/api/", "/files/")) \
            else "no-cache"

    def _same_origin(self, request: web.Request) -> None:
        allowed = {f"http://{request.host}", f"https://{request.host}"}
        origin = request.headers.get("Origin")
        if origin is not None:
            if origin not in allowed:
                raise Refused(403, "origin", f"origin {origin[:80]!r} is not this editor")
            return
        referer = request.headers.get("Referer")
        if referer is not None and any(referer == o or referer.startswith(o + "/") for o in allowed):
            return
        raise Refused(403, "origin", "no Origin or Referer of this editor")

    def _session(self, request: web.Request) -> str:
        sid = request.cookies.get(SESSION_COOKIE, "")
        if sid not in self.sessions:
            raise Refused(401, "unauthenticated", "open the address gidabot edit printed (it holds the token)")
        return sid

    def _read(self, handler: Callable[[web.Request], Awaitable[web.StreamResponse]]) -> Handler:
        async def guarded(request: web.Request) -> web.StreamResponse:
            self._session(request)
            return await handler(request)
        return guarded

    def _action(self, handler: Callable[[dict], Awaitable[dict]]) -> Handler:
        async def guarded(request: web.Request) -> web.StreamResponse:
            self._same_origin(request)
            sid = self._session(request)
            if not hmac.compare_digest(request.headers.get(CSRF_HEADER, "").encode(), self.sessions[sid].encode()):
                raise Refused(403, "csrf", "missing or wrong CSRF token")
            body = await _json_body(request)
            return web.json_response(await handler(body))
        return guarded

    def _static(self, name: str) -> Handler:
        async def handler(_request: web.Request) -> web.StreamResponse:
            return web.Response(body=(STATIC / name).read_bytes(), headers={"Content-Type": STATIC_FILES[name]})
        return handler

    # -- session -------------------------------------------------------------------------------------------------
    async def _login(self, request: web.Request) -> web.StreamResponse:
        self._same_origin(request)
        if not hmac.compare_digest(request.headers.get(TOKEN_HEADER, "").encode(), self.token.encode()):
            raise Refused(401, "token", "wrong or missing token: open the address gidabot edit printed")
        sid, csrf = secrets.token_urlsafe(32), secrets.token_urlsafe(32)
        while len(self.sessions) >= 100:
            self.sessions.pop(next(iter(self.sessions)))
        self.sessions[sid] = csrf
        response = web.json_response({"csrf": csrf})
        response.set_cookie(SESSION_COOKIE, sid, httponly=True, samesite="Strict", path="/")
        return response

    async def _session_info(self, request: web.Request) -> web.StreamResponse:
        sid = self._session(request)
        return web.json_response({"csrf": self.sessions[sid]})

    # -- reads ---------------------------------------------------------------------------------------------------
    async def _state(self, request: web.Request) -> web.StreamResponse:
        """The document and everything the page draws; ``?since=<revision>``: only what changes without an edit
        (the check, the preview) when the document is still at that revision."""
        doc = self.document
        preview = await asyncio.to_thread(self.preview.poll)       # a run that ended is stopped here: seconds
        out: dict = {"revision": doc.revision, "check": self.check.to_json() if self.check else None,
                     "preview": preview.to_json(), "undo": doc.can_undo(), "redo": doc.can_redo(),
                     "dirty": doc.dirty, "saved_exists": doc.path.exists()}
        if request.query.get("since") != str(doc.revision):
            out.update(doc=doc.plain(), folder=self.directory.name, floors=self._floor_info(doc.plain()),
                       files={"maps": [n for n, _ in folder_maps(self.directory)],
                              "images": folder_images(self.directory), "left_out": left_out(self.directory)})
        return web.json_response(out)

    def _floor_info(self, data: dict) -> list[dict]:
        """Per floor of ``data``: its map's size and frame and the image names to draw (or why not)."""
        out = []
        for floor in data.get("floors", []) if isinstance(data.get("floors"), list) else []:
            info: dict = {"map": None, "blueprint": None, "note": ""}
            floor = floor if isinstance(floor, dict) else {}
            path = folder_file(self.directory, floor.get("map"))
            if path is None:
                info["note"] = f"map {floor.get('map')!r} is not a file of the building folder"
            else:
                info["map"] = _map_info(self.directory, path)
                if info["map"] is None:
                    info["note"] = f"map {floor.get('map')!r}: its image is not a file of the building folder"
            bp = folder_file(self.directory, floor.get("blueprint"))
            if bp is None:
                info["note"] += f"{'; ' if info['note'] else ''}blueprint {floor.get('blueprint')!r} is not a " \
                                "file of the building folder"
            else:
                size = _image_size(bp)
                info["blueprint"] = {"image": bp.name, "width": size[0], "height": size[1]} if size else None
            out.append(info)
        return out

    async def _tours(self, _request: web.Request) -> web.StreamResponse:
        """The tours a preview can run: the featured places', and the tour files that fit the building."""
        data, path = self.document.plain(), self.document.path

        def fitting() -> list[str]:
            try:
                building = building_from_doc(data, path, allow_draft=True)
            except BuildingError:
                return []
            return fitting_tours(building, self.preview.tours_dir)

        return web.json_response({"tours": [FEATURED, *await asyncio.to_thread(fitting)]})

    async def _file(self, request: web.Request) -> web.StreamResponse:
        name = request.match_info["name"]
        if name not in folder_images(self.directory):
            raise Refused(404, "not_found", "not an image file of the building folder")
        path = folder_file(self.directory, name)
        if path is None:
            raise Refused(404, "not_found", "not an image file of the building folder")
        st = path.stat()
        if st.st_size > MAX_IMAGE:
            raise Refused(404, "not_found", "image too large")
        key = (name, st.st_mtime_ns, st.st_size)
        if key not in self._images:
            self._images = {k: v for k, v in self._images.items() if k[0] != name}
            self._images[key] = await asyncio.to_thread(_browser_image, path)
        body = self._images[key]
        kind = IMAGE_TYPES.get(path.suffix.lower(), "image/png")
        return web.Response(body=body, headers={"Content-Type": kind})

    # -- actions -------------------------------------------------------------------------------------------------
    def _after_change(self) -> dict:
        self.changed()
        doc = self.document
        return {"revision": doc.revision, "undo": doc.can_undo(), "redo": doc.can_redo()}

    def _apply(self, edits: object, label: str) -> dict:
        """Apply ``edits`` as one change (400 with the reason when they cannot be); the new revision."""
        try:
            self.document.apply(edits, label)  # type: ignore[arg-type]
        except EditError as err:
            raise Refused(400, "edit", str(err)) from err
        return self._after_change()

    async def _edit(self, body: dict) -> dict:
        return self._apply(body.get("edits"), str(body.get("label", "change")))

    async def _undo(self, _body: dict) -> dict:
        label = self.document.undo()
        return {**self._after_change(), "done": label}

    async def _redo(self, _body: dict) -> dict:
        label = self.document.redo()
        return {**self._after_change(), "done": label}

    def _floor_index(self, body: dict, key: str = "floor") -> int:
        floors = self.document.plain().get("floors", [])
        index = body.get(key)
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(floors):
            raise Refused(400, "invalid", f"{key}: {index!r} is not the index of a floor")
        return index

    async def _align_blueprint(self, body: dict) -> dict:
        """Fit floor ``floor``'s blueprint_transform to ``pairs`` [[[x, y], [u, v]], ...] and set it."""
        index = self._floor_index(body)
        try:
            fit = fit_blueprint(_pairs(body.get("pairs")))
        except AlignmentError as err:
            raise Refused(400, "alignment", str(err)) from err
        t = fit.transform
        value: dict = {"scale": round(t.scale, 4), "origin_px": [round(t.origin_u, 2), round(t.origin_v, 2)]}
        if abs(t.rotation) > 1e-5:
            value["rotation"] = round(t.rotation, 5)
        done = self._apply([{"op": "set", "path": ["floors", index, "blueprint_transform"], "value": value}],
                           f"align the blueprint of floor {index + 1}")
        return {**done, "transform": value, "residuals_px": [round(r, 2) for r in fit.residuals_px],
                "rms_px": round(fit.rms_px, 2), "max_px": round(fit.max_px, 2)}

    async def _align_floor(self, body: dict) -> dict:
        """Fit where floor ``floor``'s map lies in floor ``reference``'s from ``pairs`` [[[x, y], [x', y']], ...]
        and set its ``aligned_to``."""
        index, ref = self._floor_index(body), self._floor_index(body, "reference")
        if index == ref:
            raise Refused(400, "invalid", "a floor is aligned to another floor")
        try:
            fit = fit_floors(_pairs(body.get("pairs")))
        except AlignmentError as err:
            raise Refused(400, "alignment", str(err)) from err
        ref_id = self.document.plain()["floors"][ref].get("id")
        value = {"floor": ref_id, "pose": [round(fit.pose.x, 3), round(fit.pose.y, 3), round(fit.pose.yaw, 4)]}
        done = self._apply([{"op": "set", "path": ["floors", index, "aligned_to"], "value": value}],
                           f"align floor {index + 1} to floor {ref + 1}")
        return {**done, "aligned_to": value, "residuals_m": [round(r, 3) for r in fit.residuals_m],
                "rms_m": round(fit.rms_m, 3), "max_m": round(fit.max_m, 3), "scale": round(fit.scale, 4)}

    async def _floor_id(self, body: dict) -> dict:
        """Give floor ``floor`` (its index) the id ``id``, and every place, robot, meeting pose, connector and
        alignment naming it too."""
        index = self._floor_index(body)
        try:
            edits = renumber_edits(self.document.plain(), index, body.get("id"))
        except EditError as err:
            raise Refused(400, "edit", str(err)) from err
        return self._apply(edits, f"floor id {edits[0]['value']}")

    async def _floor_remove(self, body: dict) -> dict:
        """Remove floor ``floor`` (its index) with its places, robots and meeting poses."""
        index = self._floor_index(body)
        fid = self.document.plain()["floors"][index].get("id")
        try:
            edits = removal_edits(self.document.plain(), index)
        except EditError as err:
            raise Refused(400, "edit", str(err)) from err
        return self._apply(edits, f"remove floor {fid}")

    async def _save(self, body: dict) -> dict:
        """Save the building: as it is when the checks accept it, else only with ``draft`` (marked ``draft:
        true``, which gidabot check and the robots refuse)."""
        result = await self.run_check()
        doc = self.document
        draft = bool(body.get("draft", False))
        has_mark = doc.plain().get("draft") is not None
        if result.accepted and has_mark:
            doc.apply([{"op": "delete", "path": ["draft"]}], "no longer a draft")
        elif not result.accepted:
            if not draft:
                raise Refused(409, "rejected", f"not saved: the checks reject this building ({len(result.problems)} "
                                               "problem(s)); fix them, or save it as a draft (gidabot check and the "
                                               "robots refuse a draft)")
            if doc.plain().get("draft") is not True:
                doc.apply([{"op": "set", "path": ["draft"], "value": True}], "saved as a draft")
        try:
            path = await asyncio.to_thread(building_file.save, self.directory, doc.doc)
        except OSError as err:
            raise Refused(500, "save", f"cannot write {doc.path}: {err.strerror}") from err
        doc.mark_saved()
        return {**self._after_change(), "saved": str(path), "draft": not result.accepted,
                "backup": (path.parent / (path.name + building_file.BACKUP_SUFFIX)).exists()}

    async def _preview_start(self, body: dict) -> dict:
        result = await self.run_check()
        if not result.accepted:
            raise Refused(409, "rejected", "a preview needs a building the checks accept: fix the problems first")
        tour = body.get("tour", FEATURED)
        try:
            await asyncio.to_thread(self.preview.start, self.document.plain(), self.directory,
                                    tour if isinstance(tour, str) else FEATURED)
        except PreviewError as err:
            raise Refused(400, "preview", str(err)) from err
        return {"preview": (await asyncio.to_thread(self.preview.poll)).to_json()}

    async def _preview_stop(self, _body: dict) -> dict:
        await asyncio.to_thread(self.preview.stop)
        return {"preview": (await asyncio.to_thread(self.preview.poll)).to_json()}


# -- helpers ---------------------------------------------------------------------------------------------------
async def _json_body(request: web.Request) -> dict:
    if request.content_type != "application/json":
        raise Refused(400, "invalid", "expected an application/json body")
    try:
        body = json.loads((await request.read()).decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as err:
        raise Refused(400, "invalid", f"not JSON: {err}") from err
    if not isinstance(body, dict):
        raise Refused(400, "invalid", "expected a JSON object")
    return body


def _pairs(value: object) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """[[[x, y], [u, v]], ...] as pairs of number pairs (at most 100), else 400."""
    try:
        if not isinstance(value, list) or len(value) > 100:
            raise TypeError
        out = []
        for a, b in value:
            pa, pb = (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
            if not all(math.isfinite(v) for v in (*pa, *pb)) or len(a) != 2 or len(b) != 2:
                raise TypeError
            out.append((pa, pb))
        return out
    except (TypeError, ValueError, IndexError) as err:
        raise Refused(400, "invalid", "pairs: expected [[[x, y], [u, v]], ...], at most 100, finite numbers") from err


def _image_size(path: Path) -> tuple[int, int] | None:
    from PIL import Image

    try:
        with Image.open(path) as img:
            return img.size
    except (OSError, ValueError):
        return None


def _map_info(directory: Path, path: Path) -> dict | None:
    """A map_server map's frame and image (the image a file of the folder), or None."""
    try:
        doc = load_yaml(path.read_text(encoding="utf-8"))
        image = folder_file(directory, str(doc["image"]))
        res = float(doc["resolution"])
        ox, oy, oyaw = (float(v) for v in doc["origin"])
    except (OSError, ValueError, TypeError, KeyError):
        return None
    size = _image_size(image) if image is not None else None
    if image is None or size is None:
        return None
    return {"image": image.name, "width": size[0], "height": size[1], "resolution": res, "origin": [ox, oy, oyaw],
            "negate": int(bool(doc.get("negate", 0)))}


def _browser_image(path: Path) -> bytes:
    """The image's bytes as a browser shows them: PNG, JPEG, GIF and WebP as they are, others (PGM) as PNG."""
    if path.suffix.lower() in IMAGE_TYPES:
        return path.read_bytes()
    from PIL import Image

    with Image.open(path) as img:
        out = io.BytesIO()
        img.convert("RGBA" if img.mode in ("P", "PA", "RGBA", "LA") else "RGB" if img.mode != "L" else "L").save(
            out, format="PNG")
        return out.getvalue()


def _tours_dir() -> Path | None:
    from gidabot_navigation.resources import resource

    try:
        return resource("tours")
    except ResourceError:
        return None


# -- the command -------------------------------------------------------------------------------------------------
def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="gidabot edit", description="The building editor, in the browser: "
                                "open the address it prints (docs/building-format.md, 'With the editor').")
    p.add_argument("directory", type=Path, help="building folder: the floors' maps and blueprints, and building.yaml "
                                                "if there is one")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=int, default=8765, help="TCP port (default 8765; 0: any free port)")
    p.add_argument("--speed", default="20", help="the preview's sim speed (gidabot demo --speed)")
    return p.parse_args(argv)


async def serve(server: EditorServer, host: str, port: int, ready: Callable[[str], None]) -> None:
    """Serve until SIGINT or SIGTERM."""
    runner = web.AppRunner(server.app, access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    await site.start()
    sockets = site._server.sockets if site._server is not None else []  # noqa: SLF001 - the port actually bound
    bound = sockets[0].getsockname()[1] if sockets else port
    shown = f"[{host}]" if ":" in host else host
    ready(f"http://{shown}:{bound}/#token={server.token}")
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        await stop.wait()
    finally:
        await runner.cleanup()


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    directory = args.directory
    if not directory.is_dir():
        print(f"gidabot edit: {directory}: not a directory", file=sys.stderr)
        return 2
    try:
        server = EditorServer(directory, preview=Preview(tours_dir=_tours_dir(), speed=args.speed), host=args.host)
    except BuildingError as err:
        print(f"gidabot edit: {err}", file=sys.stderr)
        return 1

    def ready(url: str) -> None:
        what = "editing" if server.document.existed else "new building from the maps of"
        print(f"gidabot edit: {what} {server.directory}\n  open {url}\n  (Ctrl-C to stop)", flush=True)

    try:
        asyncio.run(serve(server, args.host, args.port, ready))
    except OSError as err:
        print(f"gidabot edit: cannot listen on {args.host}:{args.port}: {err.strerror}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
