"""Helpers of the relay system tests: the faculty's 4 masters linked by relays.launch, one probe per robot.

    mesh = RelayMesh(faculty_masters, tmp_path)     # secret file, roslaunch relays.launch per robot
    mesh.start(subscribe=[GOALS])                   # probes subscribe first, then the relays start
    mesh.publish("Tartalo", GOALS, GOAL, {"uid": "g1"})
    mesh.wait_uid("Kbot", GOALS, "g1")
"""

from __future__ import annotations

import hashlib
import os
import signal
import time
import xmlrpc.client
from collections.abc import Callable
from pathlib import Path

from probe import Probe, close_all

from gidabot_navigation.interface import Node, Topic, is_relay_end, relay_end_name
from gidabot_navigation.senders import PUBLISHERS, SPEAKS_FOR, uid_robot
from gidabot_sim.runner.procs import wait_until

REPO = Path(__file__).resolve().parents[1]
RELAYS_LAUNCH = REPO / "launch" / "relays.launch"
GOALS, GOAL = Topic.GOALS, "gidabot_msgs/Goal"
DIAG, DIAG_T = Topic.DIAGNOSTICS, "diagnostic_msgs/DiagnosticArray"
SECRET = "relay-test-secret-0123456789"


class RelayMesh:
    """The relays of a SimBuilding (conftest.faculty_masters) and one probe per robot."""

    def __init__(self, sim, tmp_path: Path, secret: bool = True) -> None:
        self.sim = sim
        self.tmp = tmp_path
        self.robots = [r.name for r in sim.building.robots]
        self.secret_file = ""
        if secret:
            path = tmp_path / "relay.secret"
            path.write_text(SECRET + "\n")
            path.chmod(0o600)
            self.secret_file = str(path)
        self.state_dir = tmp_path / "relay_state"
        self.probes: dict[str, Probe] = {}
        self.as_node: dict[tuple[str, str], Probe] = {}   # (robot, node): a probe named like that node of robot
        self.labels: dict[str, str] = {}        # uid made by legit_uid -> the test's label
        self.subscribed: dict[str, set[str]] = {r: set() for r in self.robots}

    # -- processes ------------------------------------------------------------------------
    def start(self, subscribe: list[tuple[str, str]] | None = None, timeout: float = 60.0) -> None:
        for r in self.robots:
            # named like the robot's own goal manager (which these tests do not run): a message speaks only for
            # its sender, and the relay ends forward only what one of their robot's own nodes published
            self.probes[r] = Probe(self.sim.env(r), self.sim.log_dir / f"probe_{r}.log", timeout=30,
                                   command=lambda argv, r=r: self.sim.command(r, argv), name=Node.GOAL_MANAGER)
        for r in self.robots:
            self.sub(r, DIAG, DIAG_T)
            for topic, type_ in subscribe or []:
                self.sub(r, topic, type_)
        for r in self.robots:
            self.start_relays(r)
        self.wait_connected(timeout)

    def sub(self, robot: str, topic: str, type_: str) -> None:
        self.probes[robot].sub(topic, type_)
        self.subscribed[robot].add(topic)

    def start_relays(self, robot: str) -> None:
        self.sim.procs.start(f"relays_{robot}", self.sim.command(robot, [
            "roslaunch", str(RELAYS_LAUNCH), f"building:={self.sim.path}", f"robot:={robot}",
            f"secret:={self.secret_file}", f"state_dir:={self.state_dir}"]), self.sim.env(robot))

    def close(self) -> None:
        """Stop the relays of every robot at once (each takes ~2 s to stop its ends), then the probes."""
        names = [f"relays_{r}" for r in self.robots if self.sim.procs.alive(f"relays_{r}")]
        for name in names:
            self.sim.procs.signal(name, signal.SIGINT)
        for name in names:
            self.sim.procs.stop(name)
        close_all([*self.probes.values(), *self.as_node.values()])

    def __enter__(self) -> RelayMesh:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- names ----------------------------------------------------------------------------
    def pair(self, x: str, y: str) -> tuple[str, str]:
        """The relay pair (a, b) of robots x and y, in building order."""
        return (x, y) if self.robots.index(x) < self.robots.index(y) else (y, x)

    def end_status_name(self, on: str, other: str) -> str:
        a, b = self.pair(on, other)
        return f"relay {a}-{b}: {on}"

    def robot(self, name: str):
        return self.sim.building.robot(name)

    # -- diagnostics ----------------------------------------------------------------------
    def diag(self, robot: str, name: str) -> dict[str, str] | None:
        """Values of the latest status ``name`` published on ``robot``'s master (with level and message)."""
        msgs = self.probes[robot].msgs(DIAG)
        for msg in reversed(msgs):
            for st in msg["status"]:
                if st["name"] == name:
                    values = {kv["key"]: kv["value"] for kv in st["values"]}
                    values["_level"], values["_message"] = st["level"], st["message"]
                    values["_stamp"] = msg["header"]["stamp"]
                    return values
        return None

    def end_diag(self, on: str, other: str) -> dict[str, str] | None:
        return self.diag(on, self.end_status_name(on, other))

    def wait_end(self, on: str, other: str, predicate: Callable[[dict[str, str]], bool], timeout: float,
                 what: str, after: float = 0.0) -> float:
        """Wait until the latest diagnostics of that end satisfy ``predicate``; with ``after`` (wall
        time, e.g. the moment of a fault) only diagnostics stamped later count."""
        def ok() -> bool:
            d = self.end_diag(on, other)
            return d is not None and float(d["_stamp"]) > after and predicate(d)
        return wait_until(ok, timeout, f"{what} (relay end of {on} towards {other})", interval=0.1)

    def wait_connected(self, timeout: float = 60.0) -> None:
        for r in self.robots:
            for o in self.robots:
                if o != r:
                    self.wait_end(r, o, lambda d: d.get("connected") == "True" and d.get("delivery_open") == "True",
                                  timeout, "link up")

    def end_owner(self, link_key: str) -> str:
        """The robot that runs relay end ``link_key`` (e.g. "Tartalo_Kbot.b": Kbot, the robot of side b)."""
        link, side = link_key.rsplit(".", 1)
        a, b = next((x, y) for x in self.robots for y in self.robots if f"{x}_{y}" == link)
        return a if side == "a" else b

    def _supervised(self, link_key: str) -> str | None:
        owner = self.end_owner(link_key)
        d = self.diag(owner, f"relay_supervisor: {owner}")
        return d.get(link_key) if d else None

    def end_pid(self, link_key: str) -> int:
        """Pid of relay end ``link_key`` (e.g. "Tartalo_Kbot.b"), from the supervisor of the robot that runs it."""
        found: list[int] = []

        def current() -> bool:
            text = self._supervised(link_key)
            word = text.split(",")[0].split()[1] if text else ""
            if word.isdigit():
                found.append(int(word))
            return bool(found)
        wait_until(current, 20, f"pid of relay end {link_key}")
        return found[-1]

    def link_address(self, link_key: str) -> tuple[str, int]:
        text = self._supervised(link_key)
        assert text is not None
        host, port = text.rsplit("link ", 1)[1].split(":")
        return host, int(port)

    # -- messages -------------------------------------------------------------------------
    def ends(self, robot: str) -> list[str]:
        """Node names of ``robot``'s relay ends, one towards each other robot (on ``robot``'s master)."""
        return [relay_end_name(*self.pair(robot, o)) for o in self.robots if o != robot]

    def publish(self, robot: str, topic: str, type_: str, msg: dict) -> None:
        """Publish as ``robot``'s own node once every relay end of ``robot`` (and its probe, if it records ``topic``)
        is connected. The message is made ``robot``'s as its own nodes would make it (senders.SPEAKS_FOR): the
        field naming its robot set to ``robot`` when left out, a ``uid`` label (e.g. "during-outage") replaced by
        a uid of ``robot`` (:meth:`legit_uid`; :meth:`uids` gives the labels back)."""
        msg = dict(msg)
        speech = SPEAKS_FOR.get(topic)
        if speech is not None and speech.robot:
            msg.setdefault(speech.robot, robot)
        if speech is not None and speech.uid and "uid" in msg and uid_robot(msg["uid"]) is None:
            msg["uid"] = self.legit_uid(robot, str(msg["uid"]))
        self._publisher(robot, topic).pub(topic, type_, msg, to=self.ends(robot))

    def _publisher(self, robot: str, topic: str) -> Probe:
        """The probe that publishes ``topic`` as ``robot``'s own node: its goal manager's, or on a topic only some
        own nodes may publish (senders.PUBLISHERS: a staff command) a probe named like the first of them."""
        nodes = PUBLISHERS.get(topic)
        if not nodes or Node.GOAL_MANAGER in nodes:
            return self.probes[robot]
        key = (robot, nodes[0])
        if key not in self.as_node:
            self.as_node[key] = Probe(self.sim.env(robot), self.sim.log_dir / f"probe_{robot}_{nodes[0]}.log",
                                      timeout=30, command=lambda argv: self.sim.command(robot, argv), name=nodes[0])
        return self.as_node[key]

    def legit_uid(self, robot: str, label: str) -> str:
        """A uid of ``robot`` (senders.UID_FORMAT) standing for the test's ``label``."""
        uid = f"{robot}/test/gm.{hashlib.blake2b(label.encode(), digest_size=8).hexdigest()}"
        self.labels[uid] = label
        return uid

    def uids(self, robot: str, topic: str = GOALS) -> list[str]:
        """The uids received on ``topic`` at ``robot``; those published by :meth:`publish` as their labels."""
        return [self.labels.get(m["uid"], m["uid"]) for m in self.probes[robot].msgs(topic)]

    def wait_uid(self, robot: str, topic: str, uid: str, timeout: float = 30.0) -> float:
        return wait_until(lambda: uid in self.uids(robot, topic), timeout, f"{uid} on {topic} at {robot}",
                          interval=0.02)

    def assert_no_duplicates(self, topic: str = GOALS) -> None:
        for r in self.robots:
            got = self.uids(r, topic)
            dups = sorted({u for u in got if got.count(u) > 1})
            assert not dups, f"{r} received {dups} more than once on {topic}"

    # -- master ---------------------------------------------------------------------------
    def relay_ends(self, robot: str) -> list[str]:
        uri = self.robot(robot).master_uri
        _, _, state = self.sim.call(robot, lambda: xmlrpc.client.ServerProxy(uri).getSystemState("/test"))
        nodes = {n for group in state for _, ns in group for n in ns}
        return sorted(n for n in nodes if is_relay_end(n))


def detection_delay(d: dict[str, str], since_key: str, t_fault_wall: float) -> float:
    """Seconds from the fault (wall time) to the moment the relay noticed it.

    ``d[since_key]`` is how long the condition had lasted when the diagnostics were stamped
    (wall time: the relay tests do not use sim time), so the moment it began is exact to the ms."""
    return float(d["_stamp"]) - float(d[since_key]) - t_fault_wall


def wait_pid_gone(pid: int, timeout: float) -> None:
    def gone() -> bool:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return True
        try:                                 # a zombie (not reaped yet) counts as gone
            with open(f"/proc/{pid}/stat") as f:
                return f.read().split(")")[-1].split()[0] == "Z"
        except OSError:
            return True
    wait_until(gone, timeout, f"process {pid} gone")


def settle(seconds: float) -> None:
    """Let messages that should NOT arrive have their chance (negative checks only)."""
    time.sleep(seconds)
