"""The processes of a run from /proc: their labels, the tree across sessions, their CPU."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys

from gidabot_sim.runner.proc_info import ProcInfo, cpu_seconds, machine_busy_s, process_tree, read_proc


def test_proc_labels() -> None:
    def info(*argv: str) -> ProcInfo:
        return ProcInfo(1, 0, 1, 0, 0.0, argv)

    assert info("/usr/bin/python3", "/x/nodes/sim", "__name:=sim", "__log:=/l").label == "sim"
    assert info("/v/bin/python3", "/x/lib/gidabot_sim/monitor", "_out:=/m").label == "monitor"
    assert info("/v/bin/python3", "-m", "gidabot_navigation.relay.end_node", "--robot_a", "A").label == "end_node"
    assert info("/usr/bin/python3", "/usr/bin/rosmaster", "--core", "-p", "1").label == "rosmaster"
    assert info("/v/bin/python", "-m", "gidabot_sim.cli", "demo").label == "cli"
    assert info("/usr/lib/rosbag/record", "--quiet", "-O", "x.bag").label == "record"


def test_process_tree_finds_children_in_their_own_sessions() -> None:
    # a parent that starts a child in a session of its own (as roslaunch does with every node)
    code = ("import subprocess, sys, time\n"
            "c = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)'], start_new_session=True)\n"
            "print(c.pid, flush=True)\ntime.sleep(60)\n")
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                              start_new_session=True)
    assert parent.stdout is not None
    child = int(parent.stdout.readline())
    try:
        tree = process_tree({parent.pid})
        assert set(tree) == {parent.pid, child}
        assert tree[child].pgid == child and tree[child].ppid == parent.pid
        assert read_proc(child) is not None and read_proc(child).cpu_s >= 0.0
    finally:
        for pid in (parent.pid, child):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pid, signal.SIGKILL)
        parent.wait(timeout=10)


def test_cpu_seconds_of_processes_and_of_the_machine() -> None:
    own = read_proc(os.getpid())
    assert own is not None and cpu_seconds([os.getpid()]) >= own.cpu_s
    assert cpu_seconds([0]) == 0.0          # no such process: it counts 0
    busy = machine_busy_s()
    assert busy is None or busy > 0.0
