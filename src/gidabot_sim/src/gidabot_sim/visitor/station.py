"""One robot's screen for the simulated visitors (ROS-free): what the ``visitor`` node decides.

A :class:`VisitorStation` holds the visitors (:class:`~gidabot_sim.visitor.visitor.VisitorCore`) that use
this robot's screen: the one visitor of the node's parameters, or each visitor of a population
(:mod:`gidabot_sim.visitor.population`). It

* routes every robot's navigation events to the visitors they concern: with one visitor, all of them; with
  a population, an event of a trip to the visitor its goal names (the events of a trip whose goal has not
  been seen yet wait for it), the answer to a request without a trip to the visitors who asked at that
  robot; a visitor sees an event when it happened (its stamp), never later than now;
* starts a visitor at its start robot ``start_delay`` + its ``arrive_s`` after every robot reported its
  status, and in tour mode once the tour store holds its tour; a visitor with a patience first sees the
  waits the screen shows (:class:`~gidabot_sim.visitor.visitor.Screen`) and may leave instead; what it
  chose is appended to the record file (the demo's monitor.jsonl);
* numbers the buttons the visitors press, as the GUI's commands (:meth:`VisitorStation.tick`);
* says what the visitors' bodies do on this robot's floor (:meth:`VisitorStation.bodies`: the directives
  of :mod:`gidabot_sim.world.people` for the floor's simulator): a visitor who is with this robot (its visit
  started here, or it arrived here from another floor) follows it; one who left for another floor walks off
  towards the stairs or the lift; one whose visit is over leaves the floor;
* says which inputs it still needs: every robot's status until all are up (and for good when a screen
  shows waits), the tour catalog until its tours are known.

Times are passed in (sim s for the visit, wall s for the screen's waits and the record): tests need no clock.
"""

from __future__ import annotations

import json
import math
import threading
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import replace
from typing import Any

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import TourError, TourNameError
from gidabot_navigation.guiding.messages import CommandData, NavEventData, Trip
from gidabot_navigation.interface import WAYS, Topic
from gidabot_navigation.logs import Logger
from gidabot_navigation.senders import Claim, Gate, Senders, claim_of
from gidabot_navigation.tours.tour_file import tour_from_lines
from gidabot_navigation.tours.tour_store import TourMessage
from gidabot_sim.errors import SimConfigError
from gidabot_sim.visitor.behaviour import parse_walk
from gidabot_sim.visitor.population import VisitorPlan
from gidabot_sim.visitor.visitor import ButtonPress, Screen, VisitorConfig, VisitorCore
from gidabot_sim.world.people import FOLLOW, GONE, LEAVE, Directive

MAX_UNROUTED = 2000      # events of trips whose goal was not seen yet, kept (the oldest are dropped)


def skips_of(raw: Any) -> tuple[tuple[int, int], ...]:
    """The ``~skips`` parameter: [k, m] pairs (after tour step k is done, skip to step m)."""
    try:
        return tuple((int(k), int(m)) for k, m in raw)
    except (TypeError, ValueError) as err:
        raise SimConfigError(f"~skips: {raw!r} must be a list of [k, m] step pairs") from err


def walk_of(walk: Any, behaviour_seed: Any) -> dict[str, Any]:
    """The ``~walk`` and ``~behaviour_seed`` parameters: the :class:`VisitorConfig` fields of how the one visitor's
    body walks (``walk``: :func:`~gidabot_sim.visitor.behaviour.parse_walk` text, "" = drawn from the seed; seed
    -1: :data:`~gidabot_sim.visitor.behaviour.TIDY`)."""
    if not isinstance(walk, str):
        raise SimConfigError(f"~walk: {walk!r} must be a string of key=value (gidabot demo --walk)")
    if not isinstance(behaviour_seed, int) or isinstance(behaviour_seed, bool):
        raise SimConfigError(f"~behaviour_seed: {behaviour_seed!r} must be a whole number (-1: tidy)")
    return {"behaviour_seed": behaviour_seed, "behaviour": parse_walk(walk) if walk else None}


def station_config(building: Building, robot: str, start_floor: float, **settings: Any) -> VisitorConfig:
    """The visitor configuration of the node of ``robot``: its floor, the robot where the visit starts (the first
    of ``start_floor``), the floors with a robot; ``settings``: the other fields of :class:`VisitorConfig`."""
    try:
        found = building.robot(robot)
    except KeyError as err:
        raise SimConfigError(f"~robot: {err.args[0]}") from err
    starters = building.robots_on(start_floor)
    cfg = VisitorConfig(robot=found.name, floor=found.floor, start_floor=start_floor,
                        start_robot=starters[0].name if starters else "",
                        robot_floors=tuple(sorted({r.floor for r in building.robots})), **settings)
    if cfg.way not in WAYS:
        raise SimConfigError(f"~way: {cfg.way!r} must be one of {', '.join(WAYS)}")
    return cfg


class VisitorStation:
    """See the module docstring. ``log``: what the visitors do; ``population``: the visitors (none: the one of
    ``cfg``); ``record``: the file to append the visitors' choices to ("" = none); ``screen``: what the screen
    shows (made when a visitor has a patience, unless given)."""

    def __init__(self, building: Building, cfg: VisitorConfig, log: Logger, population: Sequence[VisitorPlan] = (),
                 start_delay: float = 2.0, record: str = "", screen: Screen | None = None) -> None:
        self.building, self.cfg, self.log, self.start_delay, self.record = building, cfg, log, start_delay, record
        self.population = bool(population)
        self.cores = {p.visitor_id: VisitorCore(replace(
            cfg, start_floor=building.robot(p.robot).floor, start_robot=p.robot, way=p.way, goal_id=p.goal_id,
            tour_file=p.tour_file, skips=(), visitor_id=p.visitor_id, arrive_s=p.arrive_s,
            cancel_after_s=p.cancel_after_s, no_show=p.no_show, patience_s=p.patience_s,
            behaviour_seed=p.behaviour_seed, behaviour=None)) for p in population} \
            or {cfg.visitor_id: VisitorCore(cfg)}
        self.robots = {r.name for r in building.robots}
        # whose events it takes: a robot's own nodes for that robot, a relay end for its peer (senders.py)
        self.gate = Gate(Senders.of_building(building, cfg.robot, simulated=True), log)
        self.screen: Screen | None = None
        if any(c.cfg.patience_s >= 0 for c in self.cores.values()):
            self.screen = screen or Screen(building)
            self.screen.planner.warm_up()    # not at the first visitor's screen, while the floors wait for the CPU
        self._lock = threading.Lock()        # the callbacks' threads and the timer's
        self._seen: set[str] = set()
        self._all_up_at: float | None = None
        self._visitor_of: dict[str, str] = {}          # goal uid -> visitor id (population: from the goals)
        self._unrouted: deque[NavEventData] = deque(maxlen=MAX_UNROUTED)
        # tour mode: the tours' floors; the start robot waits until its tour store holds the tour (START_TOUR reads
        # it there)
        self._tours_missing = {c.cfg.tour_file for c in self.cores.values() if c.cfg.tour_file}
        self._first_stop: dict[str, str] = {}          # tour file -> the room of its first stop (the screen)
        self._seq = 0
        self._bodies: dict[str, int] = {}               # visitor id -> the mode last directed for its body here

    # -- which inputs ---------------------------------------------------------------------------------
    @property
    def needs_goals(self) -> bool:
        """A population: which visitor each trip is for."""
        return self.population

    @property
    def needs_pending(self) -> bool:
        """Every robot's queue, for the waits the screen shows."""
        return self.screen is not None

    @property
    def needs_status(self) -> bool:
        """Every robot's status: until all are up, and for good when the screen shows waits (their poses)."""
        return self._all_up_at is None or self.screen is not None

    @property
    def needs_catalog(self) -> bool:
        return bool(self._tours_missing)

    # -- inputs (any thread) ----------------------------------------------------------------------------
    def on_goal_from(self, sender: str, origin_robot: str, goal_uid: str, visitor_id: str, now: float) -> None:
        """A Goal published by ``sender``: taken (:meth:`on_goal`) only when its sender may speak for its origin
        robot and its uid is that robot's (else refused and counted), so a forged goal never takes a trip's uid."""
        if self.gate.admit(sender, Claim(origin_robot, goal_uid), "goal") is not None:
            self.on_goal(goal_uid, visitor_id, now)

    def on_goal(self, goal_uid: str, visitor_id: str, now: float) -> None:
        """Population: the trip ``goal_uid`` is for ``visitor_id``; its events held back so far go to it."""
        with self._lock:
            core = self.cores.get(visitor_id)
            if core is None or goal_uid in self._visitor_of:
                return
            self._visitor_of[goal_uid] = visitor_id
            core.on_goal(goal_uid)
            held = [e for e in self._unrouted if e.goal_uid == goal_uid]
            for event in held:
                self._unrouted.remove(event)
                self._deliver(core, event, now)

    def on_event_from(self, sender: str, event: NavEventData, now: float) -> None:
        """A NavEvent published by ``sender`` on this robot's master: taken (:meth:`on_event`) only when it speaks
        for a robot its sender may speak for, with a uid of that robot (else refused and counted:
        ``self.gate.refusals()``), so a forged event never moves a visitor."""
        if self.gate.admit(sender, claim_of(Topic.NAV_EVENTS, event) or Claim(""), "nav event") is not None:
            self.on_event(event, now)

    def on_event(self, event: NavEventData, now: float) -> None:
        with self._lock:
            if len(self.cores) == 1:
                self._deliver(next(iter(self.cores.values())), event, now)
            elif event.goal_uid:
                visitor = self._visitor_of.get(event.goal_uid)
                if visitor is None:
                    self._unrouted.append(event)
                else:
                    self._deliver(self.cores[visitor], event, now)
            else:      # an answer to a request, before any trip: the visitors who asked at that robot
                for core in self.cores.values():
                    if core.cfg.start_robot == event.robot:
                        self._deliver(core, event, now)

    @staticmethod
    def _deliver(core: VisitorCore, e: NavEventData, now: float) -> None:
        # the visitor sees what a robot does when it happens (the event's stamp), not when its message got here:
        # the messages' wall latency would otherwise add sim time, the more the faster the run (never later than
        # now: another floor's clock may be a little ahead)
        core.on_event(min(e.stamp, now) if e.stamp > 0 else now, e.uid, e.robot, e.phase, e.goal_uid, e.floor,
                      e.target_floor, e.tour_step, tour_file=e.tour_file, location_id=e.location_id)

    def on_catalog(self, entries: Iterable[TourMessage]) -> None:
        """The tour store's catalog: the floors of the visitors' tours, and their first stops."""
        for entry in entries:
            if entry.file_name not in self._tours_missing:
                continue
            try:
                tour = tour_from_lines(entry.file_name, entry.tour_name, list(entry.tour_goals_info), self.building)
            except (TourError, TourNameError) as err:
                self.log.warning(f"visitor on {self.cfg.robot}: tour {entry.file_name} in the catalog is invalid: "
                                 f"{err}")
                continue
            with self._lock:
                for core in self.cores.values():
                    if core.cfg.tour_file == entry.file_name:
                        core.on_tour(tuple(g.floor for g in tour.goals))
                if tour.goals:
                    self._first_stop[entry.file_name] = tour.goals[0].room
                self._tours_missing.discard(entry.file_name)

    def on_pending(self, robot: str, trips: list[Trip], wait_new: float, wall: float) -> None:
        with self._lock:
            if self.screen is not None:
                self.screen.on_pending(robot, trips, wait_new, wall)

    def on_status(self, robot: str, position: tuple[float, float], now: float, wall: float) -> None:
        with self._lock:
            if self.screen is not None:
                self.screen.on_status(robot, wall, position)
            self._seen.add(robot)
            if self._all_up_at is None and self.robots <= self._seen:
                self._all_up_at = now

    # -- the timer ------------------------------------------------------------------------------------------
    def tick(self, now: float, wall: float) -> list[CommandData]:
        """The buttons the visitors press now (sim time ``now``, wall time ``wall``), as commands to publish."""
        presses: list[tuple[VisitorConfig, ButtonPress]] = []
        with self._lock:
            for core in self.cores.values():
                commands = core.step(now)
                if (self._all_up_at is not None and not self._tours_missing and not core.started
                        and now >= self._all_up_at + self.start_delay + core.cfg.arrive_s and core.on_start_floor):
                    shown = self._shown(core, wall)
                    commands = core.start(now, shown) + commands
                    if core.started:
                        self.log.info(f"visitor {core.cfg.visitor_id} on {self.cfg.robot}: "
                                      f"{core.outcome if core.left else 'starting the visit'} (waits shown: {shown})")
                        self._write_record(core, now, wall)
                presses += [(core.cfg, cmd) for cmd in commands]
        return [self._command(cfg, press, now) for cfg, press in presses]

    def bodies(self, now: float) -> list[Directive]:
        """What changed for the visitors' bodies on this robot's floor at sim time ``now`` (see the module
        docstring); each change once."""
        out = []
        with self._lock:
            for vid, core in self.cores.items():
                here = core.present and (core.started or not core.on_start_floor) and not core.left
                last = self._bodies.get(vid)
                mode = GONE if core.finished and last is not None else FOLLOW if here else \
                    LEAVE if last == FOLLOW else last
                if mode is None or mode == last:
                    continue
                self._bodies[vid] = mode
                start = core.visit_start
                out.append(Directive(vid, mode, self.cfg.robot, math.nan, math.nan, core.behaviour,
                                     now if start is None else start))
        return out

    def _shown(self, core: VisitorCore, wall: float) -> tuple[float | None, ...]:
        """The waits this robot's screen shows the visitor before it confirms (its trip's legs)."""
        if self.screen is None or core.cfg.patience_s < 0:
            return ()
        goal = core.cfg.goal_id or self._first_stop.get(core.cfg.tour_file, "")
        return self.screen.waits(self.cfg.robot, goal, core.cfg.way, wall) if goal else ()

    def _command(self, cfg: VisitorConfig, press: ButtonPress, now: float) -> CommandData:
        self._seq += 1
        self.log.info(f"visitor {cfg.visitor_id} on {cfg.robot}: command {press.command} {press}")
        return CommandData(command=press.command, uid=f"{cfg.robot}/{cfg.visitor_id}/cmd/{self._seq}",
                           visitor_id=cfg.visitor_id, goal_id=press.goal_id, way=press.way, language=press.language,
                           goal_uid=press.goal_uid, tour_file=press.tour_file, tour_step=press.tour_step, stamp=now)

    def _write_record(self, core: VisitorCore, now: float, wall: float) -> None:
        """What the visitor chose at the screen, for the demo's statistics (one line, appended in one write)."""
        if not self.record:
            return
        line = json.dumps({"kind": "visitor", "event": "left" if core.left else "asked", "wall": wall,
                           "sim": now, "visitor": core.cfg.visitor_id, "robot": self.cfg.robot,
                           "shown": [None if w is None else round(w, 1) for w in core.shown],
                           "patience_s": core.cfg.patience_s, "detail": core.outcome if core.left else ""})
        try:
            with open(self.record, "a", encoding="utf-8") as out:
                out.write(line + "\n")
        except OSError as err:
            self.log.warning(f"visitor on {self.cfg.robot}: cannot append to {self.record}: {err}")
