"""Administrator checks (core.admin): the password, Set location's geometry, tour drafts."""

from __future__ import annotations

import io
import math
import sys

import pytest

from gidabot_gui.admin_passwd import main as admin_passwd
from gidabot_gui.core.admin import PasswordCheck, TourDraft, pose_from_drag, slug_file_name
from gidabot_gui.errors import ConfigError, TourEditError
from gidabot_navigation.passwords import hash_record, parse_record


def test_password_check() -> None:
    record = hash_record("open sesame")
    assert record.startswith("scrypt:16384:8:1:") and "open" not in record
    assert hash_record("open sesame") != record                       # salted: every record differs
    for bad in ("secret", "9e0d8b5c7a1e4f2b" * 4, "scrypt:16384:8:1:00:" + "0" * 64, record[:-2],
                record.replace(":16384:", ":16383:"), record.replace(":8:1:", ":8:99999999:"), None, 42):
        with pytest.raises(ConfigError, match="admin_password_hash .*salted hash|out of range"):
            PasswordCheck(bad)   # type: ignore[arg-type]
    check = PasswordCheck(record)
    assert not check.check("open sesam", 0.0)
    assert check.check("open sesame", 0.0)
    for i in range(5):
        assert not check.check("guess", float(i))
    assert check.locked_for(5.0) > 0
    assert not check.check("open sesame", 5.0)            # locked out, even with the right password
    assert check.check("open sesame", 40.0)
    assert not check.check("x" * 10000, 41.0)


def test_gidabot_admin_passwd_prints_a_record_of_the_password_it_read(monkeypatch, capsys) -> None:
    monkeypatch.setattr(sys, "stdin", io.StringIO("open sesame 1\n"))
    assert admin_passwd(["--password-stdin"]) == 0
    record = capsys.readouterr().out.strip()
    assert parse_record(record).matches("open sesame 1") and record != hash_record("open sesame 1")
    monkeypatch.setattr(sys, "stdin", io.StringIO("short\n"))
    assert admin_passwd(["--password-stdin"]) == 1
    assert "8 to 256 characters" in capsys.readouterr().err


def test_pose_from_drag_inverts_the_blueprint_transform(faculty) -> None:
    floor = faculty.floor(1)
    tf = floor.transform
    u, v = tf.to_pixel(30.0, 12.0)
    pose = pose_from_drag(tf, 1.0, (u, v), (u, v - 40))           # dragged up the image: +y, yaw = pi/2
    assert pose.x == pytest.approx(30.0) and pose.y == pytest.approx(12.0)
    assert pose.yaw == pytest.approx(math.pi / 2)
    pose = pose_from_drag(tf, 1.0, (u, v), (u + 1, v), default_yaw=0.7)
    assert pose.yaw == 0.7


def test_tour_draft_validation(faculty) -> None:
    draft = TourDraft("open_day.tour", "Open day", "en", [(0, "014", "Computer Technicians 1"),
                                                          (1, "101", "Secretary's Office")])
    edit = draft.to_edit(faculty, "Kbot/gui/tour-edit/1")
    assert edit.goal_lines == ("0, 014, Computer Technicians 1", "1, 101, Secretary's Office")
    assert edit.floor == 0 and not edit.deleted
    with pytest.raises(TourEditError, match="'999'"):
        TourDraft("x.tour", "X", "en", [(0, "999", "Nowhere")]).validate(faculty)
    with pytest.raises(TourEditError, match="room 101 is on floor 1, not 0"):
        TourDraft("x.tour", "X", "en", [(0, "101", "Secretary")]).validate(faculty)
    with pytest.raises(TourEditError, match="path separator"):
        TourDraft("../x.tour", "X", "en", [(0, "014", "a")]).validate(faculty)
    with pytest.raises(TourEditError, match="empty tour"):
        TourDraft("x.tour", "X", "en", []).validate(faculty)
    assert slug_file_name("Visita a la Facultad: ¡Día abierto!") == "visita_a_la_facultad_dia_abierto.tour"
