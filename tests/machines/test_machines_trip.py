"""A cross-floor trip between robots on separate machines.

The whole simulated building as `gidabot demo --machines` runs it (`SimulatedBuilding(machines=True)`):
each robot a network namespace of its own with its master, `launch/robot.launch sim:=true` and a
firewall that admits from the other machines only its relay ports; the recorders run on their robot's
machine. Before the trip, every master and every node answers on its own machine and on no other;
while the goal floor's robot waits for the visitor, every connection between two machines (`ss`) is a
relay link; a floor 0 -> floor 1 trip by the stairs then completes, every version of its goal received
once by every robot.
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest
from machines_system import assert_only_relay_links, assert_only_relay_ports_open
from sim_stack import CONTINUE, GO_TO_FLOOR, GOAL_REACHED, GOALS, WAITING_VISITOR, SimStack

from gidabot_sim.runner.procs import wait_until

pytestmark = [pytest.mark.system, pytest.mark.slow]

SPEED = 20.0            # sim seconds per wall second
TRIP_WALL = 120.0       # wall s allowed for one leg


@pytest.fixture
def stack(tmp_path) -> Iterator[SimStack]:
    t0 = time.monotonic()
    with SimStack(tmp_path, speed=SPEED, machines=True) as st:
        ready = st.wait_ready(timeout=180)
        print(f"\n[machines] 4 robots on 4 machines up in {time.monotonic() - t0:.1f} s wall "
              f"(relays and every partner seen after {ready:.1f} s)")
        yield st


@pytest.mark.timeout(420)
def test_a_cross_floor_trip_completes_with_only_relay_links_between_the_machines(stack: SimStack) -> None:
    net, building = stack.sim.net, stack.building
    assert net is not None
    closed = assert_only_relay_ports_open(net, building)
    print(f"[machines] firewalls: {closed} (master or node, other machine) pairs closed, relay ports open")

    wall0 = time.monotonic()
    uid, since = stack.request("Tartalo", "101", way="stairs")
    stack.wait_event("Tartalo", GO_TO_FLOOR, uid, timeout=TRIP_WALL, since=since)
    stack.wait_event("Kbot", WAITING_VISITOR, uid, timeout=TRIP_WALL, on="Kbot")
    crossing = assert_only_relay_links(net, building)       # mid-trip: the relays carried everything so far
    stack.command("Kbot", CONTINUE, goal_uid=uid)
    done = stack.wait_event("Kbot", GOAL_REACHED, uid, timeout=TRIP_WALL, on="Kbot")
    assert done["location_id"] == "101" and done["floor"] == 1.0
    stack.wait_event("Kbot", GOAL_REACHED, uid, timeout=10, on="Tartalo")      # the news crossed back
    print(f"[machines] floor 0 -> 1 by the stairs across machines: {time.monotonic() - wall0:.1f} s wall; "
          f"{crossing} connections between machines, every one a relay link")
    # every version of the goal (its origin broadcasts it again, attempt + 1, as the legs are assigned) reached
    # every robot's master, each once
    def attempts(r: str) -> list[int]:
        return [m["attempt"] for m in stack.rec[r].msgs(GOALS) if m["uid"] == uid]
    origin = set(attempts("Tartalo"))
    for r in stack.robots:
        wait_until(lambda r=r: set(attempts(r)) == origin, 10, f"every version {sorted(origin)} of the goal at {r}")
        assert sorted(attempts(r)) == sorted(origin), (r, attempts(r))
    for r in ("Tartalo", "Kbot"):
        wait_until(lambda r=r: stack.pending(r, r)["num"] == 0, 10, f"{r}'s empty queue")
    assert_only_relay_links(net, building)
