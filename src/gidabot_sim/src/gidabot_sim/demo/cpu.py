"""``gidabot demo --cpu`` (ROS-free): the CPU seconds each kind of process of the run used.

:class:`CpuSnapshot` is every process's CPU so far at one moment (with the whole machine's and the demo's own);
:func:`cpu_table` prints and saves (``cpu.json``) what each kind of process cost between two snapshots: the
start-up, then the tour alone.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from typing import TextIO

from gidabot_sim.runner.building_runner import SimulatedBuilding
from gidabot_sim.runner.proc_info import machine_busy_s


@dataclass
class CpuSnapshot:
    wall: float
    rows: list[dict[str, object]]
    machine_s: float | None = field(default_factory=machine_busy_s)   # the whole machine's busy CPU s so far
    own_s: float = field(default_factory=lambda: sum(os.times()[:2]))  # this demo process's own CPU s so far


def _per_kind(rows: list[dict[str, object]], before: dict[int, float] | None = None) -> dict[str, float]:
    """CPU seconds per kind of process (node name / program), all robots together; minus ``before`` (pid ->
    CPU s at an earlier snapshot) when given."""
    kinds: dict[str, float] = {}
    for r in rows:
        cpu = float(r["cpu_s"]) - (before or {}).get(int(r["pid"]), 0.0)  # type: ignore[arg-type]
        kinds[str(r["process"])] = kinds.get(str(r["process"]), 0.0) + cpu
    return kinds


def cpu_table(sim: SimulatedBuilding, begin: float, begin_machine: float | None, tour_start: CpuSnapshot | None,
               out: TextIO) -> None:
    """Print and save (cpu.json) what each kind of process cost: start-up, then the tour alone."""
    end = CpuSnapshot(time.time(), sim.cpu_usage())
    start = CpuSnapshot(begin, [], begin_machine, 0.0)
    if tour_start is None:
        phases = [("whole run", start, end, end.rows, None)]
    else:
        first = {int(r["pid"]): float(r["cpu_s"]) for r in tour_start.rows}  # type: ignore[arg-type]
        phases = [("start-up", start, tour_start, tour_start.rows, None), ("tour", tour_start, end, end.rows, first)]
    saved: dict[str, object] = {"processes": end.rows}
    for name, a, b, rows, before in phases:
        t0, t1 = a.wall, b.wall
        wall = max(t1 - t0, 1e-9)
        kinds = sorted(_per_kind(rows, before).items(), key=lambda kv: -kv[1])
        total = sum(cpu for _, cpu in kinds)
        # the whole machine over the same span: what the run's processes took, and what everything else did
        machine = b.machine_s - a.machine_s if a.machine_s is not None and b.machine_s is not None else None
        others = None if machine is None else max(0.0, machine - total - (b.own_s - a.own_s))
        saved[name] = {"wall_s": round(wall, 1), "cpu_s": round(total, 1), "cores": round(total / wall, 2),
                       "other_processes_cores": None if others is None else round(others / wall, 2),
                       "per_kind_cpu_s": {k: round(v, 1) for k, v in kinds}}
        beside = "" if others is None else f"; every other process of the machine: {others / wall:.2f} cores"
        print(f"\nCPU of the run's processes, {name}: {total:.0f} s in {wall:.0f} s of wall time "
              f"({total / wall:.2f} of {os.cpu_count()} cores{beside}); per kind of process (all robots together):",
              file=out)
        for kind, cpu in kinds:
            print(f"  {kind:<26} {cpu:7.1f} s  {100 * cpu / max(total, 1e-9):5.1f} %  {cpu / wall:5.2f} cores",
                  file=out)
    (sim.run_dir / "cpu.json").write_text(json.dumps(saved, indent=2), encoding="utf-8")
