"""The people on a simulated floor (ROS-free): visitors' bodies following their robots, and bystanders.

A :class:`Crowd` moves person-sized discs (:data:`PERSON_RADIUS`) once per stop of the floor's clock
(:meth:`Crowd.step`); the world (:meth:`gidabot_sim.world.world.World.set_people`) puts them in every laser,
stops a robot that would drive into one (a robot-person collision, counted) and the simulator lists the ones a
robot's laser sees in its ``robots_seen`` (its move_base's obstacle layer), ids starting with
:data:`~gidabot_navigation.interface.PERSON_ID_PREFIX`.

**A visitor's body** does what the visitor node of the floor's robot says (:class:`Directive`, sim-only topic
``/sim/visitor_body``):

* ``FOLLOW`` robot R: it appears (when not on this floor yet) next to ``(x, y)``, or next to R when that is not a
  number (at R's screen, or at the meeting point where R waits for it, come from the stairs or the lift) and
  walks at its behaviour's speed along R's path (the points R drove through, recorded here: free of walls),
  until it is its ``gap`` behind R; it stands while a pause of its behaviour lasts, and when its behaviour
  wanders off it walks back along R's path and leaves the floor (for good); a group is several bodies, each
  a little further behind. A body that R faces once it is within its ``gap`` (R turned back the way it came, in
  a corridor, or turned to look for it) steps aside, off R's line of travel, as a person makes room, and stands
  there until R has passed it or turned away (:meth:`Crowd._step_aside`); else R and the person it guides
  would wait for each other;
* ``LEAVE``: it walks towards ``(x, y)`` (the stairs or the lift; not a number: it stands) and leaves the floor
  there, at the latest after :data:`LEAVE_S`;
* ``GONE``: the visit is over, it leaves the floor.

A body never walks into a wall or a robot: a step that would is not taken (it waits). **Bystanders**
(:func:`~gidabot_sim.visitor.behaviour.draw_bystanders`) walk between the floor's places along planned paths,
some standing a while at the narrowest point of their walk; they too wait for a robot in their way.

**Anybody makes way for a robot**: a body that stood still this step (pausing, waiting behind its robot, a
bystander standing, or one a robot blocks) and that another robot faces from within :data:`MAKE_WAY_RANGE`
steps off that robot's line as a body does for its own robot (:meth:`Crowd._make_way`); one that is walking
walks on. Else a person standing in a corridor would stop every robot but its own for as long as it stands.

Time is passed in; nothing here reads a clock.
"""

from __future__ import annotations

import math
import random
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from gidabot_navigation.interface import PERSON_ID_PREFIX
from gidabot_sim.visitor.behaviour import Behaviour, Bystander

PERSON_RADIUS = 0.25          # m: a person's disc
TRAIL_STEP = 0.25             # m between two recorded points of a robot's path
TRAIL_MAX = 4000              # points kept per robot (1 km)
LEAVE_S = 10.0                # s a leaving body walks towards the stairs or the lift at most
WANDER_S = 20.0               # s a body wandering off walks back along the path before it leaves the floor
GROUP_SPACING = 0.7           # m between the bodies of a group, along the path
ROBOT_MARGIN = 0.05           # m a body keeps from a robot's disc
ASIDE_MARGIN = 0.3            # m a body stepping aside leaves between its disc and the robot's line of travel
FACING = math.radians(60.0)   # a body is in front of a robot within this angle of its heading
MAKE_WAY_RANGE = 1.5          # m between the discs within which a standing body makes way for a robot facing it
REJOIN_POINTS = 80            # trail points looked back over when a body rejoins its robot's way
FOLLOW, LEAVE, GONE = 0, 1, 2  # a directive's modes (gidabot_msgs/VisitorBody)
MODES = (FOLLOW, LEAVE, GONE)


@dataclass(frozen=True)
class Directive:
    """What a visitor's body does on this floor (see the module docstring); ``started``: sim time the visit
    started (its behaviour's times count from there)."""

    visitor_id: str
    mode: int
    robot: str = ""
    x: float = 0.0
    y: float = 0.0
    behaviour: Behaviour = field(default_factory=Behaviour)
    started: float = 0.0


@dataclass(frozen=True)
class RobotDisc:
    """A robot of the floor as the crowd sees it: name and disc (m, map frame)."""

    name: str
    x: float
    y: float
    radius: float
    yaw: float = math.nan     # rad, heading (not a number: unknown, nobody steps aside for it)


@dataclass(slots=True)
class Body:
    """One person's disc on the floor."""

    person_id: str           # PERSON_ID_PREFIX + visitor id (+ "/k" for the k-th of a group) or bystander id
    x: float
    y: float
    radius: float = PERSON_RADIUS
    vx: float = 0.0
    vy: float = 0.0


@dataclass
class _Follower:
    """A visitor's body and where it is along its robot's path."""

    body: Body
    directive: Directive
    member: int                           # 0: the visitor, k: the k-th companion of its group
    cursor: int = 0                       # next trail point (a sequence number of the robot's trail)
    leave_until: float = math.inf         # LEAVE / wandering: leaves the floor at this time at the latest
    wander_from: int | None = None        # wandering: walks back from this trail point
    stood_aside: bool = False             # its robot faced it: it stood off the robot's line


@dataclass
class _Walker:
    """A bystander walking its planned way between two places."""

    spec: Bystander
    body: Body
    rng: random.Random
    way: list[tuple[float, float]] = field(default_factory=list)
    next: int = 0
    stand_at: int = -1                    # index of the way's narrowest point (a stander stops there)
    stand_until: float = -math.inf


class _Trail:
    """The points a robot drove through (every ``TRAIL_STEP``), numbered from 0."""

    def __init__(self) -> None:
        self.points: deque[tuple[float, float]] = deque(maxlen=TRAIL_MAX)
        self.first = 0                    # sequence number of points[0]

    @property
    def end(self) -> int:
        return self.first + len(self.points)

    def add(self, x: float, y: float) -> None:
        if self.points:
            px, py = self.points[-1]
            if math.hypot(x - px, y - py) < TRAIL_STEP:
                return
        if len(self.points) == self.points.maxlen:
            self.first += 1
        self.points.append((x, y))

    def get(self, seq: int) -> tuple[float, float] | None:
        k = seq - self.first
        return self.points[k] if 0 <= k < len(self.points) else None


class Crowd:
    """The people of one floor. ``clearance(x, y)``: distance (m) to the nearest wall or obstacle (the world's);
    ``plan(a, b)``: a wall-free way between two points for a person, or None (bystanders only); ``places``: where
    bystanders walk between."""

    def __init__(self, clearance: Callable[[float, float], float],
                 plan: Callable[[tuple[float, float], tuple[float, float]], list[tuple[float, float]] | None]
                 | None = None, places: Sequence[tuple[float, float]] = (),
                 bystanders: Sequence[Bystander] = ()) -> None:
        self.clearance, self.plan, self.places = clearance, plan, list(places)
        self.trails: dict[str, _Trail] = {}
        self.followers: dict[str, list[_Follower]] = {}      # visitor id -> its bodies
        self.walkers = [_Walker(b, Body(PERSON_ID_PREFIX + b.person_id, math.nan, math.nan), random.Random(b.route))
                        for b in bystanders] if plan is not None and len(self.places) >= 2 else []
        self.time = 0.0

    # -- inputs -----------------------------------------------------------------------------------
    def direct(self, d: Directive, robots: Sequence[RobotDisc]) -> None:
        """A visitor node's directive for a visitor's bodies."""
        bodies = self.followers.get(d.visitor_id)
        if d.mode == GONE:
            self.followers.pop(d.visitor_id, None)
            return
        if d.mode == LEAVE:
            for f in bodies or ():
                f.directive, f.leave_until = d, min(f.leave_until, self.time + LEAVE_S)
            return
        if bodies is None:       # it arrives on this floor: next to (x, y) or its robot, away from the robots
            ax, ay = d.x, d.y
            if not (math.isfinite(ax) and math.isfinite(ay)):
                robot = next((r for r in robots if r.name == d.robot), None)
                if robot is None:
                    return       # a robot of another floor: not here
                ax, ay = robot.x, robot.y
            bodies = []
            trail = self.trails.setdefault(d.robot, _Trail())
            for k in range(d.behaviour.group):
                x, y = self._free_spot(ax, ay, robots, [(f.body.x, f.body.y) for f in bodies])
                suffix = f"/{k}" if k else ""
                bodies.append(_Follower(Body(PERSON_ID_PREFIX + d.visitor_id + suffix, x, y), d, k, trail.end))
            self.followers[d.visitor_id] = bodies
        trail = self.trails.setdefault(d.robot, _Trail())
        for f in bodies:
            if f.directive.robot != d.robot:
                f.cursor = trail.end
            f.directive, f.leave_until = d, math.inf

    def _free_spot(self, x: float, y: float, robots: Sequence[RobotDisc],
                   taken: Sequence[tuple[float, float]]) -> tuple[float, float]:
        """A spot near (x, y) on rings of 1.0..2.4 m (then 0.8 m) where a body fits clear of walls, robots and
        ``taken`` (a robot usually stands at (x, y): a metre leaves its costmap a way out); (x, y) when none does."""
        for ring in (1.0, 1.3, 1.6, 2.0, 2.4, 0.8):
            for k in range(16):
                a = math.pi + k * math.pi / 8.0
                px, py = x + ring * math.cos(a), y + ring * math.sin(a)
                if self._fits(px, py, robots) and all(math.hypot(px - tx, py - ty) >= 2 * PERSON_RADIUS
                                                      for tx, ty in taken):
                    return px, py
        return x, y

    def _fits(self, x: float, y: float, robots: Sequence[RobotDisc]) -> bool:
        if self.clearance(x, y) < PERSON_RADIUS:
            return False
        return all(math.hypot(r.x - x, r.y - y) >= r.radius + PERSON_RADIUS + ROBOT_MARGIN for r in robots)

    # -- stepping ---------------------------------------------------------------------------------
    def step(self, t: float, robots: Sequence[RobotDisc]) -> None:
        """Move every body from the last step's time to ``t`` (sim s), the robots being where ``robots`` says."""
        dt = max(0.0, t - self.time) if self.time > 0.0 else 0.0
        self.time = t
        for r in robots:
            if r.name in self.trails:
                self.trails[r.name].add(r.x, r.y)
        before = [(b, b.x, b.y) for b in self.bodies]
        for visitor_id in list(self.followers):
            keep = []
            for f in self.followers[visitor_id]:
                x, y = f.body.x, f.body.y
                if not self._step_follower(f, t, dt, robots):
                    continue
                keep.append(f)
                if (f.body.x, f.body.y) == (x, y) and not f.stood_aside:
                    self._make_way(f.body, f.directive.behaviour.speed * dt, robots, f.directive.robot)
            if keep:
                self.followers[visitor_id] = keep
            else:
                del self.followers[visitor_id]
        for w in self.walkers:
            x, y = w.body.x, w.body.y
            self._step_walker(w, t, dt, robots)
            if math.isfinite(x) and (w.body.x, w.body.y) == (x, y):
                self._make_way(w.body, w.spec.speed * dt, robots, "")
        for b, x, y in before:           # the velocity of the step just made (the laser's and the mates' view)
            moved = dt > 0 and math.isfinite(x) and math.isfinite(b.x)
            b.vx, b.vy = ((b.x - x) / dt, (b.y - y) / dt) if moved else (0.0, 0.0)

    def _step_follower(self, f: _Follower, t: float, dt: float, robots: Sequence[RobotDisc]) -> bool:
        """Moves a visitor's body; False when it has left the floor."""
        d, b = f.directive, f.body
        since = t - d.started
        if t >= f.leave_until:
            return False
        trail = self.trails.get(d.robot)
        if d.mode == LEAVE:
            if not (math.isfinite(d.x) and math.isfinite(d.y)):
                return True
            return self._walk_to(b, d.x, d.y, d.behaviour.speed, dt, robots) > 0.3
        if d.behaviour.wandered(since) and trail is not None:
            if f.wander_from is None:
                f.wander_from, f.leave_until = min(f.cursor, trail.end) - 1, t + WANDER_S
            back = trail.get(f.wander_from)
            if back is not None and self._walk_to(b, back[0], back[1], d.behaviour.speed, dt, robots) < 0.1:
                f.wander_from -= 1
            return True
        if d.behaviour.paused(since):
            return True
        robot = next((r for r in robots if r.name == d.robot), None)
        if robot is None or trail is None:
            return True
        keep = robot.radius + b.radius + d.behaviour.gap + GROUP_SPACING * f.member
        budget = d.behaviour.speed * dt
        if (f.stood_aside or math.hypot(robot.x - b.x, robot.y - b.y) <= keep) and \
                self._step_aside(b, robot, budget, robots, f.stood_aside):
            f.stood_aside = True
            return True
        if f.stood_aside:                # the robot has passed: on along its way back, not to where it turned
            f.stood_aside = False
            f.cursor = max(f.cursor, self._rejoin(trail, b))
        while budget > 1e-9:
            if math.hypot(robot.x - b.x, robot.y - b.y) <= keep:
                break
            point = trail.get(f.cursor) if f.cursor < trail.end else None
            tx, ty = point if point is not None else (robot.x, robot.y)
            if point is None and f.cursor < trail.first:
                f.cursor = trail.first
                continue
            dist = math.hypot(tx - b.x, ty - b.y)
            if point is not None and dist <= budget:
                if not self._move(b, tx, ty, robots):
                    break
                budget -= dist
                f.cursor += 1
                continue
            if dist < 1e-9:
                break
            step = min(budget, dist)
            if not self._move(b, b.x + (tx - b.x) * step / dist, b.y + (ty - b.y) * step / dist, robots):
                break
            budget -= step
        return True

    @staticmethod
    def _rejoin(trail: _Trail, b: Body) -> int:
        """The newest of the trail's last :data:`REJOIN_POINTS` points within 1.5 m of the body (where the robot
        just passed it), else the trail's end."""
        for seq in range(trail.end - 1, max(trail.first, trail.end - REJOIN_POINTS) - 1, -1):
            p = trail.get(seq)
            if p is not None and math.hypot(p[0] - b.x, p[1] - b.y) <= 1.5:
                return seq
        return trail.end

    def _make_way(self, b: Body, budget: float, robots: Sequence[RobotDisc], own: str) -> None:
        """A body that stood still this step steps off the line of the nearest robot but ``own`` (its own robot
        has its rule: :meth:`_step_follower`) that faces it from within :data:`MAKE_WAY_RANGE`."""
        near = None
        for r in robots:
            if r.name == own or not math.isfinite(r.yaw):
                continue
            gap = math.hypot(r.x - b.x, r.y - b.y) - r.radius - b.radius
            hx, hy = math.cos(r.yaw), math.sin(r.yaw)
            ahead = (b.x - r.x) * hx + (b.y - r.y) * hy
            side = (b.x - r.x) * -hy + (b.y - r.y) * hx
            if gap <= MAKE_WAY_RANGE and ahead > 0.0 and math.atan2(abs(side), ahead) <= FACING and \
                    (near is None or gap < near[0]):
                near = (gap, r)
        if near is not None and budget > 0.0:
            self._step_aside(b, near[1], budget, robots, False)

    def _step_aside(self, b: Body, robot: RobotDisc, budget: float, robots: Sequence[RobotDisc],
                    aside: bool) -> bool:
        """A body in front of ``robot`` (within :data:`FACING` of its heading; anywhere ahead once ``aside``)
        steps sideways off its line of travel until :data:`ASIDE_MARGIN` m lie between them, on the side it
        already is (the roomier one when on the line), at most ``budget`` m, and then stands there (it does not
        walk back onto the line after the robot's path) until the robot has passed; True while it is ahead."""
        if not math.isfinite(robot.yaw):
            return False
        hx, hy = math.cos(robot.yaw), math.sin(robot.yaw)
        ahead = (b.x - robot.x) * hx + (b.y - robot.y) * hy
        side = (b.x - robot.x) * -hy + (b.y - robot.y) * hx      # signed distance from the line of travel
        if ahead <= 0.0 or (not aside and math.atan2(abs(side), ahead) > FACING):
            return False
        need = robot.radius + b.radius + ASIDE_MARGIN - abs(side)
        if need <= 0.0:
            return True
        sign = math.copysign(1.0, side) if abs(side) > 0.05 else \
            (1.0 if self.clearance(b.x - hy * 0.5, b.y + hx * 0.5) >= self.clearance(b.x + hy * 0.5, b.y - hx * 0.5)
             else -1.0)
        step = min(budget, need)
        if step > 1e-9:
            self._move(b, b.x - hy * sign * step, b.y + hx * sign * step, robots)
        return True

    def _move(self, b: Body, x: float, y: float, robots: Sequence[RobotDisc]) -> bool:
        """Take a step to (x, y) unless it would bring the body into a wall or onto a robot (closer than now)."""
        for r in robots:
            near = r.radius + b.radius + ROBOT_MARGIN
            after = math.hypot(r.x - x, r.y - y)
            if after < near and after < math.hypot(r.x - b.x, r.y - b.y):
                return False
        c = self.clearance(x, y)
        if c < b.radius * 0.8 and c < self.clearance(b.x, b.y):
            return False
        b.x, b.y = x, y
        return True

    def _walk_to(self, b: Body, x: float, y: float, speed: float, dt: float, robots: Sequence[RobotDisc]) -> float:
        """One step straight towards (x, y); returns the distance left."""
        dist = math.hypot(x - b.x, y - b.y)
        step = min(speed * dt, dist)
        if step > 1e-9 and not self._move(b, b.x + (x - b.x) * step / dist, b.y + (y - b.y) * step / dist, robots):
            return dist
        return dist - step

    def _step_walker(self, w: _Walker, t: float, dt: float, robots: Sequence[RobotDisc]) -> None:
        b = w.body
        if t < w.spec.start_s:
            return
        if w.next >= len(w.way):
            self._new_walk(w, robots)
            return
        if t < w.stand_until:
            return
        budget = w.spec.speed * dt
        while budget > 1e-9 and w.next < len(w.way):
            tx, ty = w.way[w.next]
            dist = math.hypot(tx - b.x, ty - b.y)
            step = min(budget, dist)
            x, y = (tx, ty) if step >= dist else (b.x + (tx - b.x) * step / dist, b.y + (ty - b.y) * step / dist)
            if not self._move(b, x, y, robots):
                break
            budget -= step
            if step >= dist:
                if w.next == w.stand_at and w.spec.stand_s > 0:
                    w.stand_until = t + w.spec.stand_s
                    w.next += 1
                    break
                w.next += 1

    def _new_walk(self, w: _Walker, robots: Sequence[RobotDisc]) -> None:
        """A bystander at the end of its walk (or not yet on the floor): the way to its next place."""
        assert self.plan is not None
        b = w.body
        start = (b.x, b.y) if math.isfinite(b.x) else w.rng.choice(self.places)
        for _ in range(5):
            goal = w.rng.choice(self.places)
            if math.hypot(goal[0] - start[0], goal[1] - start[1]) < 3.0:
                continue
            way = self.plan(start, goal)
            if way:
                break
        else:
            return
        if not math.isfinite(b.x):
            if not self._fits(start[0], start[1], robots):
                return
            b.x, b.y = start
        w.way, w.next = list(way), 0
        w.stand_at = min(range(len(way) // 4, max(len(way) * 3 // 4, len(way) // 4 + 1)),
                         key=lambda k: self.clearance(*way[k])) if len(way) >= 4 else -1

    # -- outputs ----------------------------------------------------------------------------------
    @property
    def bodies(self) -> list[Body]:
        """Every body now on the floor."""
        out = [f.body for bodies in self.followers.values() for f in bodies]
        out += [w.body for w in self.walkers if math.isfinite(w.body.x)]
        return out

    def __bool__(self) -> bool:
        return bool(self.followers) or bool(self.walkers)
