"""Helpers of the multi-master system tests: the whole simulated building and recording probes.

    with SimStack(tmp, speed=20, robot_args={...}) as stack:   # 4 masters, robot.launch sim:=true each
        stack.wait_ready()                                      # relays up, every robot heard everywhere
        uid = stack.request("Tartalo", "305", way="stairs")
        stack.wait_event("Tartalo", phase=GOAL_REACHED, goal_uid=uid, timeout=60)

The building is `gidabot_sim.runner.building_runner.SimulatedBuilding` (the scaffolding of `gidabot demo`):
one master per robot on this test session's loopback addresses (`procs.robot_address`), the building
relocated to them, `launch/robot.launch sim:=true gui:=false` per robot, every process in its own
process group and stopped by group (and by process tree) when the stack closes. One
:class:`Recorder` (a `tests/ros_probe.py` process) per robot master records the topics the tests
look at; it caches what it fetched, so waiting never transfers a message twice.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from pathlib import Path

from probe import Probe, ProbeError, close_all

from gidabot_navigation.building.model import Building, load_building
from gidabot_navigation.interface import GUIDING_NODES, Node, Phase, Topic, global_name
from gidabot_sim.runner.building_runner import SimulatedBuilding
from gidabot_sim.runner.procs import robot_address, wait_until

REPO = Path(__file__).resolve().parents[1]
FACULTY = REPO / "maps" / "faculty"
ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")

EVENTS, GOALS, CANCELS = Topic.NAV_EVENTS, Topic.GOALS, Topic.CANCELS
STATUS, PENDING, POSES = Topic.STATUS, Topic.PENDING, Topic.POSES
MB_RESULT, AMCL = Topic.MOVE_BASE_RESULT, Topic.AMCL_POSE
TYPES = {EVENTS: "gidabot_msgs/NavEvent", GOALS: "gidabot_msgs/Goal", CANCELS: "gidabot_msgs/Cancel",
         STATUS: "gidabot_msgs/RobotStatus", PENDING: "gidabot_msgs/PendingRequests", POSES: "gidabot_msgs/NavPose",
         MB_RESULT: "move_base_msgs/MoveBaseActionResult", AMCL: "geometry_msgs/PoseWithCovarianceStamped",
         Topic.VISITOR_COMMAND: "gidabot_msgs/VisitorCommand",
         Topic.INITIALPOSE: "geometry_msgs/PoseWithCovarianceStamped"}

# gidabot_msgs/NavEvent phases
(ACCEPTED, ON_THE_WAY, GOAL_REACHED, GO_TO_FLOOR, GOING_TO_MEETING, WAITING_VISITOR, UNREACHABLE, NO_ROBOT_ON_FLOOR,
 CANCELLED_HERE, CANCELLED_ELSEWHERE, TIMEOUT, PARTNER_OFFLINE, REJECTED, TOUR_STEP_DONE, TOUR_FINISHED,
 PARTNER_LOST, PARTNER_BACK, DECLINED, ASSIGNED) = range(19)
FAILURES = {UNREACHABLE, NO_ROBOT_ON_FLOOR, TIMEOUT, PARTNER_OFFLINE, REJECTED}
# gidabot_msgs/VisitorCommand commands
REQUEST, CONTINUE, CANCEL, START_TOUR, SKIP = range(5)
# actionlib_msgs/GoalStatus
PREEMPTED, SUCCEEDED = 2, 3
GUIDING = tuple(global_name(n) for n in GUIDING_NODES)      # both listen to visitor/command


class Recorder:
    """A probe on one master that records topics; fetched messages are cached here (incremental)."""

    def __init__(self, env: dict[str, str], log_path: Path, timeout: float = 30.0,
                 command: Callable[[list[str]], list[str]] = list, name: str | None = None) -> None:
        self.probe = Probe(env, log_path, timeout=timeout, command=command, name=name)
        self.cache: dict[str, list[dict]] = {}

    def sub(self, topic: str, type_: str | None = None) -> None:
        self.probe.sub(topic, type_ or TYPES[topic])
        self.cache.setdefault(topic, [])

    def pub(self, topic: str, msg: dict, to: tuple[str, ...], type_: str | None = None) -> None:
        """Publish once the nodes ``to`` (global names) are connected (see :meth:`probe.Probe.pub`)."""
        self.probe.pub(topic, type_ or TYPES[topic], msg, to=to)

    def msgs(self, topic: str) -> list[dict]:
        """Every message recorded on ``topic`` so far (fetches only the new ones)."""
        got = self.cache[topic]
        got.extend(self.probe.msgs(topic, since=len(got)))
        return got

    def count(self, topic: str) -> int:
        return len(self.msgs(topic))

    def latest(self, topic: str, pred: Callable[[dict], bool] = lambda m: True) -> dict | None:
        for m in reversed(self.msgs(topic)):
            if pred(m):
                return m
        return None

    def wait(self, topic: str, pred: Callable[[dict], bool], timeout: float, what: str, since: int = 0) -> dict:
        """The first message on ``topic`` from index ``since`` satisfying ``pred`` (polls every 50 ms)."""
        deadline = time.monotonic() + timeout
        checked = since
        while True:
            got = self.msgs(topic)
            for m in got[checked:]:
                if pred(m):
                    return m
            checked = max(checked, len(got))
            if time.monotonic() > deadline:
                raise ProbeError(f"timed out after {timeout:g} s waiting on {topic} for {what}")
            time.sleep(0.05)


def yaw_of(q: dict) -> float:
    return math.atan2(2.0 * (q["w"] * q["z"] + q["x"] * q["y"]), 1.0 - 2.0 * (q["y"] ** 2 + q["z"] ** 2))


def xy(pose_msg: dict) -> tuple[float, float]:
    """(x, y) of an amcl_pose (PoseWithCovarianceStamped) or NavPose/RobotStatus dict."""
    p = pose_msg["pose"]["pose"] if "pose" in pose_msg else pose_msg["nav_pose"]
    return p["position"]["x"], p["position"]["y"]


def dist(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


class SimStack:
    """The simulated building (default: the faculty, 4 robots) for system tests; see the module docstring.

    ``record`` maps a robot to the topics its recorder subscribes (default :data:`DEFAULT_TOPICS`).
    ``dashboard``: every robot serves its staff dashboard (``SimulatedBuilding.staff_url``).
    ``machines``: every robot a separate machine (its own network namespace and firewall,
    ``SimulatedBuilding(machines=True)``); the recorders run on their robot's machine.
    """

    DEFAULT_TOPICS = (EVENTS, GOALS, CANCELS, PENDING, MB_RESULT, AMCL)

    def __init__(self, tmp: Path, speed: float = 20.0, robot_args: dict[str, dict[str, str]] | None = None,
                 common_args: dict[str, str] | None = None, record: dict[str, tuple[str, ...]] | None = None,
                 start_delay: float = 6.0, building: Path = FACULTY, machines: bool = False,
                 dashboard: bool = False) -> None:
        self.tmp = tmp
        self.speed = speed
        self.robots = tuple(r.name for r in load_building(building).robots)
        args = {"status_rate": f"{min(2.0, 2.0 / speed):.4g}", "pose_rate": f"{min(5.0, 5.0 / speed):.4g}"}
        args.update(common_args or {})
        addresses = None if machines else [robot_address(i) for i in range(len(self.robots))]
        self.sim = SimulatedBuilding(building, tmp / "run", speed=speed, gui=False, record=False, addresses=addresses,
                                     robot_args=robot_args or {}, common_args=args, start_delay=start_delay,
                                     machines=machines, dashboard=dashboard)
        self.topics = record or {}
        self.rec: dict[str, Recorder] = {}
        self.n = 0

    # -- life cycle -----------------------------------------------------------------------
    def __enter__(self) -> SimStack:
        try:
            self.sim.start()
            for r in self.robots:     # every recorder starts at once, then each subscribes
                # named like the robot's GUI, which the stack does not run (gui:=false): the visitor's commands are
                # taken only from this robot's own nodes
                self.rec[r] = Recorder(self.sim.env(r), self.tmp / f"probe_{r}.log", command=self.on_machine(r),
                                       name=Node.GUI)
            for r, rec in self.rec.items():
                for topic in self.topics.get(r, self.DEFAULT_TOPICS):
                    rec.sub(topic)
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        close_all(rec.probe for rec in self.rec.values())
        self.sim.stop()

    def on_machine(self, robot: str) -> Callable[[list[str]], list[str]]:
        """How to run a command line on ``robot``'s machine (this host, without separate machines)."""
        return lambda argv: self.sim.command(robot, argv)

    @property
    def building(self) -> Building:
        assert self.sim.building is not None
        return self.sim.building

    def wait_ready(self, timeout: float = 120.0) -> float:
        """Until every robot's goal_manager list reaches every master (relays up), every robot's status
        reaches every master (guiding knows its partners are online), sim time runs and every
        robot is localised. Returns the wall seconds waited."""
        start = time.monotonic()
        deadline = start + timeout
        for r, rec in self.rec.items():
            if PENDING in rec.cache:
                left = deadline - time.monotonic()
                wait_until(lambda rec=rec: {m["robot"] for m in rec.msgs(PENDING)} >= set(self.robots), max(left, 1.0),
                           f"every robot's pending list on {r}'s master", interval=0.2)
        with contextlib.ExitStack() as probes:   # statuses: a short-lived probe per master, started at once
            status = {r: probes.enter_context(Probe(self.sim.env(r), self.tmp / f"probe_status_{r}.log",
                                                    command=self.on_machine(r))) for r in self.robots}
            for p in status.values():
                p.sub(STATUS, TYPES[STATUS])
            for r, p in status.items():
                left = deadline - time.monotonic()
                wait_until(lambda p=p: {m["robot"] for m in p.msgs(STATUS)} >= set(self.robots), max(left, 1.0),
                           f"every robot's status on {r}'s master", interval=0.2)
        for r, rec in self.rec.items():
            if AMCL in rec.cache:
                rec.wait(AMCL, lambda m: True, max(deadline - time.monotonic(), 1.0), f"{r} localised")
        return time.monotonic() - start

    # -- the visitor side -------------------------------------------------------------------
    def command(self, robot: str, command: int, **fields: object) -> str:
        """Publish a VisitorCommand on ``robot``'s ``visitor/command`` (goal_manager and navigation listen)."""
        self.n += 1
        uid = f"{robot}/systest/cmd/{self.n}"
        msg = {"uid": uid, "visitor_id": "systest", "command": command, "language": "en", "tour_step": -1}
        msg.update(fields)
        self.rec[robot].pub(Topic.VISITOR_COMMAND, msg, to=GUIDING)
        return uid

    def request(self, robot: str, goal_id: str, way: str = "stairs", timeout: float = 30.0) -> tuple[str, int]:
        """REQUEST at ``robot``; returns the new goal's uid and the index of ``robot``'s events before it."""
        rec = self.rec[robot]
        since = rec.count(EVENTS)
        self.command(robot, REQUEST, goal_id=goal_id, way=way)
        acc = rec.wait(EVENTS, lambda m: m["robot"] == robot and m["phase"] in (ACCEPTED, REJECTED, PARTNER_OFFLINE,
                                                                                 UNREACHABLE),
                       timeout, f"{robot}'s answer to the request for {goal_id}", since=since)
        assert acc["phase"] == ACCEPTED, f"request for {goal_id} at {robot} answered with {acc}"
        return acc["goal_uid"], since

    def relocate(self, robot: str, x: float, y: float, yaw: float = 0.0, timeout: float = 20.0) -> None:
        """Move the simulated robot (initialpose, as the GUI's admin Set location) and wait for amcl_pose."""
        rec = self.rec[robot]
        msg = {"pose": {"pose": {"position": {"x": x, "y": y, "z": 0.0},
                                 "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}}}
        rec.pub(Topic.INITIALPOSE, msg, to=(global_name(Node.SIM),))
        # amcl publishes after a jump; a robot already there publishes nothing new
        wait_until(lambda: dist(self.pose(robot), (x, y)) < 0.3, timeout, f"{robot} relocated to ({x}, {y})")

    # -- observations ---------------------------------------------------------------------
    def events(self, on: str, goal_uid: str | None = None, robot: str | None = None, since: int = 0) -> list[dict]:
        """NavEvents seen on ``on``'s master (every robot's, through the relays)."""
        return [m for m in self.rec[on].msgs(EVENTS)[since:]
                if (goal_uid is None or m["goal_uid"] == goal_uid) and (robot is None or m["robot"] == robot)]

    def wait_event(self, robot: str, phase: int | set[int], goal_uid: str | None = None, timeout: float = 60.0,
                   on: str | None = None, since: int = 0) -> dict:
        """The first event of ``robot`` with ``phase`` (and ``goal_uid``), as seen on ``on``'s master
        (default: the robot's own). A failure phase for that goal fails at once."""
        phases = {phase} if isinstance(phase, int) else phase
        rec = self.rec[on or robot]

        def match(m: dict) -> bool:
            if m["robot"] != robot or (goal_uid is not None and m["goal_uid"] != goal_uid):
                return False
            if m["phase"] in FAILURES and m["phase"] not in phases:
                raise AssertionError(f"{robot} failed: {m}")
            return m["phase"] in phases
        try:
            return rec.wait(EVENTS, match, timeout, f"phase {sorted(phases)} of {robot} for {goal_uid}", since=since)
        except ProbeError as e:
            raise ProbeError(f"{e}; {self.seen(goal_uid)}") from None

    def seen(self, goal_uid: str | None) -> str:
        """What each master saw of ``goal_uid``: (robot, phase, leg, detail) of its NavEvents, for a failure's
        message (a system test's run folder is gone when CI prints it)."""
        if goal_uid is None:
            return "no goal uid"
        return "; ".join(f"seen on {on}: " + (", ".join(
            f"{m['robot']} {phase_name(m['phase'])} {m.get('leg', '')} {m.get('detail', '')!r}".strip()
            for m in self.events(on, goal_uid)) or "nothing") for on in self.robots)

    def pose(self, robot: str) -> tuple[float, float]:
        """The robot's latest amcl_pose (x, y)."""
        m = self.rec[robot].latest(AMCL)
        assert m is not None, f"no amcl_pose from {robot}"
        return xy(m)

    def pending(self, on: str, robot: str) -> dict | None:
        """The latest /gidabot/pending of ``robot`` seen on ``on``'s master."""
        return self.rec[on].latest(PENDING, lambda m: m["robot"] == robot)

    def meeting(self, connector: str, floor: float) -> tuple[float, float]:
        """(x, y) of ``connector``'s meeting point on ``floor``."""
        c = self.building.find_connector(connector)
        assert c is not None, f"no connector {connector!r}"
        pose = c.meeting[self.building.floor(floor).id]
        return pose.x, pose.y

    def location(self, loc_id: str) -> tuple[float, float]:
        p = self.building.location(loc_id).pose
        return p.x, p.y


def phase_name(phase: object) -> str:
    """A NavEvent phase's name; a number no Phase has (a forged event) as it came."""
    try:
        return Phase(phase).name
    except ValueError:
        return repr(phase)
