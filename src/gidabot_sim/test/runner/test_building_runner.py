"""The simulated building's runner without a master: its relay secret, and no process left behind at its stop."""

from __future__ import annotations

import stat
import sys
import time
from pathlib import Path

from gidabot_sim.runner.building_runner import NODE_GRACE, SimulatedBuilding, write_secret
from gidabot_sim.runner.proc_info import ProcInfo, read_proc

REPO = Path(__file__).resolve().parents[4]


def test_secret_file_is_private_and_random(tmp_path: Path) -> None:
    a, b = write_secret(tmp_path / "a.secret"), write_secret(tmp_path / "b.secret")
    assert stat.S_IMODE(a.stat().st_mode) == 0o600
    assert len(a.read_text().strip()) == 64 and a.read_text() != b.read_text()


def test_stop_kills_nodes_left_behind_by_their_launcher(tmp_path: Path) -> None:
    """A node whose parent is gone (roslaunch killed) is still found and stopped by its process group."""
    sim = SimulatedBuilding(REPO / "maps" / "faculty", tmp_path / "run", record=False)
    # the parent obeys SIGINT as roslaunch does, also when this test runs with SIGINT ignored (nohup ... &)
    code = ("import signal, subprocess, sys, time\n"
            "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
            "c = subprocess.Popen([sys.executable, '-c', "
            "'import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); time.sleep(120)'], "
            "start_new_session=True)\nprint(c.pid, flush=True)\ntime.sleep(120)\n")
    managed = sim.procs.start("robot_Fake", [sys.executable, "-c", code])
    deadline = time.monotonic() + 20
    tree: dict[int, ProcInfo] = {}
    while len(tree) < 2 and time.monotonic() < deadline:   # the child is up
        tree = sim.track()
        time.sleep(0.05)
    [child] = [pid for pid in tree if pid != managed.popen.pid]
    began = time.monotonic()
    sim.stop()
    assert read_proc(child) is None
    assert time.monotonic() - began < NODE_GRACE + 8
    assert sim.forced == ["Fake/python -c (SIGTERM)"]
