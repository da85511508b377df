"""Users, passwords and sessions: salted scrypt hashes in a file only its owner reads, the same cost for an unknown
user, sessions with an idle timeout, the login form's token bound to its cookie, failed logins locked out."""

from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest

from gidabot_web.errors import PasswordFileError
from gidabot_web.web.auth import (
    ADMIN,
    STAFF,
    LoginLimiter,
    PasswordFile,
    Sessions,
    allows,
    load_users,
    make_user,
    save_users,
)


def test_passwords_are_salted_scrypt_hashes_in_a_private_file(tmp_path: Path) -> None:
    path = tmp_path / "d" / "users.json"
    a, b = make_user("ana", "same password", STAFF), make_user("ben", "same password", ADMIN)
    save_users(path, {"ana": a, "ben": b})
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    doc = json.loads(path.read_text())
    assert doc["users"]["ana"]["kdf"] == "scrypt" and doc["users"]["ana"]["n"] >= 2 ** 14
    assert a.salt != b.salt and a.hash != b.hash and "same password" not in path.read_text()
    pw = PasswordFile(path)
    assert pw.verify("ana", "same password").role == STAFF and pw.verify("ben", "same password").role == ADMIN
    for user, password in (("ana", "wrong password"), ("nobody", "same password"), ("ana", ""), ("ana", None),
                           (None, "same password"), ("ana", "x" * 5000)):
        assert pw.verify(user, password) is None


def test_a_password_set_while_the_server_runs_counts_at_the_next_login(tmp_path: Path) -> None:
    path = tmp_path / "users.json"
    pw = PasswordFile(path)
    assert pw.users() == {} and pw.verify("ana", "first password") is None
    save_users(path, {"ana": make_user("ana", "first password", STAFF)})
    assert pw.verify("ana", "first password") is not None
    save_users(path, {"ana": make_user("ana", "second password", ADMIN)})
    assert pw.verify("ana", "first password") is None and pw.verify("ana", "second password").role == ADMIN


@pytest.mark.parametrize("bad", [
    "not json", json.dumps({"format": "x", "users": {}}), json.dumps({"format": "gidabot-web-users/1", "users": []}),
    json.dumps({"format": "gidabot-web-users/1", "users": {"a b": {}}}),
    json.dumps({"format": "gidabot-web-users/1", "users": {"ana": {"kdf": "md5", "role": "staff"}}}),
    json.dumps({"format": "gidabot-web-users/1", "users": {"ana": {"kdf": "scrypt", "role": "root"}}}),
    json.dumps({"format": "gidabot-web-users/1", "users": {"ana": {"kdf": "scrypt", "role": "staff", "n": 2 ** 40,
                                                                    "r": 8, "p": 1, "salt": "00", "hash": "00"}}}),
    json.dumps({"format": "gidabot-web-users/1", "users": {"ana": {"kdf": "scrypt", "role": "staff", "n": 1000,
                                                                    "r": 8, "p": 1, "salt": "00", "hash": "00"}}}),
    json.dumps({"format": "gidabot-web-users/1", "users": {"ana": {"kdf": "scrypt", "role": "staff", "n": 2 ** 20,
                                                                    "r": 8, "p": 1, "salt": "00", "hash": "00"}}})])
def test_a_damaged_password_file_is_an_error_naming_it(tmp_path: Path, bad: str) -> None:
    path = tmp_path / "users.json"
    path.write_text(bad)
    with pytest.raises(PasswordFileError, match="users.json"):
        load_users(path)


@pytest.mark.parametrize("name, password, role", [("a b", "long enough pw", STAFF), ("", "long enough pw", STAFF),
                                                  ("ana", "short", STAFF), ("ana", "long enough pw", "root")])
def test_bad_users_are_refused(name: str, password: str, role: str) -> None:
    with pytest.raises(PasswordFileError):
        make_user(name, password, role)


def test_roles() -> None:
    assert allows(ADMIN, STAFF) and allows(ADMIN, ADMIN) and allows(STAFF, STAFF) and not allows(STAFF, ADMIN)
    assert not allows("", STAFF)


def test_sessions_end_after_their_idle_time_and_have_their_own_tokens() -> None:
    now = [0.0]
    s = Sessions(idle_timeout=100.0, max_sessions=3, clock=lambda: now[0])
    a, b = s.create("ana", STAFF), s.create("ana", STAFF)
    assert a.id != b.id and a.csrf != b.csrf and len(a.id) >= 40
    now[0] = 90.0
    assert s.get(a.id) is a
    now[0] = 150.0
    assert s.get(a.id) is a and s.get(b.id) is None        # a was used at 90, b not since 0
    for _ in range(4):
        s.create("ben", STAFF)
    assert s.get(a.id) is None and len(s) == 3             # the oldest made way
    assert s.get(None) is None and s.get(5) is None
    token = s.pre_token("n" * 20)
    assert s.check_pre_token("n" * 20, token) and not s.check_pre_token("m" * 20, token)
    assert not s.check_pre_token("short", s.pre_token("short")) and not s.check_pre_token(None, token)
    assert Sessions().pre_token("n" * 20) != token          # a per-process secret


def test_failed_logins_lock_an_address_out_for_a_while() -> None:
    lim = LoginLimiter(max_failures=3, window=10.0, lockout=60.0)
    lim.failed("a", 0.0)
    lim.failed("a", 5.0)
    lim.failed("a", 12.0)                 # the first is out of the window: 2 failures
    assert not lim.locked("a", 12.0)
    lim.failed("a", 13.0)
    assert lim.locked("a", 13.0) and lim.locked("a", 72.9) and not lim.locked("b", 13.0)
    assert not lim.locked("a", 73.0)      # and the count starts again
    lim.failed("a", 74.0)
    assert not lim.locked("a", 74.0)
    lim.succeeded("a")
