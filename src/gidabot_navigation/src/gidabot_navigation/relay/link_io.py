"""The socket side of a relay end (ROS-free): the I/O loop that carries the link's bytes for the core.

One thread runs :meth:`LinkIO.run`: a :mod:`selectors` loop over the sockets it is given (end b's
listening socket, end a's connections from an injected connect function, or connected sockets
handed in with :meth:`LinkIO.add_connection`). It feeds the core
(:class:`gidabot_navigation.relay.end.RelayEndCore`) received bytes, opened and closed
connections and its ticks, and carries out the :class:`~gidabot_navigation.relay.end.Send` /
:class:`~gidabot_navigation.relay.end.Close` actions the core returns: a send is written at once
(non-blocking), what the socket cannot take yet waits in that connection's buffer until the
selector says it is writable.

- **Threads**: other threads (rospy callbacks) reach the core only through :meth:`LinkIO.perform`,
  under :attr:`LinkIO.lock`, so every send happens in order; a send left unfinished, and
  :meth:`LinkIO.stop`, wake the loop through a socket pair.
- **Time** comes from the injected ``clock`` (the core's): the loop waits in ``select()`` until the
  earliest of the core's next tick (:meth:`RelayEndCore.next_tick_in`: a coalesced state that is
  due), its heartbeat tick (every half heartbeat), the adapter's periodic jobs, the next connect
  attempt and a connect deadline. The heartbeat ticks and the periodic jobs are on one grid
  (:class:`Periodic`), not rescheduled from each late wake-up, so they share their wake-ups; and
  whatever is due when ``select()`` returns runs in the same iteration: the loop wakes a bounded
  number of times per second and never spins.
- **Connecting** (end a): while the core has no connection and none is being made, ``connect()``
  is called every ``retry_interval`` s; an attempt still unfinished after ``connect_timeout`` s
  is closed.

The ROS adapter (:mod:`gidabot_navigation.relay.end_node`) creates the sockets, runs its
housekeeping with the heartbeat (delivery hold, pruning) and its diagnostics as a periodic job,
and publishes the core's deliveries after every iteration.
"""

from __future__ import annotations

import contextlib
import errno
import selectors
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from gidabot_navigation.relay.end import Action, Close, RelayEndCore

CONNECT_TIMEOUT = 1.0    # s for one TCP connect attempt
RETRY_INTERVAL = 0.25    # s between connect attempts
RECV_BYTES = 1 << 18
_WAKE = "wake"           # selector data of the wake-up socket
_LISTEN = "listen"       # selector data of the listening socket

Connect = Callable[[], socket.socket | None]


def open_listener(host: str, port: int, backlog: int = 8) -> socket.socket:
    """A non-blocking TCP socket listening on ``host``:``port`` (raises OSError if it cannot bind)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(backlog)
    except OSError:
        sock.close()
        raise
    sock.setblocking(False)
    return sock


def tcp_connector(host: str, port: int, bind_ip: str = "") -> Connect:
    """A connect function for :class:`LinkIO`: each call starts a non-blocking TCP connect to
    ``host``:``port`` from ``bind_ip`` and returns the socket (connected or in progress); None when
    the attempt failed at once (nobody listening: try again later); OSError when this machine
    cannot even try (e.g. ``bind_ip`` is not one of its addresses)."""

    def connect() -> socket.socket | None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            if bind_ip:
                sock.bind((bind_ip, 0))
            sock.setblocking(False)
            err = sock.connect_ex((host, port))
        except OSError as e:
            sock.close()
            raise OSError(e.errno, f"cannot connect to {host}:{port} from {bind_ip or 'any address'}: "
                                   f"{e.strerror}") from e
        if err not in (0, errno.EINPROGRESS):
            sock.close()
            return None
        return sock

    return connect


@dataclass
class Periodic:
    """A job the loop runs every ``period`` s (first at the first iteration): ``run(now)``."""

    period: float
    run: Callable[[float], None]
    due: float | None = None

    def is_due(self, now: float) -> bool:
        return self.due is None or now >= self.due

    def advance(self, now: float) -> None:
        """The next run: one period after the one due (on the same grid), or one period from ``now`` if
        that is past already (the loop was late by more than a period)."""
        nxt = (now if self.due is None else self.due) + self.period
        self.due = nxt if nxt > now else now + self.period

    def run_if_due(self, now: float) -> None:
        if self.is_due(now):
            self.advance(now)
            self.run(now)


@dataclass
class _Sock:
    sock: socket.socket
    outbuf: bytearray
    connecting: bool = False
    deadline: float = 0.0


class LinkIO:
    """The I/O loop of one relay end (see the module docstring).

    ``listener``: a listening socket (end b) or None; ``connect``: a connect function (end a,
    e.g. :func:`tcp_connector`) or None; ``on_heartbeat(now)`` runs with every heartbeat tick of the
    core (every half heartbeat); ``jobs``: the adapter's other periodic jobs, on the same grid (they
    start at the first iteration too); ``after_io()`` runs at the end of every iteration (the adapter
    publishes the core's deliveries there);
    ``selector``: a :class:`selectors.BaseSelector` (default :class:`selectors.DefaultSelector`).
    Every time is read from ``clock`` (seconds, monotonic), the core's own clock.
    """

    def __init__(self, core: RelayEndCore, clock: Callable[[], float] = time.monotonic, *,
                 listener: socket.socket | None = None, connect: Connect | None = None,
                 on_heartbeat: Callable[[float], None] | None = None, jobs: tuple[Periodic, ...] = (),
                 after_io: Callable[[], None] | None = None,
                 selector: selectors.BaseSelector | None = None, retry_interval: float = RETRY_INTERVAL,
                 connect_timeout: float = CONNECT_TIMEOUT) -> None:
        self.core = core
        self.clock = clock
        self.lock = threading.Lock()
        self.jobs = tuple(jobs)
        self.after_io = after_io
        self.connect = connect
        self.retry_interval = retry_interval
        self.connect_timeout = connect_timeout
        self.heartbeat = Periodic(core.cfg.heartbeat / 2, on_heartbeat or (lambda _now: None))   # the core's ticks
        self.sel = selector if selector is not None else selectors.DefaultSelector()
        self.socks: dict[int, _Sock] = {}
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self.sel.register(self._wake_r, selectors.EVENT_READ, _WAKE)
        self.listener: socket.socket | None = None
        if listener is not None:
            self.listen(listener)
        self._next_id = 1
        self._next_connect = -float("inf")
        self._stop = threading.Event()
        self._io_thread: threading.Thread | None = None

    def listen(self, listener: socket.socket) -> None:
        """Accept the connections of ``listener`` (a listening socket, e.g. :func:`open_listener`)."""
        listener.setblocking(False)
        self.listener = listener
        self.sel.register(listener, selectors.EVENT_READ, _LISTEN)

    # -- from any thread -------------------------------------------------------------------
    def perform(self, call: Callable[[RelayEndCore], list[Action]]) -> None:
        """``call(core)`` under the lock, and carry out the actions it returns."""
        with self.lock:
            self.apply(call(self.core))

    def stop(self) -> None:
        """End :meth:`run` (it returns within one iteration)."""
        self._stop.set()
        self.wake()

    def wake(self) -> None:
        """Make the loop's ``select()`` return now."""
        with contextlib.suppress(BlockingIOError, OSError):
            self._wake_w.send(b"\0")

    def add_connection(self, sock: socket.socket, initiator: bool) -> int:
        """A connected socket (accepted, or made elsewhere): the core's connection, from now on; its id."""
        sock.setblocking(False)
        with contextlib.suppress(OSError):      # not TCP (a test's socket pair): no Nagle to turn off
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        with self.lock:
            cid = self._new_id()
            self.socks[cid] = _Sock(sock, bytearray())
            self.sel.register(sock, selectors.EVENT_READ, cid)
            self.apply(self.core.connection_opened(cid, initiator))
        return cid

    # -- actions (lock held) ---------------------------------------------------------------
    def apply(self, actions: list[Action]) -> None:
        """Carry out the core's actions (lock held): append and send at once (non-blocking); the loop
        sends what the socket could not take yet. Every send happens under the lock, in order."""
        wake = False
        for act in actions:
            s = self.socks.get(act.conn)
            if s is None:
                continue
            if isinstance(act, Close):
                s.outbuf.clear()
                self._close_sock(act.conn, notify=False)
                continue
            s.outbuf += act.data
            self._flush(s)
            if s.outbuf:
                wake = True
        if wake and threading.current_thread() is not self._io_thread:
            self.wake()

    def _flush(self, s: _Sock) -> None:
        try:
            while s.outbuf:
                n = s.sock.send(s.outbuf)
                if n <= 0:
                    break
                del s.outbuf[:n]
        except (BlockingIOError, InterruptedError):
            pass
        except OSError:
            s.outbuf.clear()        # the reader side will see the connection fail

    def _close_sock(self, conn_id: int, notify: bool, reason: str = "closed") -> None:
        s = self.socks.pop(conn_id, None)
        if s is None:
            return
        with contextlib.suppress(KeyError, ValueError):
            self.sel.unregister(s.sock)
        with contextlib.suppress(OSError):
            s.sock.close()
        if notify:
            self.core.connection_closed(conn_id, reason)

    def _new_id(self) -> int:
        cid = self._next_id
        self._next_id += 1
        return cid

    # -- the loop ---------------------------------------------------------------------------
    def run(self, keep_running: Callable[[], bool] = lambda: True) -> None:
        """Loop until :meth:`stop` or ``keep_running()`` is False; then say goodbye to the peer, close
        every socket and the core (its journal)."""
        self._io_thread = threading.current_thread()
        try:
            while keep_running() and not self._stop.is_set():
                self.step()
        finally:
            self.close()

    def step(self) -> None:
        """One iteration: wait for a socket or for what is due next, handle it, run what is due."""
        now = self.clock()
        schedule = (self.heartbeat, *self.jobs)
        with self.lock:
            timeout = min([self.core.next_tick_in()] + [j.due - now for j in schedule if j.due is not None])
            if any(j.due is None for j in schedule):
                timeout = 0.0
            self._update_interest()
            busy = self._busy()
            timeout = min([timeout] + [s.deadline - now for s in self.socks.values() if s.connecting])
        if self.connect is not None and not busy:
            if now >= self._next_connect:
                self._start_connect(now)
                timeout = min(timeout, self.retry_interval)
            else:
                timeout = min(timeout, self._next_connect - now)
        for key, mask in self.sel.select(max(0.0, timeout)):
            self._handle(key, mask)
        now = self.clock()
        self._check_connect_timeouts(now)
        heartbeat = self.heartbeat.is_due(now)
        with self.lock:
            # the core's own schedule too (a coalesced state due): select() above waited for it,
            # so not ticking now would make the next select() return at once (a spin)
            if heartbeat or self.core.next_tick_in() <= 0:
                self.apply(self.core.tick())
        self.heartbeat.run_if_due(now)
        for job in self.jobs:
            job.run_if_due(now)
        if self.after_io is not None:
            self.after_io()

    def close(self) -> None:
        """Send the core's goodbye, close every socket and the core (idempotent)."""
        with self.lock:
            if self.sel.get_map() is None:
                return
            self.apply(self.core.shutdown())
            for cid in list(self.socks):
                self._close_sock(cid, notify=False)
            if self.listener is not None:
                with contextlib.suppress(KeyError, ValueError):
                    self.sel.unregister(self.listener)
                self.listener.close()
            self.sel.close()
            self._wake_r.close()
            self._wake_w.close()

    def _busy(self) -> bool:
        """A connection exists or is being made (lock held): no new connect attempt."""
        return self.core.active is not None or bool(self.core.conns) or any(s.connecting for s in self.socks.values())

    def _update_interest(self) -> None:
        for cid, s in self.socks.items():
            want = selectors.EVENT_WRITE if s.connecting else \
                selectors.EVENT_READ | (selectors.EVENT_WRITE if s.outbuf else 0)
            try:
                key = self.sel.get_key(s.sock)
                if key.events != want:
                    self.sel.modify(s.sock, want, cid)
            except KeyError:
                self.sel.register(s.sock, want, cid)

    def _handle(self, key: selectors.SelectorKey, mask: int) -> None:
        if key.data == _WAKE:
            with contextlib.suppress(BlockingIOError, OSError):
                while self._wake_r.recv(4096):
                    pass
            return
        if key.data == _LISTEN:
            self._accept()
            return
        cid = key.data
        s = self.socks.get(cid)
        if s is None:
            return
        if s.connecting:
            self._finish_connect(cid, s)
            return
        if mask & selectors.EVENT_READ:
            try:
                data = s.sock.recv(RECV_BYTES)
            except (BlockingIOError, InterruptedError):
                data = None
            except OSError as err:
                with self.lock:
                    self._close_sock(cid, notify=True, reason=f"receive error: {err.strerror}")
                return
            if data == b"":
                with self.lock:
                    self._close_sock(cid, notify=True, reason="connection closed by the other side")
                return
            if data:
                with self.lock:
                    self.apply(self.core.data_received(cid, data))
        if mask & selectors.EVENT_WRITE:
            with self.lock:
                s = self.socks.get(cid)
                if s is not None:
                    self._flush(s)

    def _accept(self) -> None:
        assert self.listener is not None
        while True:
            try:
                sock, _ = self.listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as err:
                with self.lock:
                    self.core.rlog.warning("accept", f"{self.core.name}: accept failed: {err.strerror}")
                return
            self.add_connection(sock, initiator=False)

    def _start_connect(self, now: float) -> None:
        assert self.connect is not None
        self._next_connect = now + self.retry_interval
        try:
            sock = self.connect()
        except OSError as err:
            with self.lock:
                self.core.rlog.warning("connect", f"{self.core.name}: {err.strerror or err}")
            return
        if sock is None:
            return
        with self.lock:
            cid = self._new_id()
            self.socks[cid] = _Sock(sock, bytearray(), connecting=True, deadline=now + self.connect_timeout)
            self.sel.register(sock, selectors.EVENT_WRITE, cid)

    def _finish_connect(self, cid: int, s: _Sock) -> None:
        try:
            err = s.sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
        except OSError as e:
            err = e.errno or errno.EIO
        with self.lock:
            if err != 0:
                self._close_sock(cid, notify=False)
                return
            s.connecting = False
            with contextlib.suppress(OSError):
                s.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.sel.modify(s.sock, selectors.EVENT_READ, cid)
            self.apply(self.core.connection_opened(cid, True))

    def _check_connect_timeouts(self, now: float) -> None:
        with self.lock:
            for cid, s in list(self.socks.items()):
                if s.connecting and now >= s.deadline:
                    self._close_sock(cid, notify=False)
