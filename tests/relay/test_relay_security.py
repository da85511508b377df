"""Spoofed, unauthenticated, oversized and malformed traffic is rejected and counted (issue 3, security).

The mesh runs with a shared secret. Attacks come from the network (frames sent to a relay
end's link port) and from a robot's own master (publishers impersonating a shared topic).
"""

from __future__ import annotations

import contextlib
import socket
import time

import pytest
from relay_system import GOAL, GOALS, RelayMesh, settle, spoof_publish

from gidabot_navigation.interface import Node, Topic, global_name
from gidabot_navigation.relay.protocol import HEADER, FrameType, Hello, Message, encode_frame, encode_message, hello_key

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

    mesh.wait_end(b, a, counted, 10, "attacks counted")
    d = mesh.end_diag(b, a)
    assert d["connected"] == "True" and d["delivered_events"] == "0"
    # the real link was never disturbed
    mesh.publish(a, GOALS, GOAL, {"uid": "real"})
    mesh.wait_uid(b, GOALS, "real")
    assert mesh.uids(b) == ["real"]


def test_local_impostors_wrong_types_malformed_and_oversized_messages_do_not_cross(mesh) -> None:
    src = "Tartalo"
    env = mesh.sim.env(src)
    n_ends = len(mesh.robots) - 1
    spoof_publish(env, "impostor", GOALS, "std_msgs/String", "wrong-type", subs=n_ends)
    # the right type: the probe subscribes it too (the impostor's std_msgs/String it refuses)
    spoof_publish(env, "garbler", GOALS, GOAL, "garbage", subs=n_ends + 1)
    spoof_publish(env, "gidabot_relay_fake", GOALS, GOAL, "fake-relay", subs=n_ends + 1)
    big = ["0, 014, " + "x" * (1 << 20)]                          # a 1 MiB tour: over the 1 MiB limit
    mesh.publish(src, Topic.TOURS, "gidabot_msgs/Tour", {"uid": "huge-tour", "tour_goals_info": big})
    mesh.publish(src, GOALS, GOAL, {"uid": "legit"})
    others = [r for r in mesh.robots if r != src]
    for r in others:
        mesh.wait_uid(r, GOALS, "legit")

    def counted(d: dict[str, str]) -> bool:
        return (int(d["rejected_type"]) >= 1 and int(d["rejected_malformed"]) >= 1
                and int(d["rejected_oversize"]) >= 1 and int(d["ignored_relay"]) >= 1
                and int(d["forwarded_events"]) >= 1)

    arrived = time.time()           # diagnostics stamped later count "legit" as forwarded (1 Hz)
    for o in others:
        mesh.wait_end(src, o, counted, 10, "impostors counted", after=arrived)
        assert mesh.end_diag(src, o)["forwarded_events"] == "1"   # only "legit"
    settle(1.0)
    for r in others:
        assert mesh.uids(r) == ["legit"], r
        assert mesh.uids(r, Topic.TOURS) == [], r
    assert "fake-relay" in mesh.uids(src)                         # it was published locally, just not relayed
