"""The relay supervisor: starts this robot's relay ends as child processes.

A building of n robots has n(n-1)/2 relays, one per pair, derived from the building
file; each relay has one end on each of its two robots. Robot i runs the n-1 ends of
its own relays, all against its own master (ROS_IP = its address): for a pair (a, b)
with a listed first, end ``a`` (on robot a) connects to end ``b`` (on robot b), which
listens on b's address, port ``building.relay_link_port(a, b)`` (docs/deploy.md). The
only traffic between two robots' machines is that link. Each end runs in its own
process group, killed if the supervisor dies (parent-death signal, and the ends also
watch their parent), restarted with exponential backoff if it dies.

:func:`plan_relays` and :class:`Backoff` are ROS-free; :class:`ChildProcess` is plain
process handling; the ROS adapter is :mod:`gidabot_navigation.relay.supervisor_node`.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from gidabot_navigation.building.model import Building
from gidabot_navigation.interface import relay_end_name
from gidabot_navigation.relay.end import EXIT_CONFIG, EXIT_PORT, PARENT_ENV

RELAY_END = "gidabot_navigation.relay.end_node"   # the end's module, run with ``python -m``: no file to find


@dataclass(frozen=True)
class EndSpec:
    """One relay end process: which pair, which side, which master, where the link is."""

    robot_a: str
    robot_b: str
    side: str            # "a" (connects) or "b" (listens)
    master_uri: str      # master of the robot of this side
    ros_ip: str          # ROS_IP of this end: the address of the robot of this side
    link_host: str       # end b's listening address (robot b's)
    link_port: int
    bind_ip: str         # end a's source address (robot a's)

    @property
    def pair(self) -> str:
        return f"{self.robot_a}_{self.robot_b}"

    @property
    def key(self) -> str:
        return f"{self.pair}.{self.side}"

    @property
    def node_name(self) -> str:
        return relay_end_name(self.robot_a, self.robot_b)


def plan_relays(building: Building, robot: str) -> list[EndSpec]:
    """The ends robot ``robot`` runs: one per other robot, in building order, each on this robot's master."""
    me = building.robot(robot)
    ends: list[EndSpec] = []
    for a, b in building.relay_pairs():
        if me.name not in (a.name, b.name):
            continue
        port = building.relay_link_port(a.name, b.name)
        side = "a" if a.name == me.name else "b"
        ends.append(EndSpec(a.name, b.name, side, me.master_uri, me.ip, b.ip, port, a.ip))
    return ends


@dataclass
class Backoff:
    """Restart delays: ``initial`` doubling to ``maximum``; back to ``initial`` after ``stable`` s running."""

    initial: float = 0.5
    maximum: float = 10.0
    stable: float = 30.0
    delay: float = 0.5

    def __post_init__(self) -> None:
        self.delay = self.initial

    def next_delay(self, ran_for: float) -> float:
        if ran_for >= self.stable:
            self.delay = self.initial
        d = self.delay
        self.delay = min(self.maximum, self.delay * 2)
        return d


@dataclass(frozen=True)
class EndOptions:
    """What every end gets besides its EndSpec (passed as private parameters)."""

    state_dir: str
    secret_file: str = ""
    topics_file: str = ""
    extra: tuple[tuple[str, str], ...] = ()     # further end options (tuning): (name, value)
    robot_ends: tuple[str, ...] = ()            # node names of every end of this robot (its links)


def end_argv(spec: EndSpec, opts: EndOptions, python: str = sys.executable) -> list[str]:
    """Command line of one end (the secret travels as a file path, never as a value)."""
    argv = [python, "-m", RELAY_END, "--robot_a", spec.robot_a, "--robot_b", spec.robot_b, "--side", spec.side,
            "--link_host", spec.link_host, "--link_port", str(spec.link_port), "--bind_ip", spec.bind_ip,
            "--state_dir", opts.state_dir, "--secret_file", opts.secret_file]
    if opts.topics_file:
        argv += ["--topics_file", opts.topics_file]
    if opts.robot_ends:
        argv += ["--robot_ends", ",".join(opts.robot_ends)]
    for k, v in opts.extra:
        argv += [f"--{k}", v]
    return argv


def end_env(spec: EndSpec, base: Mapping[str, str], parent_pid: int) -> dict[str, str]:
    env = dict(base)
    for var in ("ROS_HOSTNAME", "ROS_NAMESPACE"):
        env.pop(var, None)
    env.update({"ROS_MASTER_URI": spec.master_uri, "ROS_IP": spec.ros_ip, PARENT_ENV: str(parent_pid),
                "PYTHONUNBUFFERED": "1"})
    return env


class ChildProcess:
    """One end process: its own process group, SIGTERM when the supervisor dies, restart with backoff."""

    def __init__(self, spec: EndSpec, opts: EndOptions, log: Callable[[str, str], None],
                 base_env: Mapping[str, str] | None = None, output_dir: Path | None = None,
                 argv_for: Callable[[EndSpec, EndOptions], list[str]] = end_argv) -> None:
        self.spec = spec
        self.output_dir = output_dir
        self.argv_for = argv_for
        self.opts = opts
        self.log = log
        self.base_env = dict(os.environ if base_env is None else base_env)
        self.popen: subprocess.Popen | None = None
        self.backoff = Backoff()
        self.started_at = 0.0
        self.next_start = 0.0
        self.restarts = 0
        self.last_exit: int | None = None

    @property
    def pid(self) -> int | None:
        return self.popen.pid if self.popen is not None and self.popen.poll() is None else None

    def start(self, now: float) -> None:
        argv = self.argv_for(self.spec, self.opts)
        setpriv = shutil.which("setpriv")
        if setpriv:
            argv = [setpriv, "--pdeathsig", "TERM", "--", *argv]
        out = None
        try:
            if self.output_dir is not None:
                out = open(self.output_dir / f"{self.spec.key}.log", "ab")  # noqa: SIM115 - closed below
            self.popen = subprocess.Popen(argv, env=end_env(self.spec, self.base_env, os.getpid()),
                                          stdin=subprocess.DEVNULL, stdout=out,
                                          stderr=subprocess.STDOUT if out else None, start_new_session=True,
                                          preexec_fn=None if setpriv else _pdeathsig)
        except OSError as err:
            self.popen = None
            self.next_start = now + self.backoff.next_delay(0.0)
            self.log("error", f"cannot start relay end {self.spec.key}: {err.strerror}")
            return
        finally:
            if out is not None:
                out.close()
        self.started_at = now
        self.log("info", f"started relay end {self.spec.node_name} side {self.spec.side} on "
                         f"{self.spec.master_uri} (pid {self.popen.pid}, link {self.spec.link_host}:"
                         f"{self.spec.link_port})")

    def poll(self, now: float) -> int | None:
        """The exit code if the process ended since the last poll (then a restart is scheduled)."""
        if self.popen is None or self.popen.poll() is None:
            return None
        code = self.popen.returncode
        self.popen = None
        self.last_exit = code
        self.restarts += 1
        delay = self.backoff.next_delay(now - self.started_at)
        if code == EXIT_CONFIG:
            delay = max(delay, self.backoff.maximum)
        why = (f" (cannot listen on {self.spec.link_host}:{self.spec.link_port}: is the port taken, or is this "
               f"not {self.spec.robot_b}'s address?)" if code == EXIT_PORT else "")
        self.next_start = now + delay
        self.log("warning", f"relay end {self.spec.key} exited with {code}{why}; restarting in {delay:.1f} s")
        return code

    def due(self, now: float) -> bool:
        return self.popen is None and now >= self.next_start

    def stop(self, grace: float = 3.0) -> None:
        if self.popen is None:
            return
        pgid = self.popen.pid
        for sig, wait in ((signal.SIGINT, grace), (signal.SIGTERM, 2.0), (signal.SIGKILL, 5.0)):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pgid, sig)
            try:
                self.popen.wait(timeout=wait)
                break
            except subprocess.TimeoutExpired:
                continue
        with contextlib.suppress(ProcessLookupError):
            os.killpg(pgid, signal.SIGKILL)
        self.popen = None


def _pdeathsig() -> None:       # pragma: no cover - runs in the child between fork and exec
    import ctypes

    ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)      # PR_SET_PDEATHSIG


class RelaySupervisor:
    """Keeps every planned end running (no rospy): call :meth:`step` periodically, :meth:`stop` at the end."""

    def __init__(self, ends: list[EndSpec], opts: EndOptions, log: Callable[[str, str], None],
                 base_env: Mapping[str, str] | None = None, output_dir: Path | None = None,
                 argv_for: Callable[[EndSpec, EndOptions], list[str]] = end_argv) -> None:
        """``output_dir``: where each end's stdout/stderr goes (``<key>.log``); None = inherited.
        ``argv_for``: the command of an end (tests replace the relay end by a stand-in; the relay
        benchmark runs each end inside its robot's network namespace)."""
        self.children = [ChildProcess(s, opts, log, base_env, output_dir, argv_for) for s in ends]
        self.log = log

    def step(self, now: float) -> None:
        for child in self.children:
            child.poll(now)
        for child in self.children:
            if child.due(now):
                child.start(now)

    def stop(self, grace: float = 3.0) -> None:
        """Stop every end at once: SIGINT, then SIGTERM, then SIGKILL to each process group."""
        running = [c for c in self.children if c.popen is not None]
        for sig, wait in ((signal.SIGINT, grace), (signal.SIGTERM, 2.0), (signal.SIGKILL, 5.0)):
            for c in running:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(c.popen.pid, sig)
            deadline = time.monotonic() + wait
            for c in running:
                with contextlib.suppress(subprocess.TimeoutExpired):
                    c.popen.wait(timeout=max(0.0, deadline - time.monotonic()))
            running = [c for c in running if c.popen.poll() is None]
            if not running:
                break
        for c in self.children:
            if c.popen is not None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(c.popen.pid, signal.SIGKILL)
                c.popen = None

    def status(self) -> list[tuple[str, int | None, int, int | None, str]]:
        """(end key, pid or None, restarts, last exit code, link address) per end."""
        return [(c.spec.key, c.pid, c.restarts, c.last_exit, f"{c.spec.link_host}:{c.spec.link_port}")
                for c in self.children]
