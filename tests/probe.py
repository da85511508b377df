"""Python side of tests/ros_probe.py: a process on one robot's master that publishes and records.

    with Probe(sim.env("Kbot"), log_dir) as p:
        p.sub("tour_store/catalog", "gidabot_msgs/TourCatalog")
        p.pub("tour_store/edit", "gidabot_msgs/Tour", {"file_name": "x.tour", ...}, to=["/tour_store"])
        p.wait("tour_store/catalog", lambda m: ..., timeout=5)

The process runs in its own session and is killed by process group on close.

Publishing once is only safe once the subscribers that must see the message are connected to
the publisher: :meth:`Probe.pub` waits for the nodes named in ``to`` (and for the probe itself
when it records that topic); :meth:`Probe.publish_until` repeats a message until its effect is
seen; :func:`wait_connected` waits for the connections of any other node's publisher (through
its ``getBusInfo``). All of them wait on :func:`wait_subscribers`.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

PROBE = Path(__file__).resolve().parent / "ros_probe.py"
CONNECT_TIMEOUT = 60.0     # s a publisher waits for its subscribers' connections (a loaded 2-core machine)


class ProbeError(RuntimeError):
    pass


def wait_subscribers(connected: Callable[[], Iterable[str]], subscribers: Iterable[str], timeout: float,
                     what: str) -> None:
    """Until every node of ``subscribers`` (global names, e.g. "/goal_manager") is among ``connected()``, the
    subscribers connected to a publisher; TimeoutError naming the missing ones after ``timeout`` s."""
    want = set(subscribers)
    deadline = time.monotonic() + timeout
    while True:
        missing = want - set(connected())
        if not missing:
            return
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what}: {', '.join(sorted(missing))} not connected after {timeout:g} s")
        time.sleep(0.02)


def bus_subscribers(bus_info: Iterable[list], topic: str) -> set[str]:
    """Caller ids of the subscribers connected to ``topic`` (a global name), from a node's ``getBusInfo``
    answer (rows: connection id, destination, direction, transport, topic, connected, ...)."""
    return {str(row[1]) for row in bus_info
            if row[2] == "o" and row[4] == topic and (len(row) < 6 or row[5] in (True, 1))}


def connected_subscribers(master_uri: str, publisher: str, topic: str) -> set[str]:
    """The subscribers connected to node ``publisher``'s publisher of ``topic`` (global names); empty while the
    node is not registered or not answering."""
    try:
        code, _, api = xmlrpc.client.ServerProxy(master_uri).lookupNode("/test_probe", publisher)
        if code != 1:
            return set()
        code, _, info = xmlrpc.client.ServerProxy(api).getBusInfo("/test_probe")
    except (OSError, xmlrpc.client.Error):
        return set()
    return bus_subscribers(info, topic) if code == 1 else set()


def close_all(probes: Iterable[Probe]) -> None:
    """Close every probe of ``probes`` side by side (each may take a moment to leave its master)."""
    probes = list(probes)
    with ThreadPoolExecutor(max(1, len(probes))) as pool:
        list(pool.map(Probe.close, probes))


def wait_connected(master_uri: str, publisher: str, topic: str, subscribers: Iterable[str],
                   timeout: float = CONNECT_TIMEOUT) -> None:
    """Until every node of ``subscribers`` is connected to node ``publisher``'s publisher of ``topic`` (all global
    names): what a node that publishes a message once (a GUI button) needs before the test presses it."""
    wait_subscribers(lambda: connected_subscribers(master_uri, publisher, topic), subscribers, timeout,
                     f"{publisher}'s publisher of {topic}")


class Probe:
    def __init__(self, env: Mapping[str, str], log_path: Path | None = None, timeout: float = 30.0,
                 command: Callable[[list[str]], list[str]] = list, name: str | None = None) -> None:
        """``command``: how to run the probe's command line (e.g. in a robot's machine, conftest.SimBuilding);
        ``name``: the node's name (default: an anonymous probe), e.g. to impersonate a node."""
        self.timeout = timeout
        self.log_path = log_path
        self._log = open(log_path, "ab") if log_path else subprocess.DEVNULL  # noqa: SIM115 - closed in close()
        argv = [sys.executable, str(PROBE), *(["--name", name] if name else [])]
        self.proc = subprocess.Popen(command(argv), env=dict(env), stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self._log, start_new_session=True,
                                     text=True, bufsize=1)
        self._name = ""

    def __enter__(self) -> Probe:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(OSError, ValueError):
                self.proc.stdin.write(json.dumps({"op": "quit"}) + "\n")
                self.proc.stdin.flush()
            try:
                self.proc.wait(timeout=3)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(timeout=5)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        for stream in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(OSError):
                stream.close()
        if hasattr(self._log, "close"):
            self._log.close()

    def call(self, reply_timeout: float | None = None, **cmd: object) -> dict:
        """Send one command; its reply (within ``reply_timeout`` s, default the probe's ``timeout``)."""
        if self.proc.poll() is not None:
            raise ProbeError(f"probe exited with {self.proc.returncode} (log {self.log_path})")
        self.proc.stdin.write(json.dumps(cmd) + "\n")
        self.proc.stdin.flush()
        limit = self.timeout if reply_timeout is None else reply_timeout
        ready, _, _ = select.select([self.proc.stdout], [], [], limit)
        if not ready:
            raise ProbeError(f"probe did not answer {cmd.get('op')} within {limit} s (log {self.log_path})")
        line = self.proc.stdout.readline()
        if not line:
            raise ProbeError(f"probe closed its output (log {self.log_path})")
        reply = json.loads(line)
        if not reply.get("ok"):
            raise ProbeError(f"probe {cmd.get('op')} failed: {reply.get('error')}")
        return reply

    def sub(self, topic: str, type_: str) -> None:
        self.call(op="sub", topic=topic, type=type_)

    @property
    def name(self) -> str:
        """The probe's node name (its caller id), e.g. for another publisher to wait for it."""
        if not self._name:
            self._name = self.call(op="name")["name"]
        return self._name

    def pub(self, topic: str, type_: str, msg: dict, to: Iterable[str] = (), latch: bool = False,
            raw: bytes | None = None, timeout: float = CONNECT_TIMEOUT) -> None:
        """Publish ``msg`` once every node of ``to`` (global names) is connected, and the probe itself when it
        records ``topic``. ``raw``: publish these bytes as the message instead (a malformed one of ``type_``)."""
        self.call(op="pub", topic=topic, type=type_, msg=msg, to=list(to), latch=latch, timeout=timeout,
                  raw=None if raw is None else list(raw), reply_timeout=timeout + self.timeout)

    def publish_until(self, topic: str, type_: str, msg: dict, done: Callable[[], bool], what: str,
                      to: Iterable[str] = (), timeout: float = CONNECT_TIMEOUT, every: float = 0.5,
                      raw: bytes | None = None) -> int:
        """Publish ``msg`` (as :meth:`pub`) every ``every`` s until ``done()``; returns how many times it was
        published. For a message whose subscribers cannot all be named, or whose first copy may be lost."""
        to = list(to)
        deadline = time.monotonic() + timeout
        sent = 0
        while True:
            self.pub(topic, type_, msg, to=to, raw=raw, timeout=max(1.0, deadline - time.monotonic()))
            sent += 1
            next_at = time.monotonic() + every
            while time.monotonic() < next_at:
                if done():
                    return sent
                if time.monotonic() > deadline:
                    raise ProbeError(f"timed out after {timeout:g} s publishing on {topic} until {what}")
                time.sleep(0.02)

    def msgs(self, topic: str, since: int = 0) -> list[dict]:
        return self.call(op="msgs", topic=topic, since=since)["msgs"]

    def wait(self, topic: str, predicate: Callable[[dict], bool], timeout: float, what: str = "",
             since: int = 0) -> dict:
        """The first message on ``topic`` (from index ``since``) satisfying ``predicate``."""
        deadline = time.monotonic() + timeout
        while True:
            for msg in self.msgs(topic, since):
                if predicate(msg):
                    return msg
            if time.monotonic() > deadline:
                raise ProbeError(f"timed out after {timeout} s waiting on {topic} for {what or 'a message'}")
            time.sleep(0.05)
