"""``gidabot demo --trace`` (ROS-free): which processes used the CPU while the floors fell behind.

Every floor's clock advances in lockstep with its controllers, at most at the speed ceiling; its timeline slot
counts the wall time it was *behind* the ceiling (:class:`gidabot_sim.world.timeline.Clock`). That time comes in
short stalls (tens of ms). With ``--trace``, at every look at the floors' clocks (``LOOK_PERIOD``, 0.2 s of wall
time) the demo also reads every process's CPU time so far (``SimulatedBuilding.cpu_usage``, right after the
clocks) and
:class:`TraceWriter` appends one JSON line to ``<run>/trace.jsonl``::

    {"wall": 1712345678.123456,                                  # wall time of the look (s since the epoch)
     "floors": {"Kbot": [412.2, 0.0312, 1.204], ...},            # robot: [sim s, behind s, wait_controllers s]
     "cpu": {"Kbot/goal_manager": [4242, 3.41], ...},            # <robot>/<process>: [pid, CPU s so far]
     "trace_cpu_s": 0.52}                                         # the trace's own CPU s so far (this process)

A *window* is the wall time between two consecutive samples. In it a floor's time behind grew by its ``behind``
at the later sample minus at the earlier one (never below 0: a restarted floor's counters start again); the
window's growth is the largest over the floors present in both samples (not the change of the largest
``behind``, which jumps when another floor leads). A window in which that growth is at least ``min_stall_ms`` is
a *stall window*. :func:`summarize` gives each kind of process's CPU (in cores) during stall windows and during
the others, and the largest stall windows with the processes that used the most CPU in them and just before:
which processes burst when the floors stall. A process's CPU counts from its first sample (a pid not in the
earlier sample adds nothing to that window). CPU times come from ``/proc`` in clock ticks (10 ms): over one
window of 0.2 s a process's CPU is known to 0.05 cores.

The sampling costs CPU (a scan of ``/proc`` and a write, in the demo's own process: ``time.process_time``);
:func:`summarize` reports it as ``trace_cores``.

:func:`load` reads a trace (a line that is not a valid sample, such as a last line cut short by a crash, is
skipped and counted); :func:`summarize` and :func:`format_summary` are pure.
"""

from __future__ import annotations

import json
import math
import re
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any, TextIO

TRACE_FILE = "trace.jsonl"
TOP_PROCESSES = 3        # processes named per stall window (and per window before it)


@dataclass(frozen=True)
class Sample:
    """One look: ``wall`` (s since the epoch); per floor (robot) its sim s, behind s and wait_controllers s; per
    process (``<robot>/<process>``) its pid and CPU s so far; the trace's own CPU s so far."""

    wall: float
    floors: dict[str, tuple[float, float, float]]
    cpu: dict[str, tuple[int, float]]
    trace_cpu_s: float = 0.0


@dataclass(frozen=True)
class Trace:
    """A trace file read back: its samples in file order, and how many lines were skipped (not a sample)."""

    samples: list[Sample] = field(default_factory=list)
    skipped: int = 0


def robot_of(owner: str) -> str:
    """The robot of a process owner of ``SimulatedBuilding.cpu_usage`` (``robot_Kbot``, ``master_Kbot``,
    ``record_Kbot.1`` -> ``Kbot``); an owner without a robot as it is (``monitor``, ``?``)."""
    if "_" not in owner:
        return owner
    return re.sub(r"\.\d+$", "", owner.split("_", 1)[1])


def process_key(owner: str, process: str) -> str:
    """``<robot>/<process>``, e.g. ``Kbot/goal_manager``."""
    return f"{robot_of(owner)}/{process}"


def _named(key: str) -> str:
    """``<robot>/<process>`` of a key (``#<pid>`` of a duplicate dropped: which of two processes of one name
    gets it may change from sample to sample)."""
    return key.split("#", 1)[0]


def kind_of(key: str) -> str:
    """The kind of process of a key (``Kbot/goal_manager`` -> ``goal_manager``; ``#<pid>`` of a duplicate
    dropped)."""
    return key.split("/", 1)[-1].split("#", 1)[0]


class TraceWriter:
    """Appends one sample per :meth:`sample` to the trace file ``path`` (created, or emptied), one JSON line each,
    flushed at once (a crash loses at most the line being written)."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        try:
            self._file: TextIO | None = open(self.path, "w", encoding="utf-8")  # noqa: SIM115 - closed by close()
        except OSError as err:
            raise OSError(f"trace file {self.path}: cannot be written: {err}") from err
        self.cpu_s = 0.0      # CPU s the trace took so far (the line being written counts in the next sample)
        self.samples = 0

    def sample(self, wall: float, clocks: Mapping[str, Any], rows: Iterable[Mapping[str, object]],
               cost_from: float | None = None) -> None:
        """Append the floors' ``clocks`` (robot -> Clock) and the processes' CPU ``rows`` (``cpu_usage``: owner,
        process, pid, cpu_s) at wall time ``wall`` (s since the epoch). ``cost_from``: ``time.process_time()``
        before the rows were read (their ``/proc`` scan is the trace's cost too); None: this call's only."""
        if self._file is None:
            raise ValueError(f"trace file {self.path}: already closed")
        begin = time.process_time() if cost_from is None else cost_from
        floors = {str(robot): [round(float(c.sim), 4), round(float(c.behind), 6), round(float(c.wait_controllers), 6)]
                  for robot, c in clocks.items()}
        cpu: dict[str, list[float]] = {}
        for row in rows:
            key, pid = process_key(str(row["owner"]), str(row["process"])), int(row["pid"])  # type: ignore[arg-type]
            if key in cpu:           # two live processes of one name (a recorder restarted...): told apart by pid
                key = f"{key}#{pid}"
            cpu[key] = [pid, float(row["cpu_s"])]  # type: ignore[arg-type]
        so_far = self.cpu_s + time.process_time() - begin
        line = json.dumps({"wall": round(wall, 6), "floors": floors, "cpu": cpu, "trace_cpu_s": round(so_far, 4)},
                          separators=(",", ":"))
        self._file.write(line + "\n")
        self._file.flush()
        self.samples += 1
        self.cpu_s += time.process_time() - begin

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> TraceWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- reading back (pure but for load) ---------------------------------------------------------------------------

def _number(value: object) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return None
    return float(value)


def parse_sample(obj: object) -> Sample | None:
    """A sample from one decoded trace line; None if it is not one (no finite ``wall``, ``floors`` or ``cpu`` not
    objects). A floor or process entry that is not well formed is left out (as if missing in that sample)."""
    if not isinstance(obj, dict):
        return None
    wall, floors, cpu = _number(obj.get("wall")), obj.get("floors", {}), obj.get("cpu", {})
    if wall is None or not isinstance(floors, dict) or not isinstance(cpu, dict):
        return None
    clocks: dict[str, tuple[float, float, float]] = {}
    for robot, values in floors.items():
        numbers = [_number(v) for v in values] if isinstance(values, list) and len(values) == 3 else [None]
        if None not in numbers:
            clocks[robot] = tuple(numbers)  # type: ignore[assignment]
    processes: dict[str, tuple[int, float]] = {}
    for key, values in cpu.items():
        if isinstance(values, list) and len(values) == 2 and isinstance(values[0], int) \
                and _number(values[1]) is not None:
            processes[key] = (values[0], float(values[1]))
    return Sample(wall, clocks, processes, _number(obj.get("trace_cpu_s")) or 0.0)


def load(path: Path) -> Trace:
    """The trace file ``path`` (see the module's docstring); lines that are not a sample (not JSON, such as a last
    line cut short, or not a sample's fields) are skipped and counted. Raises OSError naming the file."""
    samples, skipped = [], 0
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                if not line.strip():
                    continue
                try:
                    sample = parse_sample(json.loads(line))
                except ValueError:
                    sample = None
                if sample is None:
                    skipped += 1
                else:
                    samples.append(sample)
    except OSError as err:
        raise OSError(f"trace file {path}: cannot be read: {err}") from err
    return Trace(samples, skipped)


@dataclass(frozen=True)
class Window:
    """The wall time between two consecutive samples (s since the epoch): the largest growth of a floor's time
    behind (wall s, >= 0) and that floor ('' if no floor is in both samples), every process's CPU s in it (those
    that used some), and the trace's own CPU s in it."""

    begin: float
    end: float
    growth: float
    floor: str
    cpu: dict[str, float]
    trace_cpu_s: float

    @property
    def span(self) -> float:
        return self.end - self.begin


def window(a: Sample, b: Sample) -> Window:
    """The window from sample ``a`` to the next one ``b``. A floor counts only if it is in both; a decrease of its
    ``behind`` (a restarted floor) is no growth. A process counts by pid, with the same ``<robot>/<process>`` in
    both samples (a pid new in ``b``, or reused by another process, adds nothing: its CPU counts from its first
    sample), under its key in ``b``; a CPU time that went down (pid reused) adds nothing."""
    growth, floor = 0.0, ""
    for robot, (_, behind, _) in b.floors.items():
        if robot in a.floors:
            grew = behind - a.floors[robot][1]
            if grew > growth:
                growth, floor = grew, robot
    before = {pid: (_named(key), cpu_s) for key, (pid, cpu_s) in a.cpu.items()}
    cpu = {}
    for key, (pid, cpu_s) in b.cpu.items():
        earlier = before.get(pid)
        if earlier is not None and earlier[0] == _named(key) and cpu_s > earlier[1]:
            cpu[key] = cpu_s - earlier[1]
    return Window(a.wall, b.wall, growth, floor, cpu, max(0.0, b.trace_cpu_s - a.trace_cpu_s))


def _busiest(cpu: Mapping[str, float], n: int = TOP_PROCESSES) -> list[dict[str, object]]:
    """The ``n`` processes of a window that used the most CPU: process (``<robot>/<process>``), CPU ms."""
    ms = {key: round(1000.0 * cpu_s, 1) for key, cpu_s in cpu.items()}     # ties (to 0.1 ms): by name
    ranked = sorted(ms.items(), key=lambda kv: (-kv[1], kv[0]))[:n]
    return [{"process": key, "cpu_ms": cpu_ms} for key, cpu_ms in ranked]


def summarize(trace: Trace | Sequence[Sample | Mapping[str, object]], start_wall: float | None = None,
              end_wall: float | None = None, top: int = 5, min_stall_ms: float = 5.0) -> dict[str, object]:
    """What a trace says (JSON-able), over the windows wholly between ``start_wall`` and ``end_wall`` (s since
    the epoch; None: the trace's first / last sample). ``trace``: a :class:`Trace` (:func:`load`) or its samples
    (:class:`Sample`, or decoded lines: one that is not a sample is skipped and counted).

    Keys: ``start_wall``, ``end_wall`` (s since the epoch, None without windows) and ``wall_s`` of the windows
    counted; ``samples``, ``skipped_lines``, ``windows``; ``min_stall_ms``; ``stalls`` (windows in which a floor's
    time behind grew by at least ``min_stall_ms``), ``stall_ms`` (their growth together), ``stall_wall_s`` (their
    wall time); ``behind_ms`` (growth in every window, stalls or not); ``net_behind_ms`` (the largest growth of a
    floor's time behind from the first counted sample to the last: a floor makes up a short lateness, world/clock.py's
    slack, by not sleeping, so this is less than the growth in the windows); ``cores`` per kind of process (``stall`` /
    ``other``: its CPU in cores during the stall windows / during the other windows; ``all``: every process),
    largest during the stalls first; ``top``: the ``top`` largest stall windows, largest first (``at_s``: wall s
    from the start to the window's beginning, ``span_s``, ``growth_ms``, ``floor``, ``processes``: the
    :data:`TOP_PROCESSES` that used the most CPU in it, ``before``: in the window before it, as
    ``{"process", "cpu_ms"}``); ``trace_cpu_s`` and ``trace_cores``: the trace's own CPU over the windows."""
    if isinstance(trace, Trace):
        samples, skipped = list(trace.samples), trace.skipped
    else:
        samples, skipped = [], 0
        for s in trace:
            parsed = s if isinstance(s, Sample) else parse_sample(s)
            if parsed is None:
                skipped += 1
            else:
                samples.append(parsed)
    threshold = min_stall_ms / 1000.0

    def is_stall(w: Window) -> bool:
        return w.growth > 0 and w.growth >= threshold

    every = [window(a, b) for a, b in pairwise(samples)]
    counted = [(i, w) for i, w in enumerate(every) if w.span > 0
               and (start_wall is None or w.begin >= start_wall) and (end_wall is None or w.end <= end_wall)]
    start = start_wall if start_wall is not None else (samples[0].wall if samples else None)
    stalls = [(i, w) for i, w in counted if is_stall(w)]
    stall_wall = sum(w.span for _, w in stalls)
    other_wall = sum(w.span for _, w in counted) - stall_wall
    used: dict[str, list[float]] = {}          # kind -> [CPU s in stall windows, in the others]
    for _, w in counted:
        slot = 0 if is_stall(w) else 1
        for key, cpu_s in w.cpu.items():
            for kind in (kind_of(key), "all"):
                used.setdefault(kind, [0.0, 0.0])[slot] += cpu_s

    def cores(cpu_s: float, wall: float) -> float:
        return round(cpu_s / wall, 3) if wall > 0 else 0.0

    kinds = sorted(used.items(), key=lambda kv: (kv[0] != "all", -kv[1][0], -kv[1][1], kv[0]))
    largest = sorted(stalls, key=lambda iw: (-iw[1].growth, iw[1].begin))[:max(0, top)]
    trace_cpu = sum(w.trace_cpu_s for _, w in counted)
    wall_s = sum(w.span for _, w in counted)
    net = 0.0                      # the worst floor's time behind, last counted sample minus first
    if counted:
        first, last = samples[counted[0][0]], samples[counted[-1][0] + 1]
        net = max((last.floors[f][1] - first.floors[f][1] for f in first.floors if f in last.floors), default=0.0)
    return {
        "start_wall": counted[0][1].begin if counted else None, "end_wall": counted[-1][1].end if counted else None,
        "wall_s": round(wall_s, 3), "samples": len(samples), "skipped_lines": skipped, "windows": len(counted),
        "min_stall_ms": min_stall_ms, "stalls": len(stalls),
        "stall_ms": round(1000.0 * sum(w.growth for _, w in stalls), 1), "stall_wall_s": round(stall_wall, 3),
        "behind_ms": round(1000.0 * sum(w.growth for _, w in counted), 1),
        "net_behind_ms": round(1000.0 * max(0.0, net), 1),
        "cores": {kind: {"stall": cores(s, stall_wall), "other": cores(o, other_wall)} for kind, (s, o) in kinds},
        "top": [{"at_s": round(w.begin - start, 3) if start is not None else 0.0, "span_s": round(w.span, 3),
                 "growth_ms": round(1000.0 * w.growth, 1), "floor": w.floor, "processes": _busiest(w.cpu),
                 "before": _busiest(every[i - 1].cpu) if i > 0 else []} for i, w in largest],
        "trace_cpu_s": round(trace_cpu, 3), "trace_cores": cores(trace_cpu, wall_s),
    }


def _processes(entries: Sequence[Mapping[str, object]]) -> str:
    return ", ".join(f"{e['process']} {e['cpu_ms']:.0f} ms" for e in entries) or "none"


def format_summary(summary: Mapping[str, Any], min_cores: float = 0.01) -> list[str]:
    """The lines ``gidabot demo --trace`` prints for a :func:`summarize` result; kinds of process under
    ``min_cores`` both during and outside the stalls are left out."""
    skipped = summary["skipped_lines"]
    note = f"; {skipped} line{'s' if skipped != 1 else ''} skipped (not a sample)" if skipped else ""
    head = f"Trace ({TRACE_FILE}): {summary['samples']} samples, {summary['windows']} windows over " \
           f"{summary['wall_s']:.1f} s of wall time{note}"
    if not summary["windows"]:
        return [head, "  no window to judge (fewer than two samples in the span)"]
    stall_wall, other_wall = summary["stall_wall_s"], summary["wall_s"] - summary["stall_wall_s"]
    windows = "window" if summary["stalls"] == 1 else "windows"
    lines = [head,
             f"  stalls: {summary['stalls']} {windows} in which a floor's time behind its ceiling grew by >= "
             f"{summary['min_stall_ms']:g} ms, {summary['stall_ms']:.0f} ms in all (of {summary['behind_ms']:.0f} ms "
             f"behind in all the windows; net over the span, the worst floor's: {summary['net_behind_ms']:.0f} ms, "
             f"a floor makes up a lateness of a few tens of ms by not sleeping before its next steps)",
             f"  CPU per kind of process (all robots), cores: during the stalls ({stall_wall:.1f} s) / the other "
             f"windows ({other_wall:.1f} s)"]
    for kind, c in summary["cores"].items():
        if kind == "all" or max(c["stall"], c["other"]) >= min_cores:
            lines.append(f"    {'every process' if kind == 'all' else kind:<28} {c['stall']:5.2f}  {c['other']:5.2f}")
    if summary["top"]:
        lines.append("  largest stalls (wall s from the start, growth of the floor's time behind; the processes "
                     "using the most CPU in that window, and in the one before):")
    for t in summary["top"]:
        lines.append(f"    at {t['at_s']:7.1f} s +{t['growth_ms']:.0f} ms ({t['floor']}, {1000 * t['span_s']:.0f} ms "
                     f"window): {_processes(t['processes'])}; before: {_processes(t['before'])}")
    lines.append(f"  the trace's own CPU (reading /proc, writing {TRACE_FILE}): {summary['trace_cpu_s']:.1f} s, "
                 f"{summary['trace_cores']:.3f} cores")
    return lines
