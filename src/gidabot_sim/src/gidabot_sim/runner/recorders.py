"""The bag parts of a run of the simulated building and the recorders that write them (ROS-free).

One ``rosbag record`` per robot records on that robot's master what the report reads (``RECORDED_TOPICS``)
into ``<robot>.bag``. ``rosbag record`` never re-registers with a restarted master, so after a restart the
robot's recording goes on in a new part (``<robot>.<n>.bag``, recorder ``record_<robot>.<n>``), and the old
recorder is retired: it records on until a newer part has recorded for ``RECORDER_OVERLAP`` s
(:func:`obsolete_recorders`). :class:`Recorders` keeps every robot's parts, which recorders to stop, and, once
every recorder stopped, the parts that were never written.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from gidabot_navigation.interface import SHARED_TOPICS, Topic, global_name

RECORDER_OVERLAP = 5.0   # wall s the old recorder of a restarted master goes on after a newer one records
# what every robot's bag holds: the shared topics (docs/interfaces.md) and the visitor's commands, the robot's
# localisation, when its move_base took each goal (Table 5's legs start then), the floor's /diagnostics
# (its simulator's timing and its people's true positions, its controllers' and guiding loops' rates) and what
# its tracker reported of the visitor (to read against those positions when a robot waited or searched)
RECORDED_TOPICS = (*(t.name for t in SHARED_TOPICS), global_name(Topic.VISITOR_COMMAND), global_name(Topic.AMCL_POSE),
                   global_name(Topic.MOVE_BASE_CURRENT_GOAL), Topic.DIAGNOSTICS, global_name(Topic.PEOPLE_VISITOR))


def recorder_name(robot: str, part: int) -> str:
    """The process name of the recorder of ``robot``'s bag part ``part``."""
    return f"record_{robot}" if part == 0 else f"record_{robot}.{part}"


def obsolete_recorders(retired: dict[str, tuple[str, int]], bags: dict[str, list[Path]],
                       recording_from: dict[Path, float], now: float, overlap: float = RECORDER_OVERLAP) -> list[str]:
    """The retired recorders to stop now: ``retired`` maps a recorder to (robot, its bag part); one is stopped
    once a later part of its robot has been recording (``recording_from``: when its file appeared) for
    ``overlap`` s. Until then it records on: a new recorder waits for the simulated clock, which may stand still
    for minutes (the other floors wait while one that was down catches up), and stopping the old one after a
    fixed time left the master unrecorded (a chaos run's missing part and gap)."""
    out = []
    for name, (robot, n) in retired.items():
        started = [recording_from[p] for p in bags.get(robot, [])[n + 1:] if p in recording_from]
        if started and now - min(started) >= overlap:
            out.append(name)
    return out


@dataclass
class Recorders:
    """Every robot's bag parts, in ``run_dir``, and their recorders."""

    run_dir: Path
    bags: dict[str, list[Path]] = field(default_factory=dict)          # robot -> its bag parts, in order
    retired: dict[str, tuple[str, int]] = field(default_factory=dict)  # old recorders -> (robot, bag part): stopped
    never_recorded: list[str] = field(default_factory=list)            # parts replaced before they recorded
    _stopped: set[str] = field(default_factory=set)                    # retired recorders stopped
    _recording_from: dict[Path, float] = field(default_factory=dict)   # bag part -> monotonic time first seen

    def next_part(self, robot: str) -> tuple[str, Path]:
        """(recorder name, bag file) of ``robot``'s next part; :meth:`add` lists it once its recorder started."""
        n = len(self.bags.get(robot, []))
        return recorder_name(robot, n), self.run_dir / (f"{robot}.bag" if n == 0 else f"{robot}.{n}.bag")

    def add(self, robot: str, bag: Path) -> None:
        self.bags.setdefault(robot, []).append(bag)

    def retire(self, robot: str, part: int) -> None:
        """The recorder of ``robot``'s part ``part`` is retired: a newer part records after it."""
        self.retired[recorder_name(robot, part)] = (robot, part)

    def obsolete(self, now: float, alive: Callable[[str], bool]) -> list[str]:
        """The retired recorders to stop now (monotonic time ``now``; ``alive``: whether a recorder still runs),
        each once: a later part of its robot has recorded for RECORDER_OVERLAP s (until then the old one records
        on: no gap while the new one waits for the simulated clock)."""
        running = {n: r for n, r in self.retired.items() if n not in self._stopped and alive(n)}
        for part in (p for parts in self.bags.values() for p in parts[1:]):
            self._recording_since(part, now)
        names = obsolete_recorders(running, self.bags, self._recording_from, now)
        self._stopped.update(names)
        return names

    def _recording_since(self, bag: Path, now: float) -> float | None:
        """When ``bag``'s recorder was first seen writing it (rosbag creates ``<bag>.active`` once it records)."""
        if bag not in self._recording_from and (bag.exists() or bag.with_name(bag.name + ".active").exists()):
            self._recording_from[bag] = now
        return self._recording_from.get(bag)

    def close(self) -> None:
        """Once every recorder stopped: the bags of recorders that had to be killed reindexed; the parts replaced
        before the clock let them record (the older part did) left out of :attr:`bags`, into ``never_recorded``."""
        for active in self.run_dir.glob("*.bag.active"):   # a recorder that had to be killed
            subprocess.run(["rosbag", "reindex", str(active)], capture_output=True, timeout=120, check=False)
            shutil.move(str(active), str(active.with_suffix("")))
            for orig in self.run_dir.glob("*.bag.orig.active"):   # reindex's backup
                orig.unlink()
        for robot, parts in self.bags.items():
            self.never_recorded += [p.name for p in parts[1:] if not p.exists()]
            self.bags[robot] = [parts[0], *(p for p in parts[1:] if p.exists())] if parts else parts
