"""The gui node on a real master (system tests): topics, a visitor's trip, the launch file, shutdown.

The node under test is the real adapter (rospy) with the real window, offscreen;
tests/ros_probe.py plays the guiding nodes and the tour store on the same master.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import sys
import time
import xmlrpc.client
from pathlib import Path

import pytest
from probe import Probe, wait_connected

from gidabot_navigation.interface import GUIDING_NODES, Cmd, Node, Topic, global_name
from gidabot_navigation.senders import make_uid
from gidabot_sim.runner.procs import ProcessGroup, robot_address, ros_env, start_master, wait_until

pytestmark = pytest.mark.system
REPO = Path(__file__).resolve().parents[3]
FACULTY = REPO / "maps" / "faculty"
DRIVER = Path(__file__).resolve().parent / "gui_driver.py"
STATUS = "gidabot_msgs/RobotStatus"
EVENT = "gidabot_msgs/NavEvent"
GUI, COMMANDS = global_name(Node.GUI), global_name(Topic.VISITOR_COMMAND)
OFFLINE_AFTER = 2.0     # s (wall): the guiding nodes' offline_after in the test's own launch


class Driver:
    """The gui node in a subprocess of its own session, driven through stdin/stdout."""

    def __init__(self, env: dict[str, str], robot: str, log: Path) -> None:
        self._log = open(log, "ab")  # noqa: SIM115 - closed in close()
        self.proc = subprocess.Popen([sys.executable, str(DRIVER), str(FACULTY), robot], env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log,
                                     start_new_session=True, text=True, bufsize=1)
        assert self._read(60.0).get("ready")

    def _read(self, timeout: float) -> dict:
        deadline = time.monotonic() + timeout
        while True:                       # rospy's log lines share stdout: skip them
            ready, _, _ = select.select([self.proc.stdout], [], [], max(0.0, deadline - time.monotonic()))
            assert ready, "the gui node did not answer"
            line = self.proc.stdout.readline()
            assert line, f"the gui node exited ({self.proc.poll()})"
            if line.startswith("{"):
                return json.loads(line)

    def __call__(self, op: str, **kw: object) -> dict:
        self.proc.stdin.write(json.dumps({"op": op, **kw}) + "\n")
        self.proc.stdin.flush()
        reply = self._read(30.0)
        assert reply["ok"], reply
        return reply

    def until(self, pred, timeout: float, what: str) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            st = self("state")
            if pred(st):
                return st
            assert time.monotonic() < deadline, f"timed out waiting for {what}: {st}"
            time.sleep(0.05)

    def close(self) -> None:
        with contextlib.suppress(OSError, ValueError):
            self.proc.stdin.write(json.dumps({"op": "quit"}) + "\n")
            self.proc.stdin.flush()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=5)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait(timeout=5)
        for stream in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(OSError):
                stream.close()
        self._log.close()


@pytest.fixture
def kbot(tmp_path: Path):
    with ProcessGroup(tmp_path / "logs") as procs:
        uri = start_master(procs, "master", robot_address(1))
        env = ros_env(uri, robot_address(1), log_dir=tmp_path / "logs" / "ros", QT_QPA_PLATFORM="offscreen",
                      XDG_RUNTIME_DIR=os.environ.get("XDG_RUNTIME_DIR", "/tmp"))
        yield procs, env, uri


def status(robot: str, floor: float, pending: int = 0, busy: float = 0.0) -> dict:
    return {"robot": robot, "floor": floor, "nav_pose": {"position": {"x": 30.0, "y": 12.0},
                                                         "orientation": {"w": 1.0}},
            "battery": 0.9, "state": "idle", "pending": pending, "busy_for": busy}


def test_a_visitor_trip_through_the_real_topics(kbot, tmp_path: Path) -> None:
    procs, env, uri = kbot
    driver = Driver(env, "Kbot", tmp_path / "logs" / "gui.log")
    try:
        with Probe(env, tmp_path / "logs" / "probe.log") as probe, \
                Probe(env, tmp_path / "logs" / "nav.log", name=Node.MULTIROBOT_NAVIGATION) as nav:   # Kbot's own
            probe.sub(Topic.VISITOR_COMMAND, "gidabot_msgs/VisitorCommand")
            for name, floor in (("Tartalo", 0), ("Kbot", 1), ("Galtxagorri", 2), ("MariSorgin", 3)):
                probe.pub(Topic.STATUS, STATUS, status(name, floor, pending=1, busy=240.0), to=[GUI])
            probe.pub(Topic.PENDING, "gidabot_msgs/PendingRequests",
                      {"robot": "Galtxagorri", "floor": 2, "num": 2, "wait_new": 400.0}, to=[GUI])
            driver.until(lambda s: all(s["robots"].values()) and s["pending"]["Galtxagorri"], 20,
                         "every robot's status and Galtxagorri's pending requests")
            st = driver("pick", goal="223")
            assert st["popup"] == "confirm"
            assert "Galtxagorri meets you there: about" in st["body"]      # its 400 s, and the drive there
            wait_connected(uri, GUI, COMMANDS, [probe.name])              # the button publishes once
            driver("press", key="go")
            driver("press", key="stairs")
            cmd = probe.wait(Topic.VISITOR_COMMAND, lambda m: m["command"] == Cmd.REQUEST, 10, "the REQUEST")
            assert (cmd["goal_id"], cmd["way"], cmd["language"], cmd["visitor_id"]) == ("223", "stairs", "en",
                                                                                        "guidriver")
            uid = "Kbot/guidriver/r1.1"
            nav.pub(Topic.NAV_EVENTS, EVENT, {"uid": make_uid("Kbot", "event", "nav"), "robot": "Kbot", "phase": 1,
                                                "goal_uid": uid, "connector": "stairs_west",
                                                "location_id": "stairs_west", "target_floor": 2.0,
                                                "language": "en", "way": "stairs"}, to=[GUI])
            st = driver.until(lambda s: s["popup"] == "event:ON_THE_WAY", 10, "the walk-behind pop-up")
            assert "walk behind me" in st["note"] and st["cancel"] and "walk behind me" in st["said"]
            # another robot's event is not shown here
            probe.pub(Topic.NAV_EVENTS, EVENT, {"uid": "Tartalo/event/1", "robot": "Tartalo", "phase": 7,
                                                "goal_uid": "x"}, to=[GUI])
            st = driver("cancel")
            cancel = probe.wait(Topic.VISITOR_COMMAND, lambda m: m["command"] == Cmd.CANCEL, 10, "the CANCEL")
            assert cancel["goal_uid"] == uid
            assert driver("state")["popup"] == ""
    finally:
        driver.close()


def test_launch_file_registers_the_documented_topics_and_stops_cleanly(kbot, tmp_path: Path) -> None:
    procs, env, uri = kbot
    env = dict(env)
    procs.start("gui", ["roslaunch", "--skip-log-check", str(REPO / "launch" / "gui.launch"), f"building:={FACULTY}",
                        "robot:=Kbot", "speech:=false", "fullscreen:=false", "language:=eu"], env)
    master = xmlrpc.client.ServerProxy(uri)

    def topics() -> tuple[dict, dict]:
        _code, _msg, (pubs, subs, _srvs) = master.getSystemState("/test")
        return ({t: n for t, n in pubs}, {t: n for t, n in subs})

    gui, commands = global_name(Node.GUI), global_name(Topic.VISITOR_COMMAND)
    subscribed = (Topic.STATUS, Topic.POSES, Topic.PENDING, Topic.NAV_EVENTS,
                  global_name(Topic.TOUR_CATALOG), global_name(Topic.TOUR_EDIT_RESULT))
    # the node registers its publishers, then its subscribers: wait for the last of them (a loaded machine)
    wait_until(lambda: gui in topics()[0].get(commands, [])
               and all(gui in topics()[1].get(t, []) for t in subscribed), 60, "the gui node's topics")
    pubs, subs = topics()
    for topic in (commands, global_name(Topic.INITIALPOSE), global_name(Topic.TOUR_EDIT)):
        assert gui in pubs.get(topic, []), topic
    for topic in subscribed:
        assert gui in subs.get(topic, []), topic
    published_by_gui = sorted(t for t, nodes in pubs.items() if gui in nodes)
    assert published_by_gui == sorted([global_name(Topic.INITIALPOSE), "/rosout", global_name(Topic.TOUR_EDIT),
                                       commands, Topic.DIAGNOSTICS])
    t0 = time.monotonic()
    rc = procs.stop("gui", grace=15.0)
    assert rc == 0 and time.monotonic() - t0 < 15.0
    wait_until(lambda: gui not in topics()[0].get(commands, []), 10, "the gui node to unregister")


def test_with_the_real_guiding_nodes_and_simulator(kbot, tmp_path: Path) -> None:
    """Kbot's floor simulated at 10x with its guiding nodes: the GUI's trip end to end, and a refusal."""
    procs, env, uri = kbot
    launch = tmp_path / "kbot.launch"
    launch.write_text(f"""<launch>
  <param name="/use_sim_time" value="true"/>
  <include file="{REPO}/launch/sim_floor.launch">
    <arg name="building" value="{FACULTY}"/> <arg name="robot" value="Kbot"/> <arg name="speed" value="10"/>
  </include>
  <include file="{REPO}/launch/guiding.launch">
    <arg name="building" value="{FACULTY}"/> <arg name="robot" value="Kbot"/>
    <arg name="offline_after" value="{OFFLINE_AFTER:g}"/>
  </include>
</launch>
""")
    procs.start("stack", ["roslaunch", "--skip-log-check", str(launch)], env)
    driver = Driver(env, "Kbot", tmp_path / "logs" / "gui.log")
    try:
        # Kbot's goal_manager runs by the time its first pending list is shown (it counts partners never heard
        # of as online for offline_after s after it started, in wall time: no message says when that ends)
        driver.until(lambda s: s["robots"]["Kbot"] and "Here:" in s["here"] and s["pending"]["Kbot"], 90,
                     "Kbot's status and pending list")
        manager_up = time.monotonic()
        wait_connected(uri, GUI, COMMANDS, [global_name(n) for n in GUIDING_NODES])   # the buttons publish once
        driver("pick", goal="103")                                   # Dean's Office, same floor
        st = driver("press", key="go")
        assert st["popup"] == "" and st["cancel"]
        st = driver.until(lambda s: s["popup"] == "event:ON_THE_WAY", 60, "guiding to start")
        assert "walk behind me" in st["note"] and "To: Dean's Office (103)" in st["trip"]
        st = driver.until(lambda s: s["popup"] == "event:GOAL_REACHED", 120, "the goal")
        assert "Dean's Office (103)" in st["body"] and not st["cancel"]
        # the second floor's robot has never been heard of: refused at once, nothing queued (once the goal
        # manager's first offline_after s are over, usually long before the trip above ends)
        wait_until(lambda: time.monotonic() - manager_up > OFFLINE_AFTER + 0.5, 30, "Galtxagorri counted offline")
        driver("pick", goal="223")
        driver("press", key="go")
        st = driver("press", key="stairs")
        st = driver.until(lambda s: s["popup"].startswith("event:") and s["popup"] != "event:GOAL_REACHED", 30,
                          "the answer to a request needing an offline robot")
        assert st["popup"] == "event:PARTNER_OFFLINE" and not st["cancel"], st
    finally:
        driver.close()
