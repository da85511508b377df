"""Making way in narrow corridors (ROS-free): an idle robot standing in the way of another robot of its floor
steps aside when asked, and goes back after.

The robots of a floor see each other's poses and states (their relayed statuses). Both sides run this core:

* **the asker** (:meth:`MakeWay.asks_for`): when it starts a move, it plans its way on the floor's map and
  looks for the *idle* robots of its floor standing on it: a robot whose disc comes within ``margin`` of
  its own along the way, where the way cannot go round it with room (no plan for its radius + ``ROOM``
  with that robot's disc grown by ``margin``, or only one longer by ``detour`` m). In a hall it drives
  round; in a corridor too narrow to pass with room it asks. The ask
  (:class:`~gidabot_navigation.guiding.messages.WayAsk`, relayed as gidabot_msgs/MakeWay) names the
  robots asked and the asker's way; it speaks only for its sender (``robot`` is the asker). When the
  move ends the asker sends an empty ask: the robots it asked go back.
* **the asked robot** (:meth:`MakeWay.on_ask`, :meth:`MakeWay.step`): while it is idle, it drives to the
  nearest spot it can reach that is off every way it was asked to clear (its disc at least ``margin``
  away from the asker's disc anywhere along that way: a doorway, a niche, a wider part, a hall) and waits
  there. It goes back to where it stood once no ask names it any more, once the asker is ``passed`` m
  beyond it (where it stood and where it waits) along its way (the visitor behind it too), or after
  ``timeout`` s. A trip of its own takes over at once (:meth:`MakeWay.drop`): it serves it from where
  it is.

Times are ROS seconds, passed in; nothing here reads a clock.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import Building
from gidabot_navigation.building.planning import Circle, GridPlanner, cells_of, sample_polyline
from gidabot_navigation.errors import PlanningError
from gidabot_navigation.guiding.messages import MAX_WAY_POINTS, WayAsk, same_floor
from gidabot_navigation.logs import Logger

ROOM = 0.1                    # m beyond its radius from the walls where the asked robot waits
SPOTS_TRIED = 8               # nearest candidate spots planned to before giving up


@dataclass(frozen=True)
class MakeWayConfig:
    """``margin``: m kept between two robots' discs when one passes the other; ``detour``: m a way round an idle
    robot may be longer before it is asked instead; ``passed``: m the asker is beyond an asked robot along its
    way before that one goes back; ``timeout``: s at most aside for one ask."""

    margin: float = 0.3
    detour: float = 3.0
    passed: float = 3.0
    timeout: float = 180.0


@dataclass(frozen=True)
class Mate:
    """Another robot of this floor as its status shows it: pose, radius, whether it is idle."""

    name: str
    x: float
    y: float
    radius: float
    idle: bool


@dataclass(frozen=True)
class Aside:
    """Where the asked robot goes (``spot``), and where it goes back to after (``home``)."""

    spot: Pose2D
    home: Pose2D


def _densify(way: Sequence[tuple[float, float]], step: float) -> np.ndarray:
    xs, ys = sample_polyline(list(way), step)
    return np.stack([xs, ys], axis=1)


def distance_along(way: Sequence[tuple[float, float]], x: float, y: float, step: float = 0.1) -> tuple[float, float]:
    """(arc length of the point of ``way`` nearest to (x, y), its distance) in m."""
    pts = _densify(way, step)
    d = np.hypot(pts[:, 0] - x, pts[:, 1] - y)
    k = int(np.argmin(d))
    seg = np.hypot(np.diff(pts[:k + 1, 0]), np.diff(pts[:k + 1, 1]))
    return float(seg.sum()), float(d[k])


class MakeWay:
    """One robot's side of making way (see the module docstring). Planners per radius are built lazily."""

    def __init__(self, building: Building, robot: str, log: Logger, config: MakeWayConfig | None = None) -> None:
        me = building.robot(robot)
        self.building = building
        self.me = me.name
        self.radius = me.radius
        self.floor = me.floor
        self.grid = building.floor(me.floor).map
        self.cfg = config or MakeWayConfig()
        self.log = log
        self._planner: GridPlanner | None = None
        self._roomy: GridPlanner | None = None       # its radius + ROOM: the way round an idle robot
        self.asks: dict[str, WayAsk] = {}            # the asks naming this robot, by asker
        self.asked_at: dict[str, float] = {}         # when each arrived (ROS s)
        self.aside: Aside | None = None              # where it went (None: where it belongs)
        self.place: Pose2D | None = None             # where it belongs while idle: where the first ask found it
        self.going_back = False
        self.asked = 0                               # asks this robot sent naming somebody
        self._last_ask: tuple[tuple[str, ...], tuple[float, float]] | None = None   # (robots, goal) last asked
        self.made_way = 0                            # times it stepped aside

    @property
    def planner(self) -> GridPlanner:
        if self._planner is None:
            self._planner = GridPlanner(self.grid, self.radius)
        return self._planner

    @property
    def roomy(self) -> GridPlanner:
        if self._roomy is None:
            self._roomy = GridPlanner(self.grid, self.radius + ROOM)
        return self._roomy

    # ------------------------------------------------------------------ the asker
    def asks_for(self, start: tuple[float, float], goal: tuple[float, float], mates: Sequence[Mate],
                 now: float) -> WayAsk | None:
        """The ask to send as this robot starts a move from ``start`` to ``goal`` (None: nobody to ask; an empty
        ask when the previous one named robots that are not in the way any more is the caller's)."""
        idle = [m for m in mates if m.idle and m.name != self.me]
        if not idle:
            return None
        planner = self.planner
        try:
            path = planner.plan(start, goal)
        except PlanningError:
            return None
        pts = _densify(path.points, self.grid.resolution)
        near = [m for m in idle
                if float(np.min(np.hypot(pts[:, 0] - m.x, pts[:, 1] - m.y))) < self.radius + m.radius + self.cfg.margin]
        if not near:
            return None
        in_way = []
        roomy = self.roomy
        for mate in near:
            roomy.set_obstacles({"mate": Circle(mate.x, mate.y, mate.radius + self.cfg.margin)})
            try:
                around = roomy.plan(start, goal)
                if around.length > path.length + self.cfg.detour:
                    in_way.append(mate.name)
            except PlanningError:
                in_way.append(mate.name)
            finally:
                roomy.set_obstacles({})
        if not in_way:
            return None
        way = tuple((round(float(x), 3), round(float(y), 3)) for x, y in path.points[:MAX_WAY_POINTS])
        if (tuple(in_way), goal) != self._last_ask:
            self.asked += 1
            self.log.info(f"make way: asking {', '.join(in_way)} to make way along my way to "
                          f"({goal[0]:.1f}, {goal[1]:.1f})")
        self._last_ask = (tuple(in_way), goal)
        return WayAsk(self.me, self.floor, tuple(in_way), way, now)

    def end_ask(self, now: float) -> WayAsk:
        """The empty ask: whoever this robot asked may go back."""
        self._last_ask = None
        return WayAsk(self.me, self.floor, (), (), now)

    # ------------------------------------------------------------------ the asked robot
    def on_ask(self, ask: WayAsk, now: float) -> None:
        """An ask from another robot of this floor (validated): remembered while it names this robot."""
        if ask.robot == self.me or not same_floor(ask.floor, self.floor):
            return
        if self.me in ask.robots and ask.way:
            if ask.robot not in self.asks:
                self.log.info(f"make way: {ask.robot} asks me to make way")
                self.asked_at[ask.robot] = now
            self.asks[ask.robot] = ask
        elif self.asks.pop(ask.robot, None) is not None:
            self.asked_at.pop(ask.robot, None)
            self.log.info(f"make way: {ask.robot} no longer needs the way")

    def on_asker_pose(self, robot: str, x: float, y: float) -> None:
        """Where an asker is now: once it is ``passed`` m beyond this robot along its way, its ask is over."""
        ask = self.asks.get(robot)
        if ask is None:
            return
        if self.aside is None:
            return
        mine = max(distance_along(ask.way, p.x, p.y)[0] for p in (self.aside.home, self.aside.spot))
        theirs, off = distance_along(ask.way, x, y)
        if theirs - mine >= self.cfg.passed and off < 2.0:
            self.log.info(f"make way: {robot} has passed")
            del self.asks[robot]
            self.asked_at.pop(robot, None)

    def drop(self) -> None:
        """A trip of this robot's own starts: it serves it from where it is (no going back)."""
        if self.aside is not None:
            self.log.info("make way: a trip of my own starts; not going back")
        self.asks.clear()
        self.asked_at.clear()
        self.aside = None
        self.place = None
        self.going_back = False

    def step(self, pose: Pose2D | None, idle: bool, now: float) -> Pose2D | None:
        """Where this idle robot must drive now (None: stay, or keep driving where it was sent). Call it when
        the robot is idle and not driving a move of its own; :meth:`arrived` when a move it returned ends."""
        for robot, since in list(self.asked_at.items()):
            if now - since >= self.cfg.timeout:
                self.log.warning(f"make way: {robot}'s ask is {now - since:.0f} s old; going back")
                self.asks.pop(robot, None)
                self.asked_at.pop(robot, None)
        if not idle or pose is None:
            return None
        if self.asks and self.aside is None:
            spot = self.spot(pose, list(self.asks.values()))
            if spot is None:
                self.log.warning(f"make way: no spot off the way of {', '.join(sorted(self.asks))} within reach; "
                                 "staying")
                self.asks.clear()
                self.asked_at.clear()
                return None
            if self.place is None:
                self.place = pose
            self.aside = Aside(spot, self.place)     # back to where it belongs, not where this ask found it
            self.going_back = False
            self.made_way += 1
            self.log.info(f"make way: moving aside to ({spot.x:.2f}, {spot.y:.2f}) for "
                          f"{', '.join(sorted(self.asks))}")
            return spot
        if not self.asks and self.aside is not None and not self.going_back:
            self.going_back = True
            self.log.info(f"make way: going back to ({self.aside.home.x:.2f}, {self.aside.home.y:.2f})")
            return self.aside.home
        return None

    def arrived(self, succeeded: bool) -> None:
        """A make-way move ended (``succeeded`` or not): back home ends the episode."""
        if self.going_back:
            if not succeeded:
                self.log.warning("make way: could not go back; staying here")
            self.aside = None
            self.going_back = False

    def spot(self, pose: Pose2D, asks: Sequence[WayAsk]) -> Pose2D | None:
        """The nearest spot this robot reaches from ``pose`` whose disc keeps ``margin`` from every asker's disc
        anywhere along its way (None: none)."""
        planner, grid = self.planner, self.grid
        near_way = np.zeros((grid.height, grid.width), dtype=bool)
        for ask in asks:
            rows, cols = cells_of(grid, *sample_polyline(list(ask.way), grid.resolution))
            inside = (rows >= 0) & (rows < grid.height) & (cols >= 0) & (cols < grid.width)
            mask = np.zeros_like(near_way)
            mask[rows[inside], cols[inside]] = True
            dist = ndimage.distance_transform_edt(~mask) * grid.resolution
            near_way |= dist < self.radius + self.building.robot(ask.robot).radius + self.cfg.margin
        try:
            ok = planner.reachable((pose.x, pose.y)) & ~near_way & (planner.static_distance >= self.radius + ROOM)
        except PlanningError:
            return None
        rows, cols = np.nonzero(ok)
        if rows.size == 0:
            return None
        row, col = grid.world_to_cell(pose.x, pose.y)
        order = np.argsort((rows - row) ** 2 + (cols - col) ** 2)
        for k in order[:SPOTS_TRIED]:
            x, y = grid.cell_to_world(int(rows[k]), int(cols[k]))
            try:
                planner.plan((pose.x, pose.y), (x, y))
            except PlanningError:
                continue
            return Pose2D(x, y, pose.yaw)
        return None
