"""Hostile requests against the dashboard's web application (aiohttp test server, no master): each is refused with
the right status and counted (the counters the page and the diagnostics show), nothing stored or published changes,
and valid requests are still answered."""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from web_support import ADDRESS, ADMIN_PASSWORD, ADMIN_USER, STAFF_PASSWORD, STAFF_USER, Site, run_site

from gidabot_web.dashboard.app import STATIC
from gidabot_web.dashboard.dashboard import Section
from gidabot_web.web.app import CSP

TRIP = "Tartalo/v1/gm.a.1"
ACTIONS = {"/api/trips/cancel": {"trip": TRIP}, "/api/robots/service": {"robot": "Tartalo", "out": True},
           "/api/alerts/ack": {"id": 1}, "/api/tours/save": {"file_name": "x.tour", "text": "Tour\n1, 113, x\n"},
           "/api/tours/delete": {"file_name": "paper_example.tour"}, "/api/logout": {}}
VALID_TOUR = "Tour: Open day\n0, 014, Technicians\n1, 113, Laboratory\n"


def refused(site: Site) -> dict[str, int]:
    return {k: v for k, v in site.app.web.counters.items() if k.startswith("refused_")}


def shown(site: Site) -> dict[str, int]:
    """The refusal counters as the page's server section shows them."""
    site.app.versions()
    return site.app.core.section(Section.SERVER)["refused"]


async def refuse_every_action(site: Site, status: int, variants: list[dict]) -> int:
    """Post every action once per variant (keyword arguments of ``Site.post``); each must be refused with
    ``status``. Returns how many were sent."""
    for path, body in ACTIONS.items():
        for kw in variants:
            r = await site.post(path, body, **kw)
            assert r.status == status, (path, kw)
    return len(ACTIONS) * len(variants)


async def login_refused(site: Site, address: str, **headers: object) -> None:
    """A login from a fresh browser at ``address`` with the right password, refused with 403."""
    site.client.session.cookie_jar.clear()
    pre = (await site.session(address))["csrf"]
    r = await site.client.post("/api/login", json={"user": STAFF_USER, "password": STAFF_PASSWORD},
                               headers=site.headers(address, **{"csrf": pre, **headers}))
    assert r.status == 403


def unchanged(site: Site, files: dict[str, bytes]) -> None:
    core = site.app.core
    assert site.bus.sent == 0 and site.tour_files() == files
    assert not core.trips[TRIP].cancel and not core.service and not any(a.acked_by for a in core.alerts.values())


# ------------------------------------------------------------------ headers and the page
def test_every_answer_carries_the_security_headers(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        for path in ("/", "/static/dashboard.js", "/api/state", "/nothing", "/api/trips/cancel"):
            r = await site.client.get(path)
            h = r.headers
            assert h["Content-Security-Policy"] == CSP, path
            assert (h["X-Frame-Options"], h["X-Content-Type-Options"]) == ("DENY", "nosniff"), path
        r = await site.client.get("/api/state")
        assert r.headers["Cache-Control"] == "no-store"
    run_site(faculty, tmp_path, test)
    assert "unsafe" not in CSP and "script-src 'self'" in CSP and "frame-ancestors 'none'" in CSP


def test_the_page_has_no_inline_script_or_style_and_loads_nothing_from_elsewhere() -> None:
    html = (STATIC / "index.html").read_text(encoding="utf-8")
    assert all(re.search(r'\bsrc="/', tag) for tag in re.findall(r"<script[^>]*>", html))
    assert not re.search(r"<script[^>]*>(?!</script>)", html) and "<style" not in html
    assert not re.search(r'\s(style|on[a-z]+)=', html)
    for path in STATIC.iterdir():
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"https?://(?!www\.w3\.org/2000/svg)", text), path.name        # no CDN, works offline
        assert "innerHTML" not in text and "eval(" not in text, path.name


# ------------------------------------------------------------------ actions
def test_actions_without_login_are_refused(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        files = site.tour_files()
        n = await refuse_every_action(site, 401, [{"csrf": "anything"}, {"csrf": None}])
        assert refused(site) == {"refused_unauthenticated": n} == shown(site)
        unchanged(site, files)
    run_site(faculty, tmp_path, test)


def test_the_refused_actions_are_every_change_the_application_offers(faculty, tmp_path: Path) -> None:
    """The tests of this file send every action of ACTIONS: a change added to the application must join it (the
    login, checked on its own, aside)."""
    async def test(site: Site) -> None:
        posts = {r.resource.canonical for r in site.app.app.router.routes() if r.method == "POST"}
        others = {r.method for r in site.app.app.router.routes()} - {"GET", "HEAD", "POST"}
        assert posts - {"/api/login"} == set(ACTIONS) and not others
    run_site(faculty, tmp_path, test)


def test_a_missing_or_forged_csrf_token_is_refused(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        files = site.tour_files()
        other = site.app.web.sessions.create(ADMIN_USER, "admin").csrf      # another session's token
        good = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        n = await refuse_every_action(site, 403, [{"csrf": t} for t in (
            None, "", "x" * 43, other, good[:-1] + ("A" if good[-1] != "A" else "B"))])
        await login_refused(site, ADDRESS, csrf="0" * 64)
        assert refused(site) == {"refused_csrf": n + 1}
        good = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        unchanged(site, files)
        r = await site.post("/api/alerts/ack", {"id": 1}, csrf=good)         # the right token still works
        assert r.status == 200
    run_site(faculty, tmp_path, test)


def test_another_origin_is_refused(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        files = site.tour_files()
        csrf = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        n = await refuse_every_action(site, 403, [{"csrf": csrf, **h} for h in (
            {"origin": "http://evil.example"}, {"origin": "null"},
            {"origin": site.origin.replace("127.0.0.1", "127.0.0.2")},
            {"origin": None, "Referer": "http://evil.example/page"}, {"origin": None})])
        await login_refused(site, "10.1.0.7", origin="http://evil.example")
        assert refused(site) == {"refused_origin": n + 1} == shown(site)
        unchanged(site, files)
        csrf = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        r = await site.post("/api/alerts/ack", {"id": 1}, csrf=csrf, origin=None, Referer=site.origin + "/#alerts")
        assert r.status == 200                                     # a same-origin Referer is enough
    run_site(faculty, tmp_path, test)


def test_a_name_the_robot_is_not_known_by_is_refused(faculty, tmp_path: Path) -> None:
    """DNS rebinding: a page of evil.example whose name now resolves to the robot is same-origin with itself (Host
    and Origin both evil.example): every request for that name is refused, reads included; names staff were
    given (~hosts, an origin's) and addresses are answered."""
    async def test(site: Site) -> None:
        files = site.tour_files()
        port = site.origin.rsplit(":", 1)[1]
        evil = {"Host": f"evil.example:{port}", "Origin": f"http://evil.example:{port}"}
        for path in ("/", "/api/session", "/api/state"):
            assert (await site.client.get(path, headers={**site.headers(origin=None), **evil})).status == 403, path
        r = await site.client.post("/api/login", json={"user": STAFF_USER, "password": STAFF_PASSWORD},
                                   headers={**site.headers(), **evil})
        assert r.status == 403 and (await r.json())["error"] == "host"
        csrf = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        n = 0
        for path, body in ACTIONS.items():
            r = await site.client.post(path, json=body, headers={**site.headers(csrf=csrf), **evil})
            assert r.status == 403, path
            n += 1
        r = await site.client.get("/live", headers={**site.headers(origin=None), **evil, "Connection": "Upgrade",
                                                    "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
                                                    "Sec-WebSocket-Key": "x" * 24})
        assert r.status == 403
        for host in (f"127.0.0.1.evil.example:{port}", "", f"kbot.staff.lan.evil.example:{port}", f"[::1:{port}",
                     f"127.0.0.1@evil.example:{port}"):
            assert (await site.client.get("/api/session", headers={**site.headers(), "Host": host})).status == 403
        assert refused(site) == {"refused_host": n + 10} == shown(site)
        unchanged(site, files)
        for host in (f"kbot.staff.lan:{port}", f"KBOT.staff.lan:{port}", "kbot.example.org", f"localhost:{port}",
                     f"[::1]:{port}", f"10.0.0.12:{port}"):
            r = await site.client.get("/api/session", headers={**site.headers(origin=None), "Host": host})
            assert r.status == 200, host
    run_site(faculty, tmp_path, test, hosts=frozenset({"kbot.staff.lan"}),
             origins=frozenset({"https://kbot.example.org"}))


def test_nothing_changes_on_get(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        files = site.tour_files()
        csrf = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        n = 0
        for path in ACTIONS:
            for method in ("GET", "HEAD", "PUT", "DELETE", "PATCH"):
                r = await site.client.request(method, path + "?trip=" + TRIP + "&id=1&robot=Tartalo&out=true",
                                              headers=site.headers(csrf=csrf))
                assert r.status == 405, (method, path)
                n += 1
        r = await site.client.post("/api/state", headers=site.headers(csrf=csrf))       # a read is GET only
        assert r.status == 405
        assert refused(site) == {"refused_method": n + 1}
        unchanged(site, files)
        assert (await site.client.get("/api/session", headers=site.headers())).status == 200
    run_site(faculty, tmp_path, test)


def test_a_login_is_a_post_only(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        pre = (await site.session())["csrf"]
        query = f"?user={STAFF_USER}&password={STAFF_PASSWORD}"
        for method in ("GET", "HEAD", "PUT", "DELETE", "PATCH"):
            r = await site.client.request(method, "/api/login" + query, headers=site.headers(csrf=pre))
            assert r.status == 405, method
        assert refused(site) == {"refused_method": 5}
        assert len(site.app.web.sessions) == 0 and (await site.session())["user"] is None
    run_site(faculty, tmp_path, test)


def test_a_staff_user_may_not_edit_tours(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        files = site.tour_files()
        csrf = await site.login()
        for path in ("/api/tours/save", "/api/tours/delete"):
            assert (await site.post(path, ACTIONS[path], csrf=csrf)).status == 403
        assert refused(site) == {"refused_role": 2}
        unchanged(site, files)
    run_site(faculty, tmp_path, test)


@pytest.mark.parametrize("body, content_type", [(b"{not json", "application/json"), (b"[1, 2]", "application/json"),
                                                (b"\xff\xfe", "application/json"), (b"trip=x", "text/plain"),
                                                (b"trip=x", "application/x-www-form-urlencoded")])
def test_an_action_body_that_is_not_a_json_object_is_refused(faculty, tmp_path: Path, body: bytes,
                                                               content_type: str) -> None:
    async def test(site: Site) -> None:
        csrf = await site.login()
        r = await site.client.post("/api/trips/cancel", data=body,
                                   headers=site.headers(csrf=csrf, **{"Content-Type": content_type}))
        assert r.status == 400 and refused(site) == {"refused_invalid": 1}
        assert site.bus.sent == 0
    run_site(faculty, tmp_path, test)


def test_the_session_cookie_is_http_only_and_same_site_strict(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        r = await site.client.get("/api/session", headers=site.headers())
        assert "HttpOnly" in r.headers["Set-Cookie"] and "SameSite=Strict" in r.headers["Set-Cookie"]
        pre = (await r.json())["csrf"]
        r = await site.client.post("/api/login", json={"user": STAFF_USER, "password": STAFF_PASSWORD},
                                   headers=site.headers(csrf=pre))
        cookie = next(v for v in r.headers.getall("Set-Cookie") if v.startswith("gidabot_session="))
        assert all(flag in cookie for flag in ("HttpOnly", "SameSite=Strict", "Path=/"))
        assert "Secure" not in cookie
    run_site(faculty, tmp_path, test)


# ------------------------------------------------------------------ files
TRAVERSALS = ["..", "../..", "%2e%2e", "%2e%2e%2f%2e%2e%2fetc%2fpasswd", "..%2f..%2f..%2fetc%2fpasswd",
              "..%5c..%5cwindows", "%252e%252e%252fetc%252fpasswd", "/etc/passwd", "%2fetc%2fpasswd",
              "....//....//etc/passwd", ".%00./", "index.html%00.png", "dashboard.js/", "..;/app.py",
              "%c0%ae%c0%ae/%c0%ae%c0%ae/etc/passwd", "app.py", "dashboard.py", "__init__.py", ".hidden",
              "floor0.png", "floor-0.png/../../../../etc/passwd", "floor-9.png", "~root", "*", "%2A"]


def test_no_request_reaches_a_file_outside_its_directory(faculty, tmp_path: Path) -> None:
    secret = b"root:x:0:0"

    async def test(site: Site) -> None:
        n = 0
        for prefix in ("/static/", "/web/", "/blueprints/", "/i18n/", "/api/history/", "/"):
            for t in TRAVERSALS:
                r = await site.raw("GET", prefix + t, address=f"10.4.{n}.1")     # the rate limit is not tested here
                body = await r.read()
                assert r.status in (404, 405), (prefix + t, r.status)
                assert secret not in body and b"import " not in body and b"\x89PNG" not in body, prefix + t
                n += 1
        assert refused(site) == {"refused_not_found": n}
        for path in ("/static/dashboard.js", "/web/web.js", "/blueprints/floor-0.png", "/i18n/eu"):
            assert (await site.client.get(path, headers=site.headers())).status == 200, path
    run_site(faculty, tmp_path, test)


def test_history_days_and_languages_are_names_not_paths(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        for path in ("/api/history/2027-1-1", "/api/history/..", "/api/history/2027-01-15x/csv", "/i18n/fr",
                     "/i18n/..%2f..%2fetc"):
            assert (await site.raw("GET", path)).status == 404, path
        r = await site.client.get("/api/history/2027-01-15/csv", headers=site.headers())
        assert r.status == 200 and r.headers["Content-Disposition"].startswith("attachment;")
    run_site(faculty, tmp_path, test)


# ------------------------------------------------------------------ tours
HOSTILE_NAMES = ["../evil.tour", "/etc/passwd", "..", "a/b.tour", "a\\b.tour", ".hidden.tour", "con.tour",
                 "x\x00.tour", "é.tour", "a" * 70 + ".tour", "evil.sh", "", " .tour", "-x.tour", 5, None,
                 ["a.tour"], "x.tour\n", "%2e%2e%2fevil.tour"]


def test_hostile_tour_names_and_contents_are_refused_and_nothing_is_written(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        files = site.tour_files()
        csrf = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        for i, name in enumerate(HOSTILE_NAMES):
            for path in ("/api/tours/save", "/api/tours/delete"):
                r = await site.post(path, {"file_name": name, "text": VALID_TOUR}, csrf=csrf, address=f"10.2.{i}.1")
                assert r.status == 400, (name, path)
        bad = {"Tour\n9, 999, nowhere\n": "invalid_tour", "\x00\x01binary": "invalid_tour", "": "invalid_tour",
               "Tour\n" + "0, 014, x\n" * 101: "invalid_tour"}
        for text, reason in bad.items():
            r = await site.post("/api/tours/save", {"file_name": "ok.tour", "text": text}, csrf=csrf)
            assert (r.status, (await r.json())["error"]) == (400, reason)
        r = await site.post("/api/tours/save", {"file_name": "ok.tour", "text": VALID_TOUR, "language": "fr"},
                            csrf=csrf)
        assert r.status == 400
        assert refused(site) == {"refused_invalid_name": 2 * len(HOSTILE_NAMES), "refused_invalid_tour": len(bad),
                                 "refused_invalid": 1}
        unchanged(site, files)
    run_site(faculty, tmp_path, test, session_burst=1000.0)      # the session's rate limit is not tested here


def test_oversized_uploads_are_refused_before_anything_is_sent(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        files = site.tour_files()
        csrf = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        just_over = "Tour\n" + "0, 014, " + "x" * (64 * 1024) + "\n"            # over a tour file's 64 KiB
        r = await site.post("/api/tours/save", {"file_name": "big.tour", "text": just_over}, csrf=csrf)
        assert r.status == 413
        huge = "x" * (1024 * 1024)                                                 # over the 128 KiB body limit
        r = await site.post("/api/tours/save", {"file_name": "huge.tour", "text": huge}, csrf=csrf)
        assert r.status == 413
        r = await site.post("/api/trips/cancel", {"trip": huge}, csrf=csrf)
        assert r.status == 413
        assert refused(site) == {"refused_too_large": 3}
        unchanged(site, files)
    run_site(faculty, tmp_path, test)


def test_an_admin_uploads_edits_and_deletes_a_tour_through_the_store(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        csrf = await site.login(ADMIN_USER, ADMIN_PASSWORD)
        r = await site.post("/api/tours/save", {"file_name": "open_day.tour", "text": VALID_TOUR, "language": "eu"},
                            csrf=csrf)
        assert r.status == 200, await r.text()
        saved = site.tours_dir / "open_day.tour"
        assert saved.read_text(encoding="utf-8") == "Tour\n0, 014, Technicians\n1, 113, Laboratory\n"   # canonical
        [edit] = site.bus.edits
        assert (edit.origin_robot, edit.language, edit.tour_name, edit.tour_goals_info) == (
            "Kbot", "eu", "", ("0, 014, Technicians", "1, 113, Laboratory"))    # the name derived from the file's
        r = await site.post("/api/tours/delete", {"file_name": "open_day.tour"}, csrf=csrf)
        assert r.status == 200 and not saved.exists() and site.bus.edits[-1].deleted
        r = await site.post("/api/tours/delete", {"file_name": "never_was.tour"}, csrf=csrf)
        assert r.status == 400 and (await r.json())["error"].startswith("tour_")      # the store's own refusal
    run_site(faculty, tmp_path, test)


# ------------------------------------------------------------------ floods
def frozen_limits(site: Site) -> Callable[[float], None]:
    """The rate limits' clock stopped: no token comes back while a test runs, however slow the machine (the buckets
    hold their burst, then refuse). Returns what moves that clock on by some seconds."""
    now = [time.monotonic()]
    site.app.web.clock = lambda: now[0]

    def advance(seconds: float) -> None:
        now[0] += seconds
    return advance


def test_a_thousand_rapid_requests_are_limited_and_others_still_answered(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        files = site.tour_files()
        advance = frozen_limits(site)
        statuses = [(await site.client.get("/api/state", headers=site.headers("10.9.9.9"))).status
                    for _ in range(1000)]
        burst, rate = int(site.app.web.config.address_burst), int(site.app.web.config.address_rate)
        assert statuses == [200] * burst + [429] * (1000 - burst)          # the burst gets through, then nothing
        r = await site.post("/api/trips/cancel", {"trip": TRIP}, csrf="x", address="10.9.9.9")
        assert r.status == 429                                 # the limit holds for actions too
        advance(1.0)                                           # a second later: the rate's worth again
        again = [(await site.client.get("/api/state", headers=site.headers("10.9.9.9"))).status
                 for _ in range(rate + 1)]
        assert again == [200] * rate + [429]
        limited = statuses.count(429) + 2
        assert refused(site) == {"refused_rate_limited": limited} == shown(site)
        unchanged(site, files)
        assert (await site.client.get("/api/state", headers=site.headers("10.9.9.10"))).status == 200
        csrf = await site.login(address="10.9.9.11")
        assert (await site.post("/api/trips/cancel", {"trip": TRIP}, csrf=csrf, address="10.9.9.11")).status == 200
        assert len(site.bus.cancels) == 1
    run_site(faculty, tmp_path, test)


def test_two_hundred_login_attempts_are_locked_out_and_others_may_still_log_in(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        pre = (await site.session("10.6.6.6"))["csrf"]
        statuses = []
        for i in range(200):
            r = await site.client.post("/api/login", json={"user": STAFF_USER, "password": f"guess-{i:04d}"},
                                       headers=site.headers("10.6.6.6", csrf=pre))
            statuses.append(r.status)
        assert statuses[:5] == [401] * 5 and set(statuses[5:]) == {429}
        r = await site.client.post("/api/login", json={"user": STAFF_USER, "password": STAFF_PASSWORD},
                                   headers=site.headers("10.6.6.6", csrf=pre))
        assert r.status == 429                                 # locked out: even the right password
        c = refused(site)
        assert c["refused_login_failed"] == 5 and c.get("refused_login_locked", 0) + c.get("refused_rate_limited", 0) \
            == 196 and set(c) <= {"refused_login_failed", "refused_login_locked", "refused_rate_limited"}
        assert len(site.app.web.sessions) == 0
        await site.login(address="10.6.6.7")                   # another address: answered
        assert len(site.app.web.sessions) == 1
    run_site(faculty, tmp_path, test)


def test_a_session_that_acts_too_fast_is_limited(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        csrf = await site.login()
        frozen_limits(site)
        statuses = [(await site.post("/api/alerts/ack", {"id": 1}, csrf=csrf, address=f"10.3.{i}.1")).status
                    for i in range(60)]
        assert statuses == [200] * 20 + [429] * 40                # the session's burst, then nothing
        assert refused(site) == {"refused_session_rate": statuses.count(429)}
    run_site(faculty, tmp_path, test)


# ------------------------------------------------------------------ what staff may do
def test_valid_staff_actions_are_carried_out(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        csrf = await site.login()
        r = await site.post("/api/trips/cancel", {"trip": TRIP}, csrf=csrf)
        assert r.status == 200 and site.bus.cancels[0].goal_uid == TRIP
        assert (await site.post("/api/trips/cancel", {"trip": TRIP}, csrf=csrf)).status == 409
        assert (await site.post("/api/trips/cancel", {"trip": "Kbot/x/1"}, csrf=csrf)).status == 404
        r = await site.post("/api/robots/service", {"robot": "Tartalo", "out": True, "reason": "bumper"}, csrf=csrf)
        assert r.status == 200 and site.bus.commands[0].detail == "bumper"
        assert (await site.post("/api/robots/service", {"robot": "Tartalo", "out": "yes"}, csrf=csrf)).status == 400
        r = await site.post("/api/alerts/ack", {"id": 1}, csrf=csrf)
        assert r.status == 200 and (await r.json())["acked_by"] == STAFF_USER
        r = await site.post("/api/logout", {}, csrf=csrf)
        assert r.status == 200
        assert (await site.post("/api/alerts/ack", {"id": 2}, csrf=csrf)).status == 401
    run_site(faculty, tmp_path, test)


def test_the_live_socket_refuses_another_origin(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        r = await site.client.get("/live", headers={**site.headers(origin="http://evil.example"),
                                                    "Connection": "Upgrade", "Upgrade": "websocket",
                                                    "Sec-WebSocket-Version": "13", "Sec-WebSocket-Key": "x" * 24})
        assert r.status == 403 and refused(site) == {"refused_origin": 1}
        ws = await site.client.ws_connect("/live", headers=site.headers())
        msg = await ws.receive_json(timeout=5.0)
        assert msg["type"] == "update" and set(msg["sections"]) >= {"building", "robots", "alerts"}
        assert msg["sections"]["building"]["me"] == "Kbot"
        await ws.close()
    run_site(faculty, tmp_path, test)


def test_the_page_texts_come_in_three_languages(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        texts = {lang: await (await site.client.get(f"/i18n/{lang}", headers=site.headers())).json()
                 for lang in ("eu", "en", "es")}
        assert texts["en"]["Cancel trip"] == "Cancel trip"
        assert texts["es"]["Cancel trip"] == "Cancelar el trayecto"
        assert texts["eu"]["Cancel trip"] == "Ibilbidea bertan behera utzi"
        assert len(texts["eu"]) == len(texts["es"]) == len(texts["en"]) > 150
    run_site(faculty, tmp_path, test)


def test_address_is_the_peer_unless_a_trusted_proxy_says_otherwise(faculty, tmp_path: Path) -> None:
    async def test(site: Site) -> None:
        for i in range(400):       # X-Forwarded-For of an untrusted peer is ignored: one address, one bucket
            await site.client.get("/api/session", headers={"X-Forwarded-For": f"10.{i % 250}.0.{i // 250}"})
        assert site.app.web.counters.get("refused_rate_limited", 0) >= 5
    run_site(faculty, tmp_path, test, trusted_proxies=frozenset())
    assert ADDRESS
