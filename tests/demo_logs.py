"""What a failed demo run leaves for the reader of a test's failure: the last lines of each robot's guiding,
move_base, simulator and people logs (the run folder itself is gone with the test machine)."""

from __future__ import annotations

from pathlib import Path

NODES = ("multirobot_navigation", "move_base", "sim", "people", "visitor")


def log_tails(run_folder: Path, lines: int = 15) -> str:
    """The last ``lines`` lines (rospy's own chatter left out: connections, shutdown) of every robot's logs of
    :data:`NODES` under ``run_folder``'s ``ros/<robot>/``, each under a heading; "" when there is no such folder."""
    parts: list[str] = []
    for robot_dir in sorted((run_folder / "ros").glob("*")):
        for node in NODES:
            for log in sorted(robot_dir.rglob(f"{node}*.log")):
                if log.name.endswith("-stdout.log") or log.is_symlink():
                    continue
                text = [ln for ln in log.read_text(errors="replace").splitlines() if not ln.startswith("[rospy.")]
                if text:
                    parts.append(f"--- {robot_dir.name}/{log.name} (last {min(lines, len(text))} of {len(text)})")
                    parts += [ln[:300] for ln in text[-lines:]]
    return "\n".join(parts)


def run_folder_of(stderr: str) -> Path | None:
    """The run folder a demo names on its standard error ("run folder: <path>"), None if it names none."""
    for line in stderr.splitlines():
        if line.strip().startswith("run folder:"):
            return Path(line.split(":", 1)[1].split()[0])
    return None
