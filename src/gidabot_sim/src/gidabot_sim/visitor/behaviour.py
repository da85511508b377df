"""How a simulated person walks (ROS-free): a visitor's behaviour drawn from its seed, and the bystanders'.

A visitor's body (:mod:`gidabot_sim.world.people`) follows its guiding robot ``gap`` metres behind along the
robot's path at its own ``speed`` (0.5-1.4 m/s: a slow one falls behind a robot driving faster), stops to look
at something now and then (``pauses``: (start, duration) in sim s after the visit started), may walk as a
``group`` (several bodies, one visitor) and may wander off for good (``wander_at`` s after the visit started:
from then on it neither follows nor presses a button). The single visitor of ``gidabot demo`` keeps :data:`TIDY`
(a steady pace, no pauses) unless ``--walk`` says how it walks (:func:`parse_walk`, e.g.
``speed=0.5,pause=20:60,group=3,wander_at=40``); a population's visitors draw theirs from their
``behaviour_seed`` (:func:`draw_behaviour`).

Bystanders (``--people N``) are nobody's visitor: each walks between places of its floor at its own speed,
and some stop for a while in the middle of a corridor, in the way of whoever comes (:func:`draw_bystanders`).
Everything is deterministic from the seed: the same seed gives the same people.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

from gidabot_sim.errors import SimConfigError

SPEED_RANGE = (0.5, 1.4)        # m/s, a person's walking speed
MAX_GROUP = 4                   # bodies of one visitor at most
# a drawn visitor's kind, with its probability
KINDS = (("steady", 0.35), ("slow", 0.2), ("pauses", 0.2), ("group", 0.15), ("wanders", 0.1))


@dataclass(frozen=True)
class Behaviour:
    """How a visitor's body walks (times in sim s after the visit started)."""

    speed: float = 1.1                               # m/s
    gap: float = 1.0                                 # m behind its robot, along the robot's path
    pauses: tuple[tuple[float, float], ...] = ()     # (start, duration): stands still meanwhile
    group: int = 1                                   # bodies walking together
    wander_at: float = -1.0                          # walks off for good then (< 0: never)
    kind: str = "steady"

    def __post_init__(self) -> None:
        problems = []
        if not (math.isfinite(self.speed) and SPEED_RANGE[0] <= self.speed <= SPEED_RANGE[1]):
            problems.append(f"speed {self.speed!r} m/s must be in {SPEED_RANGE[0]}..{SPEED_RANGE[1]}")
        if not (math.isfinite(self.gap) and 0.3 <= self.gap <= 5.0):
            problems.append(f"gap {self.gap!r} m must be in 0.3..5")
        if not (isinstance(self.group, int) and 1 <= self.group <= MAX_GROUP):
            problems.append(f"group {self.group!r} must be 1..{MAX_GROUP} bodies")
        if not math.isfinite(self.wander_at):
            problems.append(f"wander_at {self.wander_at!r} must be finite (s; < 0: never)")
        for start, duration in self.pauses:
            if not (math.isfinite(start) and math.isfinite(duration) and start >= 0 and duration > 0):
                problems.append(f"pause ({start!r}, {duration!r}) must be (start >= 0, duration > 0) s")
        if problems:
            raise SimConfigError(f"behaviour: {'; '.join(problems)}")

    @property
    def wanders(self) -> bool:
        return self.wander_at >= 0

    def wandered(self, since_start: float) -> bool:
        """Gone for good ``since_start`` s after the visit started."""
        return self.wanders and since_start >= self.wander_at

    def paused(self, since_start: float) -> bool:
        """Standing still to look at something ``since_start`` s after the visit started."""
        return any(start <= since_start < start + duration for start, duration in self.pauses)


TIDY = Behaviour()


WALK_KIND = "walk"              # the kind of a behaviour given by --walk
WALK_KEYS = ("speed", "gap", "pause", "group", "wander_at")


def parse_walk(text: str) -> Behaviour:
    """A behaviour from ``--walk`` text: comma-separated ``key=value`` of :data:`WALK_KEYS`, each at most once but
    ``pause`` (``START:DURATION`` s after the visit started; may repeat); the keys left out keep :data:`TIDY`'s
    values. ``speed=0.5,pause=20:60,group=3,wander_at=40``: 0.5 m/s, stands still from 20 s to 80 s, three bodies,
    walks off for good at 40 s. :class:`SimConfigError` lists every bad key or value, and what
    :class:`Behaviour` itself refuses."""
    problems: list[str] = []
    values: dict[str, object] = {}
    pauses: list[tuple[float, float]] = []
    items = [item.strip() for item in text.split(",")]
    if not text.strip():
        problems.append("empty: expected key=value[,key=value...]")
        items = []
    for item in items:
        key, sep, value = (part.strip() for part in item.partition("="))
        if not sep or not key or not value:
            problems.append(f"{item!r}: expected key=value")
        elif key not in WALK_KEYS:
            problems.append(f"unknown key {key!r} (keys: {', '.join(WALK_KEYS)})")
        elif key in values:
            problems.append(f"{key} given twice")
        elif key == "pause":
            try:
                start, duration = value.split(":")
                pauses.append((float(start), float(duration)))
            except ValueError:
                problems.append(f"pause {value!r}: expected START:DURATION (s)")
        elif key == "group":
            try:
                values[key] = int(value)
            except ValueError:
                problems.append(f"group {value!r}: expected a whole number of bodies")
        else:
            try:
                number = float(value)
            except ValueError:
                problems.append(f"{key} {value!r}: expected a number")
                continue
            if key == "wander_at" and not number >= 0:   # leaving the key out is "never"
                problems.append(f"wander_at {value!r}: expected s >= 0 after the visit started")
                continue
            values[key] = number
    try:
        behaviour = Behaviour(**values, pauses=tuple(pauses), kind=WALK_KIND)   # type: ignore[arg-type]
    except SimConfigError as err:
        problems.append(str(err))
    if problems:
        raise SimConfigError(f"walk {text!r}: {'; '.join(problems)}")
    return behaviour


def draw_behaviour(seed: int) -> Behaviour:
    """A visitor's behaviour from ``seed`` (< 0: :data:`TIDY`): its kind, then its numbers."""
    if seed < 0:
        return TIDY
    rng = random.Random(f"behaviour {seed}")
    roll, kind = rng.random(), KINDS[-1][0]
    for name, p in KINDS:
        if roll < p:
            kind = name
            break
        roll -= p
    speed = round(rng.uniform(0.9, SPEED_RANGE[1]), 2)
    gap = round(rng.uniform(0.8, 1.5), 2)
    if kind == "slow":                                # slower than a robot: falls behind
        return Behaviour(speed=round(rng.uniform(SPEED_RANGE[0], 0.7), 2), gap=gap, kind=kind)
    if kind == "pauses":
        pauses, t = [], 0.0
        for _ in range(rng.randint(1, 3)):
            t += rng.uniform(20.0, 120.0)
            duration = rng.uniform(5.0, 60.0)
            pauses.append((round(t, 1), round(duration, 1)))
            t += duration
        return Behaviour(speed=speed, gap=gap, pauses=tuple(pauses), kind=kind)
    if kind == "group":
        return Behaviour(speed=round(min(speed, 1.1), 2), gap=gap, group=rng.randint(2, 3), kind=kind)
    if kind == "wanders":
        return Behaviour(speed=speed, gap=gap, wander_at=round(rng.uniform(30.0, 150.0), 1), kind=kind)
    return Behaviour(speed=speed, gap=gap, kind=kind)


@dataclass(frozen=True)
class Bystander:
    """Somebody who walks the corridors of a floor between places: ``route`` is the seed of its choices of
    places; ``stand_s`` > 0: it stops that long halfway along each walk (in the way of whoever comes)."""

    person_id: str
    speed: float
    route: int
    stand_s: float = 0.0
    start_s: float = 0.0          # sim s before it sets off


def draw_bystanders(count: int, seed: int, floor_label: str) -> tuple[Bystander, ...]:
    """``count`` bystanders of a floor from ``seed``: one in three stands a while halfway along its walks."""
    if not 0 <= count <= 100:
        raise SimConfigError(f"people: {count!r} bystanders per floor (expected 0..100)")
    rng = random.Random(f"bystanders {seed} {floor_label}")
    people = []
    for k in range(count):
        stands = rng.random() < 1.0 / 3.0
        people.append(Bystander(person_id=f"bystander{k + 1}", speed=round(rng.uniform(*SPEED_RANGE), 2),
                                route=rng.randrange(1 << 30), stand_s=round(rng.uniform(20.0, 60.0), 1) if stands
                                else 0.0, start_s=round(rng.uniform(0.0, 20.0), 1)))
    return tuple(people)
