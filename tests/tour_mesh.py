"""Helpers of the tour sharing system test: 4 masters, the relays, a tour store per robot.

    with TourMesh(tmp) as mesh:          # masters, relays.launch and tour_store.launch per robot
        mesh.edit("Galtxagorri", tour("x.tour", VISIT))
        mesh.wait_same(ROBOTS, timeout=2)

Masters run on this test session's loopback addresses (`procs.robot_address`) with the
faculty relocated to them; the relays come from `tests/relay_system.RelayMesh`
(`launch/relays.launch`, HMAC secret, one probe per robot), the stores from
`launch/tour_store.launch` (seeded from the repository's `tours/`), each robot with its own
directory. Every process is in a ProcessGroup and stopped by process group on close.
"""

from __future__ import annotations

import json
import os
import time
import xmlrpc.client
from collections.abc import Callable, Sequence
from pathlib import Path

from probe import wait_connected
from relay_system import RelayMesh
from sim_building import SimBuilding
from tour_system import FACULTY, TOUR, start_store

from gidabot_navigation.building.model import load_building, relocate_building
from gidabot_navigation.interface import Node, Topic, global_name
from gidabot_navigation.tours.tour_store import META_NAME
from gidabot_sim.errors import ProcessError
from gidabot_sim.runner.procs import ProcessGroup, robot_address, start_master, wait_until

ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")
CATALOG, RESULT, DIAG = Topic.TOUR_CATALOG, Topic.TOUR_EDIT_RESULT, Topic.DIAGNOSTICS
TYPES = {CATALOG: "gidabot_msgs/TourCatalog", RESULT: "gidabot_msgs/TourEditResult"}


def dir_files(directory: Path, hidden: bool = False) -> dict[str, bytes]:
    """Regular files of a tour directory and their bytes; with ``hidden`` also the store's metadata
    (lock file and temporary files excluded)."""
    out = {}
    for name in sorted(os.listdir(directory)):
        if name.startswith(".") and (not hidden or name.endswith(".lock") or name.startswith(".gidabot-tmp")):
            continue
        path = directory / name
        if path.is_file() and not path.is_symlink():
            out[name] = path.read_bytes()
    return out


def committed(directory: Path) -> bool:
    """The store's metadata records no change half done: every tour's file is the store's copy of its
    record and every deleted tour's file is gone (the second phase of each change is written; see
    ``TourStore._apply``). Until then the store writes its metadata once more."""
    try:
        meta = json.loads((directory / META_NAME).read_bytes())
    except (OSError, ValueError):
        return False
    return all(rec["disk"] == ("" if rec["deleted"] else rec["sha256"]) for rec in meta["tours"].values())


def node_pid(master_uri: str, node: str) -> int | None:
    """PID of ``node`` registered on the master (None if unknown or not answering)."""
    try:
        code, _, uri = xmlrpc.client.ServerProxy(master_uri).lookupNode("/tour_mesh_test", node)
        if code != 1:
            return None
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/tour_mesh_test")
        return int(pid) if code == 1 else None
    except (OSError, xmlrpc.client.Error):
        return None


def has_param(master_uri: str, key: str) -> bool:
    try:
        code, _, value = xmlrpc.client.ServerProxy(master_uri).hasParam("/tour_mesh_test", key)
    except (OSError, xmlrpc.client.Error):
        return False
    return code == 1 and bool(value)


class TourMesh:
    """4 masters + relays + tour stores; see the module docstring."""

    def __init__(self, tmp: Path) -> None:
        self.tmp = tmp
        self.procs = ProcessGroup(tmp / "logs")
        self.mesh: RelayMesh | None = None
        self.masters: SimBuilding | None = None
        self.dirs = {r: tmp / "tours" / r for r in ROBOTS}
        self.n = 0

    def __enter__(self) -> TourMesh:
        try:
            self.start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self, timeout: float = 90.0) -> None:
        base = load_building(FACULTY)
        uris = {r.name: start_master(self.procs, f"master_{r.name}", robot_address(i))
                for i, r in enumerate(base.robots)}
        path = relocate_building(FACULTY, self.tmp / "building", uris)
        self.masters = SimBuilding(path, load_building(path), self.procs, self.tmp / "logs")
        self.mesh = RelayMesh(self.masters, self.tmp)
        self.mesh.start(subscribe=[(CATALOG, TYPES[CATALOG]), (RESULT, TYPES[RESULT])], timeout=timeout)
        for r in ROBOTS:
            self.start_store(r)
        for r in ROBOTS:
            self.probe(r).wait(CATALOG, lambda m: len(m["tours"]) >= 3, timeout, f"{r}'s seeded catalog")

    def close(self) -> None:
        if self.mesh is not None:
            for r in ROBOTS:
                if self.procs.alive(f"tour_store_{r}"):
                    self.procs.signal(f"tour_store_{r}", 2)   # SIGINT to every store at once
            self.mesh.close()
        self.procs.close()

    # -- processes ------------------------------------------------------------------------
    def start_store(self, robot: str) -> None:
        assert self.masters is not None
        start_store(self.procs, self.masters.env(robot), robot, self.masters.path, self.dirs[robot])

    def stop_robot(self, robot: str) -> None:
        """The robot goes down: its tour store and its relays (supervisor and the relay ends it runs)
        stop, then its master is killed (SIGKILL)."""
        self.procs.stop(f"tour_store_{robot}")
        self.procs.stop(f"relays_{robot}")
        self.procs.signal(f"master_{robot}", 9)
        self.procs.stop(f"master_{robot}")

    def start_robot(self, robot: str) -> float:
        """The robot comes back: master (same address and port), relays, tour store. Returns the
        seconds until the master answered."""
        assert self.masters is not None and self.mesh is not None
        t0 = time.monotonic()
        self.masters.restart_master(robot)
        t_master = time.monotonic() - t0
        self.mesh.start_relays(robot)
        # two roslaunch processes starting at once on a fresh master race for /run_id (the loser
        # exits with "run_id on parameter server does not match"): the store starts once it is set
        uri = self.masters.building.robot(robot).master_uri
        wait_until(lambda: has_param(uri, "/run_id"), 30, f"/run_id on {robot}'s master", interval=0.02)
        self.start_store(robot)
        return t_master

    def store_pid(self, robot: str) -> int | None:
        assert self.masters is not None
        return node_pid(self.masters.building.robot(robot).master_uri, global_name(Node.TOUR_STORE))

    # -- messages -------------------------------------------------------------------------
    def probe(self, robot: str):
        assert self.mesh is not None
        return self.mesh.probes[robot]

    def edit(self, robot: str, msg: dict, wait: bool = True) -> dict | None:
        """An admin edit on ``robot``'s ``tour_store/edit`` (as the GUI sends it); with ``wait`` returns
        its TourEditResult."""
        self.n += 1
        msg = {**msg, "uid": f"systest/edit/{self.n}"}
        since = len(self.probe(robot).msgs(RESULT))
        # the store answers once, unlatched: the probe must hear its result topic before the edit is sent (it
        # subscribed before the store started; that connection can come later than the catalog's)
        assert self.masters is not None
        wait_connected(self.masters.building.robot(robot).master_uri, global_name(Node.TOUR_STORE),
                       f"/{RESULT}", [self.probe(robot).name])
        self.probe(robot).pub(Topic.TOUR_EDIT, TOUR, msg, to=[global_name(Node.TOUR_STORE)])
        if not wait:
            return None
        return self.result(robot, msg["uid"], since)

    def result(self, robot: str, uid: str, since: int = 0, timeout: float = 10.0) -> dict:
        return self.probe(robot).wait(RESULT, lambda m: m["uid"] == uid, timeout, f"edit result {uid}", since=since)

    def store_diag(self, robot: str) -> dict[str, str]:
        """Latest ``tour_store: <robot>`` diagnostics values on the robot's master."""
        assert self.mesh is not None
        return self.mesh.diag(robot, f"tour_store: {robot}") or {}

    # -- directories ----------------------------------------------------------------------
    def files(self, robot: str, hidden: bool = False) -> dict[str, bytes]:
        return dir_files(self.dirs[robot], hidden)

    def wait_files(self, robots: Sequence[str], check: Callable[[dict[str, bytes]], bool], timeout: float,
                   what: str, t0: float | None = None) -> dict[str, float]:
        """Poll the directories (every 5 ms) until ``check`` holds for each robot's files; returns
        the seconds from ``t0`` (default: now) to the moment each robot's directory first passed."""
        t0 = time.monotonic() if t0 is None else t0
        deadline = time.monotonic() + timeout
        done: dict[str, float] = {}
        while True:
            for r in robots:
                if r not in done and check(self.files(r)):
                    done[r] = time.monotonic() - t0
            if len(done) == len(robots):
                return done
            if time.monotonic() > deadline:
                missing = [r for r in robots if r not in done]
                raise ProcessError(f"timed out after {timeout:g} s waiting for {what} on {missing}")
            time.sleep(0.005)

    def wait_same(self, timeout: float, what: str = "the same tours everywhere") -> dict[str, bytes]:
        """Until every robot's directory holds the same files, byte for byte, and no store is between
        the two metadata writes of a change (:func:`committed`); returns the files."""
        wait_until(lambda: all(self.files(r) == self.files(ROBOTS[0]) for r in ROBOTS[1:])
                   and all(committed(self.dirs[r]) for r in ROBOTS), timeout, what, interval=0.02)
        return self.files(ROBOTS[0])
