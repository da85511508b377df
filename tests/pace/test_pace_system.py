"""Guiding at the visitor's pace, end to end (docs/guiding.md, *Guiding at the visitor's pace*): `bin/gidabot demo`
on maps/faculty with one visitor whose walk is given (`--walk`, docs/simulator.md, *People*), judged from the
demo's JSON report (its pace figures: gidabot_sim.report.pace), its run.json and the robots' bags (events, and when
a recorder got them).

- a visitor who stops for 60 s in the middle of the leg is waited for, and the trip completes;
- one who wanders off for good is searched for and declared lost (VISITOR_LOST), the trip ends as lost, and
  Kbot, waiting upstairs at the meeting point, drops the trip within 5 s of sim time of the declaration;
- a visitor slower than the robot arrives with it: the robot's distance ahead stays bounded;
- a group of three walking as one visitor is guided as one.

Every case is one short demo run (Tartalo, floor 0, from its home at (30, 12)): the same-floor cases go to
012 (61, 11.4), a leg of 31 m (52 s at Tartalo's 0.6 m/s); the wander-off case goes to 101 on floor 1, Tartalo
guiding 26 m to the west staircase where Kbot waits.
"""

from __future__ import annotations

import json
import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest
from demo_logs import log_tails
from rosbags.highlevel import AnyReader

import gidabot_sim.runner.procs as procs_mod
from gidabot_navigation.guiding.pacing import PacingConfig
from gidabot_navigation.interface import FINAL_PHASES, Phase, Topic
from gidabot_sim.report.bags import load_run
from gidabot_sim.runner.command_line import EXIT_FAILED, EXIT_OK

pytestmark = [pytest.mark.system, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
GIDABOT = REPO / "bin" / "gidabot"
# sim s per wall s: the legs are short (start-up and stop take most of a run's wall time), and neither the people
# node nor the relays run in lockstep with the floors: at 5x a starved people node loses 0.2 s of sim time per
# 40 ms stall, and the 5 s of sim time the robot upstairs has to drop the trip are 1 s of wall time (at 20x a
# quarter of a second of a starved relay would miss it)
SPEED = 5.0
DEMO_TIMEOUT_S = 480.0       # wall s the demo gives itself (a loaded machine slows the floors down)
TEST_TIMEOUT_S = 660         # pytest's: the demo's, plus its start-up, report and stop
SAME_FLOOR_GOAL = "012"      # floor 0, 31 m east of Tartalo's home
UPSTAIRS_GOAL = "101"        # floor 1: Tartalo guides to the west staircase, Kbot waits there
PACING = PacingConfig()      # the guiding node's defaults (launch/guiding.launch leaves them)
DROP_WITHIN_S = 5.0          # sim s: the robot upstairs drops the trip this soon after the declaration


@dataclass
class Run:
    returncode: int
    report: dict
    run: dict
    folder: Path
    stderr: str

    @property
    def pace(self) -> dict:
        return self.report["pace"]["totals"]

    @property
    def legs(self) -> list[dict]:
        return self.report["pace"]["legs"]


def demo(tmp_path: Path, goal: str, walk: str) -> Run:
    """One demo run of ``goal`` with the visitor walking as ``walk``, to its end."""
    out_dir = tmp_path / "runs"
    argv = [str(GIDABOT), "demo", "--goal", goal, "--walk", walk, "--out", str(out_dir), "--net",
            str(procs_mod.test_network()), "--speed", f"{SPEED:g}", "--seed", "1", "--timeout",
            f"{DEMO_TIMEOUT_S:g}", "--json"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=DEMO_TIMEOUT_S + 120)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
        pytest.fail(f"demo still running after {DEMO_TIMEOUT_S + 120:g} s; stopped it\n{err[-3000:]}")
    assert out.strip(), f"no report (exit {proc.returncode})\n{err[-4000:]}"
    report = json.loads(out)
    folder = Path(report["run_folder"])
    run = json.loads((folder / "run.json").read_text(encoding="utf-8"))
    assert run["walk"] == walk, run
    return Run(proc.returncode, report, run, folder, err)


def recorded(bag: Path, phase: int, goal_uid: str) -> dict[str, float]:
    """Robot -> when ``bag``'s recorder got its first NavEvent of ``phase`` about ``goal_uid`` (its clock, s)."""
    out: dict[str, float] = {}
    with AnyReader([bag]) as reader:
        conns = [c for c in reader.connections if c.topic == Topic.NAV_EVENTS]
        for conn, t_ns, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            if msg.phase == phase and msg.goal_uid == goal_uid:
                out.setdefault(msg.robot, t_ns * 1e-9)
    return out


def completed(r: Run) -> None:
    assert r.returncode == EXIT_OK, f"{r.run['outcome']}\n{r.stderr[-4000:]}\n{log_tails(r.folder)}"
    assert r.report["tour"]["goals"] == 1 and r.report["tour"]["completed"] == 1, r.report["tour"]
    assert r.pace["lost"] == 0 and r.pace["searches"] == 0, r.pace


@pytest.mark.timeout(TEST_TIMEOUT_S)
def test_a_visitor_who_stops_a_minute_in_the_middle_of_the_leg_is_waited_for(tmp_path: Path) -> None:
    # stands still from 15 s after asking (the robot is some 8 m along the leg) to 75 s
    r = demo(tmp_path, SAME_FLOOR_GOAL, "pause=15:60")
    completed(r)
    assert r.pace["legs"] == 1 and r.pace["waits"] >= 1, r.pace
    # the robot waits from when it sees the visitor stand beyond `near` for `still_for` s (a few s into the
    # pause, the tracker's speed estimate settling) until the visitor walks again and comes within `resume`
    assert r.pace["waiting_s"] >= 60.0 - PACING.still_for - 6.0, r.pace


@pytest.mark.timeout(TEST_TIMEOUT_S)
def test_a_visitor_who_wanders_off_is_searched_for_and_lost_and_the_robot_upstairs_drops_the_trip(
        tmp_path: Path) -> None:
    # walks off for good 15 s after asking, in the middle of Tartalo's leg to the staircase
    r = demo(tmp_path, UPSTAIRS_GOAL, "wander_at=15")
    assert r.returncode == EXIT_FAILED and r.run["outcome"].startswith("visitor lost (Tartalo:"), \
        f"{r.run['outcome']}\n{r.stderr[-4000:]}"
    assert r.report["tour"]["completed"] == 0, r.report["tour"]
    [tartalo] = [leg for leg in r.legs if leg["robot"] == "Tartalo"]
    assert tartalo["waits"] >= 1 and tartalo["searches"] >= 1 and tartalo["lost"] == 1, tartalo
    assert tartalo["found_again"] == 0, tartalo

    _, records = load_run(r.folder)
    events = {rec.name: rec.events for rec in records}
    [lost] = [e for e in events["Tartalo"] if e.phase == Phase.VISITOR_LOST]
    uid = tartalo["goal_uid"]
    assert lost.goal_uid == uid
    kbot = [e for e in events["Kbot"] if e.goal_uid == uid]
    assert any(e.phase == Phase.WAITING_VISITOR for e in kbot), kbot      # it was waiting at the meeting point
    # Kbot's goal manager drops the trip on Tartalo's cancel (reason visitor_lost) and says so: its VISITOR_LOST
    assert [e.phase for e in kbot if e.phase in FINAL_PHASES] == [Phase.VISITOR_LOST], kbot
    assert not any(e.phase == Phase.ON_THE_WAY for e in kbot), kbot
    # within 5 s, on one clock: the floors' clocks differ by up to their drift bound (seconds at a loaded demo), so
    # the two robots' stamps do not compare; Tartalo's recorder heard its own declaration, then Kbot's drop come
    # back through the relay (an upper bound: the way back counts too)
    heard = recorded(r.folder / "Tartalo.bag", Phase.VISITOR_LOST, uid)
    assert set(heard) == {"Tartalo", "Kbot"}, heard
    assert 0.0 <= heard["Kbot"] - heard["Tartalo"] <= DROP_WITHIN_S, heard


@pytest.mark.timeout(TEST_TIMEOUT_S)
def test_a_visitor_slower_than_the_robot_arrives_with_it(tmp_path: Path) -> None:
    # 0.5 m/s behind Tartalo's 0.6: it falls behind until, beyond `near`, the robot slows to `slow_speed`
    # (0.3 m/s, slower than the visitor), so the visitor catches up; beyond `far` the robot would stop and wait.
    # The robot's distance ahead stays within `far`: pacing held the visitor without a wait.
    r = demo(tmp_path, SAME_FLOOR_GOAL, "speed=0.5")
    completed(r)
    assert r.pace["slowdowns"] >= 1, r.pace
    assert r.pace["worst_behind_m"] is not None and r.pace["worst_behind_m"] <= PACING.far, r.pace
    assert r.pace["waits"] == 0, r.pace


@pytest.mark.timeout(TEST_TIMEOUT_S)
def test_a_group_of_three_walking_as_one_visitor_is_guided_as_one(tmp_path: Path) -> None:
    r = demo(tmp_path, SAME_FLOOR_GOAL, "group=3")
    completed(r)
    assert len({leg["goal_uid"] for leg in r.legs}) == 1 and r.pace["legs"] == 1, r.legs   # one trip, one visitor
    assert r.pace["worst_behind_m"] is not None, r.pace        # the robot saw its visitor and paced the leg
