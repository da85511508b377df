"""A fixed CPU workload every benchmark times and prints beside its figures (ROS-free): numbers that travel.

Two runs of a benchmark on two machines (or on one machine at two busy moments) compare only once each says
how fast its machine ran plain Python while it ran: :func:`workload` is a small deterministic pure-Python job
(integer arithmetic, a dict, a sort, string building: what our nodes do, no numpy, no I/O) of about 0.3 s of
CPU on the 2-core machine the docs were measured on; :func:`calibrate` times it ``repeats`` times and keeps the
fastest (the least disturbed by other processes), in CPU seconds of this process and in wall seconds (the wall
time grows when other processes share the core, the CPU time far less). :func:`describe` is the line the
benchmarks print, :func:`as_json` what they add to their ``--json`` object (``calibration``).

A benchmark measures at its start and again at its end (``Calibration.measure`` twice): the machine may get
busier meanwhile, and the two figures say so.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

WORKLOAD = "gidabot-calibration-1"   # change the name when the workload changes: its times compare only with its own
ROUNDS = 400                         # about 0.3 s of CPU on the docs' machine
CHECKSUM = 988_444_724               # what workload() returns: the same work everywhere


def workload(rounds: int = ROUNDS) -> int:
    """The fixed job: ``rounds`` rounds of a linear congruential stream into a dict, sorted, and formatted; returns a
    checksum of everything computed (the same on every machine and Python)."""
    state, checksum = 12345, 0
    for _ in range(rounds):
        counts: dict[int, int] = {}
        for _ in range(2000):
            state = (1103515245 * state + 12345) & 0x7FFFFFFF
            key = state % 997
            counts[key] = counts.get(key, 0) + (state >> 16)
        ordered = sorted(counts.items(), key=lambda kv: (kv[1], kv[0]))
        text = ",".join(f"{k}:{v}" for k, v in ordered[:200])
        checksum = (checksum * 31 + sum(v for _, v in ordered) + len(text)) & 0x7FFFFFFF
    return checksum


@dataclass(frozen=True)
class Timing:
    """The fastest of ``repeats`` runs of the workload: CPU s of this process and wall s."""

    cpu_s: float
    wall_s: float
    repeats: int


def calibrate(repeats: int = 3, rounds: int = ROUNDS) -> Timing:
    """Time the workload ``repeats`` times; the fastest CPU and wall times."""
    if repeats < 1:
        raise ValueError(f"repeats {repeats}: expected at least 1")
    cpu, wall = [], []
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        workload(rounds)
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return Timing(round(min(cpu), 4), round(min(wall), 4), repeats)


@dataclass
class Calibration:
    """A benchmark's calibration: the workload timed at its start and at its end."""

    times: list[Timing] = field(default_factory=list)

    def measure(self, repeats: int = 3) -> Timing:
        timing = calibrate(repeats)
        self.times.append(timing)
        return timing


def as_json(calibration: Calibration) -> dict:
    """What a benchmark's ``--json`` carries under ``calibration``."""
    return {"workload": WORKLOAD, "repeats": calibration.times[0].repeats if calibration.times else 0,
            "cpu_s": [t.cpu_s for t in calibration.times], "wall_s": [t.wall_s for t in calibration.times]}


def describe(calibration: Calibration | dict | None) -> str:
    """One line: the workload's times on this machine, at the benchmark's start (and end); of a
    :class:`Calibration` or of what :func:`as_json` saved of one."""
    saved = as_json(calibration) if isinstance(calibration, Calibration) else calibration or {}
    cpu, wall = saved.get("cpu_s") or [], saved.get("wall_s") or []
    if not cpu:
        return "calibration: not measured"
    when = ("at the start", "at the end")
    parts = [f"{c:.3f} s CPU / {w:.3f} s wall {when[min(i, 1)]}"
             for i, (c, w) in enumerate(zip(cpu, wall, strict=True))]
    return (f"calibration ({saved.get('workload', WORKLOAD)}, the fastest of {saved.get('repeats', '?')} runs): "
            + "; ".join(parts) + " (compare figures between machines by it)")
