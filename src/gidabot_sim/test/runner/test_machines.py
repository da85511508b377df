"""Separate machines: names that carry their owner, leftovers of dead owners, ss output, clock offsets."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from gidabot_sim.errors import MachinesError
from gidabot_sim.runner.clock_shim import OFFSET_ENV, SHIM_DIR
from gidabot_sim.runner.machines import Connection, Machines, Owner, clock_env, leftovers, parse_netns, parse_ss


def test_namespace_names_carry_the_owner_and_are_recognised() -> None:
    owner = Owner(4242, 987654)
    name = owner.netns("r3")
    assert name == "gbm-4242-987654-r3"
    assert parse_netns(name) == (owner, "r3")
    assert parse_netns("gbm-4242-x-r3") is None
    assert parse_netns("docker-ns") is None
    assert len(owner.link_prefix + "v179") <= 15          # interface names: at most 15 characters
    with pytest.raises(MachinesError):
        owner.netns("Robot A")


def test_a_namespace_is_a_leftover_once_its_owner_is_gone_or_its_pid_reused() -> None:
    starts = {100: 5000, 200: 7000}                          # pid -> start time of the live processes
    names = ["gbm-100-5000-net", "gbm-100-5000-r0",          # owner alive
             "gbm-200-6999-r0",                              # pid 200 reused by another process
             "gbm-300-1-r1",                                 # owner gone
             "other-ns"]                                     # not ours
    assert leftovers(names, starts.get) == ["gbm-200-6999-r0", "gbm-300-1-r1"]


def test_this_process_owns_names_that_are_not_leftovers() -> None:
    me = Owner.this_process()
    assert me.alive()
    assert leftovers([me.netns("net")]) == []


def test_machines_get_addresses_namespaces_and_offsets_without_creating_anything() -> None:
    m = Machines(["Tartalo", "Kbot"], extra=["intruder"], clock_offsets={"Kbot": -300.0},
                    owner=Owner(11, 22))
    assert m.address("Tartalo") == "10.10.0.11" and m.address("Kbot") == "10.10.0.12"
    assert m.address("intruder") == "10.10.0.200"
    assert m.machine("Kbot").netns == "gbm-11-22-r1" and m.bridge_netns == "gbm-11-22-net"
    assert m.wrap("Kbot", ["rosmaster"])[1:] == ["--net=/run/netns/gbm-11-22-r1", "--", "rosmaster"]
    env = m.env("Kbot", {"PYTHONPATH": "/x"})
    assert env[OFFSET_ENV] == "-300.0" and env["PYTHONPATH"] == f"{SHIM_DIR}{os.pathsep}/x"
    assert m.env("Tartalo", {"A": "1"}) == {"A": "1"}
    with pytest.raises(MachinesError, match="unknown machines"):
        Machines(["A"], clock_offsets={"B": 1.0}, owner=Owner(1, 2))
    with pytest.raises(MachinesError, match="distinct"):
        Machines(["A", "A"], owner=Owner(1, 2))
    with pytest.raises(MachinesError, match="unknown machine"):
        m.address("Ghost")
    with pytest.raises(MachinesError, match="probability"):
        m.drop("Tartalo", "Kbot", 1.5)


def test_established_connections_are_read_from_ss() -> None:
    text = ("0      0      10.10.0.12:11412   10.10.0.11:40022  \n"
            "0      0      127.0.0.1:11311    127.0.0.1:50000 users:((\"rosmaster\",pid=1,fd=3))\n"
            "garbage\n")
    assert parse_ss(text) == [Connection("10.10.0.12", 11412, "10.10.0.11", 40022),
                                 Connection("127.0.0.1", 11311, "127.0.0.1", 50000)]


def test_the_clock_shim_offsets_wall_time_only() -> None:
    code = ("import time; w = time.time(); m = time.monotonic(); time.sleep(0.05); "
            "print(round(w), round(time.time_ns() / 1e9), round(time.monotonic() - m, 1))")
    env = clock_env(-300.0, {k: v for k, v in os.environ.items()})
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60,
                         check=True).stdout.split()
    real = round(__import__("time").time())
    assert abs(int(out[0]) - (real - 300)) <= 2 and abs(int(out[1]) - (real - 300)) <= 2
    assert float(out[2]) < 1.0                                # sleeps and the monotonic clock are untouched
    assert clock_env(0.0, {"A": "1"}) == {"A": "1"}
