"""Separate machines leave nothing behind: not at the end of a run, not after a run that was killed.

A run that dies (SIGKILL) leaves its namespaces, their links and the processes inside; the next run
finds them by their owner (pid and start time in the name, owner gone) and removes them before it
makes its own. Nothing is ever added to the host's own network namespace.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from gidabot_sim.runner import machines
from gidabot_sim.runner.procs import wait_until

pytestmark = pytest.mark.system

CRASHING_RUN = r'''
import subprocess, sys, time
from gidabot_sim.runner.machines import Machines
net = Machines(["A", "B"]).create()
sleeper = subprocess.Popen(net.wrap("A", ["sleep", "600"]), start_new_session=True)
print(net.owner.prefix, sleeper.pid, flush=True)
time.sleep(600)
'''


def _host_links() -> str:
    return subprocess.run(["ip", "-o", "link"], capture_output=True, text=True, check=True).stdout


def _alive(pid: int) -> bool:
    return machines.process_start(pid) is not None


def test_a_killed_runs_namespaces_are_removed_by_the_next_run_and_a_run_removes_its_own() -> None:
    run = subprocess.Popen([sys.executable, "-c", CRASHING_RUN], stdout=subprocess.PIPE, text=True,
                           start_new_session=True)
    try:
        prefix, sleeper = run.stdout.readline().split()
        left = [n for n in machines.list_netns() if n.startswith(prefix + "-")]
        assert len(left) == 3, left                              # the bridge's namespace and A's and B's
        assert "gbm" not in _host_links()                         # the bridge and veths are not on the host
    finally:
        os.killpg(run.pid, signal.SIGKILL)                        # the run crashes: nothing is cleaned up
        run.wait(timeout=10)
    assert set(left) <= set(machines.list_netns()) and _alive(int(sleeper))
    assert set(left) <= set(machines.leftovers(machines.list_netns()))

    with machines.Machines(["A"]) as net:                               # the next run
        assert set(left) <= set(net.removed_leftovers)
        assert not set(left) & set(machines.list_netns())
        wait_until(lambda: not _alive(int(sleeper)), 10, "the process left in the dead run's namespace killed")
        inside = subprocess.Popen(net.wrap("A", ["sleep", "600"]), start_new_session=True)
        mine = [n for n in machines.list_netns() if n.startswith(net.owner.prefix + "-")]
        assert len(mine) == 2
    assert not set(mine) & set(machines.list_netns())                   # its own namespaces are gone
    wait_until(lambda: inside.poll() is not None, 10, "the process left in this run's namespace killed")
    assert "gbm" not in _host_links()
