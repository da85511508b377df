"""Reliability under faults, the small version: `bin/gidabot chaos --profile quick` on a short tour.

Four masters, six relays, every robot's nodes and the simulated visitor run a four-goal tour
(three floor changes) while one or two faults of every kind are injected: a link cut by
iptables and one by a stopped relay end, a relay supervisor killed, a master restarted, two
masters down at once, a link cut during a master restart, both guiding nodes of a robot of the
trip under way killed (respawned), a process frozen, a person in a robot's way and six hostile
messages. Targets: every request of the visitor completed, no goal lost or duplicated, every
recovery within 5 s, Table 3 as without faults (from the probes and from the bags), every hostile
message counted by a node of the master it was sent to, no node crash, every tour directory
unchanged. The full run (the Table 2 tour) is `bin/gidabot chaos`; measured runs are in docs/chaos.md.
With separate machines (`--machines`) the faults of a real network are added: a robot
partitioned, every link flapping, one-way and partial loss, a machine down and back, and every
robot's clock off by up to 5 minutes. Needs root (iptables, network namespaces); bounded to
about 4 minutes each.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
from pathlib import Path

import pytest

import gidabot_sim.runner.procs as procs_mod

pytestmark = [pytest.mark.system, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[2]
GIDABOT = REPO / "bin" / "gidabot"
TOUR = ("Tour: Chaos test\n0, 008, Caretakers' Office\n1, 101, Secretary's Office\n2, 203, An office\n"
        "0, 014, Computer Technicians 1\n")
KEYS = {"accepted", "completed", "lost", "duplicated", "max_recovery_s", "faults", "table3_bags", "node_crashes",
        "requests"}


@pytest.mark.timeout(600)
@pytest.mark.skipif(shutil.which("iptables") is None or os.geteuid() != 0, reason="needs iptables and root")
@pytest.mark.parametrize("machines", [False, True], ids=["loopback", "machines"])
def test_quick_chaos_run_keeps_every_promise(tmp_path: Path, machines: bool) -> None:
    tour = tmp_path / "chaos_test.tour"
    tour.write_text(TOUR, encoding="utf-8")
    where = ["--machines"] if machines else ["--net", str(procs_mod.test_network())]
    argv = [str(GIDABOT), "chaos", "--profile", "quick", "--seed", "3", "--tour", str(tour), "--out",
            str(tmp_path / "runs"), *where, "--json", "--timeout", "480"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=540)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=60)
        pytest.fail(f"chaos run still going after 540 s\n{err[-4000:]}")
    print(err[-6000:])                       # the progress and the table (shown with -s or on failure)
    doc = json.loads(out)
    assert set(doc) >= KEYS
    counts = doc["fault_counts"]
    assert {f["kind"] for f in doc["faults"]} == {k for k, n in counts.items() if n}
    assert counts["node_restart"] == 2 and counts["hostile_message"] >= 5
    assert counts["masters_down"] == 1 and counts["link_cut_master_restart"] == 1      # overlapping faults
    if machines:          # the faults of a real network between separate machines, and their clocks
        assert all(counts[k] >= 1 for k in ("partition", "links_flapping", "one_way_loss", "lossy_link",
                                             "machine_down")), counts
        assert counts["clock_offset"] == 4 and doc["relay_counters"]["link_losses"] > 0
    # a trip the system ended (e.g. its partner offline) is asked for again by the visitor: one more goal
    assert doc["completed"] == 4 and doc["accepted"] == 4 + len(doc["ended_by_system"]), doc
    assert doc["lost"] == 0 and doc["duplicated"] == 0 and doc["cancels_duplicated"] == 0, doc
    assert all(r["passed"] for r in doc["requests"]) and len(doc["requests"]) == 4, doc["requests"]
    assert isinstance(doc["max_recovery_s"], float) and doc["max_recovery_s"] <= 5.0, doc["faults"]
    assert doc["table3"]["unchanged"], doc["table3"]
    assert doc["table3_bags"] == doc["table3"]["bags_expected"] and not doc["table3"]["bags_error"], doc["table3"]
    assert doc["node_crashes"] == 0, (doc["crashes"], doc["tracebacks"])
    assert doc["tours_intact"], doc["tours_problems"]
    hostile = [f for f in doc["faults"] if f["kind"] == "hostile_message"]
    assert all(f["accounted"] for f in hostile), [(f["target"], f["robot"]) for f in hostile if not f["accounted"]]
    assert doc["passed"] and proc.returncode == 0, doc["failures"]
    run = Path(doc["run_folder"])
    assert (run / "chaos.json").exists() and len(list(run.glob("*.bag"))) >= 5     # a new part after the restart
