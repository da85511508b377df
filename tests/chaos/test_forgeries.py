"""Forged messages about every real trip never touch it: `bin/gidabot chaos --profile forgeries` on the Table 2 tour.

The simulated Faculty runs the paper's Table 2 long tour (15 goals) with no fault but a forger on every master
(``gidabot_sim.chaos.forgery``): a node named like a relay end of a link the building does not have, which, for
every goal uid it sees published by a guiding node or a relay end of its master, publishes a goal with that uid
and other content, a cancel of it, its GOAL_REACHED and REJECTED, and a goal, a cancel and a GOAL_REACHED for each
of the next two uids (as if uids were counters). Targets: the tour completes, no goal lost or duplicated, Table 3
from the bags is the paper's (15 / 7, 8, 8, 6), the tour directories are unchanged, and on every master each node
that receives the forged goals, cancels and events (goal_manager, multirobot_navigation, the simulated visitor's
screen; the relay ends drop
their connection to any relay-named publisher at once, so nothing it sends reaches them) counted at least as
many refusals as forged messages reached it (printed: sent / refused per node).
Needs root (the chaos run checks iptables); about 5 minutes.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from chaos_cli import run_chaos

import gidabot_sim.runner.procs as procs_mod

pytestmark = [pytest.mark.system, pytest.mark.slow]

TABLE3 = {"Tartalo": [15, 7], "Kbot": [15, 8], "Galtxagorri": [15, 8], "MariSorgin": [15, 6]}
ROBOTS = tuple(TABLE3)
# per goal uid, the forged messages each receiving node gets: 10, of them 7 cancels and events, 4 events
RECEIVERS = {"guiding: goal_manager": 10, "guiding: navigation": 7, "sim: visitor": 4}


@pytest.mark.timeout(1200)
@pytest.mark.skipif(shutil.which("iptables") is None or os.geteuid() != 0, reason="needs iptables and root")
def test_forgeries_about_every_trip_are_refused_and_the_table2_tour_completes(tmp_path: Path) -> None:
    doc, returncode = run_chaos(["--profile", "forgeries", "--seed", "1", "--speed", "8", "--out",
                                 str(tmp_path / "runs"), "--net", str(procs_mod.test_network()), "--timeout", "900"],
                                1080)
    rows = doc["forgeries"]
    print("\n[forgeries] sent / refused per node: "
          + ", ".join(f"{r['node']}@{r['robot']} {r['sent']} / {r['refused']}" for r in rows))
    print(f"[forgeries] Table 3 from the bags: {doc['table3_bags']}")
    # every master had its forger, which forged about the trips it saw (a goal delivered before the forger's
    # subscriptions connected may be missed there): at least 12 goal uids, each reaching a node RECEIVERS times
    assert {(r["robot"], r["node"]) for r in rows} == {(m, n) for m in ROBOTS for n in RECEIVERS}, rows
    assert all(r["sent"] >= 12 * RECEIVERS[r["node"]] for r in rows), rows
    assert all(r["accounted"] for r in rows) and not doc["forgeries_unaccounted"], rows
    assert doc["completed"] == 15 and doc["lost"] == 0 and doc["duplicated"] == 0, doc["failures"]
    assert doc["tour_completed"], doc["outcome"]
    assert doc["table3_bags"] == TABLE3 and not doc["table3"]["bags_error"], doc["table3"]
    assert doc["node_crashes"] == 0, (doc["crashes"], doc["tracebacks"])
    assert doc["tours_intact"], doc["tours_problems"]
    assert doc["passed"] and returncode == 0, doc["failures"]
