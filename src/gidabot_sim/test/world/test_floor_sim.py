"""The floor simulator as the /sim node runs it (no ROS, no clock): inputs, stepping in lockstep, what is
published at each stop, obstacles, relocations, the clock's rate, diagnostics, the timeline and mates files."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from sim_support import ListLog

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.planning import Circle
from gidabot_navigation.interface import Topic
from gidabot_sim.errors import SimConfigError
from gidabot_sim.world import floor_sim as fs
from gidabot_sim.world.lockstep import Answer
from gidabot_sim.world.mates import Mates
from gidabot_sim.world.timeline import Clock, Timeline
from gidabot_sim.world.world import LaserSpec

MAPS = Path(__file__).resolve().parents[4] / "maps"
ODOM, TRUTH = "/odom", "/base_pose_ground_truth"



class Floor:
    """A FloorSim on a faculty floor with what it emitted."""

    def __init__(self, building, robots: tuple[str, ...] = ("Kbot",), wall: float = 100.0, listening: bool = True,
                 **kw) -> None:
        self.out: list = []
        self.log = ListLog()
        self.listening = {Topic.ODOM, Topic.BASE_POSE_GROUND_TRUTH, Topic.BASE_SCAN, Topic.ROBOTS_SEEN, Topic.TF} \
            if listening else set()
        kw.setdefault("speed", None)
        kw.setdefault("seed", 1)
        resume_at = kw.pop("resume_at", 0.0)
        self.sim = fs.FloorSim(fs.SimConfig("building", robots, **kw), building, wall, self.out.append,
                               lambda topic, _i: topic in self.listening, lambda name: "/" + name, self.log,
                               resume_at)

    def of(self, kind: type) -> list:
        return [o for o in self.out if isinstance(o, kind)]

    def tick(self, wall: float) -> float:
        self.out.clear()
        return self.sim.tick(wall)

    def answer(self, done: float, idle: bool = False, node: str = "/move_base") -> None:
        self.sim.post(fs.STEP_DONE, -1, lambda: Answer(node, 1, done, idle, () if idle else (ODOM,)))


@pytest.fixture(scope="module")
def faculty():
    return load_building(MAPS / "faculty")


@pytest.fixture(scope="module")
def faculty6():
    return load_building(MAPS / "faculty6")


def test_parameters_are_checked_with_the_parameter_named() -> None:
    assert fs.pose_of("~initial_pose", "1, 2, 0.5") == Pose2D(1.0, 2.0, 0.5)
    assert fs.pose_of("~initial_pose", [3, 4, 0]) == Pose2D(3.0, 4.0, 0.0)
    assert fs.pose_of("~initial_pose", []) is None and fs.pose_of("~initial_pose", "") is None
    with pytest.raises(SimConfigError, match=r"~initial_pose: .* must be \[x, y, yaw\]"):
        fs.pose_of("~initial_pose", [1, 2])
    assert fs.robot_names("Kbot", None) == ("Kbot",)
    assert fs.robot_names("", ["Kbot", "Tartalo"]) == ("Kbot", "Tartalo")
    for robot, robots in (("", None), ("Kbot", "Kbot"), ("", ["Kbot", ""]), ("", [])):
        with pytest.raises(SimConfigError, match="~robot .* or ~robots"):
            fs.robot_names(robot, robots)
    assert fs.initial_poses(("A", "B"), None, [1, 2, 3]) == (Pose2D(1, 2, 3), None)
    assert fs.initial_poses(("A", "B"), [[1, 2, 3], []], None) == (Pose2D(1, 2, 3), None)
    with pytest.raises(SimConfigError, match="~initial_poses: .* a list of 2"):
        fs.initial_poses(("A", "B"), [[1, 2, 3]], None)
    with pytest.raises(SimConfigError, match="~building"):
        fs.SimConfig("", ("Kbot",))
    with pytest.raises(SimConfigError, match="~step: 0.15 s must be a multiple of ~physics_dt"):
        fs.SimConfig("b", ("Kbot",), step=0.15, dt=0.02)
    with pytest.raises(SimConfigError, match="~floor"):
        fs.SimConfig("b", ("Kbot",), floor="one")
    assert fs.SimConfig("b", ("Kbot", "Tartalo")).poses == (None, None)


def test_unknown_robots_floors_and_impossible_poses_are_refused(faculty) -> None:
    with pytest.raises(SimConfigError, match="~robots: unknown robot 'R2D2'"):
        Floor(faculty, ("R2D2",))
    with pytest.raises(SimConfigError, match="~floor: unknown floor 7.0; the building has floors 0, 1, 2, 3"):
        Floor(faculty, floor=7.0)
    with pytest.raises(SimConfigError, match="robot Kbot: initial pose: .* inside a wall"):
        Floor(faculty, poses=(Pose2D(30.0, 10.35, 0.0),))


def test_before_start_wall_only_inputs_are_taken_then_the_scene_and_the_first_stop_go_out(faculty) -> None:
    f = Floor(faculty, start_wall=110.0)
    assert f.tick(100.0) == fs.START_POLL and f.out == []
    assert f.tick(109.99) == pytest.approx(0.01) and f.out == []
    assert [line for line in f.log.lines if "start_wall" in line] == ["sim: waiting 10.0 s for start_wall"]
    f.sim.post(fs.CMD_VEL, 0, lambda: (0.4, 0.0, 0.0), "/move_base")
    assert f.tick(110.0) == 0.0
    assert [type(o) for o in f.out] == [fs.MapOut, fs.Obstacles, fs.Transforms, fs.Odom, fs.Truth, fs.Scan,
                                        fs.Battery, fs.Transforms, fs.ClockTick]
    static = f.out[2]
    assert static.static and [(x.parent, x.child) for x in static.frames] == [
        ("base_footprint", "base_link"), ("base_link", "base_laser_link")]
    assert static.frames[1].z == 0.3 and static.frames[1].pose.x == 0.1
    assert f.sim.world.robots[0].cmd.vx == 0.4                  # the command taken before the start
    assert f.out[-1] == fs.ClockTick(0.0) and "running from 0.0 s" in f.log.lines[-1]


def test_a_driving_participant_holds_the_world_and_gets_the_odometry_of_every_stop(faculty) -> None:
    f = Floor(faculty)
    f.tick(100.0)
    f.answer(0.0)                        # a goal runs: every stop owed, odometry at every stop
    assert f.tick(100.0) == 0.0 and [o.t for o in f.of(fs.Odom)] == pytest.approx([0.1])
    sleep = f.tick(100.001)              # the stop at 0.1 waits for the answer
    assert 0.0 < sleep <= fs.HEARTBEAT and f.sim.world.time == pytest.approx(0.1) and f.of(fs.Odom) == []
    f.answer(0.1)
    f.tick(100.002)
    assert f.sim.world.time == pytest.approx(0.2) and [o.t for o in f.of(fs.Odom)] == pytest.approx([0.2])
    f.answer(0.2, idle=True)            # the goal is over: odometry at the rest rate again
    for k in range(5):
        f.tick(100.003 + k * 1e-3)
    assert f.sim.world.time == pytest.approx(0.7) and f.of(fs.Odom) == []


def test_a_participant_that_starts_driving_in_a_stop_gets_its_odometry_for_that_stop(faculty) -> None:
    f = Floor(faculty)
    f.tick(100.0)
    for _ in range(3):
        f.tick(100.0)                    # at rest: the odometry of 0.0 only
    f.answer(0.0)                        # a goal at 0.3: owes 0.3, whose odometry was not sent
    f.tick(100.0)
    assert f.sim.world.time == pytest.approx(0.3) and [o.t for o in f.of(fs.Odom)] == pytest.approx([0.3])


def test_commands_drive_the_robot_and_bad_inputs_are_counted_and_logged(faculty) -> None:
    f = Floor(faculty)
    f.tick(100.0)
    f.sim.post(fs.CMD_VEL, 0, lambda: (math.nan, 0.0, 0.0), "/move_base")
    f.sim.post(fs.STEP_DONE, -1, lambda: Answer("", 1, 0.0))
    f.sim.post(fs.INITIALPOSE, 0, lambda: Pose2D(30.0, 10.35, 0.0))     # in the wall
    f.tick(100.0)
    assert f.sim.rejected.counts == {fs.CMD_VEL: 1, fs.STEP_DONE: 1, fs.INITIALPOSE: 1}
    assert any(line.startswith("E rejected cmd_vel (#1)") for line in f.log.lines)
    for k in range(20):
        f.sim.post(fs.CMD_VEL, 0, lambda: (0.5, 0.0, 0.0), "/move_base")
        f.tick(100.0 + k)
    assert f.sim.world.robots[0].pose.x > 30.3


def test_a_relocation_moves_the_robot_and_its_true_pose_goes_out_at_the_next_stop(faculty) -> None:
    f = Floor(faculty)
    f.tick(100.0)
    f.tick(100.0)
    assert f.of(fs.Truth) == []          # at rest: once a second
    f.sim.post(fs.INITIALPOSE, 0, lambda: Pose2D(20.0, 12.0, 1.0))
    f.tick(100.0)
    [truth] = f.of(fs.Truth)
    assert (truth.pose.x, truth.pose.y, truth.pose.yaw) == pytest.approx((20.0, 12.0, 1.0))
    assert f.log.lines[-1] == "sim: Kbot set to (20.00, 12.00, 1.00)"
    assert f.sim.world.robots[0].odom == Pose2D(0.0, 0.0, 0.0)     # odometry does not jump


def test_obstacles_are_applied_together_published_once_and_a_flood_waits(faculty) -> None:
    f = Floor(faculty)
    f.tick(100.0)
    f.sim.post(fs.OBSTACLE, -1, lambda: fs.ObstacleChange(fs.ADD, "b", Circle(40.0, 12.0, 0.2)))
    f.sim.post(fs.OBSTACLE, -1, lambda: fs.ObstacleChange(fs.ADD, "a", Circle(42.0, 12.0, 0.2)))
    f.sim.post(fs.OBSTACLE, -1, lambda: fs.ObstacleChange(fs.REMOVE, "nothing"))
    f.tick(100.0)
    [obstacles] = f.of(fs.Obstacles)
    assert [k for k, _ in obstacles.items] == ["a", "b"] and f.sim.rejected.counts == {fs.OBSTACLE: 1}
    # an obstacle and a relocation in one tick: the obstacle goes out too
    f.sim.post(fs.OBSTACLE, -1, lambda: fs.ObstacleChange(fs.ADD, "c", Circle(44.0, 12.0, 0.2)))
    f.sim.post(fs.INITIALPOSE, 0, lambda: Pose2D(20.0, 12.0, 0.0))
    f.tick(100.0)
    assert [k for k, _ in f.of(fs.Obstacles)[0].items] == ["a", "b", "c"]
    for k in range(fs.MAX_EVENTS_PER_STEP + 5):
        f.sim.post(fs.OBSTACLE, -1, lambda k=k: fs.ObstacleChange(fs.REMOVE, f"none{k}"))
    f.sim.post(fs.CMD_VEL, 0, lambda: (0.3, 0.0, 0.0), "/move_base")
    f.tick(100.0)
    assert f.sim.rejected.counts[fs.OBSTACLE] == 1 + fs.MAX_EVENTS_PER_STEP     # a flood waits ...
    assert f.sim.world.robots[0].cmd.vx == 0.3                                 # ... commands do not
    f.tick(100.0)
    assert f.sim.rejected.counts[fs.OBSTACLE] == 1 + fs.MAX_EVENTS_PER_STEP + 5


def test_the_clock_goes_out_at_most_clock_rate_max_times_per_wall_second(faculty) -> None:
    f = Floor(faculty, clock_rate_max=10.0)
    sent = []
    for k in range(100):                 # a step every 10 ms of wall time
        f.tick(100.0 + 0.01 * k)
        sent += [(100.0 + 0.01 * k, c.t) for c in f.of(fs.ClockTick)]
    assert 9 <= len(sent) <= 10 and sent[0] == (100.0, 0.0)
    assert all(b[0] - a[0] >= 0.1 - 1e-9 and b[1] > a[1] for a, b in zip(sent, sent[1:], strict=False))


def test_sensors_nobody_listens_to_are_not_computed(faculty) -> None:
    f = Floor(faculty, listening=False)
    for _ in range(20):
        f.tick(100.0)
        assert not any(isinstance(o, (fs.Odom, fs.Truth, fs.Scan, fs.Transforms)) and not getattr(o, "static", False)
                       for o in f.out)
    assert f.sim.scans == 0
    f.listening.add(Topic.BASE_SCAN)
    scans = []
    for _ in range(20):
        f.tick(100.0)
        scans += f.of(fs.Scan)
    per_2s = round(2.0 * fs.SimConfig.laser_rate)            # 20 stops of 0.1 s
    assert len(scans) == per_2s and f.sim.scans == per_2s
    assert scans[0].scan_time == pytest.approx(1.0 / fs.SimConfig.laser_rate)
    assert len(scans[0].ranges) == 360


def test_an_idle_floor_under_its_ceiling_sleeps_and_a_driving_one_only_waits(faculty) -> None:
    f = Floor(faculty, speed=1.0)
    f.tick(100.0)
    assert fs.IDLE_SLEEP <= f.tick(100.0) <= fs.HEARTBEAT
    assert f.tick(100.1) == 0.0 and f.sim.world.time == pytest.approx(0.1)
    f.sim.post(fs.CMD_VEL, 0, lambda: (0.5, 0.0, 0.0), "/move_base")
    assert f.tick(100.199) == pytest.approx(0.001)


def test_diagnostics_every_period_and_the_time_a_restart_resumes_from(faculty) -> None:
    f = Floor(faculty, diagnostics_period=1.0)
    f.tick(100.0)
    f.answer(0.0)
    for k in range(10):
        f.answer(0.1 * k)
        f.tick(100.0 + 0.1 * k)
    assert f.of(fs.Diagnostics) == []
    f.answer(1.0)
    f.tick(101.0)
    [diag] = f.of(fs.Diagnostics)
    values = dict(diag.values)
    assert (diag.level, diag.name, diag.message, diag.hardware_id) == (fs.OK, "sim: floor 1", "running", "Kbot")
    assert values["speed"] == "max" and values["sim_time"] == "1.10" and values["rejected_cmd_vel"] == "0"
    assert '"absent":0' in values["participant /move_base"] and values["battery_Kbot"] == "1.0000"
    assert values["floor_robots"] == "Kbot" and values["robot_collisions"] == "0"
    [resume] = f.of(fs.ResumeAt)
    assert resume.t == pytest.approx(1.1 + 1.1 * 2.0 + 0.1)      # ahead of any stamp seen so far
    f.tick(103.5)                        # the participant has not answered for 2.5 s: the world goes on
    [diag] = f.of(fs.Diagnostics)
    assert (diag.level, diag.message) == (fs.WARN, "going on without /move_base")
    f.tick(103.5)
    assert any("has not answered for 2 s" in line for line in f.log.lines)
    again = Floor(faculty, resume_at=resume.t)
    assert again.sim.world.time == pytest.approx(resume.t) and again.sim.start_wall == 100.0


def test_the_timeline_gives_the_ceiling_and_the_drift_bound_and_gets_this_floor_s_clock(faculty, tmp_path) -> None:
    path = tmp_path / "timeline"
    with Timeline.create(path, 2, ceiling=None, max_drift=1.0, start_wall=100.0) as runner:
        runner.write(1, Clock(sim=0.0, wall=100.0))
        f = Floor(faculty, speed=5.0, timeline=str(path), timeline_slot=0)
        assert f.sim.stepper.pacer.speed is None               # the timeline's ceiling, not ~speed
        f.tick(100.0)
        for _ in range(20):
            f.tick(100.0)
        assert f.sim.world.time == pytest.approx(1.0)         # 1 s ahead of the other floor at most
        assert runner.read(0).sim == pytest.approx(1.0) and f.of(fs.ResumeAt) == []
        runner.set_ceiling(2.0)
        runner.write(1, Clock(sim=5.0, wall=100.0))
        f.tick(100.0)
        assert f.sim.stepper.pacer.speed == 2.0
        f.sim.close()
        restarted = Floor(faculty, timeline=str(path), timeline_slot=0, wall=200.0)
        assert restarted.sim.world.time == pytest.approx(1.0)  # a floor's time never goes back
        restarted.sim.close()


def test_robots_of_one_floor_simulated_apart_share_it_through_the_mates_file(faculty6, tmp_path) -> None:
    path = tmp_path / "mates"
    Mates.create(path, [r.home for r in faculty6.robots]).close()
    kbot = Floor(faculty6, ("Kbot",), mates=str(path), poses=(Pose2D(44.0, 12.0, 0.0),))
    basajaun = Floor(faculty6, ("Basajaun",), mates=str(path))
    assert kbot.sim.sees_robots and kbot.sim.mate_slots == {1: 2} and kbot.sim.own_slots == {0: 1}
    basajaun.tick(100.0)
    kbot.tick(100.0)
    kbot.tick(100.0)                     # reads Basajaun's slot before the step
    kbot.tick(100.0)                     # the next scan's time (laser_rate)
    [seen] = kbot.of(fs.Seen)
    [(name, disc)] = seen.robots
    assert name == "Basajaun" and (disc.x, disc.y, disc.radius) == pytest.approx((54.0, 12.0, 0.27))
    basajaun.tick(100.0)
    assert basajaun.sim.world.robots[1].pose.x == pytest.approx(44.0)     # and Kbot in Basajaun's world
    kbot.sim.close()
    basajaun.sim.close()


def test_several_robots_in_one_simulator_get_their_own_topics_and_frames(faculty) -> None:
    f = Floor(faculty, ("Kbot", "Tartalo"), floor=1.0, poses=(Pose2D(20.0, 12.0, 0.0), Pose2D(40.0, 12.0, math.pi)))
    assert f.sim.prefixes == ["robot_0/", "robot_1/"] and f.sim.sees_robots
    assert f.sim.odom_topics == ["/robot_0/odom", "/robot_1/odom"] and f.sim.frames[1]["odom"] == "robot_1/odom"
    f.tick(100.0)
    assert [o.index for o in f.of(fs.Odom)] == [0, 1] and {s.index for s in f.of(fs.Seen)} == {0, 1}
    [tf] = [o for o in f.of(fs.Transforms) if not o.static]
    assert [(x.parent, x.child) for x in tf.frames] == [("robot_0/odom", "robot_0/base_footprint"),
                                                        ("robot_1/odom", "robot_1/base_footprint")]


def test_the_laser_and_what_it_sees_come_at_the_tracker_s_rate(faculty) -> None:
    f = Floor(faculty, ("Kbot", "Tartalo"), floor=1.0, poses=(Pose2D(20.0, 12.0, 0.0), Pose2D(24.0, 12.0, math.pi)))
    scans, seen = [], []
    for _ in range(20):                       # 2 s of sim time in stops of 0.1 s
        f.tick(100.0)
        scans += [o for o in f.of(fs.Scan) if o.index == 0]
        seen += [o for o in f.of(fs.Seen) if o.index == 0]
    assert fs.SimConfig.laser_rate == 5.0 and len(scans) == len(seen) == 10
    assert [s.t for s in seen] == [s.t for s in scans]               # what a scan sees is that scan's
    assert all([name for name, _disc in s.robots] == ["Tartalo"] for s in seen)


def test_each_robot_s_laser_covers_what_its_building_file_declares_unless_a_field_of_view_is_given(faculty) -> None:
    assert Floor(faculty).sim.world.robots[0].spec.laser.fov == pytest.approx(2 * math.pi)   # declared: all round
    kbot = faculty.robot("Kbot")
    front = replace(faculty, robots=tuple(replace(r, laser=replace(r.laser, fov=1.5 * math.pi)) if r is kbot else r
                                          for r in faculty.robots))
    assert Floor(front).sim.world.robots[0].spec.laser.fov == pytest.approx(1.5 * math.pi)
    given = Floor(faculty, laser=LaserSpec(fov=math.pi), laser_fov_declared=False)          # /sim ~laser_fov
    assert given.sim.world.robots[0].spec.laser.fov == pytest.approx(math.pi)
