"""Process management for system tests, benchmarks, the demo and fault injection (ROS-free).

Every process is started in its own session (process group) and stopped by
group id, never by name: SIGINT, then SIGTERM, then SIGKILL after deadlines.
Waiting is always on a condition with a deadline (:func:`wait_until`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import time
import xmlrpc.client
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from gidabot_sim.errors import ProcessError


def wait_until(predicate: Callable[[], bool], timeout: float, what: str, interval: float = 0.05) -> float:
    """Poll ``predicate`` until true; return the seconds waited or raise :class:`ProcessError`."""
    start = time.monotonic()
    deadline = start + timeout
    while True:
        if predicate():
            return time.monotonic() - start
        if time.monotonic() >= deadline:
            raise ProcessError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(interval)


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port that is free on ``host`` right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind((host, 0))
        return int(sock.getsockname()[1])


def free_port_run(host: str, count: int, start: int = 11411, end: int = 32768) -> int:
    """The first port p >= ``start`` such that p .. p + count - 1 are all free on ``host`` right now (below
    the kernel's ephemeral ports, so an outgoing connection does not take one before it is bound)."""
    def free(port: int) -> bool:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
            try:
                sock.bind((host, port))
            except OSError:
                return False
        return True

    for p in range(start, end - count):
        if all(free(p + k) for k in range(count)):
            return p
    raise ProcessError(f"no {count} consecutive free TCP ports in {start}..{end} on {host}")


NET_LOCK_DIR = Path(os.environ.get("GIDABOT_NET_LOCK_DIR", "/tmp/gidabot-test-net"))
_net_lock: tuple[int, int] | None = None          # (N, fd of its lock file), held until this process exits


def _net_in_use(n: int) -> bool:
    """True if a socket of this machine is bound to an address 127.N.x.x (another run, or a leftover)."""
    prefix = f"{n:02X}7F"        # /proc/net/tcp holds addresses little-endian: 127.N.a.b -> bbaaNN7F
    for table in ("/proc/net/tcp", "/proc/net/udp"):
        with contextlib.suppress(OSError), open(table) as f:
            next(f, None)
            for line in f:
                local = line.split()[1].split(":")[0]
                if local.endswith(prefix):
                    return True
    return False


def test_network() -> int:
    """Second octet of the loopback network used by this process's tests and benchmarks.

    ``GIDABOT_TEST_NET`` (1..254) if set. Otherwise the first N from a pid-derived start
    whose lock file (``/tmp/gidabot-test-net/<N>.lock``, flock) this process can take
    and whose addresses no socket uses; the lock is held until the process exits, and
    ``GIDABOT_TEST_NET`` is set for its children. So two sessions on one machine never
    share a network, and a link cut injected with iptables in one never touches another.
    """
    global _net_lock
    value = os.environ.get("GIDABOT_TEST_NET", "")
    if value:
        if not value.isdigit() or not 1 <= int(value) <= 254:
            raise ProcessError(f"GIDABOT_TEST_NET={value!r}: expected a number 1..254 (127.N.0.x)")
        return int(value)
    if _net_lock is not None:
        return _net_lock[0]
    import fcntl

    NET_LOCK_DIR.mkdir(parents=True, exist_ok=True)
    start = os.getpid() % 200
    for k in range(200):
        n = 20 + (start + k) % 200
        fd = os.open(NET_LOCK_DIR / f"{n}.lock", os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            continue
        if _net_in_use(n):
            os.close(fd)
            continue
        _net_lock = (n, fd)
        os.environ["GIDABOT_TEST_NET"] = str(n)
        return n
    raise ProcessError(f"no free test network 127.N.0.x (N 20..219): every lock in {NET_LOCK_DIR} is held")


def robot_address(index: int, net: int | None = None) -> str:
    """Loopback address of robot ``index`` in tests and benchmarks: 127.<net>.0.<11 + index>."""
    if not 0 <= index < 200:
        raise ProcessError(f"robot index {index} out of range 0..199")
    return f"127.{test_network() if net is None else net}.0.{11 + index}"


def master_pid(uri: str, timeout: float = 0.5) -> int | None:
    """PID of the ROS master at ``uri``, or None if it does not answer within ``timeout``."""
    old = socket.getdefaulttimeout()
    socket.setdefaulttimeout(timeout)
    try:
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/gidabot_probe")
        return int(pid) if code == 1 else None
    except (OSError, xmlrpc.client.Error):
        return None
    finally:
        socket.setdefaulttimeout(old)


def node_uri(master_uri: str, node: str, caller: str) -> str:
    """The XML-RPC URI of node ``node`` (a global name) registered on the master at ``master_uri`` ("" when it
    is not registered or the master does not answer); ``caller``: the caller id the master is asked as."""
    try:
        code, _, uri = xmlrpc.client.ServerProxy(master_uri).lookupNode(caller, node)
    except (OSError, xmlrpc.client.Error):
        return ""
    return str(uri) if code == 1 else ""


def node_pid(master_uri: str, node: str, caller: str) -> int | None:
    """PID of node ``node`` registered on the master at ``master_uri``, None when it cannot be asked."""
    uri = node_uri(master_uri, node, caller)
    if not uri:
        return None
    try:
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid(caller)
    except (OSError, xmlrpc.client.Error):
        return None
    return int(pid) if code == 1 else None


def ros_env(master_uri: str, ip: str, base: Mapping[str, str] | None = None,
            log_dir: Path | None = None, **extra: str) -> dict[str, str]:
    """Environment of a process that belongs to the robot whose master is ``master_uri``."""
    env = dict(os.environ if base is None else base)
    env.update({"ROS_MASTER_URI": master_uri, "ROS_IP": ip, "PYTHONUNBUFFERED": "1"})
    env.pop("ROS_HOSTNAME", None)
    if log_dir is not None:
        log_dir.mkdir(parents=True, exist_ok=True)
        env["ROS_LOG_DIR"] = str(log_dir)
        env["ROS_HOME"] = str(log_dir)
    env.update(extra)
    return env


@dataclass
class Managed:
    name: str
    argv: list[str]
    popen: subprocess.Popen
    log_path: Path | None
    env: dict[str, str] = field(repr=False)
    cwd: str | None = None


class ProcessGroup:
    """A set of named processes, each in its own session; ``close()`` stops them all.

    Use as a context manager so that nothing is left running, whatever happens.
    """

    def __init__(self, log_dir: Path | None = None) -> None:
        self.log_dir = log_dir
        self._procs: dict[str, Managed] = {}

    def __enter__(self) -> ProcessGroup:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self, name: str, argv: Sequence[str], env: Mapping[str, str] | None = None,
              cwd: str | Path | None = None) -> Managed:
        """Start ``argv`` as ``name`` (which must not be running) in a new session."""
        if name in self._procs and self._procs[name].popen.poll() is None:
            raise ProcessError(f"process {name!r} is already running (pid {self._procs[name].popen.pid})")
        log_path = None
        out: int | object = subprocess.DEVNULL
        if self.log_dir is not None:
            self.log_dir.mkdir(parents=True, exist_ok=True)
            log_path = self.log_dir / f"{name.replace('/', '_')}.log"
            out = open(log_path, "ab")  # noqa: SIM115 - closed when the process is reaped
        try:
            popen = subprocess.Popen(list(argv), env=dict(env) if env is not None else None,
                                     cwd=str(cwd) if cwd else None, stdin=subprocess.DEVNULL,
                                     stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        except OSError as err:
            raise ProcessError(f"cannot start {name!r} ({argv[0]}): {err.strerror}") from err
        finally:
            if hasattr(out, "close"):
                out.close()  # the child holds its own copy
        managed = Managed(name, list(argv), popen, log_path, dict(env or os.environ),
                          str(cwd) if cwd else None)
        self._procs[name] = managed
        return managed

    def restart(self, name: str) -> Managed:
        """Stop ``name`` if running and start it again with the same command and environment."""
        old = self._procs[name]
        self.stop(name)
        return self.start(name, old.argv, old.env, old.cwd)

    def get(self, name: str) -> Managed:
        return self._procs[name]

    def names(self) -> list[str]:
        return list(self._procs)

    def alive(self, name: str) -> bool:
        proc = self._procs.get(name)
        return proc is not None and proc.popen.poll() is None

    def signal(self, name: str, sig: int) -> None:
        """Send ``sig`` to the whole process group of ``name`` (e.g. SIGSTOP/SIGCONT)."""
        proc = self._procs[name]
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.popen.pid, sig)

    def stop(self, name: str, grace: float = 5.0) -> int | None:
        """Stop ``name``'s process group: SIGINT, SIGTERM, then SIGKILL; returns the exit code."""
        proc = self._procs.get(name)
        if proc is None:
            return None
        pgid = proc.popen.pid
        for sig, wait in ((signal.SIGCONT, 0.0), (signal.SIGINT, grace), (signal.SIGTERM, 2.0),
                          (signal.SIGKILL, 5.0)):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pgid, sig)
            if wait == 0.0:
                continue
            try:
                proc.popen.wait(timeout=wait)
                break
            except subprocess.TimeoutExpired:
                continue
        # the leader is gone; make sure no member of its group survives it
        with contextlib.suppress(ProcessLookupError):
            os.killpg(pgid, signal.SIGKILL)
        return proc.popen.returncode

    def close(self) -> None:
        """Stop every process, newest first."""
        for name in reversed(list(self._procs)):
            self.stop(name, grace=3.0)


def start_master(group: ProcessGroup, name: str, ip: str, port: int | None = None,
                 timeout: float = 15.0) -> str:
    """Start a rosmaster on ``ip`` (a 127.x.y.z address) and wait until it answers; return its URI."""
    port = port or free_port(ip)
    uri = f"http://{ip}:{port}/"
    env = ros_env(uri, ip, log_dir=group.log_dir / name if group.log_dir else None)
    group.start(name, ["rosmaster", "--core", "-p", str(port), "-w", "3"], env)
    wait_until(lambda: master_pid(uri) is not None, timeout, f"master {name} at {uri}")
    return uri


@contextlib.contextmanager
def masters(ips: Sequence[str], log_dir: Path | None = None) -> Iterator[tuple[ProcessGroup, list[str]]]:
    """Context: one fresh master per address; yields (group, uris) and stops everything after."""
    with ProcessGroup(log_dir) as group:
        uris = [start_master(group, f"master{i}", ip) for i, ip in enumerate(ips)]
        yield group, uris
