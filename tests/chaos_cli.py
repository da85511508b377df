"""Helper of the chaos system tests: one `bin/gidabot chaos --json` run, bounded in time."""

from __future__ import annotations

import json
import os
import signal
import subprocess
from pathlib import Path

import pytest

GIDABOT = Path(__file__).resolve().parents[1] / "bin" / "gidabot"


def run_chaos(args: list[str], timeout: float) -> tuple[dict, int]:
    """``gidabot chaos <args> --json``: its JSON result and exit status. Past ``timeout`` s it is stopped the way a
    user would (SIGINT) and the test fails. The progress and the table are printed (shown with -s or on failure)."""
    argv = [str(GIDABOT), "chaos", *args, "--json"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=60)
        pytest.fail(f"chaos run still going after {timeout:g} s\n{err[-4000:]}")
    print(err[-6000:])
    return json.loads(out), proc.returncode
