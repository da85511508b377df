"""Guiding at the visitor's pace (ROS-free): from what the robot's laser knows of its visitor, how to drive.

While a robot guides (the ``GUIDING`` stage of a leg), :class:`Pacer` reads every
:class:`~gidabot_navigation.perception.people.VisitorReport` of the visitor it locked when the leg began and
decides, in order (every bound a :class:`PacingConfig` parameter):

* **normal** — the visitor is within ``near`` m: the robot drives at its own speed;
* **slow** — the visitor is between ``near`` and ``far`` m: the robot's speed is capped to ``slow_speed``
  (a *slow-down*, counted once per entry) until the visitor is within ``near - hysteresis`` m again (a visitor
  walking at about the robot's pace does not switch it at every scan);
* **wait** — the visitor is farther than ``far``, or has stood still (slower than ``still_speed``) beyond
  ``near`` for ``still_for`` s, or is out of the laser's view (behind a front laser) for ``look_after`` s: the
  robot stops its goal, turns towards where it knows the visitor is (a front laser then sees them) and says
  so (``waiting for you``); it goes on (``please follow me``) once the visitor is within ``resume`` m and
  coming, or within ``near``;
* a visitor the tracker reports LOST is waited for too, facing where they were last seen, the tracker asked for
  them anew every ``relock_every`` s;
* **search** — waiting with the visitor unseen for ``lost_after`` s, or waiting ``wait_for`` s in all (a
  visitor who stays away in sight): the robot goes back to where it last saw them, re-locks (the tracker takes
  the nearest person in its lock cone) and turns round there, ``look_turns`` times by ``look_step`` rad; seen
  again -> ``please follow me``, the leg goes on (*found again*);
* **lost** — not found within ``search_for`` s of the search's start: the trip ends (``VISITOR_LOST``).

A NONE report (the tracker was not asked for the visitor when it made it: the unlock of a relock, which the
pacer itself asks for, or a restarted people node before the latched wish reached it) says nothing of the
visitor and is ignored: taken for "unseen", each relock made the robot stop and turn, and the report after
it made it go on, in the same instant.

A leg whose visitor the laser never saw (no lock ever reached SEEN: the tracker is not running, the visitor
has no body in a simulated world, or never stood in the lock cone) is guided as without pacing: the robot
cannot tell a visitor it never saw from one who is not there. Pacing starts at the first SEEN report and
stays on for the rest of the leg.

Inputs are explicit: :meth:`Pacer.start`, :meth:`Pacer.on_visitor`, :meth:`Pacer.on_search_arrived`,
:meth:`Pacer.step` (each with the time, s); each returns a :class:`Decision` only when something changes.
:class:`PaceStats` counts what happened for the trip's report.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.errors import GuidingError
from gidabot_navigation.interface import Sight
from gidabot_navigation.perception.people import VisitorReport


class Pace(enum.Enum):
    OFF = "off"              # the visitor never seen: drive as without pacing
    NORMAL = "normal"
    SLOW = "slow"
    WAIT = "wait"
    SEARCH = "search"
    LOST = "lost"


@dataclass(frozen=True)
class PacingConfig:
    """Distances in m, speeds in m/s, times in s (the robot's clock), angles in rad."""

    near: float = 2.5
    hysteresis: float = 0.4
    far: float = 4.0
    resume: float = 3.0
    slow_speed: float = 0.3
    still_speed: float = 0.15
    still_for: float = 4.0
    look_after: float = 12.0         # < the tracker's out_of_view_lost_after (20 s)
    lost_after: float = 20.0
    wait_for: float = 180.0
    search_for: float = 60.0
    look_step: float = 2.0
    look_turns: int = 3
    relock_every: float = 6.0

    def __post_init__(self) -> None:
        problems = []
        for name in ("near", "far", "resume", "slow_speed", "still_speed", "still_for", "look_after", "lost_after",
                     "wait_for", "search_for", "look_step", "relock_every"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                problems.append(f"{name}: {value!r} must be a positive number")
        if not problems and not self.near <= self.resume <= self.far:
            problems.append(f"near <= resume <= far: {self.near:g}, {self.resume:g}, {self.far:g}")
        if not (isinstance(self.hysteresis, (int, float)) and 0 <= self.hysteresis < self.near):
            problems.append(f"hysteresis: {self.hysteresis!r} must be >= 0 and less than near")
        if not isinstance(self.look_turns, int) or self.look_turns < 0:
            problems.append(f"look_turns: {self.look_turns!r} must be a whole number >= 0")
        if problems:
            raise GuidingError("pacing: " + "; ".join(problems))


class Say(enum.Enum):
    """What the robot tells its visitor when its pace changes."""

    NOTHING = "nothing"
    WAITING = "waiting"      # waiting for you
    FOLLOW = "follow"        # please follow me (going on after a wait or a search)
    SEARCHING = "searching"  # going back to where the visitor was last seen
    LOST = "lost"            # the visitor is lost: the trip ends


@dataclass(frozen=True)
class Decision:
    """How to drive from now on. ``speed_cap``: m/s, None = the robot's own speed. ``drive``: go on to the leg's
    target; else stand (``face``: turn on the spot towards that point) or, searching, go to ``search_at``
    (then turn to ``look_yaw`` there). ``relock``: ask the tracker for the visitor anew."""

    pace: Pace
    drive: bool = True
    speed_cap: float | None = None
    face: tuple[float, float] | None = None
    search_at: Pose2D | None = None
    look_yaw: float | None = None
    relock: bool = False
    say: Say = Say.NOTHING
    found_again: bool = False
    why: str = ""             # why the robot waits (said with WAITING)


@dataclass
class PaceStats:
    """What pacing saw during one leg (distances in m, times in s)."""

    samples: int = 0
    behind_sum: float = 0.0
    worst_behind: float = 0.0
    waiting: float = 0.0
    slowdowns: int = 0
    waits: int = 0
    searches: int = 0
    lost: int = 0
    found_again: int = 0

    @property
    def mean_behind(self) -> float:
        return self.behind_sum / self.samples if self.samples else 0.0

    def as_dict(self) -> dict[str, float]:
        return {"mean_behind": round(self.mean_behind, 2), "worst_behind": round(self.worst_behind, 2),
                "waiting": round(self.waiting, 1), "slowdowns": self.slowdowns, "waits": self.waits,
                "searches": self.searches, "lost": self.lost, "found_again": self.found_again,
                "samples": self.samples}


@dataclass
class _Search:
    since: float
    at: Pose2D
    arrived: float | None = None
    turns: int = 0
    relocked: float = 0.0


@dataclass
class Pacer:
    """One guided leg's pacing (see the module's docstring)."""

    cfg: PacingConfig = field(default_factory=PacingConfig)
    pace: Pace = Pace.OFF
    stats: PaceStats = field(default_factory=PaceStats)
    _report: VisitorReport | None = None
    _t: float | None = None
    _wait_since: float | None = None
    _still_since: float | None = None
    _unseen_view_since: float | None = None
    _seen_at: float | None = None
    _relocked: float = 0.0
    _last_seen: Pose2D | None = None
    _search: _Search | None = None
    _robot: Pose2D | None = None

    # -- inputs ------------------------------------------------------------------------------------------
    def start(self, t: float) -> None:
        """The guided leg begins: the visitor lock is asked for now (by the caller)."""
        self.pace, self.stats, self._t = Pace.OFF, PaceStats(), t
        self._report = self._wait_since = self._still_since = self._unseen_view_since = self._seen_at = None
        self._last_seen = self._search = None

    def on_robot(self, pose: Pose2D) -> None:
        self._robot = pose

    def on_visitor(self, report: VisitorReport, t: float) -> Decision | None:
        """A report of the tracker (after a scan); a NONE report is ignored (see the module's docstring)."""
        self._account(t)
        if report.sight == Sight.NONE:
            return None
        self._report = report
        if report.last_seen is not None:
            self._last_seen = report.last_seen.pose
        if report.sight == Sight.SEEN:
            self._seen_at = t
        if report.sight == Sight.SEEN and report.distance is not None:
            self.stats.samples += 1
            behind = max(0.0, report.distance)
            self.stats.behind_sum += behind
            self.stats.worst_behind = max(self.stats.worst_behind, behind)
        if self.pace is Pace.OFF:
            if report.sight != Sight.SEEN:
                return None
            self.pace = Pace.NORMAL      # engaged: the visitor was seen
        return self._decide(t)

    def on_search_arrived(self, t: float) -> Decision | None:
        """The robot reached where it searches (or turned to the last look): look round there."""
        search = self._search
        if self.pace is not Pace.SEARCH or search is None:
            return None
        if search.arrived is None:
            search.arrived = t
        if search.turns >= self.cfg.look_turns:
            return None
        search.turns += 1
        yaw = (self._robot.yaw if self._robot is not None else search.at.yaw) + self.cfg.look_step
        return Decision(Pace.SEARCH, drive=False, look_yaw=math.atan2(math.sin(yaw), math.cos(yaw)),
                        search_at=self._robot or search.at)

    def step(self, t: float) -> Decision | None:
        """Time passed with no report: the bounds of waiting and searching."""
        self._account(t)
        if self.pace in (Pace.OFF, Pace.LOST):
            return None
        return self._decide(t)

    # -- the rules ---------------------------------------------------------------------------------------
    def _account(self, t: float) -> None:
        if self._t is not None and t > self._t and self.pace in (Pace.WAIT, Pace.SEARCH):
            self.stats.waiting += t - self._t
        self._t = t if self._t is None else max(self._t, t)

    def _decide(self, t: float) -> Decision | None:
        r = self._report
        cfg = self.cfg
        if self.pace is Pace.SEARCH:
            return self._searching(r, t)
        if r is None:
            return None
        if r.sight in (Sight.LOST, Sight.ACQUIRING):
            return self._unseen(t)
        dist = r.distance if r.distance is not None and math.isfinite(r.distance) else math.inf
        speed = math.hypot(r.vx or 0.0, r.vy or 0.0)
        still = speed < cfg.still_speed and dist > cfg.near
        self._still_since = (self._still_since if self._still_since is not None else t) if still else None
        out_of_view = r.sight == Sight.OUT_OF_VIEW
        self._unseen_view_since = (self._unseen_view_since if self._unseen_view_since is not None else t) \
            if out_of_view else None
        if self.pace is Pace.WAIT:
            assert self._wait_since is not None
            coming = r.sight == Sight.SEEN and (dist <= cfg.near or (dist <= cfg.resume and not still))
            if coming:
                return self._go_on(t)
            unseen_since = max(self._wait_since, self._seen_at if self._seen_at is not None else -math.inf)
            if t - unseen_since >= cfg.lost_after or t - self._wait_since >= cfg.wait_for:
                return self._start_search(t)
            return None
        stood = t - self._still_since if self._still_since is not None else 0.0
        unviewed = t - self._unseen_view_since if self._unseen_view_since is not None else 0.0
        why = (f"the visitor is {dist:.1f} m away, farther than {cfg.far:g} m" if dist > cfg.far and not out_of_view
               else f"the visitor has stood still {dist:.1f} m away for {stood:.0f} s" if stood >= cfg.still_for
               else f"the visitor has been out of the laser's view for {unviewed:.0f} s" if unviewed >= cfg.look_after
               else "")
        if why:
            self.pace, self._wait_since = Pace.WAIT, t
            self.stats.waits += 1
            return Decision(Pace.WAIT, drive=False, face=self._visitor_point(), say=Say.WAITING, why=why)
        if dist > cfg.near and not out_of_view:
            if self.pace is not Pace.SLOW:
                self.pace = Pace.SLOW
                self.stats.slowdowns += 1
                return Decision(Pace.SLOW, speed_cap=cfg.slow_speed)
            return None
        if self.pace is Pace.SLOW and dist > cfg.near - cfg.hysteresis:
            return None
        if self.pace is not Pace.NORMAL and not out_of_view:
            self.pace = Pace.NORMAL
            return Decision(Pace.NORMAL)
        return None

    def _unseen(self, t: float) -> Decision | None:
        """The tracker has no visitor (lost, or looking anew): wait facing where they were last seen and ask for
        them anew every ``relock_every`` s; search once unseen for ``lost_after`` s while waiting."""
        cfg = self.cfg
        if self.pace is not Pace.WAIT:
            self.pace, self._wait_since, self._relocked = Pace.WAIT, t, t
            self.stats.waits += 1
            r = self._report
            unseen = f" (unseen {r.unseen:.1f} s)" if r is not None and r.unseen is not None else ""
            return Decision(Pace.WAIT, drive=False, face=self._visitor_point(), relock=True, say=Say.WAITING,
                            why=f"the laser lost the visitor{unseen}")
        assert self._wait_since is not None
        unseen_since = max(self._wait_since, self._seen_at if self._seen_at is not None else -math.inf)
        if t - unseen_since >= cfg.lost_after or t - self._wait_since >= cfg.wait_for:
            return self._start_search(t)
        if t - self._relocked >= cfg.relock_every:
            self._relocked = t
            return Decision(Pace.WAIT, drive=False, relock=True)
        return None

    def _visitor_point(self) -> tuple[float, float] | None:
        r = self._report
        if r is not None and r.x is not None and r.y is not None:
            return (r.x, r.y)
        return (self._last_seen.x, self._last_seen.y) if self._last_seen is not None else None

    def _go_on(self, t: float, found: bool = False) -> Decision:
        self.pace, self._wait_since, self._still_since, self._unseen_view_since = Pace.NORMAL, None, None, None
        self._search = None
        if found:
            self.stats.found_again += 1
        return Decision(Pace.NORMAL, say=Say.FOLLOW, found_again=found)

    def _start_search(self, t: float) -> Decision:
        at = self._last_seen or self._robot
        if at is None:           # nowhere to look: the visitor is lost at once
            return self._lose()
        self.pace, self._wait_since = Pace.SEARCH, None
        self._search = _Search(since=t, at=at, relocked=t)
        self.stats.searches += 1
        return Decision(Pace.SEARCH, drive=False, search_at=at, relock=True, say=Say.SEARCHING)

    def _searching(self, r: VisitorReport | None, t: float) -> Decision | None:
        search = self._search
        assert search is not None
        if r is not None and r.sight == Sight.SEEN and t > search.since:
            return self._go_on(t, found=True)
        if t - search.since >= self.cfg.search_for:
            return self._lose()
        if r is not None and r.sight == Sight.LOST and t - search.relocked >= self.cfg.relock_every:
            search.relocked = t
            return Decision(Pace.SEARCH, drive=False, relock=True)
        return None

    def _lose(self) -> Decision:
        self.pace = Pace.LOST
        self.stats.lost += 1
        return Decision(Pace.LOST, drive=False, say=Say.LOST)

    @property
    def last_seen(self) -> Pose2D | None:
        return self._last_seen
