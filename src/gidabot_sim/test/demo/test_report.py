"""Report: Table 3/5 numbers from rosbags written like `rosbag record` does, and path plots."""

from __future__ import annotations

import functools
import io
import json
from pathlib import Path

import pytest

from gidabot_navigation.interface import Node, Phase, Topic, global_name, relay_end_name
from gidabot_sim.demo import report

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
    g = Goal(uid=uid, origin_robot=origin, visitor_id="sim-visitor", initial_floor=start.floor,
             goal_floor=loc.floor, way="stairs", connector="stairs_west" if start.floor != loc.floor else "",
             start_id="robot", goal_id=to, language="en", tour_file="t.tour" if step >= 0 else "",
             tour_step=step)
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

    assert report.main([str(tmp_path), "--json"]) == 0
    out = json.loads((tmp_path / "report.json").read_text())
    row = out["robots"][0]
    assert (row["received"], row["processed"]) == (3, 1)     # v/1 accepted but never run: not processed
    assert row["time_s"] == pytest.approx(20.0) and row["distance_m"] == pytest.approx(20.0)
    assert row["mean_velocity_mps"] == pytest.approx(1.0)
    assert out["tour"]["completed"] == 1 and out["tour"]["sim_to_wall"] == pytest.approx(10.0)
    assert len(out["plots"]) == 4 and all(Path(p).stat().st_size > 10_000 for p in out["plots"])
    assert "Tartalo" in report.format_tables(out)


def test_guiding_intervals_and_length() -> None:
    ev = [report.EventSample(0, "R", "a", Phase.ON_THE_WAY), report.EventSample(5, "R", "a", Phase.GO_TO_FLOOR),
          report.EventSample(9, "R", "b", Phase.ON_THE_WAY), report.EventSample(12, "R", "b", Phase.CANCELLED_HERE)]
    assert report.guiding_intervals(ev) == [(0, 5), (9, 12)]
    poses = [report.PoseSample(t, float(t), 0.0) for t in range(13)]
    assert report.path_length(poses, [(0, 5), (9, 12)]) == pytest.approx(8.0)
    assert report.path_length(poses + [report.PoseSample(13, float("nan"), 0.0)]) == pytest.approx(12.0)


def test_missing_run_folder(tmp_path: Path, capsys) -> None:
    assert report.main([str(tmp_path)]) == 1
    assert "run.json: cannot read" in capsys.readouterr().err
    (tmp_path / "run.json").write_text(json.dumps({"robots": [{"name": "Kbot"}]}))
    assert report.main([str(tmp_path)]) == 1
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
    assert report.main([str(tmp_path), "--json"]) == 0
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
    assert report.main([str(tmp_path), "--no-plots"]) == 0
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
    assert report.main([str(tmp_path), "--json", "--no-plots"]) == 0
    out = json.loads((tmp_path / "report.json").read_text())
    row = out["robots"][0]
    assert (row["received"], row["processed"]) == (2, 2)
    assert row["time_s"] == pytest.approx(10.0)           # one ON_THE_WAY (in both parts) -> GOAL_REACHED
    assert out["rejected_goals"] == {"Tartalo": len(hostile)}
    assert "were not goals" in report.format_tables(out)


def test_table3_leaves_hostile_input_out(tmp_path: Path) -> None:
    """Issue 19.7: hostile traffic on Kbot's master (invalid goals, valid-looking goals from a foreign node,
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
    assert report.main([str(tmp_path), "--json", "--no-plots"]) == 0
    out = json.loads((tmp_path / "report.json").read_text())
    row = out["robots"][0]
    assert (row["received"], row["processed"]) == (3, 2)
    assert row["time_s"] == pytest.approx(18.0)           # 10 -> 20 and 22 -> 30: no hostile ON_THE_WAY
    assert out["tour"]["completed"] == 2
    assert out["rejected_goals"] == {"Kbot": 3}
