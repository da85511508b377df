"""A population of simulated visitors, deterministic from a seed (ROS-free).

``make_population`` draws K visitors: each arrives at a random time (exponential gaps,
``mean_gap_s`` apart on average) on a random floor with robots, at the screen of one of them,
and asks for a random single target or, now and then, a tour, by the stairs or the lift; some
cancel after a while, some never turn up at the meeting point on the goal floor (the robot
waiting there gives up: ``TIMEOUT``). Each has a *patience*: the longest wait it accepts when the screen
shows, before it confirms, how long until the robots of its trip are there (the paper's
pending requests); a longer one and it does not confirm, it leaves. The same building,
tours, K and seed give the same visitors, so a run can be repeated and its numbers compared
(the patience and the robot of a floor with several come from streams of their own: see
:func:`make_population`).

A plan says what the visitor *chooses* (:attr:`VisitorPlan.intent`): ``complete`` (the trip
should complete), ``cancel`` (cancelling, or completing before the cancel, is as chosen),
``no_show`` (the trip should end in a timeout); and whether it confirms at all is its choice
at the screen (leaving is as chosen). The report checks each trip against it
(:mod:`gidabot_sim.report.crowd`).
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass

from gidabot_navigation.building.model import Building
from gidabot_navigation.interface import WAYS
from gidabot_sim.errors import SimConfigError

INTENT_COMPLETE, INTENT_CANCEL, INTENT_NO_SHOW = "complete", "cancel", "no_show"
MAX_VISITORS = 500


@dataclass(frozen=True)
class VisitorPlan:
    visitor_id: str                 # also the Goal.visitor_id of its trips
    arrive_s: float                 # sim s after every robot is up: when it presses the button
    robot: str                      # the robot whose screen it uses (the start robot)
    way: str                        # stairs or lift, for every floor change
    goal_id: str = ""               # a single target, or
    tour_file: str = ""             # a tour
    cancel_after_s: float = -1.0    # >= 0: presses Cancel this long after asking, if not done by then
    no_show: bool = False           # never turns up at a meeting point on another floor
    patience_s: float = -1.0        # >= 0: does not confirm when a wait shown before confirming is longer (sim s)

    @property
    def intent(self) -> str:
        if self.no_show:
            return INTENT_NO_SHOW
        return INTENT_CANCEL if self.cancel_after_s >= 0 else INTENT_COMPLETE

    def to_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(raw: object) -> VisitorPlan:
        """A plan from JSON (a run.json, a ROS parameter): every field checked, a clear error otherwise."""
        if not isinstance(raw, Mapping):
            raise SimConfigError(f"visitor plan {raw!r}: expected a mapping")
        unknown = set(raw) - set(VisitorPlan.__dataclass_fields__)
        if unknown:
            raise SimConfigError(f"visitor plan {raw.get('visitor_id')!r}: unknown keys {sorted(unknown)}")
        try:
            plan = VisitorPlan(visitor_id=str(raw["visitor_id"]), arrive_s=float(raw["arrive_s"]),
                               robot=str(raw["robot"]), way=str(raw["way"]), goal_id=str(raw.get("goal_id", "")),
                               tour_file=str(raw.get("tour_file", "")),
                               cancel_after_s=float(raw.get("cancel_after_s", -1.0)),
                               no_show=raw.get("no_show", False) is True,
                               patience_s=float(raw.get("patience_s", -1.0)))
        except (KeyError, TypeError, ValueError) as err:
            raise SimConfigError(f"visitor plan {raw.get('visitor_id')!r}: {err!r}") from err
        if not (math.isfinite(plan.arrive_s) and plan.arrive_s >= 0 and math.isfinite(plan.cancel_after_s)
                and math.isfinite(plan.patience_s)):
            raise SimConfigError(f"visitor plan {plan.visitor_id!r}: times must be finite, arrive_s >= 0")
        if plan.way not in WAYS or bool(plan.goal_id) == bool(plan.tour_file):
            raise SimConfigError(f"visitor plan {plan.visitor_id!r}: way {plan.way!r} must be one of "
                                 f"{', '.join(WAYS)}, and exactly one of goal_id and tour_file set")
        return plan


def plans_from_list(raw: object, building: Building) -> tuple[VisitorPlan, ...]:
    """Plans read back (run.json, ``~population``), checked against ``building``: known robots and targets,
    distinct visitor ids."""
    if not isinstance(raw, Sequence) or isinstance(raw, (str, bytes)) or len(raw) > MAX_VISITORS:
        raise SimConfigError(f"population: expected a list of at most {MAX_VISITORS} visitor plans")
    plans = tuple(VisitorPlan.from_dict(r) for r in raw)
    ids = [p.visitor_id for p in plans]
    if len(set(ids)) != len(ids):
        raise SimConfigError("population: visitor ids must be distinct")
    for p in plans:
        if building.find_robot(p.robot) is None:
            raise SimConfigError(f"visitor plan {p.visitor_id!r}: {p.robot!r} is not a robot of {building.id}")
        if p.goal_id and building.find_location(p.goal_id) is None:
            raise SimConfigError(f"visitor plan {p.visitor_id!r}: {p.goal_id!r} is not a location of {building.id}")
    return plans


PATIENCE_S = (300.0, 1200.0)     # sim s: the longest wait a visitor accepts, uniform between these


def make_population(building: Building, count: int, seed: int, tours: Mapping[str, int] | None = None,
                    mean_gap_s: float = 30.0, p_tour: float = 0.1, p_cancel: float = 0.2,
                    p_no_show: float = 0.15, patience_s: tuple[float, float] | None = PATIENCE_S
                    ) -> tuple[VisitorPlan, ...]:
    """``count`` visitors drawn from ``seed``. ``tours``: tour file name -> number of stops, the tours a visitor
    may take (none: single targets only). A visitor arrives on a random floor with robots, at the screen of one of
    that floor's robots (drawn from a stream of its own): two buildings with robots on the same floors and the
    same locations (``maps/faculty``, ``maps/faculty6``) get the same visitors from the same seed, only the robot
    whose screen they use may differ, so their runs compare. A no-show is only drawn for a target on another
    floor that has a robot (someone waits for the visitor there). ``patience_s``: (low, high) of the uniform
    patience (sim s; None: every visitor waits however long it is shown), drawn from a stream of its own."""
    if not 1 <= count <= MAX_VISITORS:
        raise SimConfigError(f"visitors: {count} (expected 1..{MAX_VISITORS})")
    if not (math.isfinite(mean_gap_s) and mean_gap_s > 0):
        raise SimConfigError(f"mean gap between arrivals {mean_gap_s!r}: expected s > 0")
    rng = random.Random(seed)
    patience_rng = random.Random(f"patience {seed}")
    if patience_s is not None and not (all(math.isfinite(v) and v >= 0 for v in patience_s)
                                       and patience_s[0] <= patience_s[1]):
        raise SimConfigError(f"patience {patience_s!r}: expected (low, high) s with 0 <= low <= high")
    floors = sorted({r.floor for r in building.robots})
    screen_rng = random.Random(f"screen {seed}")
    locations = sorted(building.locations, key=lambda loc: loc.id)
    tour_files = sorted(tours or {})
    width = len(str(count))
    plans, t = [], 0.0
    for i in range(count):
        t += rng.expovariate(1.0 / mean_gap_s)
        floor = rng.choice(floors)
        robot = screen_rng.choice(sorted(building.robots_on(floor), key=lambda r: r.name))
        way = rng.choice(sorted(WAYS))
        tour = rng.choice(tour_files) if tour_files and rng.random() < p_tour else ""
        target = "" if tour else rng.choice(locations).id
        cancel = rng.uniform(10.0, 150.0) if rng.random() < p_cancel else -1.0
        elsewhere = bool(target) and not math.isclose(building.location(target).floor, robot.floor) \
            and building.has_robot(building.location(target).floor)
        no_show = rng.random() < p_no_show and elsewhere and cancel < 0
        patience = round(patience_rng.uniform(*patience_s), 1) if patience_s is not None else -1.0
        plans.append(VisitorPlan(visitor_id=f"visitor{i + 1:0{width}d}", arrive_s=round(t, 1), robot=robot.name,
                                 way=way, goal_id=target, tour_file=tour, cancel_after_s=round(cancel, 1),
                                 no_show=no_show, patience_s=patience))
    return tuple(plans)
