"""Test helpers for the guiding cores: a ROS-free building of goal managers and navigations.

:class:`Bus` plays the relays and the local topics: every action of a core is queued
and delivered (in order) to every robot's cores, as the shared topics would, and every
goal manager's pending list to the others; :meth:`Bus.pump` delivers until nothing is
left. A robot in :attr:`Bus.down` is partitioned: what it sends and what is sent to it
is held (the relays queue it) until :meth:`Bus.link_up`. :attr:`Bus.tap` sees every
message between two robots and may drop, duplicate or keep it (delivered later by
:meth:`Bus.release`, in any order). move_base is replaced by a script: ``MoveTo``
succeeds (the robot jumps to the target) unless the test says otherwise.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from gidabot_navigation.building.model import Building
from gidabot_navigation.guiding.goal_manager import GoalManagerConfig, GoalManagerCore
from gidabot_navigation.guiding.messages import (
    CancelData,
    CommandData,
    MoveTo,
    NavEventData,
    SendCancel,
    SendEvent,
    SendGoal,
    StaffCommandData,
    StopMoving,
    Trip,
)
from gidabot_navigation.guiding.navigation import ABORTED, SUCCEEDED, NavigationConfig, NavigationCore
from gidabot_navigation.guiding.trips import TripPlanner
from gidabot_navigation.interface import LEG_COMMITTED, LEG_NONE, Cmd, Node, Phase, StaffCmd, global_name
from gidabot_navigation.senders import SCOPE_STAFF, make_uid
from gidabot_navigation.tours.tour_file import parse_tour
from gidabot_navigation.tours.tour_store import TourMessage

_PLANNERS: dict[int, tuple[Building, TripPlanner]] = {}
# the callerids of a robot's own nodes on its master
GM, NAV, GUI, TS, PEOPLE = (global_name(n) for n in (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.GUI,
                                                     Node.TOUR_STORE, Node.PEOPLE))
DASHBOARD = global_name(Node.DASHBOARD)


def from_robot(core: GoalManagerCore | NavigationCore, robot: str) -> str:
    """The callerid that messages of ``robot`` have on the master of ``core``'s robot: its own goal manager, or the
    relay end of the link from ``robot``."""
    return GM if robot == core.me else core.gate.senders.relay_of(robot)


def sender_of(core: GoalManagerCore | NavigationCore, msg: Trip | CancelData | NavEventData) -> str:
    """The callerid of the rightful publisher of ``msg`` (a goal, cancel or event) on ``core``'s master."""
    return from_robot(core, msg.robot if isinstance(msg, NavEventData) else msg.origin_robot)


def shared_planner(building: Building) -> TripPlanner:
    """One planner (and its cache of path lengths) per building for every test: planning is the slow part."""
    if id(building) not in _PLANNERS:
        _PLANNERS[id(building)] = (building, TripPlanner(building))
    return _PLANNERS[id(building)][1]


class ListLog:
    """A logger that keeps the lines."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def info(self, msg: str) -> None:
        self.lines.append(("info", msg))

    def warning(self, msg: str) -> None:
        self.lines.append(("warning", msg))

    def error(self, msg: str) -> None:
        self.lines.append(("error", msg))


def catalog_of(building: Building, *paths) -> list[TourMessage]:
    """The catalog's tours of tour files (pathlib paths)."""
    entries = []
    for p in paths:
        tour = parse_tour(p.read_bytes(), p.name, building)
        entries.append(TourMessage(file_name=p.name, tour_name=tour.name, tour_goals_info=tuple(tour.goal_lines())))
    return entries


@dataclass
class RobotCores:
    name: str
    gm: GoalManagerCore
    nav: NavigationCore | None
    moves: list[MoveTo] = field(default_factory=list)       # every move_base goal sent
    stops: list[StopMoving] = field(default_factory=list)
    active: MoveTo | None = None                           # the move_base goal running
    pending_version: int = -1


class Bus:
    """Four (or any number of) robots' guiding cores linked like the relays link their masters."""

    def __init__(self, building: Building, robots: list[str] | None = None, navigation: bool = True,
                 auto_move: bool = True, continue_timeout: float = 300.0, partner_timeout: float = 120.0,
                 catalog: list[TourMessage] | None = None) -> None:
        self.building = building
        self.now_ros = 100.0
        self.now_wall = 1000.0
        self.auto_move = auto_move
        self.log = ListLog()
        self.robots: dict[str, RobotCores] = {}
        names = robots or [r.name for r in building.robots]
        for name in names:
            gm = GoalManagerCore(building, GoalManagerConfig(robot=name), self.log, self.now_wall,
                                 planner=shared_planner(building))
            nav = None
            if navigation:
                nav = NavigationCore(building, NavigationConfig(robot=name, continue_timeout=continue_timeout,
                                                                partner_timeout=partner_timeout),
                                     self.log, self.now_wall)
                nav.on_move_base_available(True, self.now_ros)
                home = building.robot(name).home
                nav.on_pose(home.x, home.y, home.yaw)
            self.robots[name] = RobotCores(name, gm, nav)
            if catalog:
                gm.on_catalog(catalog, sender=TS)
                if nav:
                    nav.on_catalog(catalog, sender=TS)
        self.goals: list[Trip] = []
        self.cancels: list[CancelData] = []
        self.events: list[NavEventData] = []
        self.queue: deque[Callable[[], None]] = deque()
        self.deferred: deque[Callable[[], None]] = deque()
        self.on_event: Callable[[NavEventData], None] | None = None
        self.down: set[str] = set()          # partitioned robots: deliveries to and from them are held back
        self.held: list[tuple[str, str, Callable[[], None]]] = []
        # (sender, receiver, action) -> "pass", "drop" (lost), "dup" (delivered twice) or "keep" (see release)
        self.tap: Callable[[str, str, object], str] | None = None
        self.kept: list[tuple[str, object, Callable[[], None]]] = []
        for r in self.robots.values():
            self._sync_pending(r)

    # -- delivery -------------------------------------------------------------------
    def _to(self, robot: str, fn: Callable[[], None], sender: str = "", what: object = None) -> None:
        remote = bool(sender) and robot != sender
        verdict = self.tap(sender, robot, what) if remote and self.tap is not None else "pass"
        if verdict == "drop":
            return
        if verdict == "keep":
            self.kept.append((robot, what, fn))
            return
        for _ in range(2 if verdict == "dup" else 1):
            if remote and (robot in self.down or sender in self.down):
                self.held.append((robot, sender, fn))
            else:
                self.queue.append(fn)

    def release(self, index: int = 0) -> None:
        """Deliver the message :attr:`tap` kept at ``index`` now (then :meth:`pump`)."""
        _, _, fn = self.kept.pop(index)
        self.queue.append(fn)

    def dispatch(self, sender: str, actions: list) -> None:
        callerid = {name: from_robot(r.gm, sender) for name, r in self.robots.items()}   # of sender, per master
        for act in actions:
            if isinstance(act, SendGoal):
                self.goals.append(act.trip)
                for name, r in self.robots.items():
                    self._to(name, lambda r=r, t=act.trip, s=callerid[name]:
                             self.run(r.name, r.gm.on_goal(t, self.now_ros, self.now_wall, sender=s)), sender, act)
            elif isinstance(act, SendCancel):
                self.cancels.append(act.cancel)
                for name, r in self.robots.items():
                    self._to(name, lambda r=r, c=act.cancel, s=callerid[name]: self._cancel(r, c, s),
                             sender, act)
            elif isinstance(act, SendEvent):
                self.events.append(act.event)
                if self.on_event is not None:
                    self.on_event(act.event)
                for name, r in self.robots.items():
                    self._to(name, lambda r=r, e=act.event, s=callerid[name]: self._event(r, e, s),
                             sender, act)
            elif isinstance(act, MoveTo):
                r = self.robots[sender]
                r.moves.append(act)
                r.active = act
                if self.auto_move:
                    self.queue.append(lambda r=r, m=act: self.finish_move(r.name, SUCCEEDED, m.token))
            elif isinstance(act, StopMoving):
                r = self.robots[sender]
                r.stops.append(act)
                if r.active is not None and r.active.token == act.token:
                    r.active = None
        self._sync_pending(self.robots[sender])

    def _cancel(self, r: RobotCores, c: CancelData, sender: str) -> None:
        self.run(r.name, r.gm.on_cancel(c, self.now_ros, self.now_wall, sender=sender))
        if r.nav:
            self.run(r.name, r.nav.on_cancel(c, self.now_ros, self.now_wall, sender=sender))

    def _event(self, r: RobotCores, e: NavEventData, sender: str) -> None:
        self.run(r.name, r.gm.on_nav_event(e, self.now_ros, self.now_wall, sender=sender))
        if r.nav:
            self.run(r.name, r.nav.on_nav_event(e, self.now_ros, self.now_wall, sender=sender))

    def _sync_pending(self, r: RobotCores) -> None:
        if r.gm.version == r.pending_version:
            return
        r.pending_version = r.gm.version
        snap = r.gm.pending(self.now_ros)
        if r.nav is not None:
            self.queue.append(lambda r=r, s=snap: self.run(r.name, r.nav.on_pending(
                s.goals, s.wait_new, self.now_ros, self.now_wall, robot=s.robot, sender=GM)))
        for other in self.robots.values():
            if other.name != r.name:
                self._to(other.name, lambda o=other, s=snap: o.gm.on_pending(
                    s.robot, s.goals, s.wait_new, self.now_wall, sender=from_robot(o.gm, s.robot)), r.name, snap)

    def run(self, robot: str, actions: list) -> None:
        self.dispatch(robot, actions)

    def pump(self, limit: int = 100000) -> None:
        """Deliver everything; then run what :meth:`soon` deferred (a visitor acting after a pause)."""
        n = 0
        while self.queue or self.deferred:
            while self.queue:
                self.queue.popleft()()
                n += 1
                assert n < limit, "the bus does not settle"
            if self.deferred:
                self.deferred.popleft()()

    def soon(self, fn: Callable[[], None]) -> None:
        """Run ``fn`` once every message under way has been delivered."""
        self.deferred.append(fn)

    def link_up(self, robot: str) -> None:
        """The partition of ``robot`` heals: what was held for it and from it is delivered, in order."""
        self.down.discard(robot)
        free = [(n, s, f) for n, s, f in self.held if n not in self.down and s not in self.down]
        self.held = [h for h in self.held if h not in free]
        self.queue.extend(f for _, _, f in free)

    # -- the outside world ----------------------------------------------------------
    def finish_move(self, robot: str, status: str = SUCCEEDED, token: int | None = None, text: str = "") -> None:
        r = self.robots[robot]
        move = r.active
        if move is None or (token is not None and move.token != token):
            return
        r.active = None
        if status == SUCCEEDED and r.nav is not None:
            r.nav.on_pose(move.x, move.y, move.yaw)
            r.gm.on_pose(move.x, move.y, move.yaw)
        self.run(robot, r.nav.on_move_base_result(move.token, status, text, self.now_ros, self.now_wall))

    def abort(self, robot: str, text: str = "no path") -> None:
        self.finish_move(robot, ABORTED, text=text)
        self.pump()

    def command(self, robot: str, command: int, **fields) -> None:
        cmd = CommandData(command=command, uid=f"{robot}/v/cmd/{len(self.events)}", visitor_id="v", **fields)
        r = self.robots[robot]
        self.run(robot, r.gm.on_command(cmd, self.now_ros, self.now_wall, sender=GUI))
        if r.nav is not None and command == Cmd.CONTINUE:
            self.run(robot, r.nav.on_continue(cmd.goal_uid, self.now_ros, self.now_wall, sender=GUI))
        self.pump()

    def request(self, robot: str, goal_id: str, way: str = "stairs") -> None:
        self.command(robot, Cmd.REQUEST, goal_id=goal_id, way=way, language="en")

    def cont(self, robot: str, goal_uid: str = "") -> None:
        self.command(robot, Cmd.CONTINUE, goal_uid=goal_uid)

    def cancel(self, robot: str, goal_uid: str = "") -> None:
        self.command(robot, Cmd.CANCEL, goal_uid=goal_uid)

    def start_tour(self, robot: str, tour_file: str, way: str = "stairs") -> None:
        self.command(robot, Cmd.START_TOUR, tour_file=tour_file, way=way, language="en")

    def skip(self, robot: str, tour_file: str, step: int, goal_uid: str = "") -> None:
        self.command(robot, Cmd.SKIP, tour_file=tour_file, tour_step=step, goal_uid=goal_uid)

    def staff(self, at: str, target: str, out: bool, version: int = 1, user: str = "sara", detail: str = "") -> None:
        """A staff command at ``at``'s dashboard takes ``target`` out of service (``out``) or back; every robot
        gets it (the dashboard's own robot directly, the others through a relay)."""
        cmd = StaffCommandData(uid=make_uid(at, SCOPE_STAFF, "dash"), robot=at, user=user,
                               command=StaffCmd.OUT_OF_SERVICE if out else StaffCmd.BACK_IN_SERVICE,
                               target_robot=target, version=version, detail=detail)
        for name, r in self.robots.items():
            by = DASHBOARD if name == at else from_robot(r.gm, at)
            self._to(name, lambda r=r, by=by: self.run(r.name, r.gm.on_staff(cmd, self.now_ros, self.now_wall,
                                                                            sender=by)), at, cmd)
        self.pump()

    def status_all(self, robots: list[str] | None = None) -> None:
        """Every robot hears a status of each robot in ``robots`` (default: all) now (wall time)."""
        for r in self.robots.values():
            for name in robots or list(self.robots):
                r.gm.on_status(name, self.now_wall, sender=from_robot(r.gm, name))
                if r.nav:
                    r.nav.on_status(name, self.now_wall, sender=from_robot(r.gm, name))

    def heartbeat(self) -> None:
        """Every robot hears the status of every robot it is not partitioned from, now (wall time)."""
        for r in self.robots.values():
            for name in self.robots:
                if name == r.name or (name not in self.down and r.name not in self.down):
                    r.gm.on_status(name, self.now_wall, sender=from_robot(r.gm, name))
                    if r.nav:
                        r.nav.on_status(name, self.now_wall, sender=from_robot(r.gm, name))

    def tick(self, ros_dt: float = 0.0, wall_dt: float = 0.0) -> None:
        self.now_ros += ros_dt
        self.now_wall += wall_dt
        for r in self.robots.values():
            self.run(r.name, r.gm.tick(self.now_ros, self.now_wall))
            if r.nav:
                self.run(r.name, r.nav.tick(self.now_ros, self.now_wall))
        self.pump()

    # -- queries --------------------------------------------------------------------
    def phases(self, robot: str | None = None, goal_uid: str | None = None, assigned: bool = False) -> list[int]:
        """The phases sent (by ``robot``, about ``goal_uid``); the requester's ASSIGNED only if ``assigned``."""
        return [e.phase for e in self.events
                if (robot is None or e.robot == robot) and (goal_uid is None or e.goal_uid == goal_uid)
                and (assigned or e.phase != Phase.ASSIGNED)]

    def last(self, robot: str, phase: int) -> NavEventData:
        return [e for e in self.events if e.robot == robot and e.phase == phase][-1]

    def queue_of(self, robot: str) -> list[str]:
        return [t.uid for t in self.robots[robot].gm.queue]


def distance(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


# -- one navigation core alone ----------------------------------------------------------------
def trip(faculty, origin: str, goal_id: str, uid: str, start: tuple[float, float] | None = None,
         connector: str = "stairs_west", **kw) -> Trip:
    """A trip made at ``origin`` whose legs are committed to ``origin`` and the goal floor's first robot."""
    loc = faculty.location(goal_id)
    r = faculty.robot(origin)
    sx, sy = start or (r.home.x, r.home.y)
    goal_robot = faculty.robots_on(loc.floor)[0].name if loc.floor != r.floor and faculty.has_robot(loc.floor) else ""
    legs = {"start_robot": origin, "start_state": LEG_COMMITTED, "goal_robot": goal_robot,
            "goal_state": LEG_COMMITTED if goal_robot else LEG_NONE, "attempt": 2}
    return Trip(uid=uid, origin_robot=origin, visitor_id="v", initial_floor=r.floor, initial_x=sx, initial_y=sy,
                goal_floor=loc.floor, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw, way="stairs",
                connector=connector if loc.floor != r.floor else "", start_id="robot", goal_id=goal_id,
                language="en", **{**legs, **kw})


def nav(faculty, robot: str, **cfg) -> NavigationCore:
    """A navigation core of ``robot`` alone, at home, move_base up, every robot's status heard from its sender."""
    n = NavigationCore(faculty, NavigationConfig(robot=robot, **cfg), ListLog(), now_wall=0.0)
    n.on_move_base_available(True, 0.0)
    home = faculty.robot(robot).home
    n.on_pose(home.x, home.y, home.yaw)
    for r in faculty.robots:
        n.on_status(r.name, 0.0, sender=from_robot(n, r.name))
    return n


def evs(actions):
    return [a.event for a in actions if isinstance(a, SendEvent)]


def phases(actions):
    return [e.phase for e in evs(actions)]


def moves(actions):
    return [a for a in actions if isinstance(a, MoveTo)]


def cancels(actions):
    return [a.cancel for a in actions if isinstance(a, SendCancel)]
