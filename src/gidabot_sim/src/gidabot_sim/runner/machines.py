"""Separate machines on one host: one Linux network namespace per robot, linked by a bridge.

A real GidaBot building is one computer per robot, joined by a network (a VPN over 3G in
the paper). :class:`Machines` builds that on this one host so that everyone can run it:

- a namespace of the run holds the bridge (nothing is added to the host's own network
  namespace): ``gbm-<pid>-<start>-net`` with the bridge ``gbm<pid>br``;
- every robot (and any extra machine, e.g. an intruder for tests) gets a namespace
  ``gbm-<pid>-<start>-<role>`` with its own loopback and one interface ``eth0``, the end of
  a veth pair whose other end (``gbm<pid>v<k>``) is a port of the bridge, and an address of
  ``SUBNET`` (robot k: ``.11 + k``, extra machine j: ``.200 + j``);
- processes run inside a namespace (``nsenter --net``, :meth:`Machines.wrap`), optionally
  with a wall clock of their own, a constant offset (:func:`clock_env`: every Python process
  of the machine adds it to ``time.time()``; the monotonic clock is left alone);
- this process talks to a namespace (XML-RPC to a master, say) through a thread that
  entered it (``setns``, :meth:`Machines.call`): nothing of the host is exposed;
- a firewall per namespace (:meth:`Machines.firewall`) admits from the network only the
  TCP ports given (the relay links' listening ports) and answers to connections the
  machine opened itself; masters and nodes cannot be reached from another machine;
- faults of a real network (:meth:`Machines.partition`, :meth:`Machines.cut`,
  :meth:`Machines.drop`) are iptables rules in chains of their own (``GB-FAULT-IN`` /
  ``GB-FAULT-OUT``, jumped to first), cleared by flushing those chains.

``<pid>-<start>`` names the owner: this process's pid and its start time (clock ticks since
boot, so a reused pid is told apart). :func:`remove_leftovers` (run by :meth:`Machines.create`)
removes every namespace whose owner is gone (a run that crashed or was killed): the
processes inside are killed, then the namespace is deleted, which removes its links.
:meth:`Machines.destroy` (and leaving the ``with`` block) does the same for this run.

Needs root (CAP_NET_ADMIN, CAP_SYS_ADMIN): ``ip``, ``iptables``, ``nsenter``, ``ss``.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import ctypes
import os
import re
import shutil
import signal
import subprocess
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from gidabot_sim.errors import MachinesError
from gidabot_sim.runner.clock_shim import OFFSET_ENV, SHIM_DIR

NETNS_DIR = Path("/run/netns")
OWNER_PREFIX = "gbm"
SUBNET = "10.10.0"                  # robot k: SUBNET.(11 + k), extra machine j: SUBNET.(200 + j)
PREFIX_LEN = 24
FAULT_IN, FAULT_OUT = "GB-FAULT-IN", "GB-FAULT-OUT"
CLONE_NEWNET = 0x40000000
_NAME = re.compile(rf"^{OWNER_PREFIX}-(\d+)-(\d+)-([a-z0-9]+)$")
T = TypeVar("T")


# ---------------------------------------------------------------------------
# Names and owners (pure)
# ---------------------------------------------------------------------------

def process_start(pid: int) -> int | None:
    """Start time of process ``pid`` (clock ticks since boot), None if there is no such process."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
    except OSError:
        return None
    fields = stat[stat.rfind(")") + 2:].split()
    return int(fields[19]) if len(fields) > 19 and fields[0] != "Z" else None


@dataclass(frozen=True)
class Owner:
    """The process that owns a run's namespaces (pid and start time)."""

    pid: int
    start: int

    @classmethod
    def this_process(cls) -> Owner:
        start = process_start(os.getpid())
        if start is None:
            raise MachinesError("cannot read this process's start time from /proc")
        return cls(os.getpid(), start)

    @property
    def prefix(self) -> str:
        return f"{OWNER_PREFIX}-{self.pid}-{self.start}"

    def netns(self, role: str) -> str:
        if not re.fullmatch(r"[a-z0-9]+", role):
            raise MachinesError(f"namespace role {role!r}: expected lower-case letters and digits")
        return f"{self.prefix}-{role}"

    @property
    def link_prefix(self) -> str:
        """Prefix of the interface names in the run's bridge namespace (at most 15 characters each)."""
        return f"{OWNER_PREFIX}{self.pid}"

    def alive(self, start_of: Callable[[int], int | None] = process_start) -> bool:
        return start_of(self.pid) == self.start


def parse_netns(name: str) -> tuple[Owner, str] | None:
    """(owner, role) of a namespace named by this module, None for any other name."""
    m = _NAME.match(name)
    return (Owner(int(m.group(1)), int(m.group(2))), m.group(3)) if m else None


def leftovers(names: Iterable[str], start_of: Callable[[int], int | None] = process_start) -> list[str]:
    """The namespaces of ``names`` whose owner process is gone (same pid and start time no longer alive)."""
    out = []
    for name in names:
        parsed = parse_netns(name)
        if parsed is not None and not parsed[0].alive(start_of):
            out.append(name)
    return sorted(out)


def list_netns() -> list[str]:
    try:
        return sorted(p.name for p in NETNS_DIR.iterdir())
    except FileNotFoundError:
        return []


# ---------------------------------------------------------------------------
# Commands
# ---------------------------------------------------------------------------

def _tool(name: str) -> str:
    exe = shutil.which(name)
    if exe is None:
        raise MachinesError(f"{name} is not installed (tools/apt-packages.txt lists what make setup installs)")
    return exe


def run(argv: Sequence[str], check: bool = True, timeout: float = 30.0) -> subprocess.CompletedProcess:
    """Run a command; a failure raises :class:`MachinesError` with its output (``check``)."""
    try:
        proc = subprocess.run(list(argv), capture_output=True, text=True, timeout=timeout, check=False)
    except (OSError, subprocess.TimeoutExpired) as err:
        raise MachinesError(f"{' '.join(argv)}: {err}") from err
    if check and proc.returncode != 0:
        raise MachinesError(f"{' '.join(argv)}: {(proc.stderr or proc.stdout).strip() or f'exit {proc.returncode}'}")
    return proc


def netns_pids(name: str) -> list[int]:
    """Every process inside namespace ``name`` (``ip netns pids``)."""
    proc = run([_tool("ip"), "netns", "pids", name], check=False)
    return [int(p) for p in proc.stdout.split() if p.isdigit()]


def kill_netns(name: str, grace: float = 2.0) -> list[int]:
    """Stop every process of namespace ``name`` (SIGTERM, then SIGKILL after ``grace`` s) and delete it.
    Returns the pids that were still there."""
    pids = netns_pids(name)
    for sig, wait in ((signal.SIGCONT, 0.0), (signal.SIGTERM, grace), (signal.SIGKILL, 2.0)):
        left = [p for p in pids if process_start(p) is not None]
        for pid in left:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, sig)
        deadline = time.monotonic() + wait
        while wait and time.monotonic() < deadline and any(process_start(p) is not None for p in left):
            time.sleep(0.05)
    run([_tool("ip"), "netns", "delete", name], check=False)
    return pids


def remove_leftovers(start_of: Callable[[int], int | None] = process_start) -> list[str]:
    """Remove every namespace (processes and links included) of a run whose owner is gone."""
    gone = leftovers(list_netns(), start_of)
    for name in gone:
        kill_netns(name, grace=0.5)
    return gone


def clock_env(offset_s: float, base: Mapping[str, str]) -> dict[str, str]:
    """``base`` for a process (and its children) whose wall clock is ``offset_s`` seconds off the host's:
    the shim :mod:`gidabot_sim.runner.clock_shim` first on ``PYTHONPATH`` (every robot process is Python).
    The monotonic clock is left alone, so timeouts and sleeps are unaffected."""
    env = dict(base)
    if offset_s:
        env[OFFSET_ENV] = repr(float(offset_s))
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(SHIM_DIR), base.get("PYTHONPATH", "")) if p)
    return env


# ---------------------------------------------------------------------------
# Connections (ss)
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Connection:
    """One established TCP connection seen in a namespace: local and peer address and port."""

    local: str
    local_port: int
    peer: str
    peer_port: int


def parse_ss(text: str) -> list[Connection]:
    """Connections from ``ss -tnH state established`` (IPv4, columns Recv-Q Send-Q Local Peer [Process])."""
    out = []
    for line in text.splitlines():
        cols = line.split()
        if len(cols) < 4:
            continue
        try:
            local, lport = cols[2].rsplit(":", 1)
            peer, pport = cols[3].rsplit(":", 1)
            out.append(Connection(local.strip("[]"), int(lport), peer.strip("[]"), int(pport)))
        except ValueError:
            continue
    return out


# ---------------------------------------------------------------------------
# The machines
# ---------------------------------------------------------------------------

@dataclass
class Machine:
    """One simulated computer: its namespace, address and clock offset (wall s)."""

    name: str
    netns: str
    address: str
    clock_offset: float = 0.0
    veth: str = ""                       # the bridge side of its link

    @property
    def netns_path(self) -> str:
        return str(NETNS_DIR / self.netns)


@dataclass
class Machines:
    """Robots (and extra machines) in namespaces of their own on one bridge. See the module docstring.

    ``clock_offsets``: machine name -> wall-clock offset in s (processes started with :meth:`env`).
    """

    robots: Sequence[str]
    extra: Sequence[str] = ()
    clock_offsets: Mapping[str, float] = field(default_factory=dict)
    subnet: str = SUBNET
    owner: Owner = field(default_factory=Owner.this_process)
    machines: dict[str, Machine] = field(default_factory=dict, init=False)
    removed_leftovers: list[str] = field(default_factory=list, init=False)
    _executors: dict[str, concurrent.futures.ThreadPoolExecutor] = field(default_factory=dict, init=False)
    _created: list[str] = field(default_factory=list, init=False)

    def __post_init__(self) -> None:
        names = list(self.robots) + list(self.extra)
        if len(set(names)) != len(names):
            raise MachinesError(f"machine names must be distinct: {names}")
        if len(self.robots) > 180 or len(self.extra) > 50:
            raise MachinesError("at most 180 robots and 50 extra machines")
        unknown = set(self.clock_offsets) - set(names)
        if unknown:
            raise MachinesError(f"clock offsets for unknown machines: {sorted(unknown)}")
        for k, name in enumerate(self.robots):
            self.machines[name] = Machine(name, self.owner.netns(f"r{k}"), f"{self.subnet}.{11 + k}",
                                          float(self.clock_offsets.get(name, 0.0)), f"{self.owner.link_prefix}v{k}")
        for j, name in enumerate(self.extra):
            self.machines[name] = Machine(name, self.owner.netns(f"x{j}"), f"{self.subnet}.{200 + j}",
                                          float(self.clock_offsets.get(name, 0.0)), f"{self.owner.link_prefix}x{j}")
        self.bridge_netns = self.owner.netns("net")
        self.bridge = f"{self.owner.link_prefix}br"

    # -- life cycle -------------------------------------------------------------------------
    def __enter__(self) -> Machines:
        self.create()
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()

    def create(self) -> Machines:
        """Remove leftovers of crashed runs, then the bridge namespace and one namespace per machine."""
        if os.geteuid() != 0:
            raise MachinesError("separate machines need root (network namespaces, veth pairs, iptables)")
        ip = _tool("ip")
        for tool in ("nsenter", "iptables", "ss"):
            _tool(tool)
        self.removed_leftovers = remove_leftovers()
        try:
            self._add_netns(self.bridge_netns)
            run([ip, "-n", self.bridge_netns, "link", "add", self.bridge, "type", "bridge"])
            run([ip, "-n", self.bridge_netns, "link", "set", self.bridge, "up"])
            for m in self.machines.values():
                self._add_netns(m.netns)
                run([ip, "-n", m.netns, "link", "set", "lo", "up"])
                run([ip, "-n", m.netns, "link", "add", "eth0", "type", "veth", "peer", "name", m.veth,
                     "netns", self.bridge_netns])
                run([ip, "-n", self.bridge_netns, "link", "set", m.veth, "master", self.bridge])
                run([ip, "-n", self.bridge_netns, "link", "set", m.veth, "up"])
                run([ip, "-n", m.netns, "addr", "add", f"{m.address}/{PREFIX_LEN}", "dev", "eth0"])
                run([ip, "-n", m.netns, "link", "set", "eth0", "up"])
                for chain, hook in ((FAULT_IN, "INPUT"), (FAULT_OUT, "OUTPUT")):
                    self.iptables(m.name, "-N", chain)
                    self.iptables(m.name, "-I", hook, "1", "-j", chain)
        except MachinesError:
            self.destroy()
            raise
        return self

    def _add_netns(self, name: str) -> None:
        run([_tool("ip"), "netns", "add", name])
        self._created.append(name)

    def destroy(self) -> list[int]:
        """Kill every process left in the run's namespaces, delete them (their links go with them).
        Returns the pids that were still running. Idempotent."""
        for ex in self._executors.values():
            ex.shutdown(wait=False, cancel_futures=True)
        self._executors.clear()
        killed: list[int] = []
        for name in reversed(self._created):
            killed += kill_netns(name)
        self._created.clear()
        return killed

    # -- addressing and processes ---------------------------------------------------------
    def machine(self, name: str) -> Machine:
        try:
            return self.machines[name]
        except KeyError:
            raise MachinesError(f"unknown machine {name!r} (machines: {', '.join(self.machines)})") from None

    def address(self, name: str) -> str:
        return self.machine(name).address

    def wrap(self, name: str, argv: Sequence[str]) -> list[str]:
        """``argv`` run inside machine ``name``'s namespace (nsenter execs it: same pid, same process group)."""
        return [_tool("nsenter"), f"--net={self.machine(name).netns_path}", "--", *argv]

    def env(self, name: str, base: Mapping[str, str]) -> dict[str, str]:
        """``base`` with the machine's clock offset (:func:`clock_env`)."""
        return clock_env(self.machine(name).clock_offset, base)

    def run(self, name: str, argv: Sequence[str], check: bool = True, timeout: float = 30.0) -> \
            subprocess.CompletedProcess:
        return run(self.wrap(name, argv), check=check, timeout=timeout)

    def call(self, name: str, fn: Callable[..., T], *args: Any, timeout: float | None = 60.0) -> T:
        """``fn(*args)`` in a thread that entered machine ``name``'s network namespace (its sockets are there)."""
        m = self.machine(name)
        ex = self._executors.get(name)
        if ex is None:
            ex = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix=f"netns-{name}",
                                                       initializer=_enter_netns, initargs=(m.netns_path,))
            self._executors[name] = ex
        try:
            return ex.submit(fn, *args).result(timeout=timeout)
        except concurrent.futures.TimeoutError as err:
            raise MachinesError(f"a call in machine {name} took more than {timeout:g} s") from err

    def pids(self, name: str) -> list[int]:
        return netns_pids(self.machine(name).netns)

    def connections(self, name: str) -> list[Connection]:
        """Established TCP connections of machine ``name`` (``ss``)."""
        return parse_ss(self.run(name, [_tool("ss"), "-tnH", "state", "established"]).stdout)

    # -- firewall and faults ----------------------------------------------------------------
    def iptables(self, name: str, *args: str) -> None:
        self.run(name, [_tool("iptables"), "-w", "5", *args])

    def firewall(self, name: str, open_tcp_ports: Iterable[int], staff_ports: Iterable[int] = (),
                 staff: str | None = None) -> list[list[str]]:
        """Machine ``name`` admits from the network only new TCP connections to ``open_tcp_ports`` (and the
        replies to connections it opened), and to ``staff_ports`` from machine ``staff`` only (the staff network:
        the dashboard); its loopback is untouched. Returns the INPUT rules added."""
        rules = [["-i", "lo", "-j", "ACCEPT"],
                 ["-m", "conntrack", "--ctstate", "ESTABLISHED,RELATED", "-j", "ACCEPT"]]
        rules += [["-p", "tcp", "--dport", str(port), "-j", "ACCEPT"] for port in sorted(set(open_tcp_ports))]
        if staff is not None:
            rules += [["-p", "tcp", "-s", self.address(staff), "--dport", str(port), "-j", "ACCEPT"]
                      for port in sorted(set(staff_ports))]
        rules.append(["-j", "DROP"])
        for rule in rules:
            self.iptables(name, "-A", "INPUT", *rule)
        return rules

    def _fault(self, name: str, chain: str, *rule: str, remove: bool = False) -> None:
        self.iptables(name, "-D" if remove else "-A", chain, *rule, "-j", "DROP")

    def partition(self, name: str) -> None:
        """Machine ``name`` loses the network (every packet in or out of ``eth0`` dropped)."""
        self._fault(name, FAULT_IN, "-i", "eth0")
        self._fault(name, FAULT_OUT, "-o", "eth0")

    def cut(self, a: str, b: str) -> None:
        """Every packet between machines ``a`` and ``b`` dropped, both ways (rules on each)."""
        self.drop(a, b)
        self.drop(b, a)

    def uncut(self, a: str, b: str) -> None:
        """Undo :meth:`cut`."""
        self.undrop(a, b)
        self.undrop(b, a)

    def drop(self, src: str, dst: str, probability: float = 1.0) -> None:
        """Packets from ``src`` to ``dst`` dropped (with ``probability`` < 1: that share of them, at random);
        the other direction is untouched. Rules on ``src`` (OUTPUT)."""
        self._fault(src, FAULT_OUT, *self._drop_rule(dst, probability))

    def undrop(self, src: str, dst: str, probability: float = 1.0) -> None:
        """Undo :meth:`drop` with the same arguments."""
        self._fault(src, FAULT_OUT, *self._drop_rule(dst, probability), remove=True)

    def _drop_rule(self, dst: str, probability: float) -> list[str]:
        if not 0.0 < probability <= 1.0:
            raise MachinesError(f"drop probability {probability!r}: expected (0, 1]")
        rule = ["-d", self.address(dst)]
        if probability < 1.0:
            rule += ["-m", "statistic", "--mode", "random", "--probability", f"{probability:.4f}"]
        return rule

    def clear_faults(self, name: str | None = None) -> None:
        """Remove every fault rule (of machine ``name``, or of every machine)."""
        for m in [self.machine(name)] if name else list(self.machines.values()):
            for chain in (FAULT_IN, FAULT_OUT):
                with contextlib.suppress(MachinesError):
                    self.iptables(m.name, "-F", chain)


def _enter_netns(path: str) -> None:
    """Thread initializer: move this thread into the network namespace at ``path``."""
    fd = os.open(path, os.O_RDONLY)
    try:
        if ctypes.CDLL(None, use_errno=True).setns(fd, CLONE_NEWNET) != 0:
            err = ctypes.get_errno()
            raise MachinesError(f"setns({path}): {os.strerror(err)}")
    finally:
        os.close(fd)
