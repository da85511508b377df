"""Crashed nodes, from a run's logs (ROS-free).

A node crashed when roslaunch says a process died that the run did not kill (:func:`roslaunch_deaths`), a relay
supervisor saw one of its ends exit (:func:`relay_end_exits`), or a log holds a traceback that means our code
failed (:func:`crash_tracebacks`; rospy's and rosmaster's reports of network events while a master or a node
restarts are not crashes). :func:`log_sizes` and :func:`scan_logs` read the logs of a run folder up to where
they were when everything began to stop.
"""

from __future__ import annotations

import contextlib
import re
from pathlib import Path

_DIED = re.compile(r"\[([A-Za-z0-9_]+)-\d+\] process has died \[pid (\d+), exit code (-?\d+)")
_END_EXIT = re.compile(r"relay end (\S+) exited with (-?\d+)")
TRACEBACK = "Traceback (most recent call last)"


def roslaunch_deaths(text: str) -> list[tuple[str, int, int]]:
    """(node, pid, exit code) of every 'process has died' line of a roslaunch output."""
    return [(m.group(1), int(m.group(2)), int(m.group(3))) for m in _DIED.finditer(text)]


def relay_end_exits(text: str) -> list[tuple[str, int]]:
    """(end key, exit code) of every relay end the supervisor saw exit."""
    return [(m.group(1), int(m.group(2))) for m in _END_EXIT.finditer(text)]


_LOGGER_PREFIX = re.compile(r"^\[(rospy\.[A-Za-z_.]+|rosmaster[A-Za-z_.]*|rosgraph[A-Za-z_.]*)\]")
_CRASH_CONTEXT = ("bad callback", "Exception in thread", "Exception ignored in")


def crash_tracebacks(text: str) -> list[str]:
    """The tracebacks of a log that mean our code failed, each as its last line (the exception).

    Counted: an exception in a subscriber callback (rospy's "bad callback"), one that ended a thread,
    and a bare traceback on a process's own output (a process that crashed). Not counted: rospy's and
    rosmaster's own reports of network events (a connection refused while a master or a node restarts,
    "Unable to report rosout", Python's "--- Logging error ---" while the master is away), which log a
    traceback but change nothing, and the second half of a chained exception."""
    lines = text.splitlines()
    found = []
    for i, line in enumerate(lines):
        at = line.find(TRACEBACK)
        if at < 0:
            continue
        head = line[:at]
        context = head
        if not head.strip():                         # a bare traceback: what introduced it?
            j = i - 1
            while j >= 0 and (not lines[j].strip() or lines[j].startswith((" ", "\t"))):
                j -= 1
            context = lines[j] if j >= 0 else ""
            if "During handling of the above exception" in context or "direct cause of the following" in context:
                continue
            if context.startswith("--- Logging error ---"):
                continue
        if any(c in context for c in _CRASH_CONTEXT):
            pass
        elif head.strip() or _LOGGER_PREFIX.match(context):
            continue                                   # a library's report of an I/O error
        k = i + 1
        while k < len(lines) and (lines[k].startswith((" ", "\t")) or not lines[k].strip()):
            k += 1
        found.append(lines[k][:200] if k < len(lines) else "?")
    return found


def tracebacks(text: str) -> int:
    """How many crash tracebacks a log holds (:func:`crash_tracebacks`)."""
    return len(crash_tracebacks(text))


def log_sizes(run_dir: Path) -> dict[Path, int]:
    """How long every log of the run folder is now: what is written after (while everything stops) is not
    read by :func:`scan_logs`."""
    sizes = {}
    for path in list((run_dir / "logs").glob("*.log")) + list((run_dir / "ros").rglob("*.log")):
        with contextlib.suppress(OSError):
            sizes[path] = path.stat().st_size
    return sizes


def scan_logs(run_dir: Path, sizes: dict[Path, int], killed: set[int]) -> tuple[list[str], dict[str, int]]:
    """Unexpected process deaths (roslaunch's, the relay supervisor's; not the pids in ``killed``, which the run
    killed on purpose) and the crash tracebacks per log (its path in the run folder), in the first ``sizes``
    bytes of each log."""
    crashes: list[str] = []
    tbs: dict[str, int] = {}
    for path, size in sizes.items():
        try:
            with open(path, "rb") as fh:
                text = fh.read(size).decode(errors="replace")
        except OSError:
            continue
        rel = str(path.relative_to(run_dir))
        n = tracebacks(text)
        if n:
            tbs[rel] = n
        if path.parent.name == "logs" and path.name.startswith("robot_"):
            robot = path.stem[len("robot_"):]
            for node, pid, code in roslaunch_deaths(text):
                if pid not in killed:
                    crashes.append(f"{robot}/{node} died (pid {pid}, exit code {code})")
            for key, code in relay_end_exits(text):
                crashes.append(f"{robot}: relay end {key} exited with {code}")
    return crashes, tbs

