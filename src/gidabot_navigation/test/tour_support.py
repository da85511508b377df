"""Helpers shared by the tour store tests: a settable clock, a log that keeps its lines, directory snapshots."""

from __future__ import annotations

import os
from pathlib import Path

from gidabot_navigation.interface import Node, global_name
from gidabot_navigation.senders import uid_robot
from gidabot_navigation.tours.tour_store import Outcome, TourMessage, TourStore

REPO = Path(__file__).resolve().parents[3]
TOURS = REPO / "tours"
T0 = 1_700_000_000 * 1_000_000_000       # a wall-clock instant in ns
GUI, TOUR_STORE = global_name(Node.GUI), global_name(Node.TOUR_STORE)      # callerids of a robot's own nodes


def from_robot(store: TourStore, robot: str) -> str:
    """The callerid messages of ``robot`` have on ``store``'s master: its own tour store, or the relay end of the
    link from ``robot`` (a robot without link: a node that is no relay end)."""
    if robot == store.robot:
        return TOUR_STORE
    try:
        return store.gate.senders.relay_of(robot)
    except KeyError:
        return f"/not_a_relay_of_{robot}"


def rightful(store: TourStore, msg: TourMessage) -> str:
    """The callerid of the robot whose uid ``msg`` carries (the robot that sends it), on ``store``'s master."""
    return from_robot(store, uid_robot(msg.uid) or "")


def recv(store: TourStore, msg: TourMessage) -> Outcome:
    """``store`` receives ``msg`` from its rightful sender."""
    return store.receive(msg, sender=rightful(store, msg))


class FakeClock:
    def __init__(self, ns: int = T0) -> None:
        self.ns = ns

    def __call__(self) -> int:
        return self.ns

    def advance(self, seconds: float) -> int:
        self.ns += int(seconds * 1e9)
        return self.ns


class ListLog:
    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def info(self, msg: str) -> None:
        self.lines.append(("info", msg))

    def warning(self, msg: str) -> None:
        self.lines.append(("warning", msg))

    def error(self, msg: str) -> None:
        self.lines.append(("error", msg))

    def text(self, level: str | None = None) -> str:
        return "\n".join(m for lvl, m in self.lines if level is None or lvl == level)


def snapshot(directory: Path, hidden: bool = False) -> dict[str, bytes | str]:
    """Every name in ``directory`` -> its bytes (regular file) or its kind (symlink, dir, other)."""
    out: dict[str, bytes | str] = {}
    for name in sorted(os.listdir(directory)):
        if name.startswith(".") and not hidden:
            continue
        path = directory / name
        if path.is_symlink():
            out[name] = f"symlink->{os.readlink(path)}"
        elif path.is_dir():
            out[name] = "dir"
        elif path.is_file():
            out[name] = path.read_bytes()
        else:
            out[name] = "other"
    return out


def tour_msg(file_name: str, goals: list[str] | tuple[str, ...], *, name: str = "", version: int = 0,
             editor: str = "", origin: str = "", deleted: bool = False, language: str = "en",
             floor: float | None = None, uid: str = "") -> TourMessage:
    if floor is None:
        floor = float(goals[0].split(",")[0]) if goals and not deleted else 0.0
    return TourMessage(uid=uid, origin_robot=origin, editor_robot=editor, version=version, deleted=deleted,
                       language=language, floor=floor, tour_name=name, file_name=file_name,
                       tour_goals_info=tuple(goals))


def open_store(directory: Path, building, robot: str = "Galtxagorri", clock: FakeClock | None = None,
               log: ListLog | None = None, seed_dir: Path | None = None, **kw) -> TourStore:
    return TourStore(directory, building, robot, wall_ns=clock or FakeClock(), log=log or ListLog(),
                     seed_dir=seed_dir, **kw).open()
