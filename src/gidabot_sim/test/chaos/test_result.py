"""The result of a chaos run: its JSON, its table and every target it checks."""

from __future__ import annotations

from pathlib import Path

import pytest

from gidabot_navigation.building.model import load_building
from gidabot_sim.chaos.bookkeeping import GoalFate, StepFate
from gidabot_sim.chaos.result import ChaosResult, FaultResult
from gidabot_sim.chaos.schedule import Fault, Kind

REPO = Path(__file__).resolve().parents[4]


@pytest.fixture(scope="module")
def faculty():
    return load_building(REPO / "maps" / "faculty")


def _result(faculty, **kw) -> ChaosResult:
    f1 = FaultResult(Fault(Kind.CUT_IPTABLES, "Tartalo", "Kbot", duration=5.0), injected=1.0, cleared=6.0,
                        recovery_s=0.4)
    f2 = FaultResult(Fault(Kind.HOSTILE, "Kbot", target="goal_nan_pose"), injected=7.0, cleared=7.0,
                        accounted={"goal_manager: Kbot.rejected_pose": 1})
    table = {"Tartalo": (1, 1), "Kbot": (1, 0)}
    fate = GoalFate("T/v/1", "Tartalo", 0.0, 0.0, "008", 0, ["Tartalo"], ["Tartalo"], completed=True)
    args = dict(seed=1, tour="t.tour", speed=5.0, faults=[f1, f2], fates={"T/v/1": fate}, duplicated_cancels={},
                table3_expected=table, table3_measured=dict(table), table3_bags=dict(table), tours_intact=True,
                tours_problems=[], crashes=[], tracebacks={}, hostile_rejected={"guiding.rejected": 3},
                partner_lost=0, partner_answered=0, tour_completed=True, outcome="completed", run_folder="/tmp/x",
                steps=[StepFate(0, ["T/v/1"], completed_by="T/v/1")], table3_bags_expected=dict(table))
    args.update(kw)
    return ChaosResult(**args)


def test_result_json_and_table(faculty) -> None:
    res = _result(faculty)
    doc = res.to_json()
    for key in ("accepted", "completed", "lost", "duplicated", "max_recovery_s", "faults", "table3_bags",
                "node_crashes", "requests"):
        assert key in doc
    assert [f["kind"] for f in doc["faults"]] == [Kind.CUT_IPTABLES, Kind.HOSTILE]
    assert doc["fault_counts"][Kind.CUT_IPTABLES] == 1 and doc["fault_counts"][Kind.HOSTILE] == 1
    assert doc["max_recovery_s"] == 0.4 and doc["passed"] and doc["lost"] == 0 and doc["duplicated"] == 0
    assert doc["table3_bags"] == {"Tartalo": [1, 1], "Kbot": [1, 0]}
    text = res.format()
    assert "link_cut_iptables" in text and "RESULT: PASSED" in text
    slow = _result(faculty, crashes=["Kbot/sim died (pid 1, exit code 1)"])
    slow.faults[0].recovery_s = 7.5
    assert "a recovery took 7.5 s" in slow.failures() and "1 node crash(es)" in slow.failures()
    told = _result(faculty, partner_lost=2, partner_answered=1)
    assert any("never followed" in f for f in told.failures())
    unrec = _result(faculty)
    unrec.faults[0].recovered, unrec.faults[0].recovery_s = False, None
    assert unrec.to_json()["max_recovery_s"] == "not recovered" and not unrec.to_json()["passed"]


def test_a_verdict_cannot_pass_a_dropped_trip_an_uncounted_hostile_message_or_unread_bags(faculty) -> None:
    dropped = _result(faculty, steps=[StepFate(0, ["T/v/1"], system_ends=["T/v/1: partner offline from Kbot"])])
    assert any("neither completed nor ended by the visitor" in f and "partner offline from Kbot" in f
               for f in dropped.failures())
    retried = _result(faculty, steps=[StepFate(0, ["T/v/1", "T/v/2"], completed_by="T/v/2",
                                                  system_ends=["T/v/1: partner offline from Kbot"])])
    assert retried.failures() == [] and retried.to_json()["ended_by_system"] == ["T/v/1: partner offline from Kbot"]
    by_visitor = _result(faculty, steps=[StepFate(0, ["T/v/1"], visitor_ends=["T/v/1: cancelled at Kbot"])])
    assert by_visitor.failures() == []
    silent = _result(faculty)
    silent.faults[1].accounted = {}
    assert any("hostile message(s) not rejected and counted" in f for f in silent.failures())
    unread = _result(faculty, bags_error="Kbot.bag: cannot read bag: truncated", table3_bags={})
    assert any("bags could not be read" in f for f in unread.failures())
    off = _result(faculty, table3_bags={"Tartalo": (2, 1), "Kbot": (1, 0)})
    assert any("Table 3 from the bags" in f for f in off.failures())
