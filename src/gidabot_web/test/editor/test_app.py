"""The editor's web server: the token, the session, CSRF and same origin on every change, nothing changed by a GET,
files of the building folder only; edits, undo, alignment, live checks and saving (drafts) through the API."""

from __future__ import annotations

import asyncio
import shutil
from collections.abc import Awaitable, Callable
from pathlib import Path
from urllib.parse import quote

import pytest
import yaml
from aiohttp.test_utils import TestClient, TestServer

from gidabot_navigation.building.geometry import BlueprintTransform
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import BuildingError
from gidabot_web.editor.app import CSRF_HEADER, SESSION_COOKIE, TOKEN_HEADER, EditorServer
from gidabot_web.editor.preview import Preview, Run

REPO = Path(__file__).resolve().parents[4]
TOKEN = "t" * 43


@pytest.fixture
def faculty_dir(tmp_path: Path) -> Path:
    dest = tmp_path / "faculty"
    shutil.copytree(REPO / "maps" / "faculty", dest)
    return dest


@pytest.fixture
def maps_only(tmp_path: Path) -> Path:
    dest = tmp_path / "lab"
    dest.mkdir()
    for f in (REPO / "maps" / "faculty").iterdir():
        if f.name != "building.yaml":
            shutil.copy(f, dest / f.name)
    return dest


class Page:
    """A client that behaves as the editor's page: same origin, the session cookie, the CSRF token."""

    def __init__(self, client: TestClient) -> None:
        self.client = client
        self.origin = str(client.make_url("")).rstrip("/")
        self.csrf = ""

    async def login(self) -> None:
        r = await self.client.post("/api/session", headers={TOKEN_HEADER: TOKEN, "Origin": self.origin})
        assert r.status == 200, await r.text()
        self.csrf = (await r.json())["csrf"]

    async def post(self, path: str, body: dict, **headers: str) -> tuple[int, dict]:
        h = {"Origin": self.origin, CSRF_HEADER: self.csrf, **headers}
        r = await self.client.post(path, json=body, headers={k: v for k, v in h.items() if v is not None})
        return r.status, await r.json()

    async def get(self, path: str) -> tuple[int, dict]:
        r = await self.client.get(path)
        return r.status, await r.json()

    async def checked(self, revision: int | None = None) -> dict:
        """The state once the live check of the current revision is in."""
        for _ in range(200):
            _, state = await self.get("/api/state")
            check = state["check"]
            if check is not None and check["revision"] == state["revision"]:
                return state
            await asyncio.sleep(0.05)
        raise AssertionError("no check of the current revision")


def run(directory: Path, test: Callable[[Page, EditorServer], Awaitable[None]]) -> None:
    async def main() -> None:
        server = EditorServer(directory, token=TOKEN, preview=Preview(tours_dir=REPO / "tours"))
        async with TestClient(TestServer(server.app, host="127.0.0.1")) as client:
            await test(Page(client), server)
    asyncio.run(main())


def test_every_read_and_change_needs_the_session_from_the_token(faculty_dir: Path) -> None:
    async def test(page: Page, server: EditorServer) -> None:
        c = page.client
        assert (await c.get("/")).status == 200                                   # the page itself is public
        assert (await c.get("/static/editor.js")).status == 200
        for path in ("/api/state", "/api/session", "/files/floor0.png", "/api/tours"):
            assert (await c.get(path)).status == 401, path
        r = await c.post("/api/session", headers={TOKEN_HEADER: "wrong", "Origin": page.origin})
        assert r.status == 401
        r = await c.post("/api/session", headers={TOKEN_HEADER: TOKEN, "Origin": "http://evil.example"})
        assert r.status == 403
        await page.login()
        assert SESSION_COOKIE in {cookie.key for cookie in c.session.cookie_jar}
        status, state = await page.get("/api/state")
        assert status == 200 and state["doc"]["id"] == "faculty"
        assert (await page.get("/api/tours"))[1] == {"tours": ["featured", "long_tour.tour", "paper_example.tour",
                                                               "real_world.tour"]}
        r = await c.get("/")
        for header in ("Content-Security-Policy", "X-Frame-Options", "X-Content-Type-Options", "Referrer-Policy"):
            assert header in r.headers
        assert "'unsafe-inline'" not in r.headers["Content-Security-Policy"]
        for host in ("evil.example", "evil.example:8765", "127.0.0.1.nip.io"):     # DNS rebinding
            r = await c.get("/api/state", headers={"Host": host})
            assert r.status == 403 and (await r.json())["error"] == "host", host
        assert (await c.get("/api/state", headers={"Host": "localhost:1"})).status == 200
    run(faculty_dir, test)


def test_changes_need_same_origin_csrf_and_json_and_a_get_changes_nothing(faculty_dir: Path) -> None:
    edit = {"edits": [{"op": "set", "path": ["name"], "value": "Changed"}], "label": "rename"}

    async def test(page: Page, server: EditorServer) -> None:
        await page.login()
        assert (await page.post("/api/edit", edit, Origin="http://evil.example"))[0] == 403
        assert (await page.post("/api/edit", edit, Origin=None))[0] == 403          # neither Origin nor Referer
        assert (await page.post("/api/edit", edit, **{CSRF_HEADER: "nope"}))[0] == 403
        r = await page.client.post("/api/edit", data="name=x", headers={"Origin": page.origin, CSRF_HEADER: page.csrf,
                                                                        "Content-Type": "text/plain"})
        assert r.status == 400
        for path in ("/api/edit", "/api/undo", "/api/save", "/api/preview/start"):
            assert (await page.client.get(path)).status == 405, path
        assert server.document.revision == 0 and server.document.plain()["name"] != "Changed"
        status, answer = await page.post("/api/edit", edit, Origin=None, Referer=page.origin + "/")
        assert status == 200 and answer["revision"] == 1 and answer["undo"] == "rename"
        assert server.document.plain()["name"] == "Changed"
    run(faculty_dir, test)


def test_files_are_images_of_the_folder_only(faculty_dir: Path) -> None:
    (faculty_dir / "secret.txt").write_text("secret")
    (faculty_dir / "link.png").symlink_to(faculty_dir / "floor0.png")

    async def test(page: Page, server: EditorServer) -> None:
        await page.login()
        r = await page.client.get("/files/floor0.png")
        assert r.status == 200 and r.headers["Content-Type"] == "image/png"
        r = await page.client.get("/files/floor0.pgm")                          # a map image, as PNG for browsers
        assert r.status == 200 and (await r.read()).startswith(b"\x89PNG")
        for name in ("secret.txt", "link.png", "..%2Fbuilding.yaml", "%2Fetc%2Fpasswd", "building.yaml", "nothing.png"):
            assert (await page.client.get(f"/files/{name}")).status == 404, name
        bad = {"edits": [{"op": "set", "path": ["floors", 0, "blueprint"], "value": "../../etc/passwd"}]}
        status, answer = await page.post("/api/edit", bad)
        assert status == 400 and "not a file of the building folder" in answer["message"]
    run(faculty_dir, test)


def test_live_checks_save_and_drafts(faculty_dir: Path) -> None:
    async def test(page: Page, server: EditorServer) -> None:
        await page.login()
        state = await page.checked()
        assert state["check"]["accepted"] and state["check"]["problems"] == []
        into_wall = {"edits": [{"op": "set", "path": ["locations", 2, "pose"], "value": [19.0, 10.4, 0.0]}],
                     "label": "move 005"}
        await page.post("/api/edit", into_wall)
        state = await page.checked()
        [problem] = state["check"]["problems"]
        assert not state["check"]["accepted"] and "inside a wall" in problem["message"]
        status, answer = await page.post("/api/save", {})
        assert status == 409 and "not saved: the checks reject this building" in answer["message"]
        assert "draft" not in (faculty_dir / "building.yaml").read_text()
        status, answer = await page.post("/api/save", {"draft": True})
        assert status == 200 and answer["draft"] and answer["backup"]
        assert "draft: true" in (faculty_dir / "building.yaml").read_text()
        with pytest.raises(BuildingError, match="draft"):
            load_building(faculty_dir)
        await page.post("/api/undo", {})                  # the draft mark
        await page.post("/api/undo", {})                  # the move
        state = await page.checked()
        assert state["check"]["accepted"]
        status, answer = await page.post("/api/save", {})
        assert status == 200 and not answer["draft"]
        original = (REPO / "maps" / "faculty" / "building.yaml").read_bytes()
        assert (faculty_dir / "building.yaml").read_bytes() == original            # undone and saved: unchanged
        assert len(load_building(faculty_dir).locations) == 56
    run(faculty_dir, test)


def test_a_new_building_aligned_by_two_point_pairs(maps_only: Path) -> None:
    truth = BlueprintTransform(16.0, 24.0, 408.0)

    async def test(page: Page, server: EditorServer) -> None:
        await page.login()
        _, state = await page.get("/api/state")
        assert [f["map"]["image"] for f in state["floors"]] == [f"floor{i}.pgm" for i in range(4)]
        assert state["files"]["maps"] == [f"floor{i}.yaml" for i in range(4)]
        pairs = [[[x, y], list(truth.to_pixel(x, y))] for x, y in ((3.0, 7.5), (69.0, 16.5))]
        status, answer = await page.post("/api/align/blueprint", {"floor": 1, "pairs": pairs})
        assert status == 200 and answer["transform"] == {"scale": 16.0, "origin_px": [24.0, 408.0]}
        assert answer["max_px"] < 0.01
        status, answer = await page.post("/api/align/blueprint", {"floor": 1, "pairs": pairs[:1]})
        assert status == 400 and "click at least 2 matching points" in answer["message"]
        status, answer = await page.post("/api/align/floor", {"floor": 1, "reference": 0,
                                                              "pairs": [[[1, 1], [1, 1]], [[9, 2], [9, 2]]]})
        assert status == 200 and answer["aligned_to"] == {"floor": 0, "pose": [0.0, 0.0, 0.0]}
        assert server.document.plain()["floors"][1]["aligned_to"] == {"floor": 0, "pose": [0.0, 0.0, 0.0]}
        status, answer = await page.post("/api/save", {})
        assert status == 409                             # no place, no robot yet
        status, answer = await page.post("/api/save", {"draft": True})
        assert status == 200 and answer["draft"] and not answer["backup"]
        assert yaml.safe_load((maps_only / "building.yaml").read_text())["draft"] is True
    run(maps_only, test)


HOSTILE = ("evil name.png", "<img src=x onerror=alert(1)>.png", "new\nline.png", ".hidden.png", "-rf.png",
           "ünï.png", "x" * 140 + ".png")


def test_hostile_file_names_are_refused_with_the_reason(faculty_dir: Path) -> None:
    """Files whose names a building must not hold are neither offered nor served nor accepted in an edit, and the
    page is told which were left out and why; a map whose image lies outside the folder too."""
    for name in HOSTILE:
        shutil.copy(faculty_dir / "floor0.png", faculty_dir / name)
    (faculty_dir / "outside.yaml").write_text("image: ../faculty/floor0.pgm\nresolution: 0.05\n"
                                              "origin: [0, 0, 0]\nnegate: 0\n")

    async def test(page: Page, server: EditorServer) -> None:
        await page.login()
        _, state = await page.get("/api/state")
        offered = state["files"]["images"] + state["files"]["maps"]
        assert not set(HOSTILE) & set(offered) and "outside.yaml" not in offered
        reasons = {f["name"]: f["reason"] for f in state["files"]["left_out"]}
        assert set(reasons) == {*HOSTILE, "outside.yaml"}, reasons
        assert all(r.startswith("not a plain file name") for n, r in reasons.items() if n != "outside.yaml")
        assert reasons["outside.yaml"].startswith("its image '../faculty/floor0.pgm': not a plain file name")
        for name in (*HOSTILE, "../faculty/floor0.png"):
            r = await page.client.get("/files/" + quote(name, safe=""))
            assert r.status == 404, name
            status, answer = await page.post("/api/edit", {"edits": [
                {"op": "set", "path": ["floors", 0, "blueprint"], "value": name}]})
            assert status == 400 and "not a file of the building folder: not a plain file name" in \
                answer["message"], (name, answer)
        for key, name, reason in (("map", "floor9.yaml", "not a file of the building folder: no such file"),
                                  ("map", "outside.yaml", "its image '../faculty/floor0.pgm': not a plain file"),
                                  ("map", "floor0.png", "not a map_server map"),
                                  ("blueprint", "outside.yaml", "not an image")):
            status, answer = await page.post("/api/edit", {"edits": [
                {"op": "set", "path": ["floors", 0, key], "value": name}]})
            assert status == 400 and reason in answer["message"], (name, answer)
        assert server.document.revision == 0
    run(faculty_dir, test)


def test_floors_renumbered_and_removed_through_the_api(faculty_dir: Path) -> None:
    async def test(page: Page, server: EditorServer) -> None:
        await page.login()
        status, answer = await page.post("/api/floor/id", {"floor": 0, "id": -0.5})
        assert status == 200 and answer["undo"] == "floor id -0.5"
        state = await page.checked()
        assert state["check"]["accepted"] and state["doc"]["robots"][0]["floor"] == -0.5
        status, answer = await page.post("/api/floor/id", {"floor": 1, "id": -0.5})
        assert status == 400 and "floors[0] has it already" in answer["message"]
        assert (await page.post("/api/floor/id", {"floor": 1, "id": "1; rm"}))[0] == 400
        assert (await page.post("/api/floor/remove", {"floor": 9}))[0] == 400
        assert (await page.post("/api/floor/remove", {"floor": 3}, **{CSRF_HEADER: "nope"}))[0] == 403
        assert (await page.client.get("/api/floor/remove")).status == 405
        status, answer = await page.post("/api/floor/remove", {"floor": 3})
        assert status == 200 and answer["undo"] == "remove floor 3"
        state = await page.checked()
        assert [f["id"] for f in state["doc"]["floors"]] == [-0.5, 1, 2]
        assert state["check"]["accepted"], state["check"]["problems"]
    run(faculty_dir, test)


def test_a_save_that_cannot_be_written_loses_nothing(faculty_dir: Path, monkeypatch) -> None:
    """The disk full while the new file is written: the stored file and its backup are as they were, no partial
    file is left, the page gets the reason, and the edits are still there to save again."""
    import errno
    import os

    from gidabot_navigation.building import building_file

    async def test(page: Page, server: EditorServer) -> None:
        await page.login()
        await page.post("/api/edit", {"edits": [{"op": "set", "path": ["name"], "value": "First"}]})
        assert (await page.post("/api/save", {}))[0] == 200
        stored = (faculty_dir / "building.yaml").read_bytes()
        backup = (faculty_dir / "building.yaml.bak").read_bytes()
        files = sorted(p.name for p in faculty_dir.iterdir())
        await page.post("/api/edit", {"edits": [{"op": "set", "path": ["name"], "value": "Second"}]})

        def full(_fd: int) -> None:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        monkeypatch.setattr(building_file.os, "fsync", full)
        status, answer = await page.post("/api/save", {})
        assert status == 500 and "No space left on device" in answer["message"]
        assert (faculty_dir / "building.yaml").read_bytes() == stored
        assert (faculty_dir / "building.yaml.bak").read_bytes() == backup
        assert sorted(p.name for p in faculty_dir.iterdir()) == files
        monkeypatch.undo()
        _, state = await page.get("/api/state")
        assert state["dirty"] and state["doc"]["name"] == "Second"
        assert (await page.post("/api/save", {}))[0] == 200
        assert load_building(faculty_dir).name == "Second"
    run(faculty_dir, test)


def test_every_change_is_refused_without_same_origin_and_csrf_and_every_get_changes_nothing(
        faculty_dir: Path) -> None:
    """Each POST route of the server (read from its router, so a new one is covered) refused from another
    origin, without an origin, without or with a wrong CSRF token, and without a session; every GET of the
    same paths refused too; nothing changed, nothing saved, no preview started."""
    stored = (faculty_dir / "building.yaml").read_bytes()
    body = {"edits": [{"op": "set", "path": ["name"], "value": "X"}], "floor": 0, "id": -1, "reference": 1,
            "pairs": [[[0, 0], [0, 0]], [[5, 0], [5, 0]]], "draft": True}

    async def test(page: Page, server: EditorServer) -> None:
        posts = sorted({r.resource.canonical for r in server.app.router.routes()
                        if r.method == "POST" and r.resource.canonical != "/api/session"})
        assert {"/api/edit", "/api/save", "/api/floor/id", "/api/floor/remove", "/api/preview/start"} <= set(posts)
        await page.login()
        for path in posts:
            for headers in ({"Origin": "http://evil.example"}, {"Origin": None},
                            {CSRF_HEADER: None}, {CSRF_HEADER: "x" * 43}):
                status, _ = await page.post(path, body, **headers)
                assert status == 403, (path, headers, status)
            assert (await page.client.get(path)).status == 405, path
        page.client.session.cookie_jar.clear()
        for path in posts:
            assert (await page.post(path, body))[0] in (401, 403), path
        assert server.document.revision == 0 and server.preview.poll().state == Run.IDLE
        assert (faculty_dir / "building.yaml").read_bytes() == stored
        assert not (faculty_dir / "building.yaml.bak").exists()
    run(faculty_dir, test)
