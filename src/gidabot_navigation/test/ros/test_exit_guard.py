"""ExitGuard: a bounded exit on SIGINT/SIGTERM whatever the main thread holds or waits on (no master).

The signals are real (sent to this test process); ``exit`` is a fake that records the call, and
every guard is uninstalled (previous handlers back) at the end of its test.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from gidabot_navigation.errors import ExitGuardError
from gidabot_navigation.ros.exit_guard import ExitGuard, where

GRACE = 0.4


class ListLog:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, msg: str) -> None:
        self.lines.append(f"INFO {msg}")

    def warning(self, msg: str) -> None:
        self.lines.append(f"WARN {msg}")

    def error(self, msg: str) -> None:
        self.lines.append(f"ERROR {msg}")


class FakeExit:
    def __init__(self, then: Callable[[], None] = lambda: None) -> None:
        self.calls: list[tuple[float, int]] = []
        self.called = threading.Event()
        self.then = then

    def __call__(self, code: int) -> None:
        self.calls.append((time.monotonic(), code))
        self.called.set()
        self.then()


@pytest.fixture
def make_guard() -> Iterator[Callable[..., ExitGuard]]:
    guards: list[ExitGuard] = []

    def make(shutdown: Callable[[str], object], **kw: object) -> ExitGuard:
        kw.setdefault("grace", GRACE)
        kw.setdefault("log", ListLog())
        guard = ExitGuard(shutdown, name="test", **kw).install()  # type: ignore[arg-type]
        guards.append(guard)
        return guard

    yield make
    for guard in guards:
        guard.uninstall()


def kill_self(sig: int = signal.SIGINT) -> float:
    sent = time.monotonic()
    os.kill(os.getpid(), sig)
    return sent


def test_the_shutdown_runs_outside_the_main_thread_and_the_process_ends_at_the_deadline(make_guard) -> None:
    threads: list[str] = []
    reasons: list[str] = []
    fake_exit = FakeExit()

    def shutdown(reason: str) -> None:
        threads.append(threading.current_thread().name)
        reasons.append(reason)

    guard = make_guard(shutdown, exit=fake_exit)
    sent = kill_self()
    assert guard.shutdown_done.wait(2.0)
    assert guard.requested and guard.signum == signal.SIGINT
    assert reasons == ["signal-2"] and threads and threads[0] != threading.main_thread().name
    # this test process does not end by itself: the guard ends it at the deadline
    assert fake_exit.called.wait(GRACE + 2.0)
    at, code = fake_exit.calls[0]
    assert code == 0 and GRACE - 0.05 <= at - sent < GRACE + 1.0
    assert guard.forced and "still running" in guard.log.lines[-1]


def test_rospys_deadlock_a_shutdown_needing_a_lock_the_interrupted_main_thread_holds(make_guard) -> None:
    """rospy's handler closes the topics inside the main thread; interrupted in a queued publisher's
    write_data (a plain Lock held), the close callback takes that Lock again: a self-deadlock."""
    lock = threading.Lock()        # rospy.impl.tcpros_pubsub.QueuedConnection._lock

    # rospy's way, bounded here so that the test shows it without hanging
    acquired: list[bool] = []
    previous = signal.signal(signal.SIGINT, lambda *_: acquired.append(lock.acquire(timeout=0.2)))
    try:
        with lock:
            kill_self()
            time.sleep(0.01)        # the handler runs in this thread, here, with the lock held
    finally:
        signal.signal(signal.SIGINT, previous)
    assert acquired == [False]     # without the timeout: never

    # the guard's way: the shutdown waits in its own thread until the main thread lets the lock go
    def shutdown(_reason: str) -> None:
        with lock:
            pass

    guard = make_guard(shutdown, exit=FakeExit())
    with lock:
        kill_self()
        time.sleep(0.05)
        assert not guard.shutdown_done.is_set()
    assert guard.shutdown_done.wait(1.0)


def test_a_shutdown_that_never_returns_frozen_master_ends_the_process_within_the_grace(make_guard) -> None:
    frozen = threading.Event()
    stuck_main = threading.Lock()
    stuck_main.acquire()
    fake_exit = FakeExit(then=stuck_main.release)    # "the process ends": free the main thread
    log = ListLog()
    try:
        make_guard(lambda _r: frozen.wait(), exit=fake_exit, log=log)
        threading.Timer(0.05, kill_self).start()
        began = time.monotonic()
        # the main thread itself is stuck too (in C code, a lock, a socket send): the wake-up fd still works
        assert stuck_main.acquire(timeout=GRACE + 3.0)
        assert GRACE - 0.05 <= time.monotonic() - began < GRACE + 1.0
        assert "shutdown did not finish within" in log.lines[-1] and "exiting now" in log.lines[-1]
    finally:
        frozen.set()


def test_the_main_loop_stops_before_the_shutdown_closes_anything(make_guard) -> None:
    order: list[str] = []
    woken = threading.Event()
    guard = make_guard(lambda _r: order.append("shutdown"), main_loop=True, exit=FakeExit())
    guard.set_wake(woken.set)
    kill_self()
    assert woken.wait(1.0)                     # an idle wait of the loop ends at once
    deadline = time.monotonic() + 1.0
    while not guard.requested and time.monotonic() < deadline:    # the loop notices at its next iteration
        time.sleep(0.005)
    time.sleep(0.05)                           # ... finishes its last tick ...
    order.append("loop stopped")
    guard.loop_stopped()
    assert guard.shutdown_done.wait(1.0)
    assert order == ["loop stopped", "shutdown"]


def test_a_main_loop_that_never_stops_delays_the_shutdown_only_half_the_grace(make_guard) -> None:
    started: list[float] = []
    log = ListLog()
    guard = make_guard(lambda _r: started.append(time.monotonic()), main_loop=True, exit=FakeExit(), log=log)
    sent = kill_self()
    assert guard.shutdown_done.wait(2.0)
    assert GRACE / 2 - 0.05 <= started[0] - sent < GRACE
    assert "main loop did not stop" in log.lines[0]


def test_a_second_signal_exits_at_once(make_guard) -> None:
    frozen = threading.Event()
    fake_exit = FakeExit()
    try:
        guard = make_guard(lambda _r: frozen.wait(), exit=fake_exit, grace=30.0)
        kill_self(signal.SIGINT)
        deadline = time.monotonic() + 1.0
        while not guard.requested and time.monotonic() < deadline:     # the first one was handled
            time.sleep(0.005)
        assert guard.requested
        sent = kill_self(signal.SIGTERM)
        assert fake_exit.called.wait(1.0)
        assert fake_exit.calls[0][0] - sent < 0.5
    finally:
        frozen.set()


def test_spin_returns_when_the_shutdown_is_done_or_rospy_says_so(make_guard) -> None:
    guard = make_guard(lambda _r: None, exit=FakeExit())
    began = time.monotonic()
    guard.spin(lambda: True)                   # a shutdown started elsewhere (rosnode kill)
    assert time.monotonic() - began < 0.1
    threading.Timer(0.05, kill_self).start()
    guard.spin(lambda: False, poll=5.0)
    assert guard.shutdown_done.is_set() and time.monotonic() - began < 1.0


def test_uninstall_restores_the_handlers_and_cancels_the_exit() -> None:
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    fake_exit = FakeExit()
    guard = ExitGuard(lambda _r: None, grace=0.2, exit=fake_exit, log=ListLog()).install()
    assert signal.getsignal(signal.SIGINT) == guard._on_signal
    kill_self()
    assert guard.shutdown_done.wait(1.0)
    guard.uninstall()
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
    assert not fake_exit.called.wait(0.4)


@pytest.mark.parametrize("grace", [0.0, -1.0, float("nan"), float("inf"), "1"])
def test_bad_grace(grace) -> None:
    with pytest.raises(ExitGuardError):
        ExitGuard(lambda _r: None, grace=grace)


def test_install_only_from_the_main_thread() -> None:
    errors: list[Exception] = []

    def install() -> None:
        try:
            ExitGuard(lambda _r: None).install()
        except ExitGuardError as err:
            errors.append(err)

    t = threading.Thread(target=install)
    t.start()
    t.join(5.0)
    assert len(errors) == 1


def test_where_names_the_innermost_frames() -> None:
    here = where(threading.main_thread().ident, depth=2)
    assert "test_exit_guard.py" in here and "test_where_names_the_innermost_frames" in here
    assert where(None) == "(gone)"
