"""``gidabot dashboard-passwd``: users set, changed and removed in a dashboard directory."""

from __future__ import annotations

import io
import stat
from pathlib import Path

import pytest

from gidabot_web.dashboard.passwd import main
from gidabot_web.web.auth import PasswordFile


def run(monkeypatch: pytest.MonkeyPatch, argv: list[str], stdin: str = "") -> int:
    monkeypatch.setattr("sys.stdin", io.StringIO(stdin))
    return main(argv)


def test_set_change_and_remove_users(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys) -> None:
    d = tmp_path / "dashboard"
    assert run(monkeypatch, [str(d), "ana", "--password-stdin"], "a long password\n") == 0
    assert run(monkeypatch, [str(d), "ben", "--role", "admin", "--password-stdin"], "another password\n") == 0
    users = PasswordFile(d / "users.json")
    assert users.verify("ana", "a long password").role == "staff" and users.verify("ben", "another password").role \
        == "admin"
    assert stat.S_IMODE((d / "users.json").stat().st_mode) == 0o600
    assert run(monkeypatch, [str(d), "ana", "--role", "admin", "--password-stdin"], "a new password!\n") == 0
    assert users.verify("ana", "a long password") is None and users.verify("ana", "a new password!").role == "admin"
    assert run(monkeypatch, [str(d), "ben", "--delete"]) == 0
    assert set(users.users()) == {"ana"}
    assert run(monkeypatch, [str(d), "ben", "--delete"]) == 1
    assert run(monkeypatch, [str(d), "c d", "--password-stdin"], "a long password\n") == 1
    assert run(monkeypatch, [str(d), "cat", "--password-stdin"], "short\n") == 1
    assert "password must have" in capsys.readouterr().err
    assert set(users.users()) == {"ana"}


def test_the_password_is_asked_twice_on_a_terminal(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    answers = iter(["first password", "other password"])
    monkeypatch.setattr("getpass.getpass", lambda prompt="": next(answers))
    assert main([str(tmp_path), "ana"]) == 1 and not (tmp_path / "users.json").exists()
