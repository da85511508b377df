"""Robots on separate machines: each robot a network namespace of its own, a firewall that admits
from the other machines only its relay ports, and the relays between them.

The only connections between two machines are relay links; masters and nodes cannot be reached from
another machine; a frame forged from a machine that is not a robot is rejected and counted; a CANCEL and
a goal published during a 40 s partition reach the partitioned robot exactly once, within 2 s of the
network healing; acknowledgements lost on a one-way link are made good by the journal, not repeated.
"""

from __future__ import annotations

import socket
import time

import pytest
from machines_system import assert_only_relay_links, assert_only_relay_ports_open
from relay_system import GOAL, GOALS, RelayMesh, detection_delay, settle

from gidabot_navigation.interface import Topic
from gidabot_navigation.relay.protocol import FrameType, Hello, Message, encode_frame, encode_message, hello_key
from gidabot_sim.runner.procs import wait_until

pytestmark = pytest.mark.system

CANCELS, CANCEL = Topic.CANCELS, "gidabot_msgs/Cancel"
DETECT_S = 3.0
RESUME_S = 2.0
PARTITION_S = 40.0


@pytest.fixture
def mesh(faculty_machines, tmp_path):
    with RelayMesh(faculty_machines, tmp_path) as m:
        m.start(subscribe=[(GOALS, GOAL), (CANCELS, CANCEL)])
        yield m


def test_only_relay_links_cross_between_machines_and_forged_frames_are_counted(mesh) -> None:
    sim, net = mesh.sim, mesh.sim.net
    robots = mesh.robots
    mesh.publish("Tartalo", GOALS, GOAL, {"uid": "through-the-firewall"})
    for r in robots[1:]:
        mesh.wait_uid(r, GOALS, "through-the-firewall")
    links = {(a.name, b.name): sim.building.relay_link_port(a.name, b.name) for a, b in sim.building.relay_pairs()}

    # masters and nodes answer on their own machine only; the relay ports are open to the network;
    # every connection between two machines is a relay link, and every relay link is there
    assert_only_relay_ports_open(net, sim.building, outsiders=["intruder"])
    assert_only_relay_links(net, sim.building)

    # a frame forged on a machine that is not a robot: refused at the handshake, counted by the end it reached
    t, k = mesh.robot("Tartalo"), mesh.robot("Kbot")
    port = links[("Tartalo", "Kbot")]
    before = mesh.end_diag("Kbot", "Tartalo")
    forged = [encode_frame(FrameType.HELLO, Hello("Tartalo_Kbot", "a", b"f" * 16, b"", 7, 0, 0).encode(),
                           hello_key(b"a-guessed-secret-not-the-real-1")),
              encode_frame(FrameType.EVENT, encode_message(Message(GOALS, "/goal_manager", "0" * 32, b"x", 1), True))]

    def send(data: bytes) -> bool:
        with socket.create_connection((k.ip, port), timeout=2.0) as s:
            s.sendall(data)
            s.settimeout(5.0)
            try:
                return s.recv(4096) == b""                      # closed by the relay end
            except OSError:
                return True

    for data in forged:
        assert net.call("intruder", send, data), "the relay end kept a forged connection open"
    mesh.wait_end("Kbot", "Tartalo", lambda d: int(d["rejected_auth"]) == int(before["rejected_auth"]) + 1
                  and int(d["rejected_malformed"]) == int(before["rejected_malformed"]) + 1, 10,
                  "the forged HELLO (wrong MAC) and EVENT (no handshake) counted")
    d = mesh.end_diag("Kbot", "Tartalo")
    assert d["connected"] == "True" and "forged" not in mesh.uids("Kbot")
    assert t.ip != net.address("intruder")


def test_cancel_and_goal_of_a_40s_partition_arrive_once_within_2s_of_healing(mesh) -> None:
    net = mesh.sim.net
    src, cut = "Tartalo", "Kbot"
    others = [r for r in mesh.robots if r not in (src, cut)]
    before = mesh.end_diag(src, cut)
    t0 = time.time()
    net.partition(cut)
    for r in [src, *others]:                   # every other robot sees the link to the cut robot die, and back
        mesh.wait_end(r, cut, lambda d: d["connected"] == "False", 10, "link lost", after=t0)
        delay = detection_delay(mesh.end_diag(r, cut), "link_down_s", t0)
        assert delay <= DETECT_S, f"{r} saw the partition after {delay:.2f} s"
        mesh.wait_end(cut, r, lambda d: d["connected"] == "False", 10, "link lost (partitioned side)", after=t0)
    mesh.publish(src, CANCELS, CANCEL, {"uid": "cancel-during-partition", "goal_uid": "Tartalo/v/g.1",
                                        "origin_robot": src, "reason": "visitor"})
    mesh.publish(src, GOALS, GOAL, {"uid": "goal-during-partition"})
    for r in others:
        mesh.wait_uid(r, CANCELS, "cancel-during-partition", timeout=5)
        mesh.wait_uid(r, GOALS, "goal-during-partition", timeout=5)
    wait_until(lambda: time.time() - t0 >= PARTITION_S, PARTITION_S + 5, "the end of the partition", interval=0.5)
    assert "cancel-during-partition" not in mesh.uids(cut, CANCELS)
    assert "goal-during-partition" not in mesh.uids(cut)
    assert mesh.end_diag(src, cut)["queue_depth"] == "2"      # journaled, waiting for an acknowledgement

    net.clear_faults(cut)
    healed = time.monotonic()
    mesh.wait_uid(cut, CANCELS, "cancel-during-partition", timeout=10)
    mesh.wait_uid(cut, GOALS, "goal-during-partition", timeout=10)
    took = time.monotonic() - healed
    print(f"{PARTITION_S:g} s partition: delivered {took:.2f} s after the network healed")
    assert took <= RESUME_S, f"delivered {took:.2f} s after the partition healed"
    settle(1.0)
    assert mesh.uids(cut, CANCELS).count("cancel-during-partition") == 1
    mesh.assert_no_duplicates()
    mesh.assert_no_duplicates(CANCELS)
    after = mesh.end_diag(src, cut)
    moved = {k: int(after[k]) - int(before[k]) for k in ("link_losses", "resent", "connections")}
    print(f"relay {src}-{cut} ({src}'s end): {moved}")
    assert moved["link_losses"] >= 1 and moved["resent"] >= 2 and moved["connections"] >= 1
    assert after["queue_depth"] == "0"


def test_acknowledgements_lost_one_way_are_made_good_by_the_journal(mesh) -> None:
    net = mesh.sim.net
    src, dst = "Tartalo", "Kbot"
    before = mesh.end_diag(src, dst)
    t0 = time.time()
    net.drop(dst, src)                        # Kbot -> Tartalo dropped, Tartalo -> Kbot delivered
    mesh.publish(src, GOALS, GOAL, {"uid": "one-way"})
    mesh.wait_uid(dst, GOALS, "one-way", timeout=5)           # it crossed; its acknowledgement cannot
    mesh.wait_end(src, dst, lambda d: d["connected"] == "False", 10, "link lost (no answer)", after=t0)
    assert mesh.end_diag(src, dst)["queue_depth"] == "1"     # still unacknowledged in Tartalo's journal
    net.clear_faults(dst)
    mesh.wait_end(src, dst, lambda d: d["connected"] == "True" and d["queue_depth"] == "0", 10,
                  "link back, the event acknowledged", after=time.time())
    settle(1.0)
    assert mesh.uids(dst).count("one-way") == 1
    after = mesh.end_diag(src, dst)
    assert int(after["acked_on_reconnect"]) - int(before["acked_on_reconnect"]) == 1
    assert int(after["link_losses"]) > int(before["link_losses"])
