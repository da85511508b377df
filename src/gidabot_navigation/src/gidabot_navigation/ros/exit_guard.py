"""A bounded, prompt exit on SIGINT/SIGTERM for rospy nodes (ROS-free: the shutdown is passed in).

Why rospy's own handling is not enough: rospy's SIGINT handler runs ``rospy.signal_shutdown``
*inside the signal handler*, i.e. in the main thread at whatever point that thread was
interrupted. Two ways it then never returns:

* The main thread publishes (the simulator's tick loop, move_base's control loop). A queued
  publisher connection (``rospy.impl.tcpros_pubsub.QueuedConnection``) holds a plain,
  non-reentrant ``threading.Lock`` in ``write_data``; when SIGINT lands while it is held, the
  handler closes every topic, the connection's close callback takes the same lock in the same
  thread: a self-deadlock. SIGTERM runs the handler again, which returns at once (shutdown
  already in progress); only SIGKILL ends the process.
* Unregistering from the master (rospy's pre-shutdown hook) is an XML-RPC call without a
  timeout: a master that is frozen (SIGSTOP) or overloaded holds the node indefinitely.

:class:`ExitGuard` replaces rospy's handler. The handler only records the signal (no lock,
no I/O); the wake-up byte the interpreter writes for every handled signal
(:func:`signal.set_wakeup_fd`) wakes a watch thread even when the main thread is stuck in
C code. The watch thread lets the node's main loop stop at a clean point (bounded wait), runs
the shutdown (``rospy.signal_shutdown``) in a thread of its own, and ends the process with
``os._exit`` if it is still alive ``grace`` seconds after the signal. A second signal exits at
once. Messages go straight to stderr (``os.write``): rospy's loggers may themselves be stuck on
the master.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Sequence
from types import FrameType

from gidabot_navigation.errors import ExitGuardError
from gidabot_navigation.logs import Logger

DEFAULT_GRACE = 1.0          # wall s from the signal to a forced exit
SIGNALS = (signal.SIGINT, signal.SIGTERM)
_STOP = 0                    # byte written to the wake-up pipe by uninstall()


class StderrLog:
    """A :class:`~gidabot_navigation.logs.Logger` that writes with ``os.write(2, ...)``: no lock, no
    master, so it works while the process is stuck in rospy."""

    def __init__(self, name: str) -> None:
        self.name = name

    def _write(self, level: str, msg: str) -> None:
        with contextlib.suppress(OSError):
            os.write(2, f"[{level}] [{time.time():.6f}] {self.name}: {msg}\n".encode(errors="replace"))

    def info(self, msg: str) -> None:
        self._write("INFO", msg)

    def warning(self, msg: str) -> None:
        self._write("WARN", msg)

    def error(self, msg: str) -> None:
        self._write("ERROR", msg)


def where(thread_id: int | None, depth: int = 4) -> str:
    """The innermost ``depth`` frames of a thread, as ``file:line func`` (for the forced-exit message)."""
    frame = sys._current_frames().get(thread_id) if thread_id is not None else None
    if frame is None:
        return "(gone)"
    stack = traceback.extract_stack(frame)[-depth:]
    return " <- ".join(f"{os.path.basename(f.filename)}:{f.lineno} {f.name}" for f in reversed(stack))


class ExitGuard:
    """Ends the process within ``grace`` wall seconds of SIGINT/SIGTERM, whatever state it is in.

    ``shutdown(reason)`` is the orderly shutdown (``rospy.signal_shutdown``), run in a thread of its
    own. With ``main_loop``, the node's main loop polls :attr:`requested`, stops at a clean point
    and calls :meth:`loop_stopped`; the shutdown waits for that at most ``grace / 2`` (so the loop
    never publishes on topics the shutdown is closing). ``exit`` (``os._exit``) is injectable for
    tests. Deadlines are in wall time (``time.monotonic``): this is about the process, not the simulation.
    """

    def __init__(self, shutdown: Callable[[str], object], grace: float = DEFAULT_GRACE, main_loop: bool = False,
                 log: Logger | None = None, exit: Callable[[int], object] = os._exit,  # noqa: A002
                 name: str = "node") -> None:
        if not (isinstance(grace, (int, float)) and 0.0 < grace < 3600.0):
            raise ExitGuardError(f"exit grace: {grace!r} must be a number of wall seconds in (0, 3600)")
        self.shutdown, self.grace, self.main_loop = shutdown, float(grace), main_loop
        self.log = log or StderrLog(name)
        self.exit, self.name = exit, name
        self.signum: int | None = None          # the first signal received (set by the handler only)
        self.signalled_at: float | None = None
        self.forced = False                     # exit() was called by the guard
        self.shutdown_done = threading.Event()  # shutdown() returned
        self._loop_stopped = threading.Event()
        self._signals: tuple[int, ...] = ()
        self._previous: dict[int, object] = {}
        self._previous_wakeup = -1
        self._pipe: tuple[int, int] | None = None
        self._thread: threading.Thread | None = None
        self._main_id: int | None = None
        self._wake: Callable[[], object] | None = None
        self._cancel = threading.Event()        # uninstall(): no forced exit any more (tests)

    @property
    def requested(self) -> bool:
        """A signal asked the process to stop (the main loop checks this every iteration)."""
        return self.signum is not None

    def loop_stopped(self) -> None:
        """The main loop has stopped publishing: the shutdown may close the topics now."""
        self._loop_stopped.set()

    def set_wake(self, wake: Callable[[], object]) -> None:
        """``wake()`` is called (from the watch thread) on the first signal: it ends a wait of the main
        loop early (e.g. ``threading.Event.set``) so that the loop sees :attr:`requested` at once."""
        self._wake = wake

    def spin(self, is_shutdown: Callable[[], bool], poll: float = 0.5) -> None:
        """``rospy.spin()``, returning as soon as the guard's shutdown is done (rospy.spin sleeps up to
        0.5 s more); ``is_shutdown`` covers a shutdown started elsewhere (``rosnode kill``). Also what a
        main loop's thread does after the loop: if it returned at once, the interpreter's exit would run
        rospy's shutdown (its atexit hook) in the main thread, racing the guard's."""
        while not is_shutdown() and not self.shutdown_done.wait(poll):
            pass

    # -- install / uninstall (main thread) ------------------------------------------------
    def install(self, signals: Sequence[int] = SIGNALS) -> ExitGuard:
        """Take over ``signals`` (call from the main thread, after ``rospy.init_node``)."""
        if threading.current_thread() is not threading.main_thread():
            raise ExitGuardError("ExitGuard.install() must be called from the main thread")
        read_fd, write_fd = os.pipe()
        os.set_blocking(write_fd, False)       # the interpreter's wake-up write must never block
        self._pipe = (read_fd, write_fd)
        self._main_id = threading.main_thread().ident
        self._signals = tuple(signals)
        self._thread = threading.Thread(target=self._watch, name=f"exit_guard_{self.name}", daemon=True)
        self._thread.start()
        for sig in self._signals:
            self._previous[sig] = signal.signal(sig, self._on_signal)
        self._previous_wakeup = signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
        return self

    def uninstall(self) -> None:
        """Restore the previous handlers and wake-up fd, stop the watch thread (tests)."""
        if self._pipe is None:
            return
        signal.set_wakeup_fd(self._previous_wakeup)
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)  # type: ignore[arg-type]
        self._previous.clear()
        self._cancel.set()
        read_fd, write_fd = self._pipe
        with contextlib.suppress(OSError):
            os.write(write_fd, bytes([_STOP]))
        if self._thread is not None:
            self._thread.join(5.0)
        os.close(read_fd)
        os.close(write_fd)
        self._pipe = None

    def _on_signal(self, signum: int, _frame: FrameType | None) -> None:
        # runs in the main thread wherever it was interrupted (maybe holding one of rospy's locks):
        # no lock, no I/O, nothing that can block; the wake-up byte has already woken the watch thread
        if self.signum is None:
            self.signum = signum

    # -- the watch thread -------------------------------------------------------------------
    def _watch(self) -> None:
        assert self._pipe is not None
        read_fd = self._pipe[0]
        first = True
        while True:
            try:
                data = os.read(read_fd, 64)
            except InterruptedError:
                continue
            except OSError:
                return
            if not data:
                return
            for sig in data:
                if sig == _STOP:
                    return
                if sig not in self._signals:
                    continue
                if first:
                    first = False
                    if self.signum is None:          # the byte can come before the Python-level handler ran
                        self.signum = sig
                    self.signalled_at = time.monotonic()
                    if self._wake is not None:
                        try:
                            self._wake()
                        except Exception as err:  # noqa: BLE001 - a waker must never stop the exit
                            self.log.error(f"wake-up of the main loop failed: {err!r}")
                    threading.Thread(target=self._stop_process, args=(sig,), name=f"exit_guard_stop_{self.name}",
                                     daemon=True).start()
                else:
                    self._force(f"second signal {signal.Signals(sig).name}")
                    return

    def _stop_process(self, sig: int) -> None:
        start = self.signalled_at if self.signalled_at is not None else time.monotonic()
        deadline = start + self.grace
        if self.main_loop and not self._loop_stopped.wait(self.grace / 2) and not self._cancel.is_set():
            self.log.warning(f"main loop did not stop within {self.grace / 2:.2f} s of {signal.Signals(sig).name} "
                             f"(at {where(self._main_id)}); shutting down anyway")
        runner = threading.Thread(target=self._run_shutdown, args=(f"signal-{sig}",),
                                  name=f"exit_guard_shutdown_{self.name}", daemon=True)
        runner.start()
        runner.join(max(0.0, deadline - time.monotonic()))
        if runner.is_alive():
            self._force(f"shutdown did not finish within {self.grace:g} s of {signal.Signals(sig).name} "
                        f"(at {where(runner.ident)})")
            return
        # the orderly shutdown finished: the process ends when the main thread returns; if it is
        # still alive at the deadline (a thread that never ends, a blocked main thread), end it
        if self._cancel.wait(max(0.0, deadline - time.monotonic())):
            return
        self._force(f"still running {self.grace:g} s after {signal.Signals(sig).name} "
                    f"(main thread at {where(self._main_id)})")

    def _run_shutdown(self, reason: str) -> None:
        try:
            self.shutdown(reason)
        except Exception as err:  # noqa: BLE001 - the exit must happen whatever the shutdown raises
            self.log.error(f"shutdown failed: {err!r}")
        finally:
            self.shutdown_done.set()

    def _force(self, why: str) -> None:
        if self._cancel.is_set():
            return
        self.forced = True
        self.log.warning(f"{why}; exiting now")
        self.exit(0)


def rospy_shutdown(reason: str) -> None:
    """``rospy.signal_shutdown``, without its idle half second: rospy's registration thread waits 0.5 s
    on a condition between two looks at the shutdown flag, and signal_shutdown joins it; a shutdown
    hook (run once the flag is set) wakes it, so the shutdown takes milliseconds (~0.6 s -> ~0.1 s)."""
    import rospy

    from gidabot_navigation.ros.rospy_internals import wake_registration_thread_on_shutdown

    wake_registration_thread_on_shutdown()
    rospy.signal_shutdown(reason)


def rospy_exit_guard(name: str, grace: float = DEFAULT_GRACE, main_loop: bool = False) -> ExitGuard:
    """An installed guard whose shutdown is :func:`rospy_shutdown`. Best called *before*
    ``rospy.init_node(..., disable_signals=True)``: a signal during ``init_node`` (which waits on the master)
    then also ends the process in time; after an ``init_node`` with rospy's handlers, a signal in that
    window runs rospy's handler, which can hang for good (a relay end restarted while its master was frozen
    did, once its supervisor was gone)."""
    return ExitGuard(rospy_shutdown, grace=grace, main_loop=main_loop, name=name).install()
