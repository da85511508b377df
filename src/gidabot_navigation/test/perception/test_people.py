"""The people tracker and the visitor lock on synthetic scans of a corridor: the visitor following the robot is
locked and kept, through a bystander crossing close by, through occlusions and out of a front laser's view;
a visitor who walks away is lost after the bound."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import pytest

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.errors import PerceptionError
from gidabot_navigation.interface import Sight, Topic
from gidabot_navigation.perception import synthetic as sy
from gidabot_navigation.perception.detector import Detection, Detections, Detector, FieldOfView, Kind
from gidabot_navigation.perception.people import PeopleReport, PeopleTracker, TrackerParams

RATE = 10.0                   # Hz, scans
SPEED = 0.6                   # m/s, the robot guiding along the corridor (+x)
GAP = 1.3                     # m, the visitor behind the robot
CORRIDOR = sy.Scene(walls=(sy.Wall(-20.0, -1.5, 80.0, -1.5), sy.Wall(-20.0, 1.5, 80.0, 1.5)))
Where = Callable[[float], tuple[float, float] | None]      # t -> a person's position, None: not there


@dataclass
class Walk:
    """Robot, visitor and bystanders in the corridor, scanned at RATE by ``laser``, tracked by ``tracker``."""

    tracker: PeopleTracker
    laser: sy.Laser
    robot: Callable[[float], Pose2D]
    people: dict[str, Where]
    legs: bool = False
    seed: int = 0

    def __post_init__(self) -> None:
        self.rng = np.random.default_rng(self.seed)
        self.k = 0

    def steps(self, seconds: float) -> Iterator[tuple[float, PeopleReport]]:
        for _ in range(round(seconds * RATE)):
            t = self.k / RATE
            self.k += 1
            scene = CORRIDOR
            robot = self.robot(t)
            for where in self.people.values():
                at = where(t)
                if at is not None:     # legs spread across the line of sight (a stride seen from the side)
                    scene += sy.person(*at, legs=self.legs, heading=math.atan2(at[1] - robot.y, at[0] - robot.x))
            yield t, self.tracker.step(sy.scan(scene, robot, self.laser, self.rng), robot, t)

    def run(self, seconds: float) -> list[tuple[float, PeopleReport]]:
        return list(self.steps(seconds))


def guiding(t: float) -> Pose2D:
    return Pose2D(SPEED * t, 0.0, 0.0)


def follower(t: float) -> tuple[float, float]:
    return (SPEED * t - GAP, 0.1)


def walk(legs: bool = False, beams: int = 720, people: dict[str, Where] | None = None,
         params: TrackerParams | None = None, laser: sy.Laser | None = None,
         robot: Callable[[float], Pose2D] = guiding) -> Walk:
    laser = laser or sy.Laser(beams=beams)
    return Walk(PeopleTracker(Detector(mount=laser.mount), params), laser, robot,
                people if people is not None else {"visitor": follower}, legs)


def locked(w: Walk, seconds: float = 1.0) -> int:
    """Run ``seconds`` (the tracks confirm), lock the visitor: its track id."""
    w.run(seconds)
    assert w.tracker.lock_visitor(), w.tracker.visitor
    report = w.tracker.visitor
    assert report.sight == Sight.SEEN and report.track_id is not None
    assert report.behind == pytest.approx(GAP, abs=0.15) and abs(abs(report.bearing) - math.pi) < 0.2
    return report.track_id


@pytest.mark.parametrize("legs", [False, True], ids=["body", "legs"])
def test_the_visitor_following_behind_is_locked_and_kept(legs: bool) -> None:
    w = walk(legs)
    vid = locked(w)
    reports = [r.visitor for _, r in w.run(15.0)]          # 150 scans, 9 m along the corridor
    assert all(v.track_id == vid for v in reports)
    seen = sum(v.seen for v in reports)
    assert seen >= 0.95 * len(reports), seen
    assert all(v.behind == pytest.approx(GAP, abs=0.2) and v.distance == pytest.approx(GAP, abs=0.2)
               for v in reports if v.seen)
    last = reports[-1]
    assert last.vx == pytest.approx(SPEED, abs=0.15) and abs(last.vy) < 0.15
    assert last.last_seen is not None and last.last_seen.pose.yaw == pytest.approx(0.0, abs=0.3)
    assert last.confidence > 0.9 and last.unseen < 0.25


def crossing(lateral_speed: float, ahead_of_visitor: float, start: float) -> Where:
    """A bystander crossing the corridor (from y = +1.2 to -1.2) ``ahead_of_visitor`` m in front of the visitor
    (negative: behind it) at the time the visitor passes there."""
    meet = start + 1.2 / lateral_speed
    x = SPEED * meet - GAP + ahead_of_visitor
    return lambda t: (x, 1.2 - lateral_speed * (t - start)) if start <= t <= start + 2.4 / lateral_speed else None


@pytest.mark.parametrize("legs", [False, True], ids=["body", "legs"])
@pytest.mark.parametrize("ahead, speed", [(0.35, 1.2), (0.35, 0.6), (-0.38, 1.0)],
                         ids=["between them, fast", "between them, slow", "just behind the visitor"])
def test_a_bystander_crossing_close_does_not_take_the_lock(legs: bool, ahead: float, speed: float) -> None:
    """The bystander passes less than 0.4 m from the visitor, between it and the robot (hiding it for a few
    scans) or just behind it; the visitor's track keeps its id and is found again where the visitor is."""
    w = walk(legs, people={"visitor": follower, "bystander": crossing(speed, ahead, start=2.0)})
    vid = locked(w)
    during = w.run(2.4 / speed + 2.0)
    for t, report in during:
        v = report.visitor
        assert v.track_id == vid, (t, v)
        assert v.sight in (Sight.SEEN, Sight.HIDDEN), (t, v)
        vx, vy = follower(t)
        assert math.hypot(v.x - vx, v.y - vy) < 0.3, (t, v)         # never pulled onto the bystander
    bystander_ids = {tr.id for _, r in during for tr in r.tracks if not tr.visitor}
    assert bystander_ids and vid not in bystander_ids
    assert sum(r.visitor.seen for _, r in during[-5:]) >= 4


@pytest.mark.parametrize("legs", [False, True], ids=["body", "legs"])
@pytest.mark.parametrize("hidden", [5, 15, 25])
def test_an_occluded_visitor_is_hidden_then_found_again(legs: bool, hidden: int) -> None:
    """The visitor disappears from the scans for ``hidden`` scans (behind a pillar, a passer-by): HIDDEN, with
    its predicted position, then SEEN again with the same id."""
    gone = (3.0, 3.0 + hidden / RATE)
    w = walk(legs, people={"visitor": lambda t: None if gone[0] <= t < gone[1] else follower(t)})
    vid = locked(w)
    reports = [(t, r.visitor) for t, r in w.run(gone[1])]              # until 1 s after it reappears
    for t, v in reports:
        assert v.track_id == vid
        if gone[0] + 0.05 < t < gone[1] - 0.05:
            assert v.sight == Sight.HIDDEN and v.unseen == pytest.approx(t - gone[0] + 0.1, abs=0.11)
            assert math.hypot(v.x - follower(t)[0], v.y - follower(t)[1]) < 0.5     # coasting along
    assert sum(v.seen for t, v in reports if t > gone[1] + 0.35) >= 5


def test_a_visitor_who_walks_away_is_lost_after_the_bound() -> None:
    """The visitor turns back and walks away at 1.2 m/s: tracked while the laser sees it, hidden when too far,
    LOST ``visitor_lost_after`` s after it was last seen; the report keeps where that was."""
    params = TrackerParams(visitor_lost_after=2.0)

    def away(t: float) -> tuple[float, float]:       # from +0.6 m/s to -1.2 m/s in 1 s, from t = 2 s
        turn = min(max(t - 2.0, 0.0), 1.0)
        return (follower(2.0)[0] + 0.6 * (t - 2.0) - 0.9 * turn * turn - 1.8 * max(t - 3.0, 0.0), 0.1)
    w = walk(people={"visitor": away}, params=params)
    vid = locked(w)
    reports = [(t, r.visitor) for t, r in w.run(12.0)]
    seen_until = max(t for t, v in reports if v.seen)
    lost_at = min(t for t, v in reports if v.sight == Sight.LOST)
    assert seen_until > 4.0                                  # seen while walking away, up to about 7 m away
    assert params.visitor_lost_after <= lost_at - seen_until <= params.visitor_lost_after + 0.25
    assert all(v.sight == Sight.HIDDEN for t, v in reports if seen_until < t < lost_at)
    lost = reports[-1][1]
    assert lost.sight == Sight.LOST and lost.track_id == vid and lost.x is None
    assert lost.last_seen is not None and lost.last_seen.t == seen_until
    assert lost.last_seen.pose.x == pytest.approx(away(seen_until)[0], abs=0.3)
    assert lost.unseen == pytest.approx(reports[-1][0] - seen_until)
    assert abs(lost.last_seen.pose.yaw) == pytest.approx(math.pi, abs=0.3)      # it was walking away (-x)


FRONT = sy.Laser(beams=541, fov=math.radians(270), mount=Pose2D(0.1, 0.0, 0.0))


def test_out_of_the_view_of_a_front_laser_is_not_lost() -> None:
    """A robot with a 270 degree front laser locks the visitor in front of it (at its screen), turns round to
    guide: the visitor, now behind, is OUT_OF_VIEW (not LOST, however long the in-view bound), and SEEN again
    with its id when the robot turns to look."""
    def robot(t: float) -> Pose2D:            # faces -x (the visitor) until 1 s, turns to +x by 2 s, back by 14 s
        if t < 1.0:
            return Pose2D(0.0, 0.0, math.pi)
        if t < 12.0:
            return Pose2D(0.0, 0.0, math.pi - math.pi * min(1.0, t - 1.0))
        return Pose2D(0.0, 0.0, math.pi * min(1.0, t - 12.0))
    params = TrackerParams(lock_bearing=0.0, visitor_lost_after=1.0, out_of_view_lost_after=30.0)
    w = walk(people={"visitor": lambda t: (-1.2, 0.2)}, params=params, laser=FRONT, robot=robot)
    w.run(0.8)
    assert w.tracker.lock_visitor()
    vid = w.tracker.visitor.track_id
    reports = dict(w.run(14.0))
    assert all(r.visitor.track_id == vid for r in reports.values())
    assert all(r.visitor.sight == Sight.OUT_OF_VIEW for t, r in reports.items() if 2.0 <= t <= 12.0)
    assert reports[round(12.0 * RATE) / RATE].visitor.unseen > 9.0
    assert reports[max(reports)].visitor.seen
    v = reports[max(reports)].visitor
    assert math.hypot(v.x + 1.2, v.y - 0.2) < 0.2 and v.behind == pytest.approx(-1.2, abs=0.2)


def test_the_visitor_is_kept_through_gaps_between_scans() -> None:
    """A node that shares its CPU tracks scans irregularly: the visitor following at 0.6 m/s, with gaps of up to
    2.5 s between two tracked scans, stays SEEN with one track id, and its track does not lag behind."""
    w = walk()
    vid = locked(w)
    gaps = {15: 2.0, 30: 2.5, 45: 1.2, 60: 2.2}        # after the k-th scan from here, this many seconds unseen
    reports = []
    for k, (t, report) in enumerate(w.steps(20.0)):
        reports.append((t, report))
        if k in gaps:
            w.k += round(gaps[k] * RATE)                 # the scans of the gap are never tracked
    assert all(r.visitor.track_id == vid and r.visitor.sight == Sight.SEEN for _, r in reports), \
        [(t, r.visitor.sight) for t, r in reports if r.visitor.sight != Sight.SEEN][:3]
    t, last = reports[-1]
    assert math.hypot(last.visitor.x - follower(t)[0], last.visitor.y - follower(t)[1]) < 0.2


def test_a_laser_that_does_not_see_the_lock_cone_locks_the_nearest_person_it_sees() -> None:
    """The default cone is behind the robot; a 270 degree front laser never sees there, so its lock takes the
    nearest person it sees within lock_distance (the visitor at its screen, not the one 2 m further), and finds
    nobody when the only person is beyond it."""
    def facing(t: float) -> Pose2D:
        return Pose2D(0.0, 0.0, math.pi)
    w = walk(people={"visitor": lambda t: (-1.2, 0.2), "further": lambda t: (-3.2, -0.4)}, laser=FRONT,
             robot=facing)
    w.run(0.8)
    assert w.tracker.lock_visitor(), w.tracker.visitor
    v = w.tracker.visitor
    assert v.sight == Sight.SEEN and math.hypot(v.x + 1.2, v.y - 0.2) < 0.2
    far = walk(people={"further": lambda t: (-3.2, -0.4)}, laser=FRONT, robot=facing)
    far.run(0.8)
    assert not far.tracker.lock_visitor() and far.tracker.visitor.sight == Sight.ACQUIRING
    behind = walk(people={"visitor": follower})              # an all-round laser keeps the cone behind
    behind.run(1.0)
    assert behind.tracker.lock_visitor()
    ahead = walk(people={"ahead": lambda t: (SPEED * t + 1.0, 0.0)})
    ahead.run(1.0)
    assert not ahead.tracker.lock_visitor()


def test_out_of_view_for_too_long_is_lost() -> None:
    params = TrackerParams(lock_bearing=0.0, out_of_view_lost_after=3.0)
    w = walk(people={"visitor": lambda t: (-1.2, 0.2)}, params=params, laser=FRONT,
             robot=lambda t: Pose2D(0.0, 0.0, math.pi if t < 1.0 else 0.0))
    w.run(0.8)
    assert w.tracker.lock_visitor()
    reports = w.run(5.0)
    sights = [r.visitor.sight for _, r in reports]
    assert Sight.OUT_OF_VIEW in sights and sights[-1] == Sight.LOST
    lost_at = min(t for t, r in reports if r.visitor.sight == Sight.LOST)
    assert lost_at - 0.9 == pytest.approx(params.out_of_view_lost_after, abs=0.15)


def test_a_lock_with_nobody_behind_waits_for_the_visitor_then_gives_up() -> None:
    """Nobody in the cone at the lock: ACQUIRING; the visitor stepping behind the robot within the window is
    locked; nobody within the window: LOST."""
    late = walk(people={"visitor": lambda t: (3.0, 0.5) if t < 1.5 else follower(t)})   # ahead, then behind
    late.run(1.0)
    assert not late.tracker.lock_visitor() and late.tracker.visitor.sight == Sight.ACQUIRING
    reports = late.run(2.0)
    assert reports[-1][1].visitor.seen and reports[-1][1].visitor.behind == pytest.approx(GAP, abs=0.2)
    nobody = walk(people={"visitor": lambda t: (3.0, 0.5)}, params=TrackerParams(lock_window=2.0))
    nobody.run(1.0)
    assert not nobody.tracker.lock_visitor()
    sights = [r.visitor.sight for _, r in nobody.run(3.0)]
    assert sights[:15] == [Sight.ACQUIRING] * 15 and sights[-1] == Sight.LOST


def test_a_lock_asked_before_the_first_scan_starts_its_window_at_the_first_scan() -> None:
    w = walk()
    assert not w.tracker.lock_visitor()
    reports = w.run(1.0)
    assert reports[-1][1].visitor.seen          # the visitor's track confirmed within the window


def test_the_lock_takes_the_nearest_person_in_the_cone() -> None:
    w = walk(people={"visitor": follower, "further": lambda t: (SPEED * t - 2.3, -0.6),
                     "ahead": lambda t: (SPEED * t + 1.0, 0.0)})
    w.run(1.0)
    assert w.tracker.lock_visitor()
    v = w.tracker.visitor
    assert (v.x, v.y) == pytest.approx(follower(0.9), abs=0.15)


def test_unlock_releases_the_visitor() -> None:
    w = walk()
    vid = locked(w)
    w.tracker.unlock_visitor()
    assert w.tracker.visitor.sight == Sight.NONE
    _, report = w.run(0.5)[-1]
    assert report.visitor.sight == Sight.NONE and report.visitor.x is None
    assert [tr.id for tr in report.tracks] == [vid] and not report.tracks[0].visitor


def test_noise_and_walls_make_no_confirmed_track() -> None:
    w = walk(people={}, laser=sy.Laser(beams=720, dropout=0.02))
    assert all(not r.tracks for _, r in w.run(5.0))


# -- the association, on detections made by hand ------------------------------------------------------
FOV = FieldOfView(-math.pi, math.pi, 8.0, Pose2D(0.0, 0.0, 0.0), True)
ORIGIN = Pose2D(0.0, 0.0, 0.0)


def seen(*points: tuple[float, float]) -> Detections:
    return Detections(tuple(Detection(x, y, 0.9, Kind.BODY, 0.4) for x, y in points), FOV, np.zeros(0))


def test_an_ambiguous_detection_keeps_the_visitor_and_lowers_its_confidence() -> None:
    """Two people walk across each other's path; while they are too close to be told apart the laser sees one
    blob between them, as likely the one's as the other's: neither takes it (no swap, no third track), both
    coast on their own motion, the visitor's confidence halves; once apart each is found on its own side."""
    tracker = PeopleTracker(params=TrackerParams(lock_bearing=0.0, lock_half_angle=math.pi, lock_distance=5.0))

    def visitor(t: float) -> tuple[float, float]:        # at 1 m/s both, they meet at (2.0, 0.0) at t = 3.2
        return (2.0 + (t - 3.2), 0.0)

    def other(t: float) -> tuple[float, float]:
        return (2.0, 3.2 - t)

    def scan(t: float) -> Detections:
        (vx, vy), (ox, oy) = visitor(t), other(t)
        return seen(((vx + ox) / 2, (vy + oy) / 2)) if math.hypot(vx - ox, vy - oy) < 0.4 else seen((vx, vy), (ox, oy))

    for k in range(10):
        tracker.update(scan(k / RATE), ORIGIN, k / RATE)
    assert tracker.lock_visitor()
    vid = tracker.visitor.track_id
    reports = [tracker.update(scan(k / RATE), ORIGIN, k / RATE) for k in range(10, 60)]
    blob = [r for r in reports if len(r.detections.people) == 1]
    assert blob and all(r.ambiguous and r.visitor.sight == Sight.HIDDEN for r in blob)
    assert blob[0].visitor.confidence == pytest.approx(0.5, abs=0.01)
    other_id = next(tr.id for tr in reports[0].tracks if tr.id != vid)
    for r in reports:
        v = r.visitor
        assert v.track_id == vid and [tr.id for tr in r.tracks] == [vid, other_id], r
        assert math.dist((v.x, v.y), visitor(r.t)) <= math.dist((v.x, v.y), other(r.t)) + 1e-6, r   # no swap
    last = reports[-1].visitor
    assert last.seen and (last.x, last.y) == pytest.approx(visitor(5.9), abs=0.05)


def test_time_going_back_starts_afresh() -> None:
    tracker = PeopleTracker(params=TrackerParams(lock_bearing=0.0, lock_half_angle=math.pi))
    for k in range(5):
        tracker.update(seen((1.0, 0.0)), ORIGIN, 10.0 + k / RATE)
    assert tracker.lock_visitor()
    report = tracker.update(seen((1.0, 0.0)), ORIGIN, 0.0)
    assert report.visitor.sight == Sight.LOST and not report.tracks


def test_bad_input_is_refused() -> None:
    tracker = PeopleTracker()
    with pytest.raises(PerceptionError, match="not finite"):
        tracker.update(seen(), Pose2D(math.nan, 0.0, 0.0), 0.0)
    with pytest.raises(PerceptionError) as info:
        TrackerParams(gate_max=0.0, confirm_hits=0, lock_bearing=math.inf)
    assert all(name in str(info.value) for name in ("gate_max", "confirm_hits", "lock_bearing"))


def test_the_people_topics_stay_on_the_robot() -> None:
    """The visitor's track is this robot's own: the people topics are relative names, never /gidabot/ ones
    (which the relays share)."""
    for name in (Topic.PEOPLE_TRACKS, Topic.PEOPLE_VISITOR, Topic.PEOPLE_VISITOR_LOCK, Topic.PEOPLE_WATCH):
        assert not name.startswith("/")


def test_the_wish_for_a_visitor_locks_on_a_change_only() -> None:
    """The lock topic is latched: the same wish again (a reconnection) must not lock someone else mid-trip."""
    w = walk()
    w.run(1.0)
    assert w.tracker.want_visitor(True) and w.tracker.visitor.seen
    vid = w.tracker.visitor.track_id
    w.run(0.5)
    assert not w.tracker.want_visitor(True) and w.tracker.visitor.track_id == vid
    assert w.tracker.want_visitor(False) and w.tracker.visitor.sight == Sight.NONE
    assert not w.tracker.want_visitor(False)


def _walked_ahead(tracker: PeopleTracker) -> None:
    """The visitor, locked behind the robot (the cone), walks past it to 4 m in front; a bystander stands in
    the cone. People are watched all along (a trip), so a lock let go and asked anew keeps the tracks."""
    tracker.want_people(True)
    for k in range(10):
        tracker.update(seen((-1.5, 1.0), (-2.0, -1.2)), ORIGIN, k / RATE)
    assert tracker.want_visitor(True) and tracker.visitor.x == pytest.approx(-1.5, abs=0.05)
    for k in range(10, 80):                              # 5.5 m in 7 s, beside the robot, to (4, 1)
        x = min(-1.5 + 0.8 * (k - 10) / RATE, 4.0)
        tracker.update(seen((x, 1.0), (-2.0, -1.2)), ORIGIN, k / RATE)
    assert tracker.visitor.seen and tracker.visitor.x == pytest.approx(4.0, abs=0.1)


@pytest.mark.parametrize(("relock_now", "taken_x"), [(True, 4.0), (False, -2.0)])
def test_a_lock_asked_anew_takes_the_track_nearest_where_the_visitor_was_last_seen(relock_now: bool,
                                                                                   taken_x: float) -> None:
    """A visitor out of the cone (4 m in front of a robot that waits facing them) asked for anew (false then
    true, the guiding core's relock) is taken where they were last seen, not the bystander in the cone; after a
    scan without a visitor wanted, a lock is a new visitor's: the cone's."""
    tracker = PeopleTracker(params=TrackerParams(visitor_lost_after=1.0))
    _walked_ahead(tracker)
    tracker.want_visitor(False)
    if not relock_now:
        tracker.update(seen((4.0, 1.0), (-2.0, -1.2)), ORIGIN, 8.0)
    assert tracker.want_visitor(True)
    assert tracker.visitor.x == pytest.approx(taken_x, abs=0.1)


def test_a_visitor_lost_and_seen_again_on_a_new_track_is_taken_again_where_last_seen() -> None:
    """The visitor stands 4 m in front; a gap in the scans loses them (LOST), then they are seen again on a new
    track where they stood: a lock asked anew takes that track, not the bystander in the cone."""
    tracker = PeopleTracker(params=TrackerParams(visitor_lost_after=1.0))
    _walked_ahead(tracker)
    vid = tracker.visitor.track_id
    for k in range(80, 110):                                            # unseen: LOST, its track dropped
        report = tracker.update(seen(), ORIGIN, k / RATE)
    assert report.visitor.sight == Sight.LOST
    for k in range(110, 120):                  # seen again where it stood (a new track), the bystander too
        report = tracker.update(seen((3.9, 1.1), (-2.0, -1.2)), ORIGIN, k / RATE)
    assert vid not in {tr.id for tr in report.tracks}
    tracker.want_visitor(False)
    assert tracker.want_visitor(True)
    v = tracker.visitor
    assert v.seen and (v.x, v.y) == pytest.approx((3.9, 1.1), abs=0.05)


def test_the_laser_is_needed_only_while_people_or_the_visitor_are_wanted() -> None:
    """Watched during a trip, the visitor wanted while guiding: the laser is needed while either is. When neither
    is, the tracker pauses (tracks and time dropped); a lock asked while paused waits its window from the first
    scan after, however long the pause (the time gap is no lock window spent)."""
    tracker = PeopleTracker(params=TrackerParams(lock_window=2.0))
    assert not tracker.needs_scans
    assert tracker.want_people(True) and tracker.needs_scans
    for k in range(10):
        report = tracker.update(seen((-1.5, 0.0)), ORIGIN, k / RATE)
    assert len(report.tracks) == 1
    assert not tracker.want_visitor(False) and tracker.needs_scans          # the same wish: nothing changes
    assert tracker.want_people(False) and not tracker.needs_scans
    assert not tracker.want_people(False)
    assert tracker.want_visitor(True) and tracker.needs_scans and tracker.visitor.sight == Sight.ACQUIRING
    report = tracker.update(seen((-1.5, 0.0)), ORIGIN, 500.0)             # 500 s later: tracks start afresh
    assert report.visitor.sight == Sight.ACQUIRING and all(not t.confirmed for t in tracker._tracks)
    for k in range(1, 10):
        report = tracker.update(seen((-1.5, 0.0)), ORIGIN, 500.0 + k / RATE)
    assert report.visitor.sight == Sight.SEEN
    assert tracker.want_visitor(False) and not tracker.needs_scans and not tracker._tracks


def test_scans_are_tracked_at_most_at_the_track_rate() -> None:
    """A 10 Hz laser and a 5 Hz tracker: every other scan is tracked; a scan from before the last one (a restarted
    simulation) always is."""
    tracker = PeopleTracker(params=TrackerParams(track_rate=5.0))
    tracked = []
    for k in range(10):
        t = k / 10.0
        if tracker.wants_scan(t):
            tracker.update(seen((-1.5, 0.0)), ORIGIN, t)
            tracked.append(k)
    assert tracked == [0, 2, 4, 6, 8]
    assert tracker.wants_scan(0.1)
    with pytest.raises(PerceptionError, match="track_rate"):
        TrackerParams(track_rate=0.0)


@pytest.mark.parametrize(("relock_speed", "taken"), [(0.5, (2.5, 2.3)), (0.001, None)])
def test_a_lock_asked_anew_reaches_further_the_longer_the_visitor_was_unseen(
        relock_speed: float, taken: tuple[float, float] | None) -> None:
    """The visitor, last seen 4 m in front, is lost from view and seen again 2 m from there 4 s later (it walked
    on while the robot passed it): a lock asked anew takes them, ``relock_radius`` (1.5 m) having grown by
    ``relock_speed`` for every second unseen (up to ``relock_max``); with a radius that does not grow, nobody:
    its cone looks towards where the visitor was (they stand beyond ``lock_distance``), not at the bystander
    behind the robot."""
    tracker = PeopleTracker(params=TrackerParams(visitor_lost_after=1.0, relock_speed=relock_speed))
    _walked_ahead(tracker)
    for k in range(80, 110):                                            # unseen: LOST, its track dropped
        report = tracker.update(seen((-2.0, -1.2)), ORIGIN, k / RATE)
    assert report.visitor.sight == Sight.LOST
    for k in range(110, 120):                                           # seen again 2 m away, a new track
        tracker.update(seen((2.5, 2.3), (-2.0, -1.2)), ORIGIN, k / RATE)
    tracker.want_visitor(False)
    assert tracker.want_visitor(True)
    if taken is None:
        assert tracker.visitor.sight == Sight.ACQUIRING
    else:
        assert (tracker.visitor.x, tracker.visitor.y) == pytest.approx(taken, abs=0.05)


def test_a_lock_asked_anew_looks_towards_where_the_visitor_was_last_seen() -> None:
    """The visitor, last seen 4 m in front, lost; the robot waits facing there. Someone stands 1.6 m in front of it
    (3 m from where the visitor was: beyond the relock radius), a bystander in the cone behind it: a lock asked
    anew at once takes the one in front (its cone turned towards where the visitor was), not the bystander."""
    tracker = PeopleTracker(params=TrackerParams(visitor_lost_after=1.0, relock_speed=0.001))
    _walked_ahead(tracker)
    for k in range(80, 110):
        tracker.update(seen((-2.0, -1.2)), ORIGIN, k / RATE)
    for k in range(110, 115):
        tracker.update(seen((1.6, -0.4), (-2.0, -1.2)), ORIGIN, k / RATE)
    tracker.want_visitor(False)
    assert tracker.want_visitor(True)
    assert (tracker.visitor.x, tracker.visitor.y) == pytest.approx((1.6, -0.4), abs=0.05)
