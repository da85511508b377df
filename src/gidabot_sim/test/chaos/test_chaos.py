"""Pieces of the chaos runner and probe that need no master: hostile messages, following the tour, logs."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from gidabot_navigation.interface import Node, Phase, global_name, relay_end_name
from gidabot_sim.chaos import core as cc

# callers as the probes record them
GM, NAV, PROBE = (global_name(n) for n in (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.CHAOS_PROBE))


def test_every_hostile_template_builds_a_message() -> None:
    pytest.importorskip("gidabot_msgs.msg")
    import io

    import roslib.message

    from gidabot_sim.chaos.probe_node import build_message

    for h in cc.HOSTILE_MESSAGES:
        data = cc.fill_placeholders(h.msg, "Kbot", "Tartalo")
        data = {k: v for k, v in data.items() if k != "header"}
        msg = build_message(roslib.message.get_message_class(h.type), data)
        buf = io.BytesIO()
        msg.serialize(buf)                      # what the probe publishes is a valid message of its type
        assert buf.tell() > 0, h.name
    goal = build_message(roslib.message.get_message_class("gidabot_msgs/Goal"),
                         cc.fill_placeholders(cc.hostile_by_name("goal_huge_strings").msg, "Kbot", "Tartalo"))
    assert len(goal.goal_id) == 300_000 and goal.goal_id == "9" * 300_000
    nan = build_message(roslib.message.get_message_class("gidabot_msgs/Goal"),
                        cc.hostile_by_name("goal_nan_pose").msg)
    assert math.isnan(nan.initial_pose.x)
    pend = build_message(roslib.message.get_message_class("gidabot_msgs/PendingRequests"),
                         cc.hostile_by_name("pending_spoofed").msg)
    assert math.isnan(pend.eta[0]) and math.isinf(pend.eta[1]) and pend.wait_new == -math.inf


def test_tour_watch_follows_the_tours_own_events_only() -> None:
    from gidabot_sim.chaos.chaos import TourWatch

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
    from gidabot_sim.chaos.chaos import Tail

    f = tmp_path / "a.jsonl"
    f.write_text(json.dumps({"k": 1}) + "\n" + '{"k": 2')
    tail = Tail([f, tmp_path / "missing.jsonl"])
    assert tail.read() == [{"k": 1}]
    with open(f, "a") as out:
        out.write("}\n")
    assert tail.read() == [{"k": 2}] and tail.read() == []


def test_arguments_and_defaults() -> None:
    from gidabot_sim.chaos.chaos import DEFAULT_SEED, parse_args

    args = parse_args([])
    assert args.seed == DEFAULT_SEED and args.profile == "full" and args.tour.name == "long_tour.tour"
    assert args.speed is None and not args.json
    args = parse_args(["--seed", "7", "--profile", "quick", "--json", "--speed", "5"])
    assert (args.seed, args.profile, args.json, args.speed) == (7, "quick", True, 5.0)
    with pytest.raises(SystemExit):
        parse_args(["--profile", "nope"])


def test_cli_knows_chaos() -> None:
    from gidabot_sim.cli import COMMANDS

    assert COMMANDS["chaos"][0] == "gidabot_sim.chaos.chaos"
