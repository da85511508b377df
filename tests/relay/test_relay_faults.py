"""Relays under the faults of the paper's network: dead/restarted masters, killed relay ends, link cuts.

Detection of a lost link or dead master within 3 s, delivery within 2 s after it returns,
exactly once, nothing acknowledged lost. Times are wall time on the test machine.
"""

from __future__ import annotations

import os
import signal
import time

import pytest
from probe import Probe
from relay_system import GOAL, GOALS, RelayMesh, detection_delay, settle

from gidabot_sim.runner.procs import master_pid, wait_until

pytestmark = pytest.mark.system

DETECT_S = 3.0
RESUME_S = 2.0


@pytest.fixture
def mesh(faculty_masters, tmp_path):
    with RelayMesh(faculty_masters, tmp_path) as m:
        m.start(subscribe=[(GOALS, GOAL)])
        yield m


def _others(mesh, *skip: str) -> list[str]:
    return [r for r in mesh.robots if r not in skip]


def test_goal_published_during_a_master_outage_arrives_once_within_2s_of_the_restart(mesh) -> None:
    src, dead = "Tartalo", "Kbot"
    t_kill = time.time()
    mesh.sim.procs.get(f"master_{dead}").popen.kill()          # SIGKILL: the master just vanishes
    mesh.wait_end(src, dead, lambda d: d["peer_master_up"] == "False", 10, "dead master seen", after=t_kill)
    delay = detection_delay(mesh.end_diag(src, dead), "peer_master_down_s", t_kill)
    assert delay <= DETECT_S, f"dead master of {dead} seen by {src}'s relay end after {delay:.2f} s"
    print(f"dead master seen after {delay:.2f} s")
    mesh.publish(src, GOALS, GOAL, {"uid": "during-outage"})
    for r in _others(mesh, src, dead):
        mesh.wait_uid(r, GOALS, "during-outage")
    assert "during-outage" not in mesh.uids(dead)             # held, not published into the void

    uri = mesh.robot(dead).master_uri
    mesh.sim.procs.start(f"master_{dead}", mesh.sim.procs.get(f"master_{dead}").argv,
                         mesh.sim.procs.get(f"master_{dead}").env)
    wait_until(lambda: master_pid(uri) is not None, 15, "master back", interval=0.02)
    t_up = time.monotonic()
    mesh.wait_uid(dead, GOALS, "during-outage", timeout=10)
    took = time.monotonic() - t_up
    assert took <= RESUME_S, f"delivered {took:.2f} s after the master came back"
    print(f"goal of the outage delivered {took:.2f} s after the master came back")

    # re-registration: a node that starts after the restart is found by the relays, both ways
    with Probe(mesh.sim.env(dead), mesh.sim.log_dir / "late_probe.log") as late:
        # a plain publisher: published once every relay end of the robot and the mesh's probe are connected
        late.pub(GOALS, GOAL, {"uid": "from-new-node"}, to=[*mesh.ends(dead), mesh.probes[dead].name])
        for r in _others(mesh, dead):
            mesh.wait_uid(r, GOALS, "from-new-node")
    mesh.publish(src, GOALS, GOAL, {"uid": "after-restart"})
    mesh.wait_uid(dead, GOALS, "after-restart")
    settle(1.0)
    mesh.assert_no_duplicates()
    assert mesh.uids(dead).count("during-outage") == 1


def test_killed_relay_ends_lose_no_event_they_had_acknowledged(mesh) -> None:
    a, b = "Tartalo", "Kbot"
    # 1) sender side: end b frozen (link down), events queue in end a's journal, end a is SIGKILLed
    pid_b = mesh.end_pid(f"{a}_{b}.b")
    t0 = time.time()
    os.kill(pid_b, signal.SIGSTOP)
    try:
        mesh.wait_end(a, b, lambda d: d["connected"] == "False", 10, "link lost", after=t0)
        for k in range(3):
            mesh.publish(a, GOALS, GOAL, {"uid": f"queued-{k}"})
        mesh.wait_end(a, b, lambda d: d["queue_depth"] == "3", 10, "3 events queued")
        pid_a = mesh.end_pid(f"{a}_{b}.a")
        os.kill(pid_a, signal.SIGKILL)
        wait_until(lambda: mesh.end_pid(f"{a}_{b}.a") != pid_a, 15, "end a restarted by the supervisor")
    finally:
        os.kill(pid_b, signal.SIGCONT)
    for k in range(3):
        mesh.wait_uid(b, GOALS, f"queued-{k}", timeout=15)

    # 2) receiver side: end b acknowledged events it holds for its dead master, then is SIGKILLed
    t0 = time.time()
    mesh.sim.procs.stop(f"master_{b}")
    mesh.wait_end(a, b, lambda d: d["peer_master_up"] == "False", 10, "dead master seen", after=t0)
    for k in range(3):
        mesh.publish(a, GOALS, GOAL, {"uid": f"held-{k}"})
    t0 = time.time()
    mesh.wait_end(a, b, lambda d: d["queue_depth"] == "0" and d["forwarded_events"] == "3", 10,
                  "held events acknowledged by end b", after=t0)
    pid_b = mesh.end_pid(f"{a}_{b}.b")
    os.kill(pid_b, signal.SIGKILL)
    mesh.sim.restart_master(b)
    for k in range(3):
        mesh.wait_uid(b, GOALS, f"held-{k}", timeout=20)
    settle(1.0)
    mesh.assert_no_duplicates()
    got = mesh.uids(b)
    assert got == [f"queued-{k}" for k in range(3)] + [f"held-{k}" for k in range(3)], got


def test_link_cuts_are_detected_within_3s_and_delivery_resumes_within_2s(mesh) -> None:
    from gidabot_sim.chaos.faults import LinkCuts

    a, b = "Tartalo", "Kbot"
    # 1) a relay end stops (frozen): the link is declared lost, the other robots are unaffected
    pid_b = mesh.end_pid(f"{a}_{b}.b")
    t0 = time.time()
    os.kill(pid_b, signal.SIGSTOP)
    try:
        mesh.wait_end(a, b, lambda d: d["connected"] == "False", 10, "link lost", after=t0)
        delay = detection_delay(mesh.end_diag(a, b), "link_down_s", t0)
        assert delay <= DETECT_S, f"stopped end seen after {delay:.2f} s"
        print(f"stopped relay end seen after {delay:.2f} s")
        mesh.publish(a, GOALS, GOAL, {"uid": "while-stopped"})
        for r in _others(mesh, a, b):
            mesh.wait_uid(r, GOALS, "while-stopped")
    finally:
        os.kill(pid_b, signal.SIGCONT)
        t_back = time.monotonic()
    mesh.wait_uid(b, GOALS, "while-stopped", timeout=10)
    took = time.monotonic() - t_back
    assert took <= RESUME_S, f"delivered {took:.2f} s after the end continued"
    print(f"delivered {took:.2f} s after the stopped end continued")
    mesh.wait_connected(10)

    # 2) the network between the two robots' addresses is cut (iptables), then restored
    ip_a, ip_b = mesh.robot(a).ip, mesh.robot(b).ip
    with LinkCuts() as cuts:
        t0 = time.time()
        cuts.cut(ip_a, ip_b)
        for x, y in ((a, b), (b, a)):
            mesh.wait_end(x, y, lambda d: d["connected"] == "False", 10, "link lost (cut)", after=t0)
            delay = detection_delay(mesh.end_diag(x, y), "link_down_s", t0)
            assert delay <= DETECT_S, f"cut seen by {x}'s end after {delay:.2f} s"
            print(f"iptables cut seen by {x}'s end after {delay:.2f} s")
        mesh.publish(a, GOALS, GOAL, {"uid": "during-cut"})
        for r in _others(mesh, a, b):
            mesh.wait_uid(r, GOALS, "during-cut")
        settle(0.5)
        assert "during-cut" not in mesh.uids(b)
        cuts.restore(ip_a, ip_b)
        t_back = time.monotonic()
        mesh.wait_uid(b, GOALS, "during-cut", timeout=10)
        took = time.monotonic() - t_back
    assert took <= RESUME_S, f"delivered {took:.2f} s after the link came back"
    print(f"delivered {took:.2f} s after the cut was restored")
    settle(1.0)
    mesh.assert_no_duplicates()
