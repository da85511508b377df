"""Relays on the faculty's 4 masters: exactly once, all topics both ways, no loops, n(n-1)/2 relays.

Each test starts launch/relays.launch for every robot (with a secret file), one probe per robot.
"""

from __future__ import annotations

import os
import signal
import time
import xmlrpc.client

import pytest
from relay_system import DIAG, GOAL, GOALS, RelayMesh, settle, wait_pid_gone

from gidabot_navigation.interface import EVENT, SHARED_TOPICS, STATE, Node, Topic, global_name, relay_end_name
from gidabot_sim.runner.procs import wait_until

pytestmark = pytest.mark.system

EVENTS = [(t.name, t.type) for t in SHARED_TOPICS if t.kind == EVENT]
STATES = [(t.name, t.type) for t in SHARED_TOPICS if t.kind == STATE]


@pytest.fixture
def mesh(faculty_masters, tmp_path):
    with RelayMesh(faculty_masters, tmp_path) as m:
        yield m


def test_goal_from_robot_0_reaches_robots_1_to_3_exactly_once(mesh) -> None:
    mesh.start(subscribe=[(GOALS, GOAL)])
    first, others = mesh.robots[0], mesh.robots[1:]
    # n(n-1)/2 relays, derived from the building: every master has one end of each of its n-1 relays
    names = {relay_end_name(a.name, b.name) for a, b in mesh.sim.building.relay_pairs()}
    assert len(names) == 6
    for r in mesh.robots:
        assert len(mesh.relay_ends(r)) == 3 and set(mesh.relay_ends(r)) <= names
    assert set().union(*(mesh.relay_ends(r) for r in mesh.robots)) == names

    for k in range(5):
        mesh.publish(first, GOALS, GOAL, {"uid": f"{first}/v/{k}", "origin_robot": first})
    for r in others:
        for k in range(5):
            mesh.wait_uid(r, GOALS, f"{first}/v/{k}")
    settle(1.0)
    for r in others:
        assert mesh.uids(r) == [f"{first}/v/{k}" for k in range(5)], f"{r}: not exactly once, in order"
    assert mesh.uids(first) == [f"{first}/v/{k}" for k in range(5)]     # its own, locally, once


def test_every_robot_reaches_every_other_exactly_once_with_all_topics_both_ways(mesh) -> None:
    mesh.start(subscribe=EVENTS + STATES)
    for r in mesh.robots:
        for topic, type_ in EVENTS:
            mesh.publish(r, topic, type_, {"uid": f"{r}{topic}"})
        for topic, type_ in STATES:
            mesh.publish(r, topic, type_, {"robot": r})
    for r in mesh.robots:
        for o in mesh.robots:
            if o != r:
                for topic, _ in EVENTS:
                    mesh.wait_uid(r, topic, f"{o}{topic}")
                for topic, _ in STATES:
                    wait_until(lambda r=r, o=o, topic=topic: any(m["robot"] == o for m in mesh.probes[r].msgs(topic)),
                               10, f"{topic} of {o} at {r}")
    settle(1.5)
    for r in mesh.robots:
        for topic, _ in EVENTS:
            assert sorted(mesh.uids(r, topic)) == sorted(f"{o}{topic}" for o in mesh.robots), (r, topic)
        for topic, _ in STATES:
            assert sorted(m["robot"] for m in mesh.probes[r].msgs(topic)) == sorted(mesh.robots), (r, topic)
    # nothing circulates: every end forwarded exactly its robot's own messages, once
    for r in mesh.robots:
        for o in mesh.robots:
            if o != r:
                d = mesh.end_diag(r, o)
                events, states = str(len(EVENTS)), str(len(STATES))     # one of each shared topic
                assert d["forwarded_events"] == events and d["forwarded_states"] == states, (r, o, d)
                assert d["delivered_events"] == events and d["duplicates_suppressed"] == "0", (r, o, d)
                assert int(d["pruned_relay_connections"]) > 0   # it does not even listen to the other relays
    before = {(r, o): mesh.end_diag(r, o)["forwarded"] for r in mesh.robots for o in mesh.robots if o != r}
    settle(2.0)
    after = {(r, o): mesh.end_diag(r, o)["forwarded"] for r in mesh.robots for o in mesh.robots if o != r}
    assert before == after


def test_state_topics_are_latched_for_late_subscribers_and_resent_on_reconnect(mesh, faculty_masters) -> None:
    mesh.start()
    status = (Topic.STATUS, "gidabot_msgs/RobotStatus")
    mesh.publish("Tartalo", *status, {"robot": "Tartalo", "state": "idle"})
    mesh.wait_end("Kbot", "Tartalo", lambda d: d["delivered_states"] == "1", 10, "status delivered")
    mesh.sub("Kbot", *status)                                  # a late subscriber gets it at once
    mesh.probes["Kbot"].wait(status[0], lambda m: m["robot"] == "Tartalo", 5, "latched status")
    # a relay end restarted from scratch still gets the latest state again on reconnect
    pid = mesh.end_pid("Tartalo_Kbot.b")
    t_kill = time.time()
    os.kill(pid, signal.SIGKILL)
    wait_until(lambda: mesh.end_pid("Tartalo_Kbot.b") != pid, 15, "end restarted")
    mesh.wait_end("Kbot", "Tartalo", lambda d: d["connected"] == "True" and d["delivered_states"] == "1", 15,
                  "state re-sent to the new end", after=t_kill)


def test_relays_launch_supervisor_death_takes_its_ends_and_roslaunch_brings_them_back(mesh) -> None:
    mesh.start(subscribe=[(GOALS, GOAL)])
    owner = mesh.robots[0]
    pids = [mesh.end_pid(f"{owner}_{o}.a") for o in mesh.robots[1:]]      # its ends: one per other robot
    master = xmlrpc.client.ServerProxy(mesh.robot(owner).master_uri)
    api = master.lookupNode("/test", global_name(Node.RELAY_SUPERVISOR))[2]
    sup_pid = xmlrpc.client.ServerProxy(api).getPid("/test")[2]
    t = time.monotonic()
    os.kill(sup_pid, signal.SIGKILL)
    for pid in pids:                                            # parent-death signal: no orphaned ends
        wait_pid_gone(pid, 10)
    assert time.monotonic() - t < 10
    mesh.wait_connected(60)                                     # respawned by roslaunch, links back up
    mesh.publish(owner, GOALS, GOAL, {"uid": "after-respawn"})
    for r in mesh.robots[1:]:
        mesh.wait_uid(r, GOALS, "after-respawn")
    settle(0.5)
    mesh.assert_no_duplicates()
    assert DIAG in mesh.subscribed[owner]
