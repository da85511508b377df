"""bench idle: the CPU per robot per wall second from two readings of every process (the run is system-level)."""

from __future__ import annotations

import pytest

from gidabot_sim.bench.idle import format_text, idle_cost


def _row(owner: str, process: str, pid: int, cpu: float) -> dict:
    return {"owner": owner, "process": process, "pid": pid, "cpu_s": cpu}


def test_each_process_counts_for_the_robot_whose_process_group_started_it() -> None:
    before = [_row("robot_A", "sim", 1, 10.0), _row("robot_A", "end_node", 2, 1.0),
              _row("master_A", "rosmaster", 3, 2.0), _row("robot_B", "sim", 4, 5.0), _row("monitor", "monitor", 9, 1.0)]
    after = [_row("robot_A", "sim", 1, 12.0), _row("robot_A", "end_node", 2, 1.5),
             _row("master_A", "rosmaster", 3, 2.5), _row("robot_A", "end_node", 5, 0.5),   # new: from 0
             _row("robot_B", "sim", 4, 6.0), _row("monitor", "monitor", 9, 9.0), _row("?", "x", 10, 3.0)]
    cost = idle_cost(before, after, 10.0, ["A", "B"])
    a, b = cost["robots"]
    assert a == {"name": "A", "ms_per_wall_s": 350.0,
                 "per_kind_ms_per_wall_s": {"sim": 200.0, "end_node": 100.0, "rosmaster": 50.0}}
    assert b["ms_per_wall_s"] == 100.0 and cost["ms_per_wall_s_per_robot"] == 225.0
    assert cost["per_kind_ms_per_wall_s"] == {"sim": 300.0, "end_node": 100.0, "rosmaster": 50.0}  # not the tools'
    text = format_text(cost)
    assert "A" in text[1] and "350.0 ms/s" in text[1] and "225.0 ms of CPU per wall s (22.50 % of a core)" in text[3]
    with pytest.raises(ValueError):
        idle_cost(before, after, 0.0, ["A"])
