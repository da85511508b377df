"""Run the whole simulated building on this one machine (a thin layer over the per-robot launches).

Starts one master per robot on the robot's own loopback address (free ports, so
runs never collide), then ``launch/robot.launch sim:=true`` per robot against its
master, ``rosbag record`` of the shared topics per robot, and the progress
monitor. Every process is in its own process group; :meth:`stop` (and leaving
the ``with`` block) stops them all: recorders first so bags are closed properly.
"""

from __future__ import annotations

import shutil
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

from gidabot_navigation.building import Building, load_building, relocate_building
from gidabot_navigation.procs import ProcessGroup, ros_env, start_master, wait_until

REPO = Path(__file__).resolve().parents[4]
ROBOT_LAUNCH = REPO / "launch" / "robot.launch"
RECORDED_TOPICS = ("/gidabot/goals", "/gidabot/cancels", "/gidabot/nav_events", "/gidabot/tours",
                   "/gidabot/status", "/gidabot/poses", "/gidabot/pending", "/gidabot/tour_index")


@dataclass
class SimulatedBuilding:
    building_dir: Path
    run_dir: Path
    speed: float = 10.0
    gui: bool = False
    record: bool = True
    relay_secret: str = ""
    seed_tours: Path = REPO / "tours"
    robot_args: dict[str, dict[str, str]] = field(default_factory=dict)   # per robot extra launch args
    common_args: dict[str, str] = field(default_factory=dict)
    building: Building | None = None
    building_file: Path | None = None
    monitor_file: Path | None = None
    start_wall: float = 0.0

    def __post_init__(self) -> None:
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.procs = ProcessGroup(self.run_dir / "logs")

    def __enter__(self) -> SimulatedBuilding:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- start ---------------------------------------------------------------
    def start(self, start_delay: float = 6.0) -> None:
        base = load_building(self.building_dir)
        uris = {r.name: start_master(self.procs, f"master_{r.name}", r.ip) for r in base.robots}
        self.building_file = relocate_building(self.building_dir, self.run_dir / "building", uris)
        self.building = load_building(self.building_file)
        self.start_wall = time.time() + start_delay
        first = self.building.robots[0]
        self.monitor_file = self.run_dir / "monitor.jsonl"
        self.monitor_file.touch()
        self.procs.start("monitor", ["rosrun", "gidabot_sim", "monitor", f"_out:={self.monitor_file}"],
                         self.env(first.name))
        for robot in self.building.robots:
            if self.record:
                self.procs.start(f"record_{robot.name}", ["rosbag", "record", "--lz4", "-O",
                                                          str(self.run_dir / f"{robot.name}.bag"),
                                                          *RECORDED_TOPICS], self.env(robot.name))
            self.launch_robot(robot.name)

    def env(self, robot: str) -> dict[str, str]:
        assert self.building is not None or robot
        b = self.building or load_building(self.building_dir)
        r = b.robot(robot)
        return ros_env(r.master_uri, r.ip, log_dir=self.run_dir / "ros" / robot)

    def launch_args(self, robot: str) -> list[str]:
        tours_dir = self.run_dir / "tours" / robot
        args = {
            "building": str(self.building_file), "robot": robot, "sim": "true", "speed": f"{self.speed:g}",
            "start_wall": f"{self.start_wall:.3f}", "gui": str(self.gui).lower(), "tours_dir": str(tours_dir),
            "seed_tours": str(self.seed_tours), "relay_secret": self.relay_secret,
            "relay_state_dir": str(self.run_dir / "relay" / robot),
        }
        args.update(self.common_args)
        args.update(self.robot_args.get(robot, {}))
        return [f"{k}:={v}" for k, v in args.items()]

    def launch_robot(self, robot: str) -> None:
        """(Re)start robot's whole stack (its roslaunch) against its master."""
        name = f"robot_{robot}"
        if self.procs.alive(name):
            self.procs.stop(name, grace=20.0)
        self.procs.start(name, ["roslaunch", "--skip-log-check", str(ROBOT_LAUNCH), *self.launch_args(robot)],
                         self.env(robot))

    # -- stop ----------------------------------------------------------------
    def stop(self) -> None:
        """Stop recorders (bags closed), then robots, monitor and masters."""
        for name in self.procs.names():
            if name.startswith("record_"):
                self.procs.stop(name, grace=15.0)
        for name in self.procs.names():
            if name.startswith("robot_"):
                self.procs.stop(name, grace=20.0)
        self.procs.close()
        for active in self.run_dir.glob("*.bag.active"):   # a recorder that had to be killed
            subprocess.run(["rosbag", "reindex", str(active)], capture_output=True, timeout=120, check=False)
            shutil.move(str(active), str(active.with_suffix("")))

    def wait_for_file(self, path: Path, timeout: float) -> None:
        wait_until(path.exists, timeout, f"{path}")
