"""Admin mode (qt/admin_mode.py) on a fake screen: the password, Lock, and Set location's initialpose."""

from __future__ import annotations

import math

import pytest
from gui_fakes import FakeScreen

from gidabot_gui.core.admin import LOCKOUT, MAX_FAILURES, PasswordCheck
from gidabot_gui.core.i18n import Translator
from gidabot_gui.qt.admin_mode import AdminController, AdminScreen
from gidabot_navigation.passwords import hash_record


@pytest.fixture
def admin_of(qapp, faculty, locale_dir):
    """(fake screen, controller) of Kbot's screen (floor 1), every robot at home; ``password`` None: no admin."""
    def make(password: str | None = "robot42") -> tuple[FakeScreen, AdminController]:
        screen = FakeScreen(faculty, "Kbot", Translator("en", locale_dir))
        screen.feed_all_status()
        check = PasswordCheck(hash_record(password)) if password is not None else None
        return screen, AdminController(screen, check, "Kbot", faculty.floor(1))

    return make


def test_the_window_and_the_fake_are_admin_screens(make_gui, admin_of) -> None:
    screen, _ = admin_of()
    assert isinstance(screen, AdminScreen)
    assert isinstance(make_gui("Kbot", admin_password="x").window, AdminScreen)


def test_without_a_password_hash_there_is_no_admin_mode(admin_of) -> None:
    screen, admin = admin_of(password=None)
    admin.pressed()
    admin.unlock()
    admin.start_set_location()
    assert screen.popup == "" and not admin.unlocked and not screen.ops


def test_a_wrong_password_is_refused_the_right_one_unlocks_and_lock_leaves(admin_of) -> None:
    screen, admin = admin_of()
    screen.show_popup("event:ON_THE_WAY", lambda: None, lambda _k: None)   # what was on screen
    admin.pressed()
    assert screen.popup == "password" and screen.top.card().title == "Administrator password"
    panel = admin.password_panel
    assert screen.top.card().extra is panel
    panel.field.setText("robot41")
    panel.submitted.emit(panel.field.text())
    assert not admin.unlocked and panel.field.text() == "" and screen.logs == ["gui: wrong administrator password"]
    assert ("rebuild_popup",) in screen.ops and screen.top.card().title == "Wrong password"
    panel.submitted.emit("robot42")
    assert admin.unlocked and screen.changes
    assert screen.popup == "event:ON_THE_WAY"                  # back to what was on screen
    admin.pressed()                                            # Lock
    assert not admin.unlocked and screen.ops[-1] == ("set_location_mode", False)


def test_repeated_wrong_passwords_lock_the_prompt(admin_of) -> None:
    screen, admin = admin_of()
    admin.pressed()
    for _ in range(MAX_FAILURES):
        admin.password_panel.submitted.emit("nope")
    assert screen.top.card().title == f"Too many attempts: wait {int(LOCKOUT)} s"
    admin.password_panel.submitted.emit("robot42")              # even the right one, while locked
    assert not admin.unlocked
    screen.now += LOCKOUT + 1
    admin.password_panel.submitted.emit("robot42")
    assert admin.unlocked


def test_set_location_sends_the_dragged_pose(admin_of, faculty) -> None:
    screen, admin = admin_of()
    admin.start_set_location()
    assert not screen.ops                                      # locked: nothing
    admin.unlock()
    admin.start_set_location()
    assert screen.ops[-1] == ("set_location_mode", True)
    tf = faculty.floor(1).transform
    admin.pose_dragged(*tf.to_pixel(20.0, 12.0), *tf.to_pixel(20.0, 14.0))      # heading north
    assert not screen.outputs.poses                            # only when applied
    admin.set_location_done(True)
    (pose,) = screen.outputs.poses
    assert (pose.floor, pose.x, pose.y) == (1.0, pytest.approx(20.0), pytest.approx(12.0))
    assert pose.yaw == pytest.approx(math.pi / 2)
    assert screen.ops[-1] == ("set_location_mode", False)
    card = screen.messages[-1].card()
    assert screen.popup == "location_sent" and card.title == "Location sent"
    assert card.body == "x = 20.00 m, y = 12.00 m, heading 90°"


def test_a_tap_without_drag_keeps_the_heading_and_cancel_sends_nothing(admin_of, faculty) -> None:
    screen, admin = admin_of()
    admin.unlock()
    admin.start_set_location()
    u, v = faculty.floor(1).transform.to_pixel(20.0, 12.0)
    admin.pose_dragged(u, v, u + 1, v)
    assert admin.pending_pose.yaw == faculty.robot("Kbot").home.yaw
    admin.set_location_done(False)
    assert not screen.outputs.poses and admin.pending_pose is None
    admin.set_location_done(True)                              # nothing dragged: nothing to send
    assert not screen.outputs.poses
