"""A floor starved of CPU slows its time down, it never makes it jump; the report says the run is degraded.

`bin/gidabot demo` runs a short tour at 20x. While the second goal runs, the simulator of the floor doing
the work (Kbot's, floor 1) is stopped (SIGSTOP) for 2 wall seconds, then continued. Its clock, read from
the run's timeline file throughout, stands still while it is stopped and afterwards never advances faster
than the 20x ceiling (it must never jump 40 s ahead at once); the tour still completes, with the
same Table 3; and the report marks the run degraded (the floor was behind its ceiling for more than 1 %
of the tour), naming the floor.
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
from gidabot_sim.world.timeline import Timeline

pytestmark = [pytest.mark.system, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
GIDABOT = REPO / "bin" / "gidabot"
SHORT_TOUR = ("Tour: Starved floor\n0, 008, Caretakers' Office\n1, 101, Secretary's Office\n"
              "1, 104, Ada Lovelace Auditorium\n")
EXPECTED = {"Tartalo": (3, 2), "Kbot": (3, 2), "Galtxagorri": (3, 0), "MariSorgin": (3, 0)}
SPEED, STOPPED_S, KBOT = 20.0, 2.0, 1


def sample(timeline: Timeline, slot: int, seconds: float, out: list[tuple[float, float]]) -> None:
    """(wall, sim) of a floor's clock every 10 ms for ``seconds``."""
    end = time.time() + seconds
    while time.time() < end:
        out.append((time.time(), timeline.read(slot).sim))
        time.sleep(0.01)


@pytest.mark.timeout(420)
def test_a_stopped_simulator_slows_its_floor_down_and_the_run_is_reported_degraded(tmp_path: Path) -> None:
    tour = tmp_path / "starved.tour"
    tour.write_text(SHORT_TOUR, encoding="utf-8")
    proc = subprocess.Popen([str(GIDABOT), "demo", "--tour", str(tour), "--out", str(tmp_path / "runs"), "--net",
                             str(procs_mod.test_network()), "--speed", f"{SPEED:g}", "--seed", "1", "--timeout", "300",
                             "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    assert proc.stderr is not None
    seen = ""
    try:
        deadline = time.monotonic() + 240
        while "goal 2 of 3" not in seen:          # progress lines go to stderr with --json
            line = proc.stderr.readline()
            assert line or proc.poll() is None, f"demo ended early: {seen[-3000:]}"
            assert time.monotonic() < deadline, f"no second goal after 240 s: {seen[-3000:]}"
            seen += line
        [folder] = list((tmp_path / "runs").iterdir())
        samples: list[tuple[float, float]] = []
        with Timeline.open(folder / "timeline") as timeline:
            pid = int(timeline.read(KBOT).pid)
            sample(timeline, KBOT, 0.5, samples)
            stopped = time.time()
            os.kill(pid, signal.SIGSTOP)
            try:
                sample(timeline, KBOT, STOPPED_S, samples)
            finally:
                os.kill(pid, signal.SIGCONT)
            resumed = time.time()
            sample(timeline, KBOT, 2.0, samples)
        out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            proc.communicate(timeout=120)
    assert proc.returncode == 0, (seen + err)[-4000:]

    # stood still while stopped (a sample may still catch the last step written before the stop took effect)
    during = [sim for wall, sim in samples if stopped + 0.1 < wall < resumed]
    assert during and max(during) == min(during), during
    # and never ran ahead of the ceiling afterwards: over any 0.2 s, at most 20x plus the pacer's 50 ms slack
    after = [(wall, sim) for wall, sim in samples if wall >= resumed - 0.05]
    worst = max((s2 - s1) / (w2 - w1) for (w1, s1) in after for (w2, s2) in after if w2 - w1 >= 0.2)
    assert worst <= SPEED * (1.0 + 0.05 / 0.2) + 0.5, f"sim time jumped: {worst:.1f}x over 0.2 s"
    assert after[-1][1] - during[-1] < SPEED * (after[-1][0] - resumed) + 2.0

    report = json.loads(out)
    assert report["tour"]["completed"] == 3
    assert {r["name"]: (r["received"], r["processed"]) for r in report["robots"]} == EXPECTED
    timing = report["timing"]
    assert report["degraded"] is True and timing["degraded"] is True
    assert timing["floors"]["Kbot"]["behind_s"] >= STOPPED_S - 0.3, timing["floors"]["Kbot"]
    assert any(reason.startswith("Kbot's clock was behind") for reason in timing["reasons"]), timing["reasons"]
    # the report says so from the folder alone, too
    again = subprocess.run([str(GIDABOT), "report", str(folder), "--json", "--no-plots"],
                           capture_output=True, text=True, timeout=120, check=True)
    assert json.loads(again.stdout)["degraded"] is True
