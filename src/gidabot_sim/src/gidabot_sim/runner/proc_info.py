"""The processes of a run and the CPU they use, from ``/proc`` (ROS-free).

:func:`process_tree` finds every process that descends from the ones a run started (roslaunch starts each node
in a session of its own, so process groups alone do not find them), each as a :class:`ProcInfo`: its ids, start
time (a reused pid is told apart), CPU seconds and command line, and the name :attr:`ProcInfo.label` gives it.
:func:`cpu_seconds` and :func:`machine_busy_s` are what the demo's ``--cpu`` and the benchmarks measure.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class ProcInfo:
    """One process, from ``/proc/<pid>/stat`` and its command line."""

    pid: int
    ppid: int
    pgid: int
    start: int              # start time (clock ticks since boot): tells a reused pid apart
    cpu_s: float            # user + system CPU seconds so far
    argv: tuple[str, ...]

    @property
    def label(self) -> str:
        """The ROS node name (``__name:=``), else the program's name."""
        argv = self.argv
        for arg in argv:
            if arg.startswith("__name:="):
                return arg.split(":=", 1)[1]
        if len(argv) >= 2 and Path(argv[0]).name.startswith("python"):
            if argv[1] == "-m" and len(argv) >= 3:
                return argv[2].rsplit(".", 1)[-1]
            return "python -c" if argv[1] == "-c" else Path(argv[1]).name
        return Path(argv[0]).name if argv else "?"


def _stat_fields(pid: int) -> list[str]:
    """The fields of ``/proc/<pid>/stat`` after the command name (state first); raises OSError."""
    stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
    return stat[stat.rfind(")") + 2:].split()


def _cpu(fields: list[str]) -> float:
    """User + system CPU seconds of a process's stat fields."""
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def read_proc(pid: int) -> ProcInfo | None:
    """``/proc/<pid>`` of a live process, or None (gone, or not readable)."""
    try:
        fields = _stat_fields(pid)
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return None
    if len(fields) < 20 or fields[0] == "Z":
        return None
    return ProcInfo(pid, int(fields[1]), int(fields[2]), int(fields[19]), _cpu(fields),
                    tuple(a.decode(errors="replace") for a in argv if a))


def process_tree(roots: set[int]) -> dict[int, ProcInfo]:
    """Every live process that is one of ``roots`` or descends from one (roslaunch starts each node in
    a session of its own, so process groups alone do not find them)."""
    procs = {}
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            info = read_proc(int(entry.name))
            if info is not None:
                procs[info.pid] = info
    children: dict[int, list[int]] = {}
    for info in procs.values():
        children.setdefault(info.ppid, []).append(info.pid)
    found: dict[int, ProcInfo] = {}
    todo = [pid for pid in roots if pid in procs]
    while todo:
        pid = todo.pop()
        if pid not in found:
            found[pid] = procs[pid]
            todo.extend(children.get(pid, []))
    return found


def cpu_seconds(pids: Iterable[int]) -> float:
    """User + system CPU seconds so far of the processes ``pids`` together (one that is gone counts 0)."""
    total = 0.0
    for pid in pids:
        try:
            total += _cpu(_stat_fields(pid))
        except (OSError, IndexError, ValueError):
            continue
    return total


def machine_busy_s() -> float | None:
    """CPU seconds every core of this machine has been busy since boot (``/proc/stat``: all but idle and iowait),
    None where there is no /proc/stat."""
    try:
        with open("/proc/stat", encoding="ascii") as f:
            fields = f.readline().split()
    except OSError:
        return None
    if not fields or fields[0] != "cpu":
        return None
    ticks = [int(v) for v in fields[1:9]]            # user nice system idle iowait irq softirq steal
    return (sum(ticks) - ticks[3] - ticks[4]) / os.sysconf("SC_CLK_TCK")
