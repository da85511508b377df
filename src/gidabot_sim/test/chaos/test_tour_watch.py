"""Following the tour from the probes' records: its own events only, complete lines only."""

from __future__ import annotations

import json
from pathlib import Path

from gidabot_navigation.interface import Node, Phase, global_name, relay_end_name
from gidabot_sim.chaos.tour_watch import Tail, TourWatch

GM, NAV, PROBE = (global_name(n) for n in (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.CHAOS_PROBE))


def test_tour_watch_follows_the_tours_own_events_only() -> None:
    w = TourWatch("t.tour", last_step=1, robots={"Tartalo", "Kbot"})
    ev = {"k": "event", "m": "Tartalo", "robot": "Tartalo", "c": NAV, "tour_file": "t.tour"}
    w.feed([{"k": "goal", "m": "Tartalo", "origin": "Tartalo", "c": GM, "uid": "T/v/1",
             "tour_file": "t.tour"},
            {**ev, "phase": Phase.TOUR_STEP_DONE, "tour_step": 0},
            {**ev, "phase": Phase.UNREACHABLE, "tour_file": "other.tour"},                  # another visit
            {**ev, "c": PROBE, "phase": Phase.TOUR_FINISHED, "tour_step": 1},      # hostile
            {**ev, "m": "Kbot", "c": relay_end_name("Tartalo", "Kbot"), "phase": Phase.TOUR_FINISHED, "tour_step": 1}])
    assert w.goals == {"T/v/1"} and w.last_step_done == 0 and not w.finished and not w.failure
    w.feed([{**ev, "robot": "Kbot", "m": "Kbot", "phase": Phase.TOUR_FINISHED, "tour_step": 1}])
    assert w.finished and w.latest == "step 2 done at Kbot"
    w2 = TourWatch("t.tour", 1, {"Tartalo"})
    w2.feed([{**ev, "phase": Phase.TIMEOUT, "goal_uid": "T/v/1", "detail": "nobody came"}])
    assert "phase 10" in w2.failure


def test_tail_reads_only_complete_new_lines(tmp_path: Path) -> None:
    f = tmp_path / "a.jsonl"
    f.write_text(json.dumps({"k": 1}) + "\n" + '{"k": 2')
    tail = Tail([f, tmp_path / "missing.jsonl"])
    assert tail.read() == [{"k": 1}]
    with open(f, "a") as out:
        out.write("}\n")
    assert tail.read() == [{"k": 2}] and tail.read() == []
