"""Report: Table 3/5 numbers from rosbags written like `rosbag record` does, and path plots."""

from __future__ import annotations

import functools
import io
import json
from pathlib import Path

import pytest

from gidabot_navigation.interface import (
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_PROPOSED,
    LEG_START,
    Node,
    Phase,
    Topic,
    global_name,
    relay_end_name,
)
from gidabot_sim.report.bags import EventSample, PoseSample, RobotRecord
from gidabot_sim.report.command import main
from gidabot_sim.report.tables import MAX_GOAL_START_LAG, analyse, guiding_intervals, leg_audit, path_length
from gidabot_sim.report.text import format_tables

REPO = Path(__file__).resolve().parents[4]


def _bag(path: Path, messages: list[tuple]) -> None:
    """Write a rosbag1 file the way rosbag record does (genpy serialisation, full msgdef, one connection per
    topic and publisher): (topic, msg, t) or (topic, msg, t, callerid)."""
    from rosbags.rosbag1 import Writer

    with Writer(path) as writer:
        conns = {}
        for topic, msg, t, *caller in messages:
            key = (topic, caller[0] if caller else None)
            if key not in conns:
                msgtype = msg._type.replace("/", "/msg/")
                conns[key] = writer.add_connection(topic, msgtype, msgdef=msg._full_text, md5sum=msg._md5sum,
                                                   callerid=key[1])
            buf = io.BytesIO()
            msg.serialize(buf)
            writer.write(conns[key], int(t * 1e9), buf.getvalue())


@functools.cache
def _faculty():
    from gidabot_navigation.building.model import load_building

    return load_building(REPO / "maps" / "faculty")


def _goal(uid: str, origin: str = "Tartalo", to: str = "008", step: int = -1, **kw):
    """A goal as origin's goal manager makes it (valid for the faculty: validate_trip)."""
    from gidabot_msgs.msg import Goal

    b = _faculty()
    start, loc = b.robot(origin), b.location(to)
    goal_robot = b.robots_on(loc.floor)[0].name if start.floor != loc.floor else ""
    g = Goal(uid=uid, origin_robot=origin, visitor_id="sim-visitor", initial_floor=start.floor,
             goal_floor=loc.floor, way="stairs", connector="stairs_west" if start.floor != loc.floor else "",
             start_id="robot", goal_id=to, language="en", tour_file="t.tour" if step >= 0 else "",
             tour_step=step, start_robot=origin, start_state=LEG_COMMITTED, goal_robot=goal_robot,
             goal_state=LEG_COMMITTED if goal_robot else 0, attempt=2)
    g.initial_pose.x, g.initial_pose.y = start.home.x, start.home.y
    g.goal_pose.position.x, g.goal_pose.position.y = loc.pose.x, loc.pose.y
    g.goal_pose.orientation.w = 1.0
    for k, v in kw.items():
        setattr(g, k, v)
    return g


def _event(robot: str, uid: str, phase: int, t: float):
    from gidabot_msgs.msg import NavEvent

    ev = NavEvent(robot=robot, goal_uid=uid, phase=phase)
    ev.header.stamp.secs, ev.header.stamp.nsecs = int(t), int((t % 1) * 1e9)
    return ev


def _pose(robot: str, x: float, y: float, t: float):
    from gidabot_msgs.msg import NavPose

    p = NavPose(robot=robot)
    p.nav_pose.position.x, p.nav_pose.position.y = x, y
    p.header.stamp.secs, p.header.stamp.nsecs = int(t), int((t % 1) * 1e9)
    return p


def test_tables_from_bags(tmp_path: Path) -> None:
    pytest.importorskip("gidabot_msgs.msg")
    goals = [_goal(f"Tartalo/v/{i}") for i in range(3)]
    msgs = [(Topic.GOALS, g, 1.0 + i) for i, g in enumerate(goals)]
    msgs += [
        (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/0", Phase.ACCEPTED, 10.0), 10.0),
        (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/0", Phase.ON_THE_WAY, 10.0), 10.0),
        (Topic.NAV_EVENTS, _event("Kbot", "Tartalo/v/1", Phase.ACCEPTED, 10.5), 10.5),  # another robot's
        (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/0", Phase.GOAL_REACHED, 30.0), 30.0),
        (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/1", Phase.ACCEPTED, 31.0), 31.0),
    ]
    msgs += [(Topic.POSES, _pose("Tartalo", 10.0 + k, 12.0, 10.0 + k), 10.0 + k) for k in range(21)]
    msgs += [(Topic.POSES, _pose("Tartalo", 40.0, 12.0, 40.0), 40.0)]   # moving alone: not guiding
    msgs.sort(key=lambda m: m[2])
    _bag(tmp_path / "Tartalo.bag", msgs)
    run = {"building": str(REPO / "maps" / "faculty"), "tour": "t.tour", "goals": 3, "sim_s": 600.0, "wall_s": 60.0,
           "robots": [{"name": "Tartalo", "floor": 0, "bag": "Tartalo.bag"}]}
    (tmp_path / "run.json").write_text(json.dumps(run))

    assert main([str(tmp_path), "--json"]) == 0
    out = json.loads((tmp_path / "report.json").read_text())
    row = out["robots"][0]
    assert (row["received"], row["processed"]) == (3, 1)     # v/1 accepted but never run: not processed
    assert row["time_s"] == pytest.approx(20.0) and row["distance_m"] == pytest.approx(20.0)
    assert row["mean_velocity_mps"] == pytest.approx(1.0)
    assert out["tour"]["completed"] == 1 and out["tour"]["sim_to_wall"] == pytest.approx(10.0)
    assert len(out["plots"]) == 4 and all(Path(p).stat().st_size > 10_000 for p in out["plots"])
    assert "Tartalo" in format_tables(out)


def test_guiding_intervals_and_length() -> None:
    ev = [EventSample(0, "R", "a", Phase.ON_THE_WAY), EventSample(5, "R", "a", Phase.GO_TO_FLOOR),
          EventSample(9, "R", "b", Phase.ON_THE_WAY), EventSample(12, "R", "b", Phase.CANCELLED_HERE)]
    assert guiding_intervals(ev) == [(0, 5), (9, 12)]
    poses = [PoseSample(t, float(t), 0.0) for t in range(13)]
    assert path_length(poses, [(0, 5), (9, 12)]) == pytest.approx(8.0)
    assert path_length(poses + [PoseSample(13, float("nan"), 0.0)]) == pytest.approx(12.0)


def test_guiding_starts_when_move_base_took_the_legs_goal() -> None:
    """The guiding node decides (ON_THE_WAY) and move_base takes the goal a little later in wall time: at high
    speeds that latency is sim time no robot spent guiding. A goal taken before the ON_THE_WAY (the pickup's),
    after the leg, or implausibly late (a goal sent again after a restart) does not move the start."""
    ev = [EventSample(10, "R", "a", Phase.ON_THE_WAY), EventSample(40, "R", "a", Phase.GOAL_REACHED),
          EventSample(50, "R", "b", Phase.ON_THE_WAY), EventSample(80, "R", "b", Phase.GO_TO_FLOOR),
          EventSample(90, "R", "c", Phase.ON_THE_WAY), EventSample(95, "R", "c", Phase.GOAL_REACHED)]
    starts = [2.0, 11.2, 20.0, 50.0 + MAX_GOAL_START_LAG + 1, 96.0]
    assert guiding_intervals(ev, starts) == [(11.2, 40), (50, 80), (90, 95)]
    assert guiding_intervals(ev) == [(10, 40), (50, 80), (90, 95)]      # bags without current_goal


def test_guiding_leaves_out_the_waits_and_searches_for_the_visitor() -> None:
    """Table 5 is the guiding with the visitor behind the robot: from a WAITING_FOR_YOU or a SEARCHING_VISITOR to
    the FOLLOW_ME is left out (a search after a wait too), and its distance with it."""
    ev = [EventSample(10, "R", "a", Phase.ON_THE_WAY), EventSample(20, "R", "a", Phase.WAITING_FOR_YOU),
          EventSample(25, "R", "a", Phase.FOLLOW_ME), EventSample(30, "R", "a", Phase.WAITING_FOR_YOU),
          EventSample(50, "R", "a", Phase.SEARCHING_VISITOR), EventSample(70, "R", "a", Phase.FOLLOW_ME),
          EventSample(80, "R", "a", Phase.GOAL_REACHED),
          EventSample(90, "R", "b", Phase.ON_THE_WAY), EventSample(95, "R", "b", Phase.WAITING_FOR_YOU),
          EventSample(99, "R", "b", Phase.VISITOR_LOST)]
    assert guiding_intervals(ev, [11.0]) == [(11.0, 20), (25, 30), (70, 80), (90, 95)]
    poses = [PoseSample(t, float(t), 0.0) for t in range(100)]
    assert path_length(poses, guiding_intervals(ev)) == pytest.approx(10 + 5 + 10 + 5)


def test_missing_run_folder(tmp_path: Path, capsys) -> None:
    assert main([str(tmp_path)]) == 1
    assert "run.json: cannot read" in capsys.readouterr().err
    (tmp_path / "run.json").write_text(json.dumps({"robots": [{"name": "Kbot"}]}))
    assert main([str(tmp_path)]) == 1
    assert "Kbot.bag: missing bag of robot Kbot" in capsys.readouterr().err


def _amcl(x: float, y: float, t: float):
    from geometry_msgs.msg import PoseWithCovarianceStamped

    m = PoseWithCovarianceStamped()
    m.header.frame_id = "map"
    m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.orientation.w = x, y, 1.0
    m.header.stamp.secs, m.header.stamp.nsecs = int(t), int(round((t % 1) * 1e9))
    return m


def test_distance_from_the_robots_own_localisation(tmp_path: Path) -> None:
    """/amcl_pose (a sample every 0.1 m) wins over the coarse shared /gidabot/poses when the bag has it."""
    pytest.importorskip("gidabot_msgs.msg")
    msgs = [(Topic.GOALS, _goal("Kbot/v/0", "Kbot", "104", 0), 1.0),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/v/0", Phase.ON_THE_WAY, 10.0), 10.0),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/v/0", Phase.TOUR_FINISHED, 30.0), 30.0)]
    # an L-shaped drive: 5 m east then 5 m north, 0.1 m per amcl_pose; the shared poses cut the corner
    path = [(20.0 + 0.1 * k, 10.0) for k in range(51)] + [(25.0, 10.0 + 0.1 * k) for k in range(1, 51)]
    amcl = global_name(Topic.AMCL_POSE)
    msgs += [(amcl, _amcl(x, y, 10.0 + 0.2 * k), 10.0 + 0.2 * k) for k, (x, y) in enumerate(path)]
    msgs += [(Topic.POSES, _pose("Kbot", 20.0, 10.0, 10.0), 10.0),
             (Topic.POSES, _pose("Kbot", 25.0, 15.0, 29.9), 29.9)]
    msgs.sort(key=lambda m: m[2])
    _bag(tmp_path / "Kbot.bag", msgs)
    run = {"tour": "t.tour", "goals": 1, "robots": [{"name": "Kbot", "floor": 1, "bag": "Kbot.bag"}],
           "building": str(REPO / "maps" / "faculty")}
    (tmp_path / "run.json").write_text(json.dumps(run))
    assert main([str(tmp_path), "--json"]) == 0
    out = json.loads((tmp_path / "report.json").read_text())
    assert out["robots"][0]["distance_m"] == pytest.approx(10.0, abs=0.05)
    assert out["robots"][0]["time_s"] == pytest.approx(20.0)
    assert out["tour"]["completed"] == 1 and out["run_folder"] == str(tmp_path.resolve())
    assert (tmp_path / "paths_floor1.png").stat().st_size > 10_000


def test_an_unreadable_message_is_skipped_and_counted(tmp_path: Path, capsys) -> None:
    """A zero-length message (seen once from a relay end) must not cost the whole report."""
    pytest.importorskip("gidabot_msgs.msg")
    from rosbags.rosbag1 import Writer

    from gidabot_msgs.msg import NavPose

    good = _pose("Tartalo", 10.0, 12.0, 5.0)
    buf = io.BytesIO()
    good.serialize(buf)
    with Writer(tmp_path / "Tartalo.bag") as writer:
        conn = writer.add_connection(Topic.POSES, "gidabot_msgs/msg/NavPose", msgdef=NavPose._full_text,
                                     md5sum=NavPose._md5sum)
        writer.write(conn, int(4e9), b"")
        writer.write(conn, int(5e9), buf.getvalue())
    run = {"goals": 0, "robots": [{"name": "Tartalo", "floor": 0}], "building": str(REPO / "maps" / "faculty")}
    (tmp_path / "run.json").write_text(json.dumps(run))
    assert main([str(tmp_path), "--no-plots"]) == 0
    assert f"Tartalo: {Topic.POSES}: 1 message(s) in the bag could not be deserialised" in capsys.readouterr().out
    assert json.loads((tmp_path / "report.json").read_text())["unreadable_messages"] == {f"Tartalo: {Topic.POSES}": 1}


def test_bag_parts_are_read_together_and_hostile_goals_are_not_counted(tmp_path: Path) -> None:
    """After a master restart a robot's recording goes on in a new part; the parts overlap a little."""
    pytest.importorskip("gidabot_msgs.msg")
    goal = _goal

    ghost = goal("Ghost/v/1")
    ghost.origin_robot = "Ghost"                          # no such robot
    nan = goal("Tartalo/v/nan")
    nan.initial_pose.x = float("nan")
    hostile = [ghost, nan, goal("Tartalo/v/big", visitor_id="x" * 5000), goal("Tartalo/v/f", goal_floor=7.5),
               goal("bad uid with spaces"), goal("Tartalo/v/room", goal_id="999"),
               goal("Tartalo/v/far", goal_pose=goal("x").goal_pose.__class__())]       # a goal pose 30 m off
    first = [(Topic.GOALS, goal("Tartalo/v/0"), 1.0),
             (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/0", Phase.ACCEPTED, 2.0), 2.0),
             (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/0", Phase.ON_THE_WAY, 3.0), 3.0)]
    first += [(Topic.GOALS, h, 4.0) for h in hostile]
    second = [(Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/0", Phase.ON_THE_WAY, 3.0), 3.0),  # again
              (Topic.GOALS, goal("Tartalo/v/1"), 5.0),
              (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/1", Phase.ACCEPTED, 6.0), 6.0),
              (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/0", Phase.GOAL_REACHED, 13.0), 13.0),
              (Topic.NAV_EVENTS, _event("Tartalo", "Tartalo/v/1", Phase.GOING_TO_MEETING, 14.0), 14.0)]
    _bag(tmp_path / "Tartalo.bag", first)
    _bag(tmp_path / "Tartalo.1.bag", second)
    run = {"tour": "t.tour", "goals": 2, "building": str(REPO / "maps" / "faculty"),
           "robots": [{"name": "Tartalo", "floor": 0, "bag": "Tartalo.bag", "bags": ["Tartalo.bag", "Tartalo.1.bag"]}]}
    (tmp_path / "run.json").write_text(json.dumps(run))
    assert main([str(tmp_path), "--json", "--no-plots"]) == 0
    out = json.loads((tmp_path / "report.json").read_text())
    row = out["robots"][0]
    assert (row["received"], row["processed"]) == (2, 2)
    assert row["time_s"] == pytest.approx(10.0)           # one ON_THE_WAY (in both parts) -> GOAL_REACHED
    assert out["rejected_goals"] == {"Tartalo": len(hostile)}
    assert "were not goals" in format_tables(out)


def test_leg_audit_from_the_robots_records() -> None:
    """Each leg's robot from every bag: committed in a goal, named in ASSIGNED, serving phases."""
    t = RobotRecord("Tartalo", 0.0, assignments={("T/v/1", LEG_START, "Tartalo", LEG_COMMITTED),
                                                         ("T/v/1", LEG_GOAL, "Galtxagorri", LEG_PROPOSED),
                                                         ("T/v/1", LEG_GOAL, "Lamia", LEG_COMMITTED)})
    t.events = [EventSample(1, "Tartalo", "T/v/1", Phase.ASSIGNED, leg=LEG_GOAL, assignee="Lamia"),
                EventSample(2, "Tartalo", "T/v/1", Phase.ON_THE_WAY, leg=LEG_START),
                EventSample(9, "Tartalo", "T/v/1", Phase.GO_TO_FLOOR, leg=LEG_START)]
    galt = RobotRecord("Galtxagorri", 2.0, events=[EventSample(20, "Galtxagorri", "T/v/1", Phase.ACCEPTED,
                                                                       leg=LEG_GOAL)])
    lamia = RobotRecord("Lamia", 2.0, events=[EventSample(3, "Lamia", "T/v/1", Phase.GOING_TO_MEETING,
                                                                  leg=LEG_GOAL)])
    legs = leg_audit([t, galt, lamia])
    assert legs == {"legs": 2, "double_served": [], "unserved": [], "served_by": {"Tartalo": 1, "Lamia": 1}}
    galt.events.append(EventSample(21, "Galtxagorri", "T/v/1", Phase.GOING_TO_MEETING, leg=LEG_GOAL))
    assert leg_audit([t, galt, lamia])["double_served"] == [["T/v/1", LEG_GOAL, ["Galtxagorri", "Lamia"]]]
    text = format_tables({**analyse([t, galt, lamia], {}), "tour": {
        "time_s": 0, "distance_m": 0, "mean_velocity_mps": 0, "completed": 0, "goals": 1, "sim_s": 0, "wall_s": 0,
        "sim_to_wall": 0}})
    assert "Legs: 2, 1 served by two robots or more, 0 by none" in text


def test_table3_leaves_hostile_input_out(tmp_path: Path) -> None:
    """Hostile traffic on Kbot's master (invalid goals, valid-looking goals from a foreign node,
    ACCEPTED events for trips that do not exist, extra tour completions and legs claiming Kbot) must not
    change received (goals Kbot validated and kept), processed (trips Kbot ran) or the completions."""
    pytest.importorskip("gidabot_msgs.msg")
    gm, nav = global_name(Node.GOAL_MANAGER), global_name(Node.MULTIROBOT_NAVIGATION)
    relay, bad = relay_end_name("Tartalo", "Kbot"), "/hostile"
    real = [(Topic.GOALS, _goal("Tartalo/v/1", "Tartalo", "101", 0), 1.0, relay),     # 0 -> 1: Kbot's
            (Topic.GOALS, _goal("Tartalo/v/2", "Tartalo", "014", 1), 2.0, relay),     # 0 -> 0: not Kbot's
            (Topic.GOALS, _goal("Kbot/v/3", "Kbot", "104", 2), 3.0, gm),              # 1 -> 1
            (Topic.NAV_EVENTS, _event("Kbot", "Tartalo/v/1", Phase.ACCEPTED, 4.0), 4.0, gm),
            (Topic.NAV_EVENTS, _event("Kbot", "Tartalo/v/1", Phase.WAITING_VISITOR, 5.0), 5.0, nav),
            (Topic.NAV_EVENTS, _event("Kbot", "Tartalo/v/1", Phase.ON_THE_WAY, 10.0), 10.0, nav),
            (Topic.NAV_EVENTS, _event("Kbot", "Tartalo/v/1", Phase.TOUR_STEP_DONE, 20.0), 20.0, nav),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/v/3", Phase.ACCEPTED, 21.0), 21.0, gm),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/v/3", Phase.ON_THE_WAY, 22.0), 22.0, nav),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/v/3", Phase.TOUR_FINISHED, 30.0), 30.0, gm)]
    hostile = [(Topic.GOALS, _goal("Tartalo/v/9", "Tartalo", "101", 0), 6.0, bad),     # valid, forged
               (Topic.GOALS, _goal("Kbot/v/8", "Kbot", "104", 0), 6.0, relay),        # Kbot's, via a relay
               (Topic.GOALS, _goal("Tartalo/v/7", "Tartalo", "101", 0, goal_id="999"), 6.0, relay)]
    for k in range(10):
        uid = f"Nobody/x/{k}"
        hostile += [(Topic.NAV_EVENTS, _event("Kbot", uid, Phase.ACCEPTED, 7.0 + k), 7.0 + k, bad),
                    (Topic.NAV_EVENTS, _event("Kbot", uid, Phase.ON_THE_WAY, 7.0 + k), 7.0 + k, bad),
                    (Topic.NAV_EVENTS, _event("Kbot", uid, Phase.TOUR_STEP_DONE, 7.5 + k), 7.5 + k, bad),
                    (Topic.NAV_EVENTS, _event("Kbot", uid, Phase.TOUR_FINISHED, 7.5 + k), 7.5 + k, relay)]
    _bag(tmp_path / "Kbot.bag", sorted(real + hostile, key=lambda m: m[2]))
    run = {"tour": "t.tour", "goals": 3, "building": str(REPO / "maps" / "faculty"),
           "robots": [{"name": "Kbot", "floor": 1, "bag": "Kbot.bag"}]}
    (tmp_path / "run.json").write_text(json.dumps(run))
    assert main([str(tmp_path), "--json", "--no-plots"]) == 0
    out = json.loads((tmp_path / "report.json").read_text())
    row = out["robots"][0]
    assert (row["received"], row["processed"]) == (3, 2)
    assert row["time_s"] == pytest.approx(18.0)           # 10 -> 20 and 22 -> 30: no hostile ON_THE_WAY
    assert out["tour"]["completed"] == 2
    assert out["rejected_goals"] == {"Kbot": 3}


def _sim_diag(t: float, collisions: int | None, deadlocks: int = 0):
    """The floor simulator's /diagnostics status (``robot_collisions`` None: an old simulator without the count)."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

    values = [KeyValue("sim_time", f"{t:.2f}")]
    if collisions is not None:
        values += [KeyValue("robot_collisions", str(collisions)), KeyValue("robot_deadlocks", str(deadlocks))]
    msg = DiagnosticArray(status=[DiagnosticStatus(name="sim: floor 1", values=values)])
    msg.header.stamp.secs, msg.header.stamp.nsecs = int(t), int((t % 1) * 1e9)
    return msg


def _crowd_run(tmp_path: Path, *, collisions: tuple[int | None, ...] = (0, 0), no_show_b: bool = True,
               extra_msgs: tuple = (), extra_monitor: tuple = (), visitors: tuple = ("a", "b")) -> dict:
    """A many-visitors run folder at Kbot: a completes; b times out (as it chose when ``no_show_b``); the bag holds
    the simulator's collision counter at 10 s and 300 s. Returns the report (report.json)."""
    tmp_path.mkdir(parents=True)
    gm, nav = global_name(Node.GOAL_MANAGER), global_name(Node.MULTIROBOT_NAVIGATION)
    msgs = [(Topic.GOALS, _goal("Kbot/a/1", "Kbot", "104", visitor_id="a"), 1.0, gm),
            (Topic.GOALS, _goal("Kbot/b/1", "Kbot", "110", visitor_id="b"), 2.0, gm),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/a/1", Phase.ACCEPTED, 1.5), 1.5, gm),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/a/1", Phase.ON_THE_WAY, 5.0), 5.0, nav),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/a/1", Phase.GOAL_REACHED, 40.0), 40.0, nav),
            (Topic.NAV_EVENTS, _event("Kbot", "Kbot/b/1", Phase.TIMEOUT, 400.0), 400.0, nav),
            (Topic.DIAGNOSTICS, _sim_diag(10.0, collisions[0]), 10.0),
            (Topic.DIAGNOSTICS, _sim_diag(300.0, collisions[1]), 300.0), *extra_msgs]
    msgs.sort(key=lambda m: m[2])
    _bag(tmp_path / "Kbot.bag", msgs)
    monitor = [{"kind": "goal", "uid": "Kbot/a/1", "visitor_id": "a", "sim": 1.0, "wall": 0.1, "start_robot": "Kbot",
                "start_state": LEG_COMMITTED, "attempt": 1},
               {"kind": "goal", "uid": "Kbot/b/1", "visitor_id": "b", "sim": 2.0, "wall": 0.2, "start_robot": "Kbot",
                "start_state": LEG_COMMITTED, "attempt": 1},
               {"kind": "event", "uid": "Kbot/event/1", "robot": "Kbot", "goal_uid": "Kbot/a/1",
                "phase": Phase.ON_THE_WAY, "sim": 5.0},
               {"kind": "event", "uid": "Kbot/event/2", "robot": "Kbot", "goal_uid": "Kbot/a/1",
                "phase": Phase.GOAL_REACHED, "sim": 40.0},
               {"kind": "event", "uid": "Kbot/event/3", "robot": "Kbot", "goal_uid": "Kbot/b/1",
                "phase": Phase.TIMEOUT, "sim": 400.0}, *extra_monitor]
    (tmp_path / "monitor.jsonl").write_text("".join(json.dumps(r) + "\n" for r in monitor))
    targets = {"a": "104", "b": "110", "c": "115"}
    population = [{"visitor_id": v, "arrive_s": 0.0, "robot": "Kbot", "way": "stairs", "goal_id": targets[v],
                   "no_show": v == "b" and no_show_b} for v in visitors]
    run = {"tour": f"{len(visitors)} visitors", "goals": 2, "building": str(REPO / "maps" / "faculty"),
           "outcome": "completed", "seed": 5, "visitors": len(visitors), "population": population,
           "robots": [{"name": "Kbot", "floor": 1, "bag": "Kbot.bag"}]}
    (tmp_path / "run.json").write_text(json.dumps(run))
    code = main([str(tmp_path), "--json", "--no-plots"])
    out = json.loads((tmp_path / "report.json").read_text())
    assert code == (1 if out["verdict"] == "FAILED" else 0)
    return out


def test_a_run_with_many_visitors_gets_their_statistics_and_a_verdict_that_can_fail(tmp_path: Path) -> None:
    """Two visitors at Kbot: one completes, one never turns up at the meeting point as it chose: PASSED, with the
    statistics and the collisions counted by the simulator (0); b wanting to arrive but timing out: FAILED."""
    pytest.importorskip("gidabot_msgs.msg")
    out = _crowd_run(tmp_path / "ok")
    assert (out["visitors"], out["completed"], out["timed_out"], out["verdict"]) == (2, 1, 1, "PASSED")
    assert (out["collisions"], out["deadlocks"], out["problems"]) == (0, 0, [])
    assert (out["legs_double_served"], out["legs_unserved"], out["wait_mean_s"], out["wait_p95_s"]) == (0, 0, 4.0, 4.0)
    assert out["population"]["per_robot"][0]["legs_served"] == 2
    text = format_tables(out)
    assert "Visitors: 2 (seed 5): 1 completed" in text and "Verdict: PASSED" in text
    assert "Collisions (robot-robot): 0" in text
    out = _crowd_run(tmp_path / "not_chosen", no_show_b=False)
    assert out["verdict"] == "FAILED" and out["problems"] == ["b (complete, 110 from Kbot): timed out"]


def test_the_verdict_fails_on_a_collision_or_a_count_that_is_missing(tmp_path: Path) -> None:
    pytest.importorskip("gidabot_msgs.msg")
    out = _crowd_run(tmp_path / "hit", collisions=(0, 1))
    assert (out["collisions"], out["verdict"]) == (1, "FAILED")
    assert out["problems"] == ["1 robot-robot collision(s): Kbot 1"]
    out = _crowd_run(tmp_path / "restarted", collisions=(2, 0))       # the simulator restarted after 2: still 2
    assert out["collisions"] == 2 and out["verdict"] == "FAILED"
    out = _crowd_run(tmp_path / "old", collisions=(None, None))
    assert out["collisions"] is None and out["verdict"] == "FAILED"
    assert out["problems"] == ["robot-robot collisions not measured (no count from the simulator of Kbot)"]


def test_the_verdict_fails_on_a_leg_served_twice_or_by_nobody(tmp_path: Path) -> None:
    pytest.importorskip("gidabot_msgs.msg")
    gm, nav = global_name(Node.GOAL_MANAGER), global_name(Node.MULTIROBOT_NAVIGATION)
    # a second robot of Kbot's floor also announces the start leg of a's trip as its own: two robots on one leg
    twice = _event("Kbot", "Kbot/a/1", Phase.ASSIGNED, 1.2)
    twice.leg, twice.assignee = LEG_START, "Basajaun"
    serve = _event("Kbot", "Kbot/a/1", Phase.ON_THE_WAY, 5.0)
    serve.leg = LEG_START
    out = _crowd_run(tmp_path / "twice", extra_msgs=((Topic.NAV_EVENTS, twice, 1.2, gm),
                                                     (Topic.NAV_EVENTS, serve, 5.0, nav)))
    assert out["legs_double_served"] == 1 and out["verdict"] == "FAILED"
    assert any("served by Basajaun, Kbot" in p for p in out["problems"])
    # a goal whose start leg was proposed and never taken, and whose trip never ended: a leg served by nobody
    orphan = _goal("Kbot/c/1", "Kbot", "115", visitor_id="c", start_state=LEG_PROPOSED, attempt=1)
    out = _crowd_run(tmp_path / "nobody", visitors=("a", "b", "c"),
                     extra_msgs=((Topic.GOALS, orphan, 3.0, gm),),
                     extra_monitor=({"kind": "goal", "uid": "Kbot/c/1", "visitor_id": "c", "sim": 3.0,
                                     "start_robot": "Kbot", "start_state": LEG_PROPOSED, "attempt": 1},))
    assert out["legs_unserved"] == 1 and out["verdict"] == "FAILED"
    assert "leg start of Kbot/c/1 served by nobody" in out["problems"]


def test_the_verdict_fails_on_a_lost_or_a_duplicated_goal(tmp_path: Path) -> None:
    pytest.importorskip("gidabot_msgs.msg")
    # c asked (the visitor's record) and no goal was ever made for it: lost
    out = _crowd_run(tmp_path / "lost", visitors=("a", "b", "c"),
                     extra_monitor=({"kind": "visitor", "event": "asked", "visitor": "c", "robot": "Kbot",
                                     "shown": [0.0], "patience_s": 600.0, "sim": 2.5},))
    assert out["verdict"] == "FAILED" and "c: its request made no goal (lost)" in out["problems"]
    # a second goal for a's one request while the first is open: duplicated
    gm = global_name(Node.GOAL_MANAGER)
    dup = _goal("Kbot/a/2", "Kbot", "104", visitor_id="a")
    out = _crowd_run(tmp_path / "dup", extra_msgs=((Topic.GOALS, dup, 1.1, gm),),
                     extra_monitor=({"kind": "goal", "uid": "Kbot/a/2", "visitor_id": "a", "sim": 1.1,
                                     "start_robot": "Kbot", "start_state": LEG_COMMITTED, "attempt": 1},))
    assert out["verdict"] == "FAILED" and "a: 1 duplicated goal(s)" in out["problems"]
    # c left at the screen (shown a wait beyond its patience): as it chose, PASSED
    out = _crowd_run(tmp_path / "left", visitors=("a", "b", "c"),
                     extra_monitor=({"kind": "visitor", "event": "left", "visitor": "c", "robot": "Kbot",
                                     "shown": [900.0], "patience_s": 600.0, "sim": 2.5},))
    assert (out["left"], out["verdict"]) == (1, "PASSED")
