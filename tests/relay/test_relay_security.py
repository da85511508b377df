"""Spoofed, unauthenticated, oversized and malformed traffic is rejected and counted (security).

The mesh runs with a shared secret. Attacks come from the network (frames sent to a relay
end's link port) and from a robot's own master (publishers impersonating a shared topic).
"""

from __future__ import annotations

import contextlib
import socket
import time

import pytest
from probe import Probe
from relay_system import GOAL, GOALS, RelayMesh, settle

from gidabot_navigation.interface import Node, Topic, global_name
from gidabot_navigation.relay.protocol import HEADER, FrameType, Hello, Message, encode_frame, encode_message, hello_key
from gidabot_sim.errors import ProcessError
from gidabot_sim.runner.procs import wait_until

pytestmark = pytest.mark.system


@pytest.fixture
def mesh(faculty_masters, tmp_path):
    with RelayMesh(faculty_masters, tmp_path) as m:
        m.start(subscribe=[(GOALS, GOAL), (Topic.TOURS, "gidabot_msgs/Tour")])
        yield m


def _send(addr: tuple[str, int], data: bytes, src_ip: str) -> bool:
    """Connect from ``src_ip``, send ``data``; True if the relay end then closed the connection."""
    with socket.create_connection(addr, timeout=5, source_address=(src_ip, 0)) as s:
        with contextlib.suppress(OSError):
            s.sendall(data)
        s.settimeout(5)
        try:
            while s.recv(4096):
                pass                      # a HELLO answer may come first (replayed HELLO): read until closed
        except TimeoutError:
            return False
        except OSError:
            return True
        return True


def test_spoofed_unauthenticated_and_oversized_frames_are_rejected_and_counted(mesh) -> None:
    a, b = "Tartalo", "Kbot"
    addr = mesh.link_address(f"{a}_{b}.b")
    attacker_ip = mesh.robot("Galtxagorri").ip                  # another machine of the building
    pair = f"{a}_{b}"
    hello = Hello(pair, "a", b"n" * 16, b"", 1, 0, 0).encode()
    event = encode_message(Message(GOALS, global_name(Node.GOAL_MANAGER), "0" * 32, b"evil", 1), True)
    attacks = {
        "auth": [encode_frame(FrameType.HELLO, hello),                                     # no HMAC
                 encode_frame(FrameType.HELLO, hello, hello_key(b"guessed-wrong-secret-123")),  # bad HMAC
                 encode_frame(FrameType.EVENT, event)],                                    # data, no handshake
        "malformed": [b"GET / HTTP/1.0\r\n\r\n" + b"x" * 20],
        "oversize": [HEADER.pack(b"GR", 1, int(FrameType.EVENT), 0, 100 << 20)],
    }
    for frames in attacks.values():
        for data in frames:
            assert _send(addr, data, attacker_ip), f"relay end kept a bad connection open: {data[:20]!r}"

    def counted(d: dict[str, str]) -> bool:
        return (int(d["rejected_auth"]) >= 2 and int(d["rejected_malformed"]) >= 2
                and int(d["rejected_oversize"]) >= 1)

    mesh.wait_end(b, a, counted, 30, "attacks counted")
    d = mesh.end_diag(b, a)
    assert d["connected"] == "True" and d["delivered_events"] == "0"
    # the real link was never disturbed
    mesh.publish(a, GOALS, GOAL, {"uid": "real"})
    mesh.wait_uid(b, GOALS, "real")
    assert mesh.uids(b) == ["real"]


def test_local_impostors_wrong_types_malformed_and_oversized_messages_do_not_cross(mesh) -> None:
    src = "Tartalo"
    others = [r for r in mesh.robots if r != src]
    ends = mesh.ends(src)

    def counters(key: str) -> bool:
        return all(int((mesh.end_diag(src, o) or {}).get(key, 0)) >= 1 for o in others)

    # publishers on src's own master under the names of impostors, each repeating its message until every
    # relay end of src has counted it: a plain std_msgs/String on the shared topic, bytes that are no Goal
    # under Goal's type and md5
    for node, type_, msg, raw, key in (("impostor", "std_msgs/String", {"data": "wrong-type"}, None, "rejected_type"),
                                       ("garbler", GOAL, {}, b"\xff" * 7, "rejected_malformed")):
        with Probe(mesh.sim.env(src), mesh.sim.log_dir / f"{node}.log", name=node) as p:
            p.publish_until(GOALS, type_, msg, lambda key=key: counters(key), f"{key} counted by {ends}", to=ends,
                            raw=raw)
    # and a real Goal from a node named like a relay end. The ends close their connections to relay publishers
    # within a tick, so the Goal is latched (written as each end connects) and the node started again (the
    # ends connect again) until every end has counted it
    for attempt in range(1, 6):
        with Probe(mesh.sim.env(src), mesh.sim.log_dir / f"relay_fake_{attempt}.log", name="gidabot_relay_fake") as p:
            p.pub(GOALS, GOAL, {"uid": "fake-relay"}, to=[mesh.probes[src].name], latch=True)
            with contextlib.suppress(ProcessError):
                wait_until(lambda: counters("ignored_relay"), 10, "the fake relay end's Goal ignored by every end")
        if counters("ignored_relay"):
            break
    assert counters("ignored_relay"), f"the fake relay end's Goal not counted by every end of {src}"
    wait_until(lambda: "fake-relay" in mesh.uids(src), 30, "fake-relay at src")   # published locally, not relayed
    big = ["0, 014, " + "x" * (1 << 20)]                          # a 1 MiB tour: over the 1 MiB limit
    mesh.publish(src, Topic.TOURS, "gidabot_msgs/Tour", {"uid": "huge-tour", "tour_goals_info": big})
    mesh.publish(src, GOALS, GOAL, {"uid": "legit"})
    for r in others:
        mesh.wait_uid(r, GOALS, "legit", timeout=30)

    def counted(d: dict[str, str]) -> bool:
        return (int(d["rejected_type"]) >= 1 and int(d["rejected_malformed"]) >= 1
                and int(d["rejected_oversize"]) >= 1 and int(d["ignored_relay"]) >= 1
                and int(d["forwarded_events"]) >= 1)

    arrived = time.time()           # diagnostics stamped later count "legit" as forwarded (1 Hz)
    for o in others:
        mesh.wait_end(src, o, counted, 30, "impostors counted", after=arrived)
        assert mesh.end_diag(src, o)["forwarded_events"] == "1"   # only "legit"
    settle(1.0)
    for r in others:
        assert mesh.uids(r) == ["legit"], r
        assert mesh.uids(r, Topic.TOURS) == [], r
