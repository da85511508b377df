"""End to end through `bin/gidabot demo` (the entry point of `make demo`): the whole simulated building.

Four masters, six relays, a simulator per floor, every robot's nodes and the simulated visitor
run a short tour (three goals, one floor change by the lift); the run folder's bags then give
the paper's tables (`gidabot report`). A second run is interrupted with SIGINT: the bags are
closed and nothing of the run is left running. Both runs are bounded in time; the masters run
on this test session's loopback network (127.N.0.x, `--net`).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

import gidabot_sim.runner.procs as procs_mod

pytestmark = [pytest.mark.system, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
GIDABOT = REPO / "bin" / "gidabot"
ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")
SHORT_TOUR = ("Tour: Demo test\n0, 008, Caretakers' Office\n1, 101, Secretary's Office\n"
              "1, 104, Ada Lovelace Auditorium\n")
# goals 0->0, 0->1, 1->1: every robot receives 3; Tartalo keeps the first two, Kbot the last two
EXPECTED = {"Tartalo": (3, 2), "Kbot": (3, 2), "Galtxagorri": (3, 0), "MariSorgin": (3, 0)}
ROBOT_KEYS = {"name", "floor", "received", "processed", "time_s", "distance_m", "mean_velocity_mps"}
TOUR_KEYS = {"goals", "completed", "time_s", "distance_m", "sim_s", "wall_s"}


def run_processes(folder: Path) -> list[str]:
    """Live processes whose command line or environment names the run folder (every node of the
    run has it in its log path, ROS_LOG_DIR or state directory)."""
    needle = str(folder).encode()
    found = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            cmdline = Path(entry.path, "cmdline").read_bytes()
            environ = Path(entry.path, "environ").read_bytes()
            state = Path(entry.path, "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z" and (needle in cmdline or needle in environ):
            args = cmdline.replace(b"\0", b" ").decode(errors="replace")
            found.append(f"{entry.name}: {args[:160]}")
    return found


def start_demo(tmp_path: Path, *extra: str) -> subprocess.Popen:
    tour = tmp_path / "demo_test.tour"
    tour.write_text(SHORT_TOUR, encoding="utf-8")
    out = tmp_path / "runs"
    argv = [str(GIDABOT), "demo", "--tour", str(tour), "--out", str(out), "--net", str(procs_mod.test_network()),
            "--way", "lift", "--timeout", "240", *extra]
    return subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def finish(proc: subprocess.Popen, timeout: float) -> tuple[str, str]:
    """Wait for the demo; past ``timeout`` stop it the way a user would (SIGINT) and fail."""
    try:
        return proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
        pytest.fail(f"demo still running after {timeout:g} s; stopped it\n{err[-3000:]}")


def the_run(tmp_path: Path) -> Path:
    [folder] = list((tmp_path / "runs").iterdir())
    return folder


@pytest.mark.timeout(420)
def test_short_tour_end_to_end(tmp_path: Path) -> None:
    proc = start_demo(tmp_path, "--json")
    out, err = finish(proc, timeout=330)
    assert proc.returncode == 0, err[-4000:]
    folder = the_run(tmp_path)
    assert run_processes(folder) == []

    report = json.loads(out)
    assert set(report["tour"]) >= TOUR_KEYS
    assert report["tour"]["goals"] == 3 and report["tour"]["completed"] == 3
    assert report["tour"]["sim_s"] > 0 and report["tour"]["wall_s"] > 0
    rows = {r["name"]: r for r in report["robots"]}
    assert list(rows) == list(ROBOTS)
    for name, row in rows.items():
        assert set(row) >= ROBOT_KEYS
        assert (row["received"], row["processed"]) == EXPECTED[name], row
    for name in ("Tartalo", "Kbot"):   # they guided the visitor
        assert rows[name]["time_s"] > 0 and rows[name]["distance_m"] > 1.0
        assert 0.05 < rows[name]["mean_velocity_mps"] < 1.0
    assert report["tour"]["distance_m"] == pytest.approx(sum(r["distance_m"] for r in rows.values()), abs=0.2)

    for name in ROBOTS:
        assert (folder / f"{name}.bag").stat().st_size > 0
        assert not (folder / f"{name}.bag.active").exists()
    for floor in range(4):
        png = folder / f"paths_floor{floor}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "goal 2 of 3" in err and "Kbot: waiting for the visitor" in err   # progress lines

    # the report is the same without ROS, from the folder alone
    again = subprocess.run([str(GIDABOT), "report", str(folder), "--json", "--no-plots"], capture_output=True,
                           text=True, timeout=120, check=True)
    assert json.loads(again.stdout)["robots"] == report["robots"]


@pytest.mark.timeout(300)
def test_sigint_stops_everything_and_closes_the_bags(tmp_path: Path) -> None:
    proc = start_demo(tmp_path)
    deadline = time.monotonic() + 180
    seen = ""
    assert proc.stdout is not None
    while "goal 2 of 3" not in seen:   # progress lines go to stdout without --json
        line = proc.stdout.readline()
        assert line or proc.poll() is None, f"demo ended early: {seen[-2000:]}"
        assert time.monotonic() < deadline, f"no second goal after 180 s: {seen[-2000:]}"
        seen += line
    folder = the_run(tmp_path)
    assert len(run_processes(folder)) > 40   # 4 masters, 4 x (roslaunch + ~8 nodes + relay ends), recorders
    os.kill(proc.pid, signal.SIGINT)
    out, err = finish(proc, timeout=90)
    assert proc.returncode == 130, err[-3000:]
    assert "interrupted (SIGINT)" in out
    assert run_processes(folder) == []
    for name in ROBOTS:   # closed properly: indexed, readable
        assert (folder / f"{name}.bag").exists() and not (folder / f"{name}.bag.active").exists()
    rep = subprocess.run([str(GIDABOT), "report", str(folder), "--json", "--no-plots"], capture_output=True,
                         text=True, timeout=120, check=True)
    assert json.loads(rep.stdout)["robots"][0]["received"] >= 2
