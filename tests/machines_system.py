"""Checks of the system tests with robots on separate machines: what one machine can reach on another, and
which connections cross between them.

Every function that opens a socket runs where it is called: pass it to ``Machines.call`` to run it on a
machine (a thread inside that machine's network namespace).
"""

from __future__ import annotations

import errno
import selectors
import socket
import time
import xmlrpc.client
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from urllib.parse import urlparse

from gidabot_navigation.building.model import Building
from gidabot_sim.runner.machines import Machines

Address = tuple[str, int]


def reachable(targets: Iterable[Address], timeout: float = 2.0) -> set[Address]:
    """Which of ``targets`` accept a TCP connection from this thread's machine; every connection is tried at
    once (a firewall that drops packets costs ``timeout`` once, not once per target), and a connection
    made by the deadline counts even if this thread only looks at it after (a loaded machine)."""
    pending: dict[socket.socket, Address] = {}
    ok: set[Address] = set()
    sel = selectors.DefaultSelector()
    try:
        for target in set(targets):
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.setblocking(False)
            code = s.connect_ex(target)
            if code in (0, errno.EINPROGRESS):
                pending[s] = target
                sel.register(s, selectors.EVENT_WRITE)
            else:
                s.close()
        deadline = time.monotonic() + timeout
        while len(ok) < len(pending):
            left = deadline - time.monotonic()
            for key, _ in sel.select(max(left, 0.0)):
                s = key.fileobj
                assert isinstance(s, socket.socket)
                sel.unregister(s)
                if s.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR) == 0:
                    ok.add(pending[s])
                else:
                    del pending[s]
                    s.close()
            if left <= 0:
                break
    finally:
        for s in pending:
            s.close()
        sel.close()
    return ok


def node_apis(master_uri: str) -> dict[str, Address]:
    """Every node registered with the master at ``master_uri``: name -> address of its XML-RPC API."""
    master = xmlrpc.client.ServerProxy(master_uri)
    _, _, state = master.getSystemState("/test")
    names = {n for group in state for _, nodes in group for n in nodes}
    out: dict[str, Address] = {}
    for name in sorted(names):
        code, _, api = master.lookupNode("/test", name)
        if code == 1:
            parsed = urlparse(api)
            out[name] = (parsed.hostname or "", int(parsed.port or 0))
    return out


def assert_only_relay_ports_open(net: Machines, building: Building, outsiders: Iterable[str] = ()) -> int:
    """Each robot's master and every node registered with it answer on the robot's own machine, and from
    every other machine (the other robots and ``outsiders``) only the robot's relay ports can be reached.
    Returns the number of (master or node, other machine) pairs found closed.

    Every machine tries all its targets at once, and the machines try theirs side by side: the firewalls'
    dropped packets cost one connection timeout in all."""
    robots = [r.name for r in building.robots]
    machines = [*robots, *outsiders]
    own: dict[str, dict[str, Address]] = {}
    relay: dict[str, set[Address]] = {}
    for r in robots:
        me = building.robot(r)
        own[r] = {"master": (me.ip, me.port), **net.call(r, node_apis, me.master_uri)}
        assert len(own[r]) > 1, f"no node registered with {r}'s master"
        relay[r] = {(me.ip, port) for port in building.relay_ports(r)}

    def targets(m: str) -> list[Address]:
        """From machine ``m``: its own master and nodes, every other robot's and their relay ports."""
        out = list(own[m].values()) if m in own else []
        for r in robots:
            if r != m:
                out += [*own[r].values(), *relay[r]]
        return out

    with ThreadPoolExecutor(len(machines)) as pool:
        got = dict(zip(machines, pool.map(lambda m: net.call(m, reachable, targets(m)), machines), strict=True))
    closed = 0
    for r in robots:
        mine = set(own[r].values())
        home = got[r] & mine
        assert home == mine, f"on {r}'s own machine, closed: {sorted(mine - home)}"
        for other in machines:
            if other == r:
                continue
            seen = got[other] & (mine | relay[r])
            opened = sorted(n for n, a in own[r].items() if a in seen)
            assert not opened, f"{r}'s {opened} reachable from {other}'s machine"
            assert seen == relay[r], f"relay ports of {r} closed to {other}: {sorted(relay[r] - seen)}"
            closed += len(own[r])
    return closed


def assert_only_relay_links(net: Machines, building: Building) -> int:
    """The established TCP connections between two robots' machines (``ss`` on each) are their relay links
    only, on the building's relay ports, and every relay link is there. Returns the connections seen."""
    robots = [r.name for r in building.robots]
    links = {(a.name, b.name): building.relay_link_port(a.name, b.name) for a, b in building.relay_pairs()}
    address = {net.address(r): r for r in robots}
    seen: set[tuple[str, str]] = set()
    crossing = 0
    for r in robots:
        for c in net.connections(r):
            if c.peer not in address or c.peer == net.address(r):
                continue                                        # loopback and this machine's own address
            other = address[c.peer]
            a, b = (r, other) if robots.index(r) < robots.index(other) else (other, r)
            port = links[(a, b)]
            listening = c.local_port if r == b else c.peer_port
            assert listening == port, f"{r} <-> {other}: {c} is not their relay link (port {port})"
            seen.add((a, b))
            crossing += 1
    assert seen == set(links), f"relay links missing: {sorted(set(links) - seen)}"
    return crossing
