"""Tour sharing between several store cores in one process (no master).

A small network model stands in for the relays: every published record goes to
every other robot (the event topic), links can be down (messages lost: the worst
case, worse than the relays' queueing), and messages can be reordered, duplicated
or dropped. Index exchange (the 1 Hz TourIndex) drives anti-entropy.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from tour_support import GUI, T0, TOURS, ListLog, from_robot, recv, snapshot, tour_msg

from gidabot_navigation.errors import TourRejected
from gidabot_navigation.senders import make_uid
from gidabot_navigation.tours.tour_store import NS, TourMessage, TourStore

ROBOTS = ["Tartalo", "Kbot", "Galtxagorri", "MariSorgin"]
GOAL_SETS = [
    ["0, 014, Computer Technicians 1", "1, 101, Secretary's Office"],
    ["2, 223, M. Larrea's Office", "3, 305, RSAIT Lab"],
    ["1, 104, Ada Lovelace Auditorium"],
    ["3, 325, I. Irigoien's Office", "0, 008, Caretakers' Office", "2, 274, K. Sarasola's Office"],
]


class Clock:
    def __init__(self, world: World, skew_ns: int) -> None:
        self.world, self.skew = world, skew_ns

    def __call__(self) -> int:
        return self.world.ns + self.skew


class World:
    """Four stores and the network between them."""

    def __init__(self, tmp: Path, faculty, rng: random.Random | None = None, skews: dict[str, int] | None = None,
                 seed_dir: Path | None = TOURS) -> None:
        self.ns = T0
        self.now = 0.0                                    # monotonic s, for resend throttling
        self.rng = rng or random.Random(0)
        self.up = dict.fromkeys(ROBOTS, True)
        self.inbox: dict[str, list[tuple[str, TourMessage]]] = {r: [] for r in ROBOTS}   # (sender, message)
        self.drop = self.dup = 0.0
        self.reorder = False
        self.sent = 0
        self.logs = {r: ListLog() for r in ROBOTS}
        self.stores = {r: TourStore(tmp / r, faculty, r, wall_ns=Clock(self, (skews or {}).get(r, 0)),
                                    log=self.logs[r], seed_dir=seed_dir).open() for r in ROBOTS}
        self.dirs = {r: tmp / r for r in ROBOTS}

    def close(self) -> None:
        for s in self.stores.values():
            s.close()

    def publish(self, sender: str, msg: TourMessage) -> None:
        for r in ROBOTS:
            if r == sender or not (self.up[sender] and self.up[r]):
                continue
            if self.rng.random() < self.drop:
                continue
            self.inbox[r].append((sender, msg))
            self.sent += 1
            if self.rng.random() < self.dup:
                self.inbox[r].append((sender, msg))

    def edit(self, robot: str, msg: TourMessage) -> None:
        rec = self.stores[robot].edit(msg, sender=GUI)
        self.publish(robot, self.stores[robot].outgoing(rec))

    def deliver(self) -> None:
        for r in ROBOTS:
            batch, self.inbox[r] = self.inbox[r], []
            if self.reorder:
                self.rng.shuffle(batch)
            for sender, msg in batch:       # published by the relay end of the link from sender
                self.stores[r].receive(msg, sender=from_robot(self.stores[r], sender))

    def tick(self) -> None:
        """One second: every robot's index reaches every reachable peer, then messages are delivered."""
        self.ns += NS
        self.now += 1.0
        for holder in ROBOTS:
            for peer in ROBOTS:
                if peer != holder and self.up[holder] and self.up[peer]:
                    store = self.stores[holder]
                    for msg in store.peer_index(peer, self.stores[peer].index(), self.now,
                                                sender=from_robot(store, peer)):
                        self.publish(holder, msg)
        self.deliver()
        for s in self.stores.values():
            s.step()

    def converged(self) -> bool:
        snaps = [snapshot(self.dirs[r]) for r in ROBOTS]
        indexes = [self.stores[r].index() for r in ROBOTS]
        return all(s == snaps[0] for s in snaps) and all(i == indexes[0] for i in indexes)

    def ticks_to_converge(self, limit: int = 10) -> int:
        for n in range(limit + 1):
            if self.converged():
                return n
            self.tick()
        raise AssertionError(f"not converged after {limit} ticks: " +
                             "; ".join(f"{r}: {sorted(snapshot(self.dirs[r]))}" for r in ROBOTS))


@pytest.fixture
def world(tmp_path, faculty):
    w = World(tmp_path, faculty)
    yield w
    w.close()


def test_seeded_robots_agree_without_traffic(world: World) -> None:
    assert world.converged()
    world.tick()
    assert world.sent == 0


def test_create_edit_delete_reach_every_robot_at_once(world: World) -> None:
    world.edit("Galtxagorri", tour_msg("visit.tour", GOAL_SETS[0], name="Open day"))
    world.deliver()
    assert world.converged()
    assert all((world.dirs[r] / "visit.tour").read_bytes().startswith(b"Tour: Open day\n0, 014") for r in ROBOTS)
    world.ns += NS
    world.edit("Tartalo", tour_msg("visit.tour", GOAL_SETS[1]))
    world.deliver()
    assert world.converged() and (world.dirs["MariSorgin"] / "visit.tour").read_bytes().startswith(b"Tour\n2, 223")
    world.ns += NS
    world.edit("MariSorgin", tour_msg("visit.tour", [], deleted=True))
    world.deliver()
    assert world.converged() and not any((world.dirs[r] / "visit.tour").exists() for r in ROBOTS)


def test_offline_robot_catches_up_by_index_exchange(world: World) -> None:
    """Tartalo's master is down during two edits and one delete; the live events are lost for it."""
    world.up["Tartalo"] = False
    world.edit("Galtxagorri", tour_msg("real_world.tour", GOAL_SETS[0]))
    world.tick()
    world.edit("Kbot", tour_msg("real_world.tour", GOAL_SETS[1]))
    world.tick()
    world.edit("MariSorgin", tour_msg("long_tour.tour", [], deleted=True))
    world.tick()
    assert not world.converged()
    assert (world.dirs["Tartalo"] / "long_tour.tour").exists()
    world.up["Tartalo"] = True
    assert world.ticks_to_converge() == 1
    assert not (world.dirs["Tartalo"] / "long_tour.tour").exists()
    assert (world.dirs["Tartalo"] / "real_world.tour").read_bytes().startswith(b"Tour\n2, 223")


def test_robot_that_edited_while_offline_pushes_its_edit(world: World) -> None:
    world.up["Kbot"] = False
    world.edit("Kbot", tour_msg("offline.tour", GOAL_SETS[2]))
    world.tick()
    world.up["Kbot"] = True
    assert world.ticks_to_converge() == 1
    assert all((world.dirs[r] / "offline.tour").exists() for r in ROBOTS)


@pytest.mark.parametrize("skew_ns, winner", [(0, "MariSorgin"), (-5 * NS, "Kbot"), (5 * NS, "MariSorgin")])
def test_concurrent_edits_converge_by_the_rule(tmp_path, faculty, skew_ns: int, winner: str) -> None:
    """Kbot and MariSorgin edit one tour at the same moment while cut off from each other."""
    w = World(tmp_path, faculty, skews={"MariSorgin": skew_ns})
    try:
        w.up["Kbot"] = False
        w.edit("Kbot", tour_msg("real_world.tour", GOAL_SETS[0]))
        w.up["Kbot"], w.up["MariSorgin"] = True, False
        w.edit("MariSorgin", tour_msg("real_world.tour", GOAL_SETS[1]))
        w.up["MariSorgin"] = True
        w.deliver()
        assert w.ticks_to_converge() <= 2
        rec = w.stores["Tartalo"].get("real_world.tour")
        assert rec.editor == winner
        expected = GOAL_SETS[0] if winner == "Kbot" else GOAL_SETS[1]
        assert (w.dirs["Tartalo"] / "real_world.tour").read_text() == "Tour\n" + "\n".join(expected) + "\n"
    finally:
        w.close()


def test_reordered_and_duplicated_messages(world: World) -> None:
    msgs = []
    for i, goals in enumerate(GOAL_SETS[:3]):
        world.ns += NS
        rec = world.stores["Kbot"].edit(tour_msg("visit.tour", goals), sender=GUI)
        msgs.append(world.stores["Kbot"].outgoing(rec))
        assert i == len(msgs) - 1
    world.ns += NS
    rec = world.stores["Kbot"].edit(tour_msg("visit.tour", [], deleted=True), sender=GUI)
    msgs.append(world.stores["Kbot"].outgoing(rec))
    for msg in [msgs[3], msgs[1], msgs[3], msgs[0], msgs[2], msgs[0]]:
        for r in ("Tartalo", "Galtxagorri", "MariSorgin"):
            recv(world.stores[r], msg)
    assert world.converged()
    assert not any((world.dirs[r] / "visit.tour").exists() for r in ROBOTS)
    assert world.stores["Tartalo"].counters["accepted"] == 1


def test_hostile_peer_message_never_spreads(world: World) -> None:
    bad = tour_msg("../../escape.tour", GOAL_SETS[0], version=T0, editor="Kbot", origin="Kbot",
                   uid=make_uid("Kbot", "tour", "ts"))
    world.publish("Kbot", bad)
    world.deliver()
    world.tick()
    assert world.converged() and world.sent == 3
    assert all(world.stores[r].counters["rejected_file_name"] == 1 for r in ROBOTS if r != "Kbot")


@pytest.mark.parametrize("seed", range(12))
def test_random_edits_on_a_lossy_network_converge_to_the_largest_version(tmp_path, faculty, seed: int) -> None:
    rng = random.Random(seed)
    skews = {r: rng.randint(-3, 3) * NS // 2 for r in ROBOTS}
    w = World(tmp_path, faculty, rng=rng, skews=skews)
    try:
        w.drop, w.dup, w.reorder = 0.3, 0.2, True
        produced: dict[str, list] = {}
        names = ["a.tour", "b.tour", "real_world.tour"]
        for _ in range(60):
            robot = rng.choice(ROBOTS)
            roll = rng.random()
            if roll < 0.1:
                w.up[robot] = not w.up[robot]
                continue
            name = rng.choice(names)
            if roll < 0.3:
                msg = tour_msg(name, [], deleted=True)
            else:
                msg = tour_msg(name, rng.choice(GOAL_SETS), language=rng.choice(["eu", "en", "es"]))
            try:
                rec = w.stores[robot].edit(msg, sender=GUI)
            except TourRejected:              # deleting a tour this robot does not hold
                continue
            produced.setdefault(name, []).append(rec)
            w.publish(robot, w.stores[robot].outgoing(rec))
            if rng.random() < 0.5:
                w.tick()
            else:
                w.ns += rng.randint(0, 3) * NS // 4     # several edits within one clock tick
        w.drop, w.dup = 0.0, 0.0
        w.up = dict.fromkeys(ROBOTS, True)
        w.deliver()
        assert w.ticks_to_converge(limit=6) <= 6
        for name, recs in produced.items():
            best = max(recs, key=lambda r: r.key)
            for r in ROBOTS:
                got = w.stores[r].get(name)
                assert got.key == best.key, (name, r)
                path = w.dirs[r] / name
                assert (path.read_text() if path.exists() else None) == (None if best.deleted else best.content)
    finally:
        w.close()
