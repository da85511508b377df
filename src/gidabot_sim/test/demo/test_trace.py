"""``gidabot demo --trace``: the trace's lines (TraceWriter, from fake clocks and process rows), read back and
summarised: which processes used the CPU while the floors fell behind."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from gidabot_sim.demo import command
from gidabot_sim.demo.trace import (
    Trace,
    TraceWriter,
    format_summary,
    kind_of,
    load,
    process_key,
    robot_of,
    summarize,
    window,
)
from gidabot_sim.world.timeline import Clock

WALL0 = 1000.0


def _rows(cpu: dict[tuple[str, str, int], float]) -> list[dict[str, object]]:
    return [{"owner": owner, "process": process, "pid": pid, "cpu_s": cpu_s}
            for (owner, process, pid), cpu_s in cpu.items()]


def write_trace(path: Path, looks: list[tuple[dict[str, float], dict[tuple[str, str, int], float]]],
                period: float = 0.2) -> Path:
    """One sample per look, ``period`` wall s apart from WALL0: (robot -> behind s, (owner, process, pid) -> CPU
    s so far)."""
    with TraceWriter(path) as writer:
        for i, (behind, cpu) in enumerate(looks):
            wall = WALL0 + period * i
            clocks = {robot: Clock(sim=20.0 * period * i, wall=wall, behind=b, wait_controllers=0.001 * i)
                      for robot, b in behind.items()}
            writer.sample(wall, clocks, _rows(cpu))
    return path


GM, END, SIM, MB = ("robot_Kbot", "goal_manager", 11), ("robot_Tartalo", "end_node", 12), \
    ("robot_Tartalo", "sim", 13), ("robot_Kbot", "move_base", 14)


def burst_trace(path: Path) -> Path:
    """Six looks, five windows; in the third (0.4-0.6 s) Kbot's floor falls 30 ms behind while Kbot's goal manager
    and Tartalo's relay end burst; Kbot's floor also grows 1 ms in the second and fifth windows."""
    gm = [1.00, 1.01, 1.02, 1.20, 1.21, 1.22]
    end = [2.00, 2.01, 2.02, 2.15, 2.16, 2.17]
    sim = [3.00, 3.04, 3.08, 3.09, 3.13, 3.17]
    mb = [4.00, 4.02, 4.04, 4.06, 4.08, 4.10]
    kbot = [0.0, 0.0, 0.001, 0.031, 0.031, 0.032]
    looks = [({"Tartalo": 0.010, "Kbot": kbot[i]}, {GM: gm[i], END: end[i], SIM: sim[i], MB: mb[i]}) for i in range(6)]
    return write_trace(path, looks)


def test_a_trace_line_has_the_floors_and_every_process_by_robot(tmp_path: Path) -> None:
    path = burst_trace(tmp_path / "trace.jsonl")
    first = json.loads(path.read_text().splitlines()[0])
    assert first["wall"] == WALL0
    assert first["floors"] == {"Tartalo": [0.0, 0.01, 0.0], "Kbot": [0.0, 0.0, 0.0]}   # [sim, behind, wait_controllers]
    assert first["cpu"] == {"Kbot/goal_manager": [11, 1.0], "Tartalo/end_node": [12, 2.0], "Tartalo/sim": [13, 3.0],
                            "Kbot/move_base": [14, 4.0]}
    assert first["trace_cpu_s"] >= 0.0
    assert [robot_of(o) for o in ("robot_Kbot", "master_Kbot", "record_Kbot.1", "visitor_Mari_Sorgin", "monitor",
                                  "?")] == ["Kbot", "Kbot", "Kbot", "Mari_Sorgin", "monitor", "?"]
    assert process_key("record_Kbot.2", "record") == "Kbot/record"
    assert kind_of("Kbot/goal_manager") == "goal_manager" and kind_of("Kbot/record#41") == "record"


def test_a_stall_window_is_attributed_to_the_processes_that_burst_in_it(tmp_path: Path) -> None:
    summary = summarize(load(burst_trace(tmp_path / "trace.jsonl")))
    assert (summary["samples"], summary["windows"], summary["skipped_lines"]) == (6, 5, 0)
    assert summary["wall_s"] == pytest.approx(1.0)
    assert (summary["stalls"], summary["stall_ms"], summary["stall_wall_s"], summary["behind_ms"]) == \
        (1, 30.0, 0.2, 32.0)       # the 1 ms windows are no stall (min_stall_ms 5)
    assert summary["net_behind_ms"] == 32.0
    [top] = summary["top"]
    assert (top["at_s"], top["span_s"], top["growth_ms"], top["floor"]) == (0.4, 0.2, 30.0, "Kbot")
    assert top["processes"] == [{"process": "Kbot/goal_manager", "cpu_ms": 180.0},
                                {"process": "Tartalo/end_node", "cpu_ms": 130.0},
                                {"process": "Kbot/move_base", "cpu_ms": 20.0}]
    assert top["before"] == [{"process": "Tartalo/sim", "cpu_ms": 40.0}, {"process": "Kbot/move_base", "cpu_ms": 20.0},
                             {"process": "Kbot/goal_manager", "cpu_ms": 10.0}]
    json.dumps(summary)                             # JSON-able, for run.json
    assert summarize(load(tmp_path / "trace.jsonl"), min_stall_ms=0.5)["stalls"] == 3


def test_kinds_cpu_in_cores_during_the_stalls_and_the_other_windows(tmp_path: Path) -> None:
    cores = summarize(load(burst_trace(tmp_path / "trace.jsonl")))["cores"]
    assert list(cores)[:3] == ["all", "goal_manager", "end_node"]      # every process, then largest in the stalls
    assert cores["goal_manager"] == {"stall": pytest.approx(0.9), "other": pytest.approx(0.05)}
    assert cores["end_node"] == {"stall": pytest.approx(0.65), "other": pytest.approx(0.05)}
    assert cores["sim"] == {"stall": pytest.approx(0.05), "other": pytest.approx(0.2)}
    assert cores["move_base"] == {"stall": pytest.approx(0.1), "other": pytest.approx(0.1)}
    assert cores["all"] == {"stall": pytest.approx(1.7), "other": pytest.approx(0.4)}


def test_the_span_counts_only_the_windows_wholly_inside_it(tmp_path: Path) -> None:
    trace = load(burst_trace(tmp_path / "trace.jsonl"))
    summary = summarize(trace, start_wall=WALL0 + 0.2, end_wall=WALL0 + 0.75)
    assert (summary["windows"], summary["start_wall"], summary["end_wall"]) == (2, WALL0 + 0.2, WALL0 + 0.6)
    assert summary["top"][0]["at_s"] == pytest.approx(0.2)        # from the span's start
    assert summarize(trace, start_wall=WALL0 + 0.5)["stalls"] == 0


def test_growth_is_per_floor_not_the_change_of_the_largest(tmp_path: Path) -> None:
    # no floor grows, but A (the leader) is missing from every other look: the largest behind jumps by 100 ms
    looks = [({"A": 0.2, "B": 0.1} if i % 2 == 0 else {"B": 0.1}, {}) for i in range(6)]
    summary = summarize(load(write_trace(tmp_path / "alternate.jsonl", looks)))
    assert (summary["windows"], summary["stalls"], summary["behind_ms"], summary["top"]) == (5, 0, 0.0, [])
    # a stall of the floor that does not lead: the largest behind does not change, the floor's own does
    looks = [({"A": 0.5, "B": b}, {}) for b in (0.1, 0.1, 0.14, 0.14)]
    summary = summarize(load(write_trace(tmp_path / "behind.jsonl", looks)))
    assert summary["stalls"] == 1 and summary["top"][0]["growth_ms"] == 40.0 and summary["top"][0]["floor"] == "B"


def test_a_restarted_floor_gives_no_negative_growth(tmp_path: Path) -> None:
    looks = [({"A": b, "B": 0.05}, {}) for b in (0.3, 0.3, 0.0, 0.004, 0.010)]   # A restarted: its counters again
    trace = load(write_trace(tmp_path / "trace.jsonl", looks))
    assert [round(window(a, b).growth, 6) for a, b in zip(trace.samples, trace.samples[1:], strict=False)] == \
        [0.0, 0.0, 0.004, 0.006]
    summary = summarize(trace)
    assert (summary["stalls"], summary["stall_ms"], summary["behind_ms"]) == (1, 6.0, 10.0)


def test_processes_count_from_their_first_sample(tmp_path: Path) -> None:
    gm, gm2, end, rec = ("robot_Kbot", "goal_manager", 21), ("robot_Kbot", "goal_manager", 31), \
        ("robot_Kbot", "end_node", 22), ("record_Kbot.1", "record", 40)
    looks = [
        ({"Kbot": 0.0}, {gm: 5.0, end: 1.0}),
        ({"Kbot": 0.0}, {gm: 5.1, end: 1.1}),
        ({"Kbot": 0.0}, {gm2: 0.4, end: 1.2, rec: 9.0}),        # goal manager restarted, a recorder appears
        ({"Kbot": 0.0}, {gm2: 0.5, rec: 9.3, ("robot_Kbot", "amcl", 22): 3.0}),   # end_node gone, its pid reused
    ]
    trace = load(write_trace(tmp_path / "trace.jsonl", looks))
    windows = [window(a, b).cpu for a, b in zip(trace.samples, trace.samples[1:], strict=False)]
    assert windows[0] == {"Kbot/goal_manager": pytest.approx(0.1), "Kbot/end_node": pytest.approx(0.1)}
    assert windows[1] == {"Kbot/end_node": pytest.approx(0.1)}
    assert windows[2] == {"Kbot/goal_manager": pytest.approx(0.1), "Kbot/record": pytest.approx(0.3)}
    cores = summarize(trace)["cores"]
    assert cores["goal_manager"]["other"] == pytest.approx(0.2 / 0.6, abs=1e-3) and "amcl" not in cores


def test_two_live_processes_of_one_name_are_told_apart_by_pid(tmp_path: Path) -> None:
    a, b = ("record_Kbot", "record", 40), ("record_Kbot.1", "record", 41)
    trace = load(write_trace(tmp_path / "trace.jsonl", [({}, {a: 1.0, b: 2.0}), ({}, {a: 1.1, b: 2.5})]))
    assert window(*trace.samples).cpu == {"Kbot/record": pytest.approx(0.1), "Kbot/record#41": pytest.approx(0.5)}
    assert summarize(trace)["cores"]["record"]["other"] == pytest.approx(3.0)
    # the rows come largest first: when b passes a, the "#pid" goes to the other one, each still counts
    trace = load(write_trace(tmp_path / "swap.jsonl", [({}, {a: 1.0, b: 2.0}), ({}, {b: 2.1, a: 3.0})]))
    assert window(*trace.samples).cpu == {"Kbot/record": pytest.approx(0.1), "Kbot/record#40": pytest.approx(2.0)}


def test_a_truncated_last_line_is_skipped_and_counted(tmp_path: Path) -> None:
    path = burst_trace(tmp_path / "trace.jsonl")
    with open(path, "a", encoding="utf-8") as f:
        f.write('{"wall": 1001.2, "floors": {"Kbot": [1')          # a crash in the middle of a line
    trace = load(path)
    assert (len(trace.samples), trace.skipped) == (6, 1)
    summary = summarize(trace)
    assert summary["skipped_lines"] == 1 and summary["stalls"] == 1
    assert "1 line skipped (not a sample)" in format_summary(summary)[0]
    # decoded lines that are not samples are skipped too
    assert summarize([{"wall": 1.0}, {"floors": {}}, "x", {"wall": 1.2}])["skipped_lines"] == 2


def test_an_empty_or_one_line_trace_gives_an_empty_summary(tmp_path: Path) -> None:
    empty = tmp_path / "empty.jsonl"
    TraceWriter(empty).close()
    for path in (empty, burst_trace(tmp_path / "one.jsonl")):
        lines = path.read_text().splitlines()[:1]
        path.write_text("".join(line + "\n" for line in lines))
        summary = summarize(load(path))
        assert (summary["windows"], summary["stalls"], summary["top"], summary["cores"]) == (0, 0, [], {})
        assert (summary["start_wall"], summary["trace_cores"]) == (None, 0.0)
        assert "no window to judge" in format_summary(summary)[-1]
        json.dumps(summary)
    assert summarize(Trace())["samples"] == 0 and summarize([])["windows"] == 0


def test_the_traces_own_cpu_is_recorded_and_reported(tmp_path: Path) -> None:
    path = tmp_path / "trace.jsonl"
    with TraceWriter(path) as writer:
        writer.sample(WALL0, {"A": Clock(0.0, WALL0)}, [])
        writer.sample(WALL0 + 0.2, {"A": Clock(4.0, WALL0 + 0.2)}, [], cost_from=time.process_time() - 0.5)
        assert writer.cpu_s >= 0.5 and writer.samples == 2
    summary = summarize(load(path))
    assert summary["trace_cpu_s"] >= 0.5 and summary["trace_cores"] >= 2.5
    assert "the trace's own CPU" in format_summary(summary)[-1]
    with pytest.raises(ValueError, match="already closed"):
        writer.sample(WALL0 + 0.4, {}, [])
    with pytest.raises(OSError, match="missing.jsonl: cannot be read"):
        load(tmp_path / "missing.jsonl")


def test_the_summary_prints_the_stalls_the_kinds_and_the_largest(tmp_path: Path) -> None:
    text = "\n".join(format_summary(summarize(load(burst_trace(tmp_path / "trace.jsonl")))))
    assert "6 samples, 5 windows over 1.0 s of wall time" in text
    assert "stalls: 1 window in which a floor's time behind its ceiling grew by >= 5 ms, 30 ms in all" in text
    assert "goal_manager" in text and " 0.90 " in text
    assert "+30 ms (Kbot, 200 ms window): Kbot/goal_manager 180 ms, Tartalo/end_node 130 ms" in text
    assert "before: Tartalo/sim 40 ms" in text


def test_demo_accepts_trace() -> None:
    assert command.parse_args(["--trace"]).trace is True
    assert command.parse_args([]).trace is False
    assert "--trace" in command.__doc__ and "trace.jsonl" in command.__doc__


def test_lateness_made_up_later_counts_in_the_windows_not_in_the_net(tmp_path: Path) -> None:
    """A floor late by 30 ms that then makes it up (no sleep before its next steps): a stall window, net 0."""
    looks = [({"Kbot": b}, {GM: 1.0 + 0.01 * i}) for i, b in enumerate([0.0, 0.0, 0.030, 0.010, 0.0])]
    summary = summarize(load(write_trace(tmp_path / "trace.jsonl", looks)))
    assert (summary["stalls"], summary["stall_ms"], summary["net_behind_ms"]) == (1, 30.0, 0.0)
    assert any("net over the span" in line for line in format_summary(summary))
