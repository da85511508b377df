"""What the commands of ``bin/gidabot`` that run the simulated building share (ROS-free).

* exit statuses: 0 every target met, 1 a target missed (or the run failed), 2 bad arguments, 130 interrupted;
* :func:`run_command`: Ctrl-C and SIGTERM set a flag the run checks at safe points (:class:`Signals`), progress
  goes to stdout, or to stderr with ``--json`` (stdout then carries one JSON object), a usage error is one line
  ``gidabot <command>: <error>`` on stderr;
* run folders: ``--out`` (default ``runs/`` of the checkout), one folder per run named by its start time and
  what it runs (:func:`run_folder`), the tours every robot starts with (:func:`seed_tours`);
* the options every run of the building checks the same way (:func:`load_tour`, :func:`check_network`);
* the benchmarks' arguments (:func:`bench_arguments`: ``--json``, its docstring's first paragraph as the help)
  and output: progress only without ``--json`` (:func:`progress_printer`), the targets missed and PASS or FAIL
  (:func:`print_verdict`).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sys
from collections.abc import Callable
from datetime import datetime
from pathlib import Path
from typing import TextIO

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import TourError, TourNameError
from gidabot_navigation.resources import resource
from gidabot_navigation.tours.tour_file import Tour, check_tour_file_name, parse_tour
from gidabot_sim.errors import DemoError

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
# where the runs go by default: runs/ of the checkout (tools/env.sh sets GIDABOT_ROOT; bin/gidabot sources it),
# else of the current directory
RUNS = Path(os.environ.get("GIDABOT_ROOT", ".")) / "runs"


class Signals:
    """SIGINT/SIGTERM set a flag (checked at safe points) instead of raising anywhere."""

    def __init__(self, command: str, log: Callable[[str], None]) -> None:
        self.received: str = ""
        self._command = command
        self._log = log
        self._old: dict[int, object] = {}

    def __enter__(self) -> Signals:
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)  # type: ignore[arg-type]

    def _handle(self, signum: int, _frame: object) -> None:
        name = signal.Signals(signum).name
        if self.received:
            self._log(f"gidabot {self._command}: {name} again: still stopping everything, please wait")
            return
        self.received = name
        self._log(f"\ngidabot {self._command}: {name}: stopping everything (bags are closed first)")

    def __bool__(self) -> bool:
        return bool(self.received)


def run_command(command: str, json_out: bool, run: Callable[[TextIO, Signals], int],
                usage_errors: tuple[type[Exception], ...]) -> int:
    """``run(progress stream, signals)`` as ``gidabot <command>``: its exit status, EXIT_USAGE on one of
    ``usage_errors`` (said on stderr), EXIT_INTERRUPTED after a signal."""
    out = sys.stderr if json_out else sys.stdout
    with Signals(command, lambda text: print(text, file=out, flush=True)) as stop:
        try:
            code = run(out, stop)
        except usage_errors as err:
            print(f"gidabot {command}: {err}", file=sys.stderr)
            return EXIT_USAGE
        return EXIT_INTERRUPTED if stop else code


def run_folder(out: Path, label: str) -> Path:
    """The folder of a run starting now under ``out``: ``<date>-<time>-<label>``."""
    return out.resolve() / f"{datetime.now():%Y%m%d-%H%M%S}-{label}"


def seed_tours(run_dir: Path, tour: Path | None = None, name: str = "") -> Path:
    """``<run>/seed_tours``: the shipped tours and ``tour`` (as ``name``), what every robot's tour store starts
    with."""
    seed = run_dir / "seed_tours"
    shutil.copytree(resource("tours"), seed, dirs_exist_ok=True)
    if tour is not None:
        shutil.copy(tour, seed / name)
    return seed


def load_tour(path: Path, building: Building) -> Tour:
    """The tour file ``path``, valid for ``building``; DemoError naming the file otherwise."""
    try:
        check_tour_file_name(path.name)
        return parse_tour(path.read_bytes(), path.name, building, source=str(path))
    except (OSError, TourError, TourNameError) as err:
        raise DemoError(f"{path}: {err}") from err


def check_network(net: int | None, machines: bool) -> None:
    """``--net`` (the masters on 127.N.0.x) and ``--machines`` (a network namespace per robot)."""
    if net is not None and not 1 <= net <= 254:
        raise DemoError(f"--net {net}: expected 1..254")
    if net is not None and machines:
        raise DemoError("--net and --machines exclude each other (separate machines have addresses of their own)")


def bench_arguments(prog: str, doc: str, markdown: bool = False) -> argparse.ArgumentParser:
    """The arguments of the benchmark ``prog`` (``gidabot bench <name>``), described by the first paragraph of its
    docstring ``doc``: ``--json`` (one JSON object on stdout) and, with ``markdown``, ``--markdown`` instead."""
    parser = argparse.ArgumentParser(prog=prog, description=doc.split("\n\n")[0])
    out_format = parser.add_mutually_exclusive_group() if markdown else parser
    out_format.add_argument("--json", action="store_true", help="print one JSON object")
    if markdown:
        out_format.add_argument("--markdown", action="store_true", help="print the runs as a Markdown table")
    return parser


def progress_printer(json_out: bool) -> Callable[[str], None]:
    """A benchmark's progress lines: printed, except with ``--json`` (stdout carries the JSON object alone)."""
    def say(text: str) -> None:
        if not json_out:
            print(text, flush=True)
    return say


def print_verdict(missed: list[str]) -> None:
    """Every target missed, then PASS or FAIL."""
    for text in missed:
        print(f"missed: {text}")
    print("PASS" if not missed else "FAIL")
