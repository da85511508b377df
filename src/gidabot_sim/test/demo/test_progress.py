"""Progress of a run from monitor lines."""

from __future__ import annotations

import json

from gidabot_sim.demo.progress import Progress, stops_done


def line(**kw) -> str:
    return json.dumps(kw)


def test_tour_progress_and_end() -> None:
    p = Progress(total_goals=2)
    assert p.feed_line(line(kind="goal", uid="g1", goal_id="014", sim=100.0, wall=10.0))
    assert not p.feed_line(line(kind="goal", uid="g1", goal_id="014", sim=100.0, wall=10.0))  # seen
    p.feed_line(line(kind="event", robot="Tartalo", phase=1, goal_uid="g1", sim=101, wall=10.1))
    assert p.line() == "goal 1 of 2 (014), 0 done | Tartalo: on the way"
    p.feed_line(line(kind="event", robot="Tartalo", phase=13, goal_uid="g1", sim=150, wall=15))
    p.feed_line(line(kind="goal", uid="g2", goal_id="008", sim=160.0, wall=16.0))
    p.feed_line(line(kind="event", robot="Tartalo", phase=14, goal_uid="g2", sim=300, wall=30))
    assert p.finished and p.outcome == "completed" and len(p.completed) == 2
    assert p.sim_seconds() == 200 and p.wall_seconds() == 20


def test_failure_ends_and_garbage_is_ignored() -> None:
    p = Progress(total_goals=1, tour_mode=False)
    assert not p.feed_line("not json")
    assert not p.feed_line("[1, 2]")
    p.feed_line(line(kind="goal", uid="g", goal_id="305", sim=0, wall=0))
    p.feed_line(line(kind="event", robot="MariSorgin", phase=6, goal_uid="g", detail="no path", sim=5, wall=1))
    assert p.finished and p.outcome.startswith("unreachable (MariSorgin")


def test_single_target_done() -> None:
    p = Progress(total_goals=1, tour_mode=False)
    p.feed_line(line(kind="goal", uid="g", goal_id="305", sim=0, wall=0))
    p.feed_line(line(kind="status", robot="Kbot", state="idle"))
    p.feed_line(line(kind="event", robot="Kbot", phase=2, goal_uid="g", sim=50, wall=5))
    assert p.finished and p.outcome == "completed" and p.states == {"Kbot": "idle"}


def test_start_up_then_goal_numbers_follow_the_tour_step() -> None:
    p = Progress(total_goals=15, robots_total=4)
    assert p.feed_line(line(kind="up", robot="Kbot", sim=0, wall=0))
    assert not p.feed_line(line(kind="up", robot="Kbot", sim=0, wall=0))
    assert p.line() == "starting: 1 of 4 robots up (Kbot)"
    p.feed_line(line(kind="goal", uid="a", goal_id="002", tour_step=0, initial_floor=0, goal_floor=0, sim=1, wall=1))
    p.feed_line(line(kind="goal", uid="b", goal_id="305", tour_step=1, initial_floor=0, goal_floor=3, sim=2, wall=2))
    p.feed_line(line(kind="event", robot="MariSorgin", phase=4, goal_uid="b", sim=3, wall=3))
    assert p.line() == "goal 2 of 15 (305 0->3), 0 done | MariSorgin: going to meeting point"
    # a skip cancels the running step: not the end of the visit
    p.feed_line(line(kind="event", robot="MariSorgin", phase=9, goal_uid="b", sim=4, wall=4))
    p.feed_line(line(kind="event", robot="Tartalo", phase=15, goal_uid="b", sim=4, wall=4))
    assert not p.finished and p.line().endswith("Tartalo: partner lost")


def test_an_unfinished_run_is_measured_up_to_its_newest_record() -> None:
    p = Progress(total_goals=8)
    p.feed_line(line(kind="goal", uid="a", goal_id="014", tour_step=0, sim=100.0, wall=10.0))
    p.feed_line(line(kind="event", robot="Tartalo", phase=1, goal_uid="a", sim=160.0, wall=13.0))
    assert not p.finished and p.sim_seconds() == 60.0 and p.wall_seconds() == 3.0


def test_stops_found_alone_count_as_done() -> None:
    """Table 4 on faculty3: steps 4 and 5 are on floor 2 (no robot); the goal of step 4 sends the visitor there,
    step 5 gets no goal; the tour goes on at step 6."""
    assert stops_done({0, 1, 2, 3, 4, 6, 7}, frozenset({4, 5})) == set(range(8))
    assert stops_done({0, 1, 2, 3}, frozenset({4, 5})) == {0, 1, 2, 3}      # not sent there yet
    p = Progress(total_goals=8, alone=frozenset({4, 5}))
    for k, phase in ((3, 13), (4, 7), (6, 13), (7, 14)):
        p.feed_line(line(kind="event", robot="Kbot", phase=phase, goal_uid=f"g{k}", tour_step=k, sim=k, wall=k))
    assert p.done == 5 and p.finished and p.outcome == "completed"      # steps 3..7 (5: found alone)


def test_a_single_target_on_a_floor_without_robot_is_done_when_the_visitor_is_sent_there() -> None:
    p = Progress(total_goals=1, tour_mode=False)
    p.feed_line(line(kind="goal", uid="g", goal_id="223", sim=0, wall=0))
    p.feed_line(line(kind="event", robot="Tartalo", phase=7, goal_uid="g", sim=50, wall=5))
    assert p.finished and p.outcome == "completed" and p.done == 1
