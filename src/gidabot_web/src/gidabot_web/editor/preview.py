"""The building editor's preview (ROS-free tooling): the simulated building run on the building being edited.

:meth:`Preview.start` writes a copy of the edited building (files named by absolute path, no draft mark) and a
tour into a temporary directory and starts ``gidabot demo`` on them in the background (its own process group,
the masters on a loopback network of their own: ``--net``), with its run folder in that directory. Once the run
folder holds the building the demo runs (its masters' addresses), the *pose reader*
(:mod:`gidabot_web.editor.preview_node`: a ROS node on the first robot's master, which the relays bring every
robot's ``/gidabot/poses``) is started too; it keeps the latest pose of every robot in one JSON file, replaced
atomically a few times a second. :meth:`Preview.poll` reads that file and the demo's last progress line: that is
all the editor needs to draw the robots on its map, with no ROS in the editor's server. :meth:`Preview.stop`
stops both by process group (the demo first, with SIGINT: it stops what it started) and removes the directory.
A demo that ends with an error leaves the directory (the demo's log, its run folder with every node's log): the
failed state's message names it.

The tour: ``featured`` (every featured place, else every place, floor by floor: at most :data:`MAX_STOPS`), or a
tour file of the robots' tour directory that fits the building (``tours/real_world.tour`` on the faculty).
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from gidabot_navigation.building.model import Building, building_from_doc, format_floor
from gidabot_navigation.building.yaml_text import load_yaml
from gidabot_navigation.errors import BuildingError, TourError, TourNameError
from gidabot_navigation.tours.tour_file import check_tour_file_name, parse_tour
from gidabot_sim.runner.procs import ProcessGroup, ros_env, test_network
from gidabot_web.errors import PreviewError

FEATURED = "featured"
MAX_STOPS = 8
POSES_FILE = "poses.json"
DEMO = "demo"
READER = "poses"


class Run:
    """What a preview is doing (``PreviewState.state``; the page shows it)."""

    IDLE = "idle"              # none was started
    STARTING = "starting"      # the demo runs, no robot's pose is known yet
    RUNNING = "running"        # the robots' poses come in
    STOPPING = "stopping"
    FINISHED = "finished"      # the demo completed its tour
    FAILED = "failed"          # the demo ended with an error
    STOPPED = "stopped"        # stopped before the end


@dataclass
class PreviewState:
    state: str                                  # one of Run
    message: str = ""                           # the demo's last progress line, or why it failed
    robots: dict[str, dict] = field(default_factory=dict)   # name -> floor, x, y, yaw, stamp
    tour: str = ""
    elapsed: float = 0.0                        # wall seconds since it started

    def to_json(self) -> dict:
        return {"state": self.state, "message": self.message, "robots": self.robots, "tour": self.tour,
                "elapsed": round(self.elapsed, 1)}


class PoseBook:
    """The latest pose of each robot, as the pose reader hears them (validated: a name like a robot's, finite
    numbers; at most :data:`MAX_ROBOTS` robots), and the JSON file the editor reads."""

    MAX_ROBOTS = 64
    NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,31}\Z")

    def __init__(self) -> None:
        self.robots: dict[str, dict] = {}
        self.changed = False

    def heard(self, robot: object, floor: float, x: float, y: float, yaw: float, stamp: float) -> bool:
        """Remember a pose; False (ignored) when it is not a valid one."""
        values = (floor, x, y, yaw, stamp)
        if not isinstance(robot, str) or not self.NAME.match(robot) or not all(
                isinstance(v, (int, float)) and math.isfinite(v) for v in values):
            return False
        if robot not in self.robots and len(self.robots) >= self.MAX_ROBOTS:
            return False
        self.robots[robot] = {"floor": float(floor), "x": round(float(x), 3), "y": round(float(y), 3),
                              "yaw": round(float(yaw), 3), "stamp": float(stamp)}
        self.changed = True
        return True

    def write(self, path: Path) -> None:
        """Replace ``path`` by the poses (a temporary file renamed over it: a reader never sees half of it)."""
        tmp = path.with_name(f".{path.name}.tmp")
        tmp.write_text(json.dumps({"robots": self.robots, "wall": time.time()}), encoding="utf-8")
        os.replace(tmp, path)
        self.changed = False


def preview_copy(data: dict, directory: Path, dest: Path) -> Path:
    """Write the plain building ``data`` of folder ``directory`` into ``dest`` (a new directory) with its files
    named by absolute path and no draft mark; returns the building file."""
    copy = json.loads(json.dumps(data))
    copy.pop("draft", None)
    for floor in copy.get("floors", []):
        for key in ("map", "blueprint"):
            if isinstance(floor.get(key), str):
                floor[key] = str((directory / floor[key]).resolve())
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / "building.yaml"
    out.write_text(yaml.safe_dump(copy, sort_keys=False, allow_unicode=True), encoding="utf-8")
    return out


def featured_tour(building: Building) -> str:
    """A tour of the building's featured places (every place when none is), floor by floor."""
    order = {f.id: i for i, f in enumerate(building.floors)}
    places = [loc for loc in building.locations if loc.featured] or list(building.locations)
    places.sort(key=lambda loc: order[loc.floor])
    lines = ["Tour: Preview"] + [f"{format_floor(loc.floor)}, {loc.id}, {loc.name('en')}"
                                 for loc in places[:MAX_STOPS]]
    return "\n".join(lines) + "\n"


def tour_text(choice: str, building: Building, tours_dir: Path | None) -> tuple[str, str]:
    """(file name, text) of the tour ``choice`` for ``building``; :class:`PreviewError` when it does not fit."""
    if choice == FEATURED:
        text = featured_tour(building)
        name = "preview.tour"
    else:
        try:
            name = check_tour_file_name(choice)
        except TourNameError as err:
            raise PreviewError(f"tour {choice!r}: {err}") from err
        if tours_dir is None or not (tours_dir / name).is_file():
            raise PreviewError(f"tour {name!r}: no such file in the tours directory")
        text = (tours_dir / name).read_text(encoding="utf-8")
    try:
        parse_tour(text.encode("utf-8"), name, building)
    except TourError as err:
        raise PreviewError(f"tour {name} does not fit this building: {err}") from err
    return name, text


def fitting_tours(building: Building, tours_dir: Path | None) -> list[str]:
    """The tour files of ``tours_dir`` that fit ``building`` (their rooms and floors are in it)."""
    if tours_dir is None or not tours_dir.is_dir():
        return []
    out = []
    for path in sorted(tours_dir.glob("*.tour")):
        try:
            tour_text(path.name, building, tours_dir)
        except PreviewError:
            continue
        out.append(path.name)
    return out


class Preview:
    """At most one preview run at a time (see the module docstring). ``speed``: the demo's ``--speed``. Its methods
    may be called from several threads (the editor's server runs them off its event loop: stopping takes seconds)."""

    def __init__(self, tours_dir: Path | None = None, speed: str = "20", python: str = sys.executable) -> None:
        self.tours_dir = tours_dir
        self.speed = speed
        self.python = python
        self._dir: Path | None = None
        self._procs: ProcessGroup | None = None
        self._started = 0.0
        self._tour = ""
        self._final: PreviewState | None = None
        self._lock = threading.RLock()
        self._busy = Run.STARTING                  # what holds the lock: starting, stopping

    @property
    def running(self) -> bool:
        return self._procs is not None and self._procs.alive(DEMO)

    def start(self, data: dict, directory: Path, tour: str = FEATURED) -> None:
        """Start the demo on ``data`` (the plain document of ``directory``): it must pass the model's checks."""
        self._busy = Run.STARTING
        with self._lock:
            self._start(data, directory, tour)

    def _start(self, data: dict, directory: Path, tour: str) -> None:
        if self._procs is not None:
            self._stop()
        try:
            building = building_from_doc(data, directory / "building.yaml", allow_draft=True)
        except BuildingError as err:
            raise PreviewError(f"the building has problems; fix them before a preview ({len(err.problems)} "
                               "problem(s))") from err
        name, text = tour_text(tour, building, self.tours_dir)
        self._dir = Path(tempfile.mkdtemp(prefix="gidabot-preview-"))
        building_file = preview_copy(data, directory, self._dir / "building")
        (self._dir / name).write_text(text, encoding="utf-8")
        self._procs = ProcessGroup(self._dir / "logs")
        self._procs.start(DEMO, [self.python, "-m", "gidabot_sim.cli", "demo", "--building", str(building_file.parent),
                                 "--tour", str(self._dir / name), "--out", str(self._dir / "runs"),
                                 "--net", str(test_network()), "--speed", self.speed, "--timeout", "3600"])
        self._started, self._tour, self._final = time.monotonic(), name, None

    def _run_building(self) -> Path | None:
        runs = self._dir / "runs" if self._dir is not None else None
        if runs is None or not runs.is_dir():
            return None
        found = sorted(runs.glob("*/building/building.yaml"))
        return found[-1] if found else None

    def _start_reader(self) -> None:
        """The pose reader, once the run's building (its masters' addresses) is written."""
        assert self._procs is not None and self._dir is not None
        if READER in self._procs.names():
            return
        path = self._run_building()
        if path is None:
            return
        try:
            doc = load_yaml(path.read_text(encoding="utf-8"))
            uri = str(doc["robots"][0]["master_uri"])
        except (OSError, yaml.YAMLError, KeyError, IndexError, TypeError):
            return
        ip = uri.split("//", 1)[-1].split(":", 1)[0]
        env = ros_env(uri, ip, log_dir=self._dir / "ros")
        self._procs.start(READER, [self.python, "-m", "gidabot_web.editor.preview_node",
                                   f"_out:={self._dir / POSES_FILE}"], env)

    def poll(self) -> PreviewState:
        """Where the preview is: its state, the demo's last line, the robots' latest poses (at once: while it is
        being started or stopped, only that)."""
        if not self._lock.acquire(blocking=False):
            return PreviewState(self._busy, f"{self._busy}…", {}, self._tour)
        try:
            return self._poll()
        finally:
            self._lock.release()

    def _poll(self) -> PreviewState:
        if self._final is not None:
            return self._final
        if self._procs is None or self._dir is None:
            return PreviewState(Run.IDLE)
        elapsed = time.monotonic() - self._started
        message = _last_line(self._dir / "logs" / f"{DEMO}.log")
        robots = _read_poses(self._dir / POSES_FILE)
        if self._procs.alive(DEMO):
            self._start_reader()
            state = Run.RUNNING if robots else Run.STARTING
            return PreviewState(state, message, robots, self._tour, elapsed)
        code = self._procs.get(DEMO).popen.returncode
        message = _last_line(self._dir / "logs" / f"{DEMO}.log")     # read again: it may have ended since
        if code == 0:
            final = PreviewState(Run.FINISHED, message, robots, self._tour, elapsed)
        else:
            final = PreviewState(Run.FAILED, f"{message} (gidabot demo exited with {code}; its logs are kept in "
                                             f"{self._dir})", robots, self._tour, elapsed)
        self._stop(keep=code != 0)
        self._final = final
        return final

    def stop(self) -> None:
        """Stop the demo and the pose reader (by process group) and remove the preview's directory."""
        self._busy = Run.STOPPING
        with self._lock:
            self._stop()

    def _stop(self, keep: bool = False) -> None:
        """Stop the processes; remove the directory unless ``keep`` (a failed demo's logs)."""
        procs, directory = self._procs, self._dir
        self._procs, self._dir = None, None
        if procs is not None:
            procs.stop(DEMO, grace=30.0)                 # the demo stops its masters and nodes on SIGINT
            procs.close()
        if directory is not None and not keep:
            shutil.rmtree(directory, ignore_errors=True)
        if self._final is None and procs is not None:
            self._final = PreviewState(Run.STOPPED, "stopped", {}, self._tour, time.monotonic() - self._started)


def _last_line(path: Path, size: int = 4096) -> str:
    try:
        with open(path, "rb") as f:
            f.seek(0, 2)
            f.seek(max(0, f.tell() - size))
            lines = [ln for ln in f.read().decode("utf-8", "replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    return lines[-1][:300] if lines else ""


def _read_poses(path: Path) -> dict[str, dict]:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    robots = doc.get("robots") if isinstance(doc, dict) else None
    return robots if isinstance(robots, dict) else {}

