"""The relay end's socket loop (link_io.py) over socket pairs and loopback TCP, with the cores of two ends.

Most tests drive :meth:`LinkIO.step` by hand with a fake clock: their selector polls and, when nothing is
ready, moves the clock on by the timeout the loop asked for (so a test counts the loop's wake-ups per
second of fake time). The threaded tests use the real clock and wait on conditions with deadlines.
"""

from __future__ import annotations

import selectors
import socket
import threading
import time
from collections.abc import Callable

from relay_support import MD5, TYPES, Clock, Log, make_core

from gidabot_navigation.interface import EVENT, Node, Topic, global_name
from gidabot_navigation.relay.end import RelayEndCore
from gidabot_navigation.relay.journal import Journal
from gidabot_navigation.relay.link_io import LinkIO, Periodic, open_listener, tcp_connector

G = Topic.GOALS
S = Topic.STATUS
NODE = global_name(Node.GOAL_MANAGER)


class FakeTimeSelector(selectors.DefaultSelector):      # type: ignore[misc,valid-type]
    """Never blocks: polls, and when nothing is ready moves ``clock`` on by the timeout asked for (and
    ``late`` s more after a wait, as a real select() returns a little after its timeout)."""

    def __init__(self, clock: Clock, late: float = 0.0) -> None:
        super().__init__()
        self.clock = clock
        self.late = late
        self.timeouts: list[float] = []

    def select(self, timeout: float | None = None) -> list:
        assert timeout is not None and timeout >= 0
        self.timeouts.append(timeout)
        ready = super().select(0)
        if not ready:
            self.clock.t += timeout + (self.late if timeout > 0 else 0.0)
        return ready


class CountingSelector(selectors.DefaultSelector):      # type: ignore[misc,valid-type]
    """A real selector that counts the select() calls started and returned."""

    def __init__(self) -> None:
        super().__init__()
        self.started = 0
        self.returned = 0

    def select(self, timeout: float | None = None) -> list:
        self.started += 1
        try:
            return super().select(timeout)
        finally:
            self.returned += 1


class End:
    """A core and its LinkIO; what the core delivers is collected in ``published``."""

    def __init__(self, side: str, clock: Callable[[], float], selector: selectors.BaseSelector | None = None,
                 **kw: object) -> None:
        self.log = Log()
        core_kw = {k: v for k, v in kw.items() if k in ("heartbeat", "link_timeout", "state_rate")}
        io_kw = {k: v for k, v in kw.items() if k not in core_kw}
        self.core: RelayEndCore = make_core(side, Journal(None), clock, self.log, **core_kw)  # type: ignore[arg-type]
        self.published: list[tuple[str, str, bytes]] = []
        self.io = LinkIO(self.core, clock, selector=selector, after_io=self.deliver, **io_kw)  # type: ignore[arg-type]

    def deliver(self) -> None:
        with self.io.lock:
            ds = self.core.take_deliveries()
            events = sum(d.kind == EVENT for d in ds)
            self.core.delivered(events, len(ds) - events)
        self.published += [(d.kind, d.msg.topic, d.msg.payload) for d in ds]

    def local(self, topic: str, payload: bytes) -> None:
        self.io.perform(lambda core: core.local_message(topic, NODE, TYPES[topic], MD5[topic], payload))

    def payloads(self, topic: str = G) -> list[bytes]:
        return [p for _, t, p in self.published if t == topic]


def pump(ends: list[End], until: Callable[[], bool], steps: int = 500) -> None:
    for _ in range(steps):
        if until():
            return
        for e in ends:
            e.io.step()
    assert until(), "condition not reached"


def joined(**kw: object) -> tuple[End, End, Clock]:
    """Two ends over a socket pair, fake clock, link up."""
    clock = Clock()
    a = End("a", clock, FakeTimeSelector(clock), **kw)
    b = End("b", clock, FakeTimeSelector(clock), **kw)
    sa, sb = socket.socketpair()
    a.io.add_connection(sa, initiator=True)
    b.io.add_connection(sb, initiator=False)
    pump([a, b], lambda: a.core.active is not None and b.core.active is not None)
    return a, b, clock


def close(*ends: End) -> None:
    for e in ends:
        e.io.close()


def test_frames_cross_both_ways_in_order_also_larger_than_the_socket_buffer() -> None:
    a, b, _ = joined()
    big = b"B" * 900_000                       # far more than a socket pair's buffer: sent over several writes
    for i in range(3):
        a.local(G, b"goal%d" % i)
    a.local(G, big)
    b.local(G, b"from-b")
    assert a.io.socks and any(s.outbuf for s in a.io.socks.values())      # the rest waits for EVENT_WRITE
    pump([a, b], lambda: len(b.payloads()) == 4 and a.payloads() == [b"from-b"])
    assert b.payloads() == [b"goal0", b"goal1", b"goal2", big]
    pump([a, b], lambda: not a.core.state.outq)                           # acknowledged
    close(a, b)


def test_a_peer_saying_goodbye_and_a_peer_vanishing_close_the_link() -> None:
    a, b, _ = joined()
    b.io.close()                               # BYE, then its socket closes
    pump([a], lambda: a.core.active is None)
    assert a.log.has("peer shut down") and not a.io.socks
    a2, b2, _ = joined()
    (sock,) = (s.sock for s in b2.io.socks.values())
    sock.shutdown(socket.SHUT_RDWR)            # no goodbye: the connection just ends
    pump([a2], lambda: a2.core.active is None)
    assert a2.log.has("connection closed by the other side") and not a2.io.socks
    assert a2.core.stats.link_losses == 1
    close(a, a2, b2)


def test_end_a_connects_over_tcp_to_end_b_listening() -> None:
    clock = Clock()
    listener = open_listener("127.0.0.1", 0)
    port = listener.getsockname()[1]
    b = End("b", clock, FakeTimeSelector(clock), listener=listener)
    a = End("a", clock, FakeTimeSelector(clock), connect=tcp_connector("127.0.0.1", port, "127.0.0.1"))
    pump([a, b], lambda: a.core.active is not None and b.core.active is not None)
    a.local(G, b"over tcp")
    pump([a, b], lambda: b.payloads() == [b"over tcp"])
    close(a, b)
    assert listener.fileno() == -1


def test_a_refused_connect_is_retried_every_retry_interval() -> None:
    clock = Clock()
    calls: list[float] = []

    def refused() -> socket.socket | None:
        calls.append(clock.t)
        return None

    sel = FakeTimeSelector(clock)
    a = End("a", clock, sel, connect=refused, retry_interval=0.25)
    start = clock.t
    pump([a], lambda: clock.t >= start + 2.0)
    assert [round(t - start, 6) for t in calls] == [0.25 * i for i in range(len(calls))]
    assert len(calls) in (8, 9) and len(sel.timeouts) <= 2 * len(calls) + 2
    close(a)


def test_a_connect_that_never_completes_is_closed_after_the_connect_timeout_and_tried_again() -> None:
    clock = Clock()
    made: list[tuple[float, socket.socket]] = []
    keep: list[socket.socket] = []

    def stuck() -> socket.socket:
        s, other = socket.socketpair()
        s.setblocking(False)
        try:
            while True:                          # a full send buffer: never writable, like a SYN never answered
                s.send(b"x" * 65536)
        except BlockingIOError:
            pass
        keep.append(other)
        made.append((clock.t, s))
        return s

    a = End("a", clock, FakeTimeSelector(clock), connect=stuck, connect_timeout=1.0, retry_interval=0.25)
    start = clock.t
    pump([a], lambda: len(made) >= 2)
    (t0, first), (t1, second) = made
    assert first.fileno() == -1 and second.fileno() != -1      # the first attempt was given up
    assert 1.0 <= t1 - t0 <= 1.0 + 0.25 + 1e-9 and t0 == start
    assert not a.core.conns                                     # never a connection for the core
    close(a)
    assert second.fileno() == -1
    for s in keep:
        s.close()


def test_a_coalesced_state_that_is_due_is_sent_by_the_next_tick_and_the_loop_does_not_spin() -> None:
    a, b, clock = joined(heartbeat=0.5, link_timeout=2.0, state_rate=10.0)
    a.local(S, b"robot=Tartalo;1")              # sent at once
    sent_at = clock.t
    a.local(S, b"robot=Tartalo;2")              # too soon (10 Hz): coalesced, due 0.1 s after the first
    assert a.core.stats.forwarded_states == 1
    due = sent_at + 0.1
    sel = a.io.sel
    assert isinstance(sel, FakeTimeSelector)
    before = len(sel.timeouts)
    sent_when = None
    steps = 0
    while clock.t < sent_at + 1.0:
        a.io.step()
        steps += 1
        assert steps <= 50, f"the loop spins: {steps} iterations in {clock.t - sent_at:.3f} s of fake time"
        if sent_when is None and a.core.stats.forwarded_states == 2:
            sent_when = clock.t
    assert sent_when is not None and due - 1e-9 <= sent_when <= due + 1e-6     # by the tick when it was due
    wakeups = len(sel.timeouts) - before
    # one second: the heartbeat ticks (every 0.25 s) and the coalesced state, nothing more
    assert wakeups <= 7, sel.timeouts[before:]
    pump([a, b], lambda: b.payloads(S) == [b"robot=Tartalo;1", b"robot=Tartalo;2"])
    close(a, b)


def test_an_idle_link_wakes_the_loop_a_bounded_number_of_times() -> None:
    a, b, clock = joined(heartbeat=0.5, link_timeout=2.0)
    ran: list[float] = []
    a.io.jobs = (Periodic(1.0, ran.append),)
    start, before = clock.t, len(a.io.sel.timeouts)     # type: ignore[attr-defined]
    pump([a, b], lambda: clock.t >= start + 10.0, steps=400)
    wakeups = len(a.io.sel.timeouts) - before            # type: ignore[attr-defined]
    assert wakeups <= 80                                   # heartbeat ticks, pings and pongs: about 6 a second
    assert a.core.active is not None and 9 <= len(ran) <= 12
    close(a, b)


def test_late_wake_ups_keep_the_heartbeat_and_the_jobs_on_one_grid() -> None:
    clock = Clock()
    sel = FakeTimeSelector(clock, late=0.003)            # every wait ends 3 ms late
    beats: list[float] = []
    diagnostics: list[float] = []
    e = End("b", clock, sel, on_heartbeat=beats.append, jobs=(Periodic(1.0, diagnostics.append),))
    start = clock.t
    pump([e], lambda: clock.t >= start + 10.0)
    # a heartbeat tick every 0.25 s, the 1 Hz job on the same wake-ups: about 4 a second, not 5 or 8
    assert len(sel.timeouts) <= 42 and 40 <= len(beats) <= 41 and 10 <= len(diagnostics) <= 11
    assert set(diagnostics) <= set(beats)
    close(e)


def test_periodic_jobs_run_at_once_then_every_period_and_a_late_one_skips_ahead() -> None:
    ran: list[float] = []
    job = Periodic(1.0, ran.append)
    for now in (0.0, 0.5, 1.0, 1.2, 2.0, 4.5, 5.0, 5.5):
        job.run_if_due(now)
    assert ran == [0.0, 1.0, 2.0, 4.5, 5.5]


def test_the_loop_wakes_up_from_another_thread_and_stops_promptly() -> None:
    sel = CountingSelector()
    e = End("a", time.monotonic, sel, heartbeat=5.0, link_timeout=10.0)      # select() waits up to 2.5 s
    t = threading.Thread(target=e.io.run, daemon=True)
    t.start()
    deadline = time.monotonic() + 5.0
    while sel.started < 2 and time.monotonic() < deadline:     # the first iteration's select returns at once
        time.sleep(0.005)
    assert sel.started >= 2
    returned = sel.returned
    t0 = time.monotonic()
    e.io.wake()
    while sel.returned == returned and time.monotonic() < t0 + 2.0:
        time.sleep(0.005)
    assert sel.returned > returned and time.monotonic() - t0 < 1.0
    t0 = time.monotonic()
    e.io.stop()
    t.join(2.0)
    assert not t.is_alive() and time.monotonic() - t0 < 1.0
    assert sel.get_map() is None                                           # closed on the way out


def test_events_published_from_other_threads_cross_while_both_loops_run() -> None:
    a = End("a", time.monotonic)
    b = End("b", time.monotonic)
    sa, sb = socket.socketpair()
    a.io.add_connection(sa, initiator=True)
    b.io.add_connection(sb, initiator=False)
    threads = [threading.Thread(target=e.io.run, daemon=True) for e in (a, b)]
    for t in threads:
        t.start()
    try:
        deadline = time.monotonic() + 10.0
        while a.core.active is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert a.core.active is not None
        big = b"E" * 500_000
        a.local(G, big)                        # partly sent here; the loop sends the rest (woken)
        a.local(G, b"after")
        while len(b.payloads()) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert b.payloads() == [big, b"after"]
    finally:
        for e in (a, b):
            e.io.stop()
        for t in threads:
            t.join(5.0)
    assert not any(t.is_alive() for t in threads)
