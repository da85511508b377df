"""Foundation system checks: masters on loopback, generated messages import from the venv."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from gidabot_sim.runner.procs import master_pid, robot_address

pytestmark = pytest.mark.system


def test_messages_import_in_venv() -> None:
    out = subprocess.run([sys.executable, "-c", "from gidabot_msgs.msg import Goal; print(Goal().tour_step)"],
                         capture_output=True, text=True, timeout=60, check=True)
    assert out.stdout.strip() == "0"
    assert ".venv" in sys.executable


def test_four_masters_on_their_own_addresses(faculty_masters) -> None:
    robots = faculty_masters.building.robots
    assert [r.ip for r in robots] == [robot_address(i) for i in range(4)]
    assert len({r.ip for r in robots}) == 4
    pids = {master_pid(r.master_uri) for r in robots}
    assert None not in pids and len(pids) == 4
    faculty_masters.restart_master("Kbot")
    assert master_pid(faculty_masters.building.robot("Kbot").master_uri) is not None


def test_cli_check(tmp_path) -> None:
    repo = Path(__file__).resolve().parents[2]
    faculty = repo / "maps" / "faculty"

    ok = subprocess.run([str(repo / "bin/gidabot"), "check", str(faculty)], capture_output=True, text=True,
                        timeout=120)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    broken = tmp_path / "broken"
    import shutil

    shutil.copytree(faculty, broken)
    text = (broken / "building.yaml").read_text().replace("drive: synchro", "drive: hovercraft")
    (broken / "building.yaml").write_text(text)
    bad = subprocess.run([str(repo / "bin/gidabot"), "check", str(broken)], capture_output=True, text=True,
                         timeout=120)
    assert bad.returncode == 1
    assert f"{broken}/building.yaml: robots[3].drive: 'hovercraft' is not one of differential, synchro" in bad.stdout
