"""Robots share a narrow corridor (docs/guiding.md, *Making way*): `bin/gidabot demo` on
tests/corridors/narrow_corridor, where Parker's home is in the middle of a 2.6 m corridor that Guide must use
between the halls. Guide guides the simulated visitor along a tour back and forth past it: every leg
completes (no "robot stuck", no UNREACHABLE), in both directions, with no collision or deadlock (the visitor's
body, behind Guide when it turns back at the corridor's end, steps aside for it); Parker, whenever it stands in
Guide's way, is asked to make way, steps aside and goes back; `gidabot check` warns about its home (WARN).
"""

from __future__ import annotations

import json
import math
import re
import signal
import subprocess
from pathlib import Path

import pytest
from demo_logs import log_tails, run_folder_of

import gidabot_sim.runner.procs as procs_mod

pytestmark = [pytest.mark.system, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
GIDABOT = REPO / "bin" / "gidabot"
BUILDING = Path(__file__).resolve().parent / "narrow_corridor"
# west hall -> east hall -> west hall -> corridor end -> west hall: four passes of Parker's home, two each way
TOUR = ("Tour: Corridor\n0, east, East hall\n0, west, West hall\n0, corridor_end, Corridor end\n"
        "0, west, West hall\n")


def test_check_warns_about_the_home_in_the_corridor() -> None:
    out = subprocess.run([str(GIDABOT), "check", str(BUILDING)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "WARN" in out.stdout and "robot Parker: (16, 5)" in out.stdout and "Guide needs" in out.stdout


@pytest.mark.timeout(600)
def test_the_guide_passes_the_robot_parked_in_the_corridor_every_time_both_ways(tmp_path: Path) -> None:
    tour = tmp_path / "corridor.tour"
    tour.write_text(TOUR, encoding="utf-8")
    argv = [str(GIDABOT), "demo", "--building", str(BUILDING), "--tour", str(tour), "--out", str(tmp_path / "runs"),
            "--net", str(procs_mod.test_network()), "--timeout", "420", "--json"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=540)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
        pytest.fail(f"demo still running after 540 s; stopped it\n{err[-3000:]}")
    folder = run_folder_of(err)
    assert proc.returncode == 0, err[-4000:] + "\n" + (log_tails(folder) if folder else "")
    report = json.loads(out)
    assert report["tour"]["goals"] == 4 and report["tour"]["completed"] == 4, report["tour"]
    assert report["contacts"]["collisions"] == 0 and report["contacts"]["deadlocks"] == 0, report["contacts"]
    assert report["legs"]["served_by"] == {"Guide": 4}

    [folder] = list((tmp_path / "runs").iterdir())
    files = {p.resolve() for p in (folder / "ros").rglob("*.log") if not p.name.endswith("-stdout.log")}
    text = "\n".join(p.read_text(errors="replace") for p in sorted(files))     # each log once ("latest" links)
    assert "robot stuck" not in text and "UNREACHABLE" not in text
    # Parker is asked whenever it stands in Guide's way: always on the first pass (it starts in the middle of the
    # corridor); later passes depend on where it stopped when it went back (off the middle, Guide fits past it)
    asks = re.findall(r"make way: asking Parker to make way along my way to \(([\d.]+), ([\d.]+)\)", text)
    assert len(asks) >= 1, asks
    aside = re.findall(r"make way: moving aside to \(([\d.]+), ([\d.]+)\)", text)
    back = re.findall(r"make way: going back to \(([\d.]+), ([\d.]+)\)", text)
    assert len(aside) >= 1 and len(back) >= len(aside), (aside, back)       # every time it moved, it went back
    assert all(math.hypot(float(x) - 16.0, float(y) - 5.0) > 0.1 for x, y in aside), aside
    assert all(math.hypot(float(x) - 16.0, float(y) - 5.0) < 0.2 for x, y in back), back   # where it belongs
