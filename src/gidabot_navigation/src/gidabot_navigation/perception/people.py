"""The people around a robot and the visitor it guides, tracked scan after scan (ROS-free).

:class:`PeopleTracker` is driven by explicit calls, so tests need no clock:

- ``step(scan, robot_pose, t)``: one laser scan (:class:`~gidabot_navigation.perception.detector.Scan`),
  the robot's pose in the map when it was taken, its time (s, any monotonic clock: ROS time); returns
  a :class:`PeopleReport` (every track and the visitor's :class:`VisitorReport`).
- ``lock_visitor()``: at the moment guiding starts, the track in the *lock cone* (``lock_bearing`` +-
  ``lock_half_angle`` in the robot's frame, within ``lock_distance``; behind the robot by default)
  becomes THE visitor (a laser that does not see the cone's axis, a front laser: the nearest person it sees
  within ``lock_distance``); if none is there yet the tracker keeps looking (``ACQUIRING``) for
  ``lock_window`` s. ``unlock_visitor()`` lets it go; ``want_visitor(bool)`` does either on a change of
  the guiding core's wish (the people node's latched lock topic).
- ``want_people(bool)``: the guiding core's wish to have people watched at all (during a trip). The laser
  is worth reading only while :attr:`~PeopleTracker.needs_scans` (people or the visitor wanted); when it
  stops being needed the tracker pauses: its tracks and time are dropped, so the first scan after starts
  afresh (a lock asked meanwhile waits its ``lock_window`` from that scan).

**Tracks.** Each person is a constant-velocity Kalman filter in the map frame (state x, y, vx, vy; white
acceleration noise ``accel_sigma``; a detection's position has a standard deviation of ``meas_sigma``
divided by its confidence: a partly hidden body pulls little). Every scan, the tracks are predicted to its
time and the detections assigned to them by the Hungarian method (``scipy.optimize.linear_sum_assignment``)
on the negative log-likelihood of the innovation, gated by the Mahalanobis distance (``gate_chi2``) and a
distance (``gate_max``): confirmed tracks first, then tentative ones with what is left. Scans come irregularly
to a node that shares its CPU: a gap between two is predicted as it was, up to ``max_dt``, so a person walking
on is where their track expects them. A detection nobody takes starts a tentative track unless it lies within
``birth_exclusion`` of a track (one person, one track), which is confirmed after ``confirm_hits`` updates; a
track unseen for ``track_lost_after`` s (tentative: ``tentative_lost_after``) is dropped. A track unseen for more
than ``coast_time`` s loses its velocity with time constant ``unseen_velocity_tau`` (people stop; a prediction
does not run off).

**The visitor is not swapped.** The visitor's track is associated like the others, with its predicted
position and velocity, so a bystander crossing close by keeps its own track. When the assignment is
*ambiguous* (another confirmed track could take the visitor's detection, or the visitor the other's, for
less than ``ambiguity_margin`` more in log-likelihood; a track that gets no detection costs as one at the
gate's edge, unless it could not have been seen: out of view, or behind something nearer in the scan),
neither is updated: both coast on their own motion until they are apart again, and the visitor's
confidence is halved, rather than risk a swap (an updated rival could settle on the visitor and take its
detections afterwards). The visitor's track is never dropped as other tracks are, only reported:

- ``SEEN``: updated by this scan;
- ``HIDDEN``: not seen, predicted inside the laser's field of view (occluded, missed, beyond its range);
  ``LOST`` once it has been hidden this way for ``visitor_lost_after`` s since it was last seen (a gap between
  two scans counts at most ``max_unseen_step``: the laser did not look meanwhile);
- ``OUT_OF_VIEW``: predicted at a bearing the laser does not cover (behind a front laser: the guiding core
  may turn to look; farther than the laser reaches is ``HIDDEN``); this time does not count against
  ``visitor_lost_after``, but ``out_of_view_lost_after`` s unseen in all is ``LOST`` too;
- ``LOST``: the visitor's track is released (it becomes an ordinary track); the report keeps where and when
  the visitor was last seen until the next lock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from gidabot_navigation.building.geometry import Pose2D, wrap_angle
from gidabot_navigation.errors import PerceptionError
from gidabot_navigation.interface import Sight
from gidabot_navigation.perception.detector import Detections, Detector, FieldOfView, Scan

UNGATED = 1e9                  # cost of a pair outside the gate
CONFIDENCE_GAIN = 0.25         # the visitor's confidence grows by this at each clear sighting (to 1)
AMBIGUITY_FACTOR = 0.5         # and is multiplied by this at each ambiguous one
MIN_CONFIDENCE = 0.1           # of a detection, when it scales the measurement noise


@dataclass(frozen=True)
class TrackerParams:
    accel_sigma: float = 1.0                # m/s^2, white acceleration noise of the motion model
    meas_sigma: float = 0.08                # m, standard deviation of a detection's position
    init_speed_sigma: float = 1.0           # m/s, of a new track's velocity (it starts at 0)
    max_speed: float = 2.5                  # m/s: a track's speed is clamped to this
    max_dt: float = 5.0                     # s: a longer gap between scans is predicted as this long
    max_unseen_step: float = 0.5            # s: at most this much of a gap counts as the visitor not seen in view
    #                                         (a gap is no look: a starved node must not lose who it never looked for)
    gate_chi2: float = 9.21                 # squared Mahalanobis distance of the gate (99 % with 2 dof)
    gate_max: float = 1.0                   # m: and at most this far from the prediction
    confirm_hits: int = 3                   # updates that confirm a track
    birth_confidence: float = 0.4           # a detection less confident than this starts no track
    birth_exclusion: float = 0.45           # m: no new track this close to an existing one's prediction
    tentative_lost_after: float = 0.4       # s unseen: a tentative track is dropped
    track_lost_after: float = 1.5           # s unseen: a confirmed track (not the visitor) is dropped
    coast_time: float = 1.0                 # s unseen during which a track keeps its velocity
    unseen_velocity_tau: float = 2.0        # s, time constant of its fading velocity afterwards
    fov_margin: float = 0.25                # m inside the field of view's edges to count as in view
    lock_bearing: float = math.pi           # rad, centre of the lock cone in the robot's frame (pi: behind)
    lock_half_angle: float = 1.2            # rad, half-width of the lock cone
    lock_distance: float = 2.5              # m from the robot's centre, at most
    lock_window: float = 5.0                # s a lock waits for a track in the cone
    relock_radius: float = 1.5              # m: a lock asked anew takes a track this near where the visitor was
    #                                         last seen first, wherever it is ...
    relock_speed: float = 0.5               # m/s: ... growing by this for every second since (a visitor who walked
    relock_max: float = 3.0                 # m    on unseen, behind the robot that passed them), up to this
    visitor_lost_after: float = 3.0         # s unseen in view: the visitor is lost
    out_of_view_lost_after: float = 20.0    # s unseen in all: lost, even out of view
    ambiguity_margin: float = 4.0           # log-likelihood margin below which a visitor's assignment is ambiguous
    track_rate: float = 5.0                 # Hz: scans tracked at most (:meth:`PeopleTracker.wants_scan`); people
    #                                         walk 0.3 m at most between two, well inside the gate

    def __post_init__(self) -> None:
        problems = []
        for name, value in vars(self).items():
            if name == "lock_bearing":
                ok = isinstance(value, (int, float)) and math.isfinite(value)
            elif name == "confirm_hits":
                ok = isinstance(value, int) and value >= 1
            else:
                ok = isinstance(value, (int, float)) and math.isfinite(value) and value > 0
            if not ok:
                problems.append(f"{name}: {value!r}")
        if self.lock_half_angle > math.pi:
            problems.append(f"lock_half_angle: {self.lock_half_angle!r} is more than pi")
        if problems:
            raise PerceptionError("tracker parameters must be finite numbers > 0 (lock_bearing: any finite angle; "
                                  "confirm_hits: an integer >= 1): " + "; ".join(problems))


@dataclass
class _Track:
    id: int
    state: np.ndarray              # x, y, vx, vy (m, m/s, map frame)
    cov: np.ndarray                # 4 x 4
    seen: float                    # time of the last update
    hits: int = 1
    confirmed: bool = False
    heading: float = 0.0           # rad, direction of motion when last moving


@dataclass(frozen=True)
class Track:
    """One tracked person: position (m) and velocity (m/s) in the map frame."""

    id: int
    x: float
    y: float
    vx: float
    vy: float
    confidence: float              # 0..1: hits and recency
    unseen: float                  # s since the last update (0: updated by this scan)
    confirmed: bool
    visitor: bool


@dataclass(frozen=True)
class LastSeen:
    """Where the visitor was last seen: position (m, map), heading (rad: of its motion, or towards the robot
    when it stood), and when (s)."""

    pose: Pose2D
    t: float


@dataclass(frozen=True)
class VisitorReport:
    """What the robot knows of the visitor after a step. Positions are the track's estimate (predicted while
    unseen); ``None`` without a locked track (NONE, ACQUIRING, LOST)."""

    sight: Sight
    track_id: int | None = None
    x: float | None = None                 # m, map
    y: float | None = None
    vx: float | None = None                # m/s, map
    vy: float | None = None
    distance: float | None = None          # m from the robot's centre
    behind: float | None = None            # m behind the robot along its heading (negative: ahead)
    bearing: float | None = None           # rad in the robot's frame (0 ahead, +-pi behind)
    unseen: float | None = None            # s since last seen
    last_seen: LastSeen | None = None
    confidence: float = 0.0                # 0..1

    @property
    def seen(self) -> bool:
        return self.sight == Sight.SEEN


@dataclass(frozen=True)
class PeopleReport:
    t: float
    tracks: tuple[Track, ...]              # the confirmed tracks (the visitor's among them)
    visitor: VisitorReport
    detections: Detections | None = field(default=None, repr=False)
    ambiguous: bool = False                # the visitor's assignment was ambiguous this step


@dataclass(frozen=True)
class PeopleData:
    """A ``gidabot_msgs/PersonArray``: the confirmed tracks of one scan; ``stamp``: s, the scan's time."""

    tracks: tuple[Track, ...] = ()
    stamp: float = 0.0


@dataclass(frozen=True)
class VisitorTrackData:
    """A ``gidabot_msgs/VisitorTrack``: what the robot knew of its visitor after one scan; ``stamp``: s, the
    scan's time."""

    report: VisitorReport = field(default_factory=lambda: VisitorReport(Sight.NONE))
    stamp: float = 0.0


class PeopleTracker:
    """Tracks the people a robot's laser sees and keeps the visitor it guides (see the module's docstring)."""

    def __init__(self, detector: Detector | None = None, params: TrackerParams | None = None) -> None:
        self.detector = detector or Detector()
        self.params = params or TrackerParams()
        self._tracks: list[_Track] = []
        self._next_id = 1
        self._t: float | None = None
        self._robot: Pose2D | None = None
        self._fov: FieldOfView | None = None
        self._detections: Detections | None = None
        self._visitor: int | None = None             # id of the visitor's track
        self._acquiring_since: float | None = None   # a lock was asked (at this time; nan: before any step)
        self._sight = Sight.NONE
        self._hidden = 0.0                           # s unseen in view since last seen
        self._confidence = 0.0
        self._last_seen: LastSeen | None = None
        self._memory: LastSeen | None = None         # where the visitor was last seen, kept over a lock asked anew
        self._report = VisitorReport(Sight.NONE)
        self._wanted = False
        self._watched = False

    # -- the visitor lock ------------------------------------------------------------------------
    def lock_visitor(self) -> bool:
        """Take the track in the lock cone as the visitor (any previous visitor is released); True when one
        was there. Else the tracker looks for one at every step for ``lock_window`` s (``ACQUIRING``).

        A lock asked *anew* (the visitor lost, or let go and asked for again before the next scan: the guiding
        core's relock) first takes the confirmed track nearest where the visitor was last seen, within
        ``relock_radius`` growing by ``relock_speed`` for every second since, up to ``relock_max``, wherever it
        is: a visitor standing still far behind a robot that waits facing them is not in the cone (behind it,
        within ``lock_distance``), their track may be a new one (a scan gap, a stop the motion model did not
        expect), and one who stood aside for the robot and walked on unseen behind it as it passed is no
        longer where it was last seen."""
        self._memory = self._last_seen or self._memory
        self._visitor, self._last_seen, self._hidden = None, None, 0.0
        self._acquiring_since = self._t if self._t is not None else math.nan
        self._sight = Sight.ACQUIRING
        if self._t is not None and self._try_lock():
            self._report = self._visitor_report()
            return True
        self._report = VisitorReport(Sight.ACQUIRING)
        return False

    def unlock_visitor(self) -> None:
        """No visitor any more (guiding is over): its track becomes an ordinary one. Where it was last seen is
        forgotten at the next scan, unless a lock is asked again before it (a lock asked anew)."""
        self._memory = self._last_seen or self._memory
        self._visitor, self._acquiring_since, self._last_seen = None, None, None
        self._sight, self._confidence = Sight.NONE, 0.0
        self._report = VisitorReport(Sight.NONE)

    def want_visitor(self, wanted: bool) -> bool:
        """The guiding core's wish, as a state (a latched topic): a change to True locks the visitor
        (:meth:`lock_visitor`), False lets it go; the same wish again changes nothing (a re-sent latched
        message must not lock another person mid-trip). True when the lock changed."""
        if wanted == self._wanted:
            return False
        self._wanted = wanted
        if wanted:
            self.lock_visitor()
        else:
            self.unlock_visitor()
            self._pause_unless_needed()
        return True

    def want_people(self, wanted: bool) -> bool:
        """The guiding core's wish to have the people around the robot watched (a latched topic: during a trip,
        so that the tracks are warm when guiding starts and someone arriving at a meeting point is seen).
        True when :attr:`needs_scans` changed."""
        before = self.needs_scans
        self._watched = wanted
        self._pause_unless_needed()
        return self.needs_scans != before

    def wants_scan(self, t: float) -> bool:
        """Whether a scan taken at ``t`` s is worth tracking: at most ``track_rate`` scans a second are (a laser
        faster than that costs the tracker, and whoever reads its reports, for nothing a walking person needs);
        the first scan, and one from before the last (a restarted simulation), always are."""
        last = self._t
        return last is None or t < last or t - last >= 1.0 / self.params.track_rate - 1e-6

    @property
    def needs_scans(self) -> bool:
        """Whether the laser is worth reading: people are watched or the visitor is wanted."""
        return self._watched or self._wanted

    def _pause_unless_needed(self) -> None:
        """Nobody needs people now: drop the tracks and forget the time (the laser stops being read; the scan that
        comes when it is read again starts afresh, as after a gap)."""
        if self.needs_scans:
            return
        self._tracks.clear()
        self._t, self._detections = None, None

    @property
    def visitor(self) -> VisitorReport:
        return self._report

    def _try_lock(self) -> bool:
        """Lock the confirmed track nearest where the visitor was last seen (a lock asked anew, within
        ``relock_radius`` and what it grew since), else the one nearest the robot in the lock cone (its angle off
        the cone's axis counts as distance: 1 rad as 1 m), a lock asked anew's cone turned towards where the
        visitor was last seen."""
        p, robot = self.params, self._robot
        assert robot is not None and self._t is not None
        best: tuple[float, _Track] | None = None
        memory = self._memory
        if memory is not None:
            reach = max(p.relock_radius, min(p.relock_max, p.relock_radius + p.relock_speed * (self._t - memory.t)))
            for tr in self._tracks:
                away = math.hypot(tr.state[0] - memory.pose.x, tr.state[1] - memory.pose.y)
                if tr.confirmed and away <= reach and (best is None or away < best[0]):
                    best = (away, tr)
        blind = self._cone_unseen()
        # a lock asked anew looks towards where the visitor was last seen (the robot waits facing there; behind
        # it is where nobody it guided can be), else behind the robot (lock_bearing)
        axis = robot.yaw + p.lock_bearing if memory is None else \
            math.atan2(memory.pose.y - robot.y, memory.pose.x - robot.x)
        for tr in self._tracks if best is None else ():
            if not tr.confirmed:
                continue
            dx, dy = tr.state[0] - robot.x, tr.state[1] - robot.y
            dist = math.hypot(dx, dy)
            off = abs(wrap_angle(math.atan2(dy, dx) - axis))
            if blind:               # a laser that does not see the cone: the nearest person it sees
                off = 0.0 if tr.seen == self._t else math.inf
            if dist <= p.lock_distance and off <= p.lock_half_angle and (best is None or dist + off < best[0]):
                best = (dist + off, tr)
        if best is None:
            return False
        tr = best[1]
        self._visitor, self._acquiring_since = tr.id, None
        self._sight, self._hidden, self._confidence = Sight.SEEN if tr.seen == self._t else Sight.HIDDEN, 0.0, 1.0
        self._last_seen = LastSeen(self._pose_of(tr), tr.seen)
        return True

    def _cone_unseen(self) -> bool:
        """Whether the laser does not see the lock cone's axis (a front laser and the cone behind, as the building
        file's ``sensors.laser.fov`` says): the lock then takes the nearest person the laser sees within
        ``lock_distance``, wherever they stand (at the start of a leg the visitor stands at the robot, at its
        screen or where it waited; afterwards, behind it out of view, the guiding core turns to look)."""
        fov, robot = self._fov, self._robot
        if fov is None or robot is None or fov.full_circle:
            return False
        axis = robot.yaw + self.params.lock_bearing
        return not fov.covers(robot, robot.x + 2.0 * math.cos(axis), robot.y + 2.0 * math.sin(axis))

    # -- one scan ------------------------------------------------------------------------------------
    def step(self, scan: Scan, robot: Pose2D, t: float) -> PeopleReport:
        """Detect the people in ``scan`` (taken at ``t`` s from a robot at ``robot`` in the map) and track them."""
        return self.update(self.detector.detect(scan, robot), robot, t)

    def update(self, detections: Detections, robot: Pose2D, t: float) -> PeopleReport:
        """Track with detections found elsewhere (:meth:`step` without the detector)."""
        p = self.params
        if not (math.isfinite(t) and robot.is_finite()):
            raise PerceptionError(f"step at t={t!r} from robot pose {robot!r}: not finite")
        if self._t is not None and t < self._t:       # time went back (a restarted simulation): start afresh
            self._tracks.clear()
            if self._visitor is not None:
                self._lose()
        dt = 0.0 if self._t is None or t < self._t else min(t - self._t, p.max_dt)
        self._t, self._robot, self._fov, self._detections = t, robot, detections.fov, detections
        if self._sight == Sight.NONE:            # let go, and not asked for again: a new lock is a new visitor
            self._memory = None
        if self._acquiring_since is not None and math.isnan(self._acquiring_since):
            self._acquiring_since = t
        for tr in self._tracks:
            self._predict(tr, dt, t)

        people = detections.people
        z = np.array([(d.x, d.y) for d in people]).reshape(-1, 2)
        taken: dict[int, int] = {}                    # track index -> detection index
        confirmed = [i for i, tr in enumerate(self._tracks) if tr.confirmed]
        cost = self._costs(confirmed, z)
        taken.update(self._assign(confirmed, cost, range(len(z))))
        # ambiguous: the visitor and its rivals coast, their detections go to nobody (and start no track)
        rivals, vi = [], self._visitor_index()
        if vi is not None and vi in confirmed:
            rivals = self._rivals(vi, confirmed, cost, taken)
        withheld = {taken.pop(i) for i in ([vi, *rivals] if rivals else []) if i in taken}
        free = [j for j in range(len(z)) if j not in taken.values()]
        tentative = [i for i, tr in enumerate(self._tracks) if not tr.confirmed]
        taken.update(self._assign(tentative, self._costs(tentative, z[free]), free))

        for i, j in taken.items():
            self._correct(self._tracks[i], z[j], people[j].confidence, t)
        claimed = set(taken.values())
        for j, det in enumerate(people):
            if j in claimed or j in withheld or det.confidence < p.birth_confidence:
                continue
            if all(math.hypot(tr.state[0] - det.x, tr.state[1] - det.y) >= p.birth_exclusion for tr in self._tracks):
                self._birth(det.x, det.y, t)
        self._tracks = [tr for tr in self._tracks if tr.id == self._visitor or
                        t - tr.seen <= (p.track_lost_after if tr.confirmed else p.tentative_lost_after)]

        self._follow_visitor(min(dt, p.max_unseen_step), bool(rivals))
        tracks = tuple(self._public(tr) for tr in self._tracks if tr.confirmed)
        return PeopleReport(t, tracks, self._report, detections, bool(rivals))

    # -- the visitor ----------------------------------------------------------------------------------
    def _visitor_index(self) -> int | None:
        return next((i for i, tr in enumerate(self._tracks) if tr.id == self._visitor), None)

    def _follow_visitor(self, dt: float, ambiguous: bool) -> None:
        p, t = self.params, self._t
        assert t is not None and self._robot is not None and self._fov is not None
        if self._acquiring_since is not None:
            if self._try_lock():
                self._report = self._visitor_report()
            elif t - self._acquiring_since > p.lock_window:
                self._acquiring_since, self._sight = None, Sight.LOST
                self._report = VisitorReport(Sight.LOST)
            return
        vi = self._visitor_index()
        if vi is None:
            if self._sight == Sight.LOST and self._last_seen is not None:
                self._report = replace(self._report, unseen=max(0.0, t - self._last_seen.t))
            return
        tr = self._tracks[vi]
        if tr.seen == t and not ambiguous:
            self._sight, self._hidden = Sight.SEEN, 0.0
            self._confidence = min(1.0, self._confidence + CONFIDENCE_GAIN)
            self._last_seen = LastSeen(self._pose_of(tr), t)
        else:
            self._confidence *= AMBIGUITY_FACTOR if ambiguous else math.exp(-dt / p.visitor_lost_after)
            in_view = self._fov.covers(self._robot, float(tr.state[0]), float(tr.state[1]), p.fov_margin)
            self._sight = Sight.HIDDEN if in_view else Sight.OUT_OF_VIEW
            if in_view:
                self._hidden += dt
            if self._hidden > p.visitor_lost_after or t - tr.seen > p.out_of_view_lost_after:
                self._lose()
                return
        self._report = self._visitor_report()

    def _lose(self) -> None:
        """The visitor is lost: its track is released; the report keeps where and when it was last seen."""
        t = self._t
        assert t is not None
        unseen = t - self._last_seen.t if self._last_seen is not None else None
        self._report = VisitorReport(Sight.LOST, self._visitor, unseen=unseen, last_seen=self._last_seen)
        self._visitor, self._sight, self._confidence = None, Sight.LOST, 0.0

    def _visitor_report(self) -> VisitorReport:
        t, robot = self._t, self._robot
        vi = self._visitor_index()
        assert t is not None and robot is not None and vi is not None
        tr = self._tracks[vi]
        x, y, vx, vy = (float(v) for v in tr.state)
        dx, dy = x - robot.x, y - robot.y
        c, s = math.cos(robot.yaw), math.sin(robot.yaw)
        return VisitorReport(self._sight, tr.id, x, y, vx, vy, math.hypot(dx, dy), -(c * dx + s * dy),
                             math.atan2(-s * dx + c * dy, c * dx + s * dy), t - tr.seen, self._last_seen,
                             self._confidence)

    def _rivals(self, vi: int, confirmed: list[int], cost: np.ndarray, taken: dict[int, int]) -> list[int]:
        """The confirmed tracks that make the visitor's assignment ambiguous: swapping their detections with the
        visitor's (or moving one of them to the other track, which then misses) costs less than
        ``ambiguity_margin`` more than the chosen assignment."""
        row = {i: k for k, i in enumerate(confirmed)}
        v, dv = row[vi], taken.get(vi)
        rivals = []
        for i in confirmed:
            r, di = row[i], taken.get(i)
            mine_to_it = i != vi and dv is not None and cost[r, dv] < UNGATED
            its_to_me = i != vi and di is not None and cost[v, di] < UNGATED
            if not (mine_to_it or its_to_me):
                continue
            chosen = (cost[v, dv] if dv is not None else self._miss(vi)) + \
                (cost[r, di] if di is not None else self._miss(i))
            swapped = (cost[v, di] if its_to_me else self._miss(vi)) + (cost[r, dv] if mine_to_it else self._miss(i))
            if swapped - chosen < self.params.ambiguity_margin:
                rivals.append(i)
        return rivals

    def _miss(self, i: int) -> float:
        """The cost of track ``i`` getting no detection: that of one at the gate's edge, or of one right at its
        prediction when it could not have been seen (out of view, behind something nearer)."""
        tr = self._tracks[i]
        s = tr.cov[:2, :2] + np.eye(2) * self.params.meas_sigma ** 2
        cost = math.log(s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0])
        assert self._detections is not None
        return cost + self.params.gate_chi2 if self._detections.visible(tr.state[0], tr.state[1]) else cost

    # -- filters ---------------------------------------------------------------------------------------
    def _predict(self, tr: _Track, dt: float, t: float) -> None:
        if dt <= 0:
            return
        q = self.params.accel_sigma ** 2
        f = np.eye(4)
        f[0, 2] = f[1, 3] = dt
        g = np.array([[dt * dt / 2, 0], [0, dt * dt / 2], [dt, 0], [0, dt]])
        tr.state = f @ tr.state
        tr.cov = f @ tr.cov @ f.T + q * (g @ g.T)
        if t - tr.seen > self.params.coast_time:      # unseen for a while: people stop
            tr.state[2:] *= math.exp(-dt / self.params.unseen_velocity_tau)

    def _correct(self, tr: _Track, z: np.ndarray, confidence: float, t: float) -> None:
        """Update with a detection at ``z``: its standard deviation is ``meas_sigma`` / its confidence."""
        p = self.params
        s = tr.cov[:2, :2] + np.eye(2) * (p.meas_sigma / max(confidence, MIN_CONFIDENCE)) ** 2
        inverse = np.array([[s[1, 1], -s[0, 1]], [-s[1, 0], s[0, 0]]]) / (s[0, 0] * s[1, 1] - s[0, 1] * s[1, 0])
        gain = tr.cov[:, :2] @ inverse      # (np.linalg.inv costs 100 times more on a 2 x 2)
        tr.state = tr.state + gain @ (z - tr.state[:2])
        tr.cov = (np.eye(4) - gain @ np.eye(2, 4)) @ tr.cov
        speed = math.hypot(tr.state[2], tr.state[3])
        if speed > p.max_speed:
            tr.state[2:] *= p.max_speed / speed
        if speed > 0.2:
            tr.heading = math.atan2(tr.state[3], tr.state[2])
        tr.seen, tr.hits = t, tr.hits + 1
        tr.confirmed = tr.confirmed or tr.hits >= p.confirm_hits

    def _birth(self, x: float, y: float, t: float) -> None:
        p = self.params
        cov = np.diag([p.meas_sigma ** 2, p.meas_sigma ** 2, p.init_speed_sigma ** 2, p.init_speed_sigma ** 2])
        robot = self._robot
        heading = math.atan2(robot.y - y, robot.x - x) if robot is not None else 0.0
        self._tracks.append(_Track(self._next_id, np.array([x, y, 0.0, 0.0]), cov, t, heading=heading,
                                   confirmed=p.confirm_hits <= 1))
        self._next_id += 1

    def _costs(self, rows: list[int], z: np.ndarray) -> np.ndarray:
        """Negative log-likelihood (up to a constant) of each detection for each track; UNGATED outside the gate."""
        p = self.params
        cost = np.full((len(rows), len(z)), UNGATED)
        if not rows or not len(z):
            return cost
        pos = np.array([self._tracks[i].state[:2] for i in rows])                       # (T, 2)
        s = np.array([self._tracks[i].cov[:2, :2] for i in rows]) + np.eye(2) * p.meas_sigma ** 2
        det = s[:, 0, 0] * s[:, 1, 1] - s[:, 0, 1] * s[:, 1, 0]
        nu = z[None, :, :] - pos[:, None, :]                                            # (T, D, 2)
        d2 = (s[:, None, 1, 1] * nu[..., 0] ** 2 - 2 * s[:, None, 0, 1] * nu[..., 0] * nu[..., 1]
              + s[:, None, 0, 0] * nu[..., 1] ** 2) / det[:, None]
        gated = (d2 <= p.gate_chi2) & (np.hypot(nu[..., 0], nu[..., 1]) <= p.gate_max)
        cost[gated] = (d2 + np.log(det)[:, None])[gated]
        return cost

    @staticmethod
    def _assign(rows: list[int], cost: np.ndarray, cols: range | list[int]) -> dict[int, int]:
        """Track index -> detection index (``cols`` maps the cost's columns to detections), gated pairs only."""
        if cost.size == 0:
            return {}
        r, c = linear_sum_assignment(cost)
        cols = list(cols)
        return {rows[i]: cols[j] for i, j in zip(r, c, strict=True) if cost[i, j] < UNGATED}

    # -- outputs ---------------------------------------------------------------------------------------
    def _pose_of(self, tr: _Track) -> Pose2D:
        return Pose2D(float(tr.state[0]), float(tr.state[1]), tr.heading)

    def _public(self, tr: _Track) -> Track:
        t = self._t
        assert t is not None
        unseen = t - tr.seen
        confidence = min(1.0, tr.hits / (2.0 * self.params.confirm_hits)) * \
            math.exp(-unseen / self.params.track_lost_after)
        return Track(tr.id, float(tr.state[0]), float(tr.state[1]), float(tr.state[2]), float(tr.state[3]),
                     confidence, unseen, tr.confirmed, tr.id == self._visitor)
