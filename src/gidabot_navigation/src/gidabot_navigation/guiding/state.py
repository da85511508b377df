"""What a guiding node keeps across a restart (ROS-free): its core's state and its outbox, in a file.

goal_manager and multirobot_navigation are respawned by roslaunch when they die. A
respawned node that started empty would forget the goals it had accepted (its queue),
the uids it had handled (a replayed goal would be queued twice) and the leg it was
driving. So each node keeps one JSON file: the core's :meth:`state` and the *outbox*
(the events, goals and cancels about to be published). At start it loads the file,
restores the core and publishes the outbox again (same uids: receivers ignore what they
already handled).

When it is written (:meth:`StateFile.commit`):

- a change that publishes something is written *before* it is published, with the
  outbox, at once: what the node told others is never lost; so is a change that shows in
  the state the node publishes (goal_manager's pending list, on which its navigation acts:
  :meth:`StateFile.publish_state`), before that is published;
- any other change (uids remembered, a goal dropped after its final event, the outbox
  published) is written at most every ``soft_interval`` wall seconds (1 s): a restart
  loses at most that much of it, and the replays every node sends to a restarted
  subscriber (``ros/replay.py``, 60 s) bring it back;
- an input that changed nothing (a rejected or duplicate message) writes nothing: before
  writing, the state is compared with the one last written (counters, ``stats``, are
  written along with a change but are no change by themselves). So hostile traffic
  costs no disk write, and at most one serialisation of the state per ``soft_interval``.

Writes are atomic: a temporary file in the same directory, ``fsync``, ``rename``
(and ``fsync`` of the directory), so a crash leaves either the old or the new state.
A state older than ``max_age`` wall seconds (a robot that was off for a while) is
ignored: its visitors are gone.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

from gidabot_navigation.errors import GuidingStateError
from gidabot_navigation.guiding.messages import (
    Action,
    CancelData,
    NavEventData,
    SendCancel,
    SendEvent,
    SendGoal,
    Trip,
)
from gidabot_navigation.logs import Logger

FORMAT = 1
REMEMBERED_UIDS = 500        # most recent handled uids kept per set (replays cover the last minute)
DEFAULT_MAX_AGE = 600.0      # wall s: an older state is not resumed
SOFT_INTERVAL = 1.0          # wall s between writes of changes that publish nothing
VOLATILE = ("stats",)        # state keys written along with a change, but not a change by themselves


def default_state_dir(robot: str) -> str:
    """``$ROS_HOME/gidabot/<robot>/guiding`` (ROS_HOME defaults to ``~/.ros``)."""
    home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return os.path.join(home, "gidabot", robot, "guiding")


def dataclass_from_dict(cls: type, data: object) -> Any:
    """A frozen dataclass from a dict, checking every field's type (a damaged file is an error, not a crash)."""
    if not isinstance(data, dict):
        raise GuidingStateError(f"{cls.__name__}: expected an object, got {type(data).__name__}")
    kwargs = {}
    for f in fields(cls):
        if f.name not in data:
            continue
        value = data[f.name]
        want = {"str": str, "float": (int, float), "int": int}.get(str(f.type))
        if want is not None and (isinstance(value, bool) or not isinstance(value, want)):
            raise GuidingStateError(f"{cls.__name__}.{f.name}: {value!r} is not a {f.type}")
        kwargs[f.name] = float(value) if f.type == "float" else value
    try:
        return cls(**kwargs)
    except TypeError as err:
        raise GuidingStateError(f"{cls.__name__}: {err}") from err


def trip_to_dict(trip: Trip) -> dict[str, Any]:
    return _finite(asdict(trip))


def trip_from_dict(data: object) -> Trip:
    return dataclass_from_dict(Trip, data)


def event_from_dict(data: object) -> NavEventData:
    return dataclass_from_dict(NavEventData, data)


def cancel_from_dict(data: object) -> CancelData:
    return dataclass_from_dict(CancelData, data)


def _finite(d: dict[str, Any]) -> dict[str, Any]:
    """JSON has no NaN: non-finite numbers (never in a validated trip) become 0."""
    return {k: (0.0 if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


def actions_to_list(actions: list[Action]) -> list[dict[str, Any]]:
    """The durable part of an action list (what goes to other nodes), as JSON-able records."""
    out: list[dict[str, Any]] = []
    for a in actions:
        if isinstance(a, SendGoal):
            out.append({"kind": "goal", "data": trip_to_dict(a.trip)})
        elif isinstance(a, SendCancel):
            out.append({"kind": "cancel", "data": _finite(asdict(a.cancel))})
        elif isinstance(a, SendEvent):
            out.append({"kind": "event", "data": _finite(asdict(a.event))})
    return out


def actions_from_list(records: object) -> list[Action]:
    if not isinstance(records, list):
        raise GuidingStateError(f"outbox: expected a list, got {type(records).__name__}")
    out: list[Action] = []
    for rec in records:
        kind = rec.get("kind") if isinstance(rec, dict) else None
        if kind == "goal":
            out.append(SendGoal(trip_from_dict(rec.get("data"))))
        elif kind == "cancel":
            out.append(SendCancel(cancel_from_dict(rec.get("data"))))
        elif kind == "event":
            out.append(SendEvent(event_from_dict(rec.get("data"))))
        else:
            raise GuidingStateError(f"outbox: unknown record {str(rec)[:80]!r}")
    return out


def str_list(value: object, what: str) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise GuidingStateError(f"{what}: expected a list of strings")
    return value


def uid_records(value: object, what: str) -> list[str | list[str]]:
    """Handled uids as ``senders.HandledUids.recent`` wrote them: ``[uid, digest]`` pairs (or bare uids)."""
    if not isinstance(value, list) or not all(
            isinstance(v, str) or (isinstance(v, list) and len(v) == 2 and all(isinstance(x, str) for x in v))
            for v in value):
        raise GuidingStateError(f"{what}: expected a list of [uid, digest] pairs")
    return value


def number(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise GuidingStateError(f"{what}: {value!r} is not a finite number")
    return float(value)


class StateFile:
    """One node's state file: ``save`` (atomic) and ``load`` (None when absent, stale or unreadable)."""

    def __init__(self, path: Path, node: str, robot: str, log: Logger, max_age: float = DEFAULT_MAX_AGE,
                 fsync: bool = True, clock: Any = time.time, soft_interval: float = SOFT_INTERVAL,
                 monotonic: Callable[[], float] = time.monotonic) -> None:
        self.path = Path(path)
        self.node = node
        self.robot = robot
        self.log = log
        self.max_age = max_age
        self.fsync = fsync
        self.clock = clock
        self.soft_interval = soft_interval
        self.monotonic = monotonic
        self.saves = 0
        self.failures = 0
        self._written: bytes | None = None      # state and outbox of the file as last written
        self._dirty = False                     # changed since: written at the next flush
        self._last_save = -math.inf
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise GuidingStateError(f"cannot create the state directory {self.path.parent}: {err.strerror}") from err

    def load(self) -> tuple[dict[str, Any], list[Action]] | None:
        """(core state, outbox) of the previous run of this node, or None (logged why)."""
        try:
            raw = self.path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as err:
            self.log.error(f"{self.node}: cannot read its state {self.path}: {err.strerror}; starting empty")
            return None
        try:
            doc = json.loads(raw)
            if not isinstance(doc, dict) or doc.get("format") != FORMAT:
                raise GuidingStateError(f"not a format-{FORMAT} guiding state")
            if doc.get("node") != self.node or doc.get("robot") != self.robot:
                raise GuidingStateError(f"it belongs to {doc.get('node')!r} of {doc.get('robot')!r}")
            age = self.clock() - number(doc.get("saved"), "saved")
            if age > self.max_age:
                self.log.warning(f"{self.node}: its state {self.path} is {age:.0f} s old (more than "
                                 f"{self.max_age:g} s); starting empty")
                return None
            state = doc.get("state")
            if not isinstance(state, dict):
                raise GuidingStateError("no state object")
            return state, actions_from_list(doc.get("outbox", []))
        except (ValueError, GuidingStateError) as err:
            self.log.error(f"{self.node}: its state {self.path} is unusable ({err}); starting empty")
            return None

    def save(self, state: dict[str, Any], outbox: list[Action]) -> bool:
        """Replace the file atomically (unless it holds exactly this already); False (logged, counted)
        if it cannot be written."""
        records = actions_to_list(outbox)
        kept = {k: v for k, v in state.items() if k not in VOLATILE}
        content = json.dumps([kept, records], separators=(",", ":"), allow_nan=False).encode()
        if content == self._written:
            self._dirty = False
            return True
        doc = {"format": FORMAT, "node": self.node, "robot": self.robot, "saved": self.clock(), "state": state,
               "outbox": records}
        data = json.dumps(doc, separators=(",", ":"), allow_nan=False).encode()
        tmp = None
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", dir=self.path.parent)
            with os.fdopen(fd, "wb") as out:
                out.write(data)
                if self.fsync:
                    out.flush()
                    os.fsync(out.fileno())
            os.replace(tmp, self.path)
            tmp = None
            if self.fsync:
                dfd = os.open(self.path.parent, os.O_RDONLY)
                try:
                    os.fsync(dfd)
                finally:
                    os.close(dfd)
        except OSError as err:
            self.failures += 1
            self._last_save = self.monotonic()     # retried at the next flush, not at every input
            self.log.error(f"{self.node}: cannot save its state to {self.path}: {err.strerror}")
            return False
        finally:
            if tmp is not None:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
        self.saves += 1
        self._written, self._dirty = content, False
        self._last_save = self.monotonic()
        return True

    def resume(self, load_state: Callable[[dict[str, Any]], None]) -> list[Action] | None:
        """Load the previous run's state into a core (``load_state`` raises GuidingStateError when it
        cannot use it); the outbox to publish again, or None when nothing was resumed (logged why)."""
        loaded = self.load()
        if loaded is None:
            return None
        try:
            load_state(loaded[0])
        except GuidingStateError as err:
            self.log.error(f"{self.node}: its state {self.path} is unusable ({err}); starting empty")
            return None
        return loaded[1]

    def commit(self, state: Callable[[], dict[str, Any]], actions: list[Action], durable: list[Action],
               execute: Callable[[list[Action]], None], changed: bool = True) -> None:
        """Carry out ``actions``; with ``durable`` ones, save ``state()`` with them as the outbox first (a
        restart publishes them again, same uids: never lost). ``changed``: the input may have changed the
        state; it is saved by :meth:`flush`, within ``soft_interval`` (and not at all if it did not change)."""
        if durable:
            self.save(state(), durable)
        execute(actions)
        if durable or changed:
            self._dirty = True
        self.flush(state)

    def publish_state(self, state: Callable[[], dict[str, Any]], publish: Callable[[], None]) -> None:
        """Publish the node's state (``publish``: goal_manager's pending list) after saving what changed since
        the last save: a restarted node then never shows an older list than the one others acted on (a leg
        committed to this robot, its navigation already driving it, must not vanish from the list and back)."""
        self.flush(state, force=True)
        publish()

    def flush(self, state: Callable[[], dict[str, Any]], force: bool = False) -> None:
        """Save what changed since the last save, if ``soft_interval`` passed since it (or ``force``: at exit)."""
        if self._dirty and (force or self.monotonic() - self._last_save >= self.soft_interval):
            self.save(state(), [])
