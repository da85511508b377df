"""`gidabot demo` pieces that need no master: arguments, secret file, process tree, shutdown of stragglers."""

from __future__ import annotations

import contextlib
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

from gidabot_sim.demo import demo
from gidabot_sim.runner import building_runner as br

REPO = Path(__file__).resolve().parents[4]


def test_bad_arguments_are_refused_before_anything_starts(tmp_path: Path, capsys) -> None:
    out = tmp_path / "runs"
    cases = [
        (["--goal", "9999"], "is not a location of faculty"),
        (["--tour", str(tmp_path / "missing.tour")], "missing.tour"),
        (["--speed", "0"], "--speed 0: expected a factor"),
        (["--speed", "nan"], "--speed nan"),
        (["--start-floor", "7"], "start floor 7 has no robot"),
        (["--skip", "3:2"], "need 1 <= K < M <= 8"),
        (["--skip", "x"], "expected K:M"),
        (["--secret", str(tmp_path / "nope")], "not a file"),
        (["--net", "0"], "--net 0"),
        (["--clock-rate", "0"], "--clock-rate 0: expected 1..1000"),
        (["--clock-rate", "inf"], "--clock-rate inf"),
    ]
    for argv, expected in cases:
        assert demo.main([*argv, "--out", str(out)]) == demo.EXIT_USAGE, argv
        assert expected in capsys.readouterr().err, argv
    bad = tmp_path / "bad.tour"
    bad.write_text("Tour\n0, 999, Nowhere\n", encoding="utf-8")
    assert demo.main(["--tour", str(bad), "--out", str(out)]) == demo.EXIT_USAGE
    assert "999" in capsys.readouterr().err
    assert not out.exists()   # nothing was started, no run folder


def test_gui_needs_a_display(monkeypatch, tmp_path: Path, capsys) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("QT_QPA_PLATFORM", raising=False)
    assert demo.main(["--gui", "--out", str(tmp_path)]) == demo.EXIT_USAGE
    assert "--gui needs a display" in capsys.readouterr().err


def test_secret_file_is_private_and_random(tmp_path: Path) -> None:
    a, b = br.write_secret(tmp_path / "a.secret"), br.write_secret(tmp_path / "b.secret")
    assert stat.S_IMODE(a.stat().st_mode) == 0o600
    assert len(a.read_text().strip()) == 64 and a.read_text() != b.read_text()


def test_proc_labels() -> None:
    def info(*argv: str) -> br.ProcInfo:
        return br.ProcInfo(1, 0, 1, 0, 0.0, argv)

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
        tree = br.process_tree({parent.pid})
        assert set(tree) == {parent.pid, child}
        assert tree[child].pgid == child and tree[child].ppid == parent.pid
        assert br.read_proc(child) is not None and br.read_proc(child).cpu_s >= 0.0
    finally:
        for pid in (parent.pid, child):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pid, signal.SIGKILL)
        parent.wait(timeout=10)


def test_stop_kills_nodes_left_behind_by_their_launcher(tmp_path: Path) -> None:
    """A node whose parent is gone (roslaunch killed) is still found and stopped by its process group."""
    sim = br.SimulatedBuilding(REPO / "maps" / "faculty", tmp_path / "run", record=False)
    # the parent obeys SIGINT as roslaunch does, also when this test runs with SIGINT ignored (nohup ... &)
    code = ("import signal, subprocess, sys, time\n"
            "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
            "c = subprocess.Popen([sys.executable, '-c', "
            "'import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); time.sleep(120)'], "
            "start_new_session=True)\nprint(c.pid, flush=True)\ntime.sleep(120)\n")
    managed = sim.procs.start("robot_Fake", [sys.executable, "-c", code])
    deadline = time.monotonic() + 20
    tree: dict[int, br.ProcInfo] = {}
    while len(tree) < 2 and time.monotonic() < deadline:   # the child is up
        tree = sim.track()
        time.sleep(0.05)
    [child] = [pid for pid in tree if pid != managed.popen.pid]
    began = time.monotonic()
    sim.stop()
    assert br.read_proc(child) is None
    assert time.monotonic() - began < br.NODE_GRACE + 8
    assert sim.forced == ["Fake/python -c (SIGTERM)"]
