"""The relay benchmark's verdict: it exits non-zero when a target is missed (no master needed)."""

from __future__ import annotations

from gidabot_sim.bench.relay import targets_missed


def _result(**kw) -> dict:
    res = {"messages": 1000, "relayed_received": 1000, "added_p50_ms": 0.4, "relayed_p99_ms": 2.0,
           "mesh": [{"robots": 8, "lost": 0, "duplicated": 0, "max_ms": 120.0}]}
    res.update(kw)
    return res


def test_targets_met_and_missed() -> None:
    assert targets_missed(_result(), 1.0, 5.0, 1000.0) == []
    assert targets_missed(_result(added_p50_ms=1.6), 1.0, 5.0, 1000.0) == [
        "the relay adds 1.600 ms at p50 (target <= 1 ms)"]
    assert any("relayed p99" in m for m in targets_missed(_result(relayed_p99_ms=float("nan")), 1.0, 5.0, 1000.0))
    assert targets_missed(_result(relayed_received=998), 1.0, 5.0, 1000.0) == ["2 relayed message(s) lost"]
    lossy = _result(mesh=[{"robots": 8, "lost": 3, "duplicated": 1, "max_ms": 2400.0}])
    assert targets_missed(lossy, 1.0, 5.0, 1000.0) == [
        "mesh of 8: 3 lost, 1 duplicated", "mesh of 8: a delivery took 2400 ms (stall target < 1000 ms)"]
