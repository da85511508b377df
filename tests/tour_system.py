"""Helpers of the tour store system tests: starting the node, tour messages, hostile messages."""

from __future__ import annotations

import os
import time
from pathlib import Path

from gidabot_sim.runner.procs import ProcessGroup, robot_address

REPO = Path(__file__).resolve().parents[1]
FACULTY = REPO / "maps" / "faculty"
LAUNCH = REPO / "launch" / "tour_store.launch"
T_NOW = time.time_ns()
TOUR = "gidabot_msgs/Tour"


def robot_ip(index: int) -> str:
    """Loopback address of robot ``index`` for this test session (see procs.robot_address)."""
    return robot_address(index)


def start_store(procs: ProcessGroup, env: dict[str, str], robot: str, building: Path, tours_dir: Path,
                name: str | None = None) -> str:
    """Start the tour store of ``robot`` with launch/tour_store.launch; return its process name."""
    pname = name or f"tour_store_{robot}"
    procs.start(pname, ["roslaunch", "--skip-log-check", str(LAUNCH), f"building:={building}",
                        f"robot:={robot}", f"tours_dir:={tours_dir}"], env)
    return pname


def dir_state(directory: Path) -> dict[str, bytes]:
    """The tour files of a directory (hidden files excluded)."""
    if not directory.is_dir():
        return {}
    return {n: (directory / n).read_bytes() for n in sorted(os.listdir(directory))
            if not n.startswith(".") and (directory / n).is_file()}


def tour(file_name: str, goals: list[str], *, name: str = "", deleted: bool = False, uid: str = "",
         editor: str = "", origin: str = "", version: int = 0, language: str = "en",
         floor: float | str | None = None) -> dict:
    if floor is None:
        floor = float(goals[0].split(",")[0]) if goals else 0.0
    return {"uid": uid, "origin_robot": origin, "editor_robot": editor, "version": version, "deleted": deleted,
            "language": language, "floor": floor, "tour_name": name, "file_name": file_name,
            "tour_goals_info": goals}


VISIT = ["0, 014, Computer Technicians 1", "1, 101, Secretary's Office", "3, 305, RSAIT Lab"]


def hostile(editor: str, version: int = T_NOW) -> list[tuple[str, dict, str]]:
    """Hostile or malformed remote tours as sent by ``editor``: (label, Tour fields, expected reason)."""
    def remote(file_name: str, goals: list[str], **kw) -> dict:
        kw.setdefault("editor", editor)
        kw.setdefault("origin", editor)
        kw.setdefault("version", version)
        return tour(file_name, goals, **kw)

    def uid(n: int) -> str:
        """A uid of the editor robot (senders.UID_FORMAT): its messages are judged on their content."""
        return f"{editor}/h/ts.{n:016x}"

    ten_mb = "x" * (10 * 1024 * 1024)
    return [
        ("path traversal", remote("../../escape.tour", VISIT, uid=uid(1)), "file_name"),
        ("absolute path", remote("/tmp/abs.tour", VISIT, uid=uid(2)), "file_name"),
        ("NUL byte in name", remote("real_world\x00.tour", VISIT, uid=uid(3)), "file_name"),
        ("hidden name", remote(".gidabot-tours.json", VISIT, uid=uid(4)), "file_name"),
        ("device name", remote("con.tour", VISIT, uid=uid(5)), "file_name"),
        ("overlong name", remote("x" * 300 + ".tour", VISIT, uid=uid(6)), "file_name"),
        ("10 MB body", remote("real_world.tour", [f"0, 014, {ten_mb}"], uid=uid(7)), "oversized"),
        ("wrong columns", remote("real_world.tour", ["0, 014"], uid=uid(8)), "content"),
        ("unknown room", remote("real_world.tour", ["0, 999, Nowhere"], uid=uid(9)), "content"),
        ("NaN floor", remote("real_world.tour", VISIT, floor="nan", uid=uid(10)), "floor"),
        ("NaN floor in a goal", remote("real_world.tour", ["nan, 014, Lab"], floor=0.0, uid=uid(11)),
         "content"),
        ("line injection", remote("real_world.tour", ["0, 014, Lab\n0, 008, Injected"], uid=uid(12)),
         "content"),
        ("huge name", remote("real_world.tour", VISIT, name="n" * 5000, uid=uid(13)), "name"),
        ("unknown editor", remote("real_world.tour", VISIT, editor="Mallory", uid=uid(14)), "robot"),
        ("version from the far future", remote("real_world.tour", VISIT, version=2**64 - 1, uid=uid(15)),
         "version"),
        ("delete through traversal", remote("../long_tour.tour", [], deleted=True, uid=uid(16)),
         "file_name"),
    ]
