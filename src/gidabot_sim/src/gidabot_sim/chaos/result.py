"""The result of a chaos run (ROS-free): every fault and its recovery, the goals' fates, Table 3, crashes,
the printed table and the JSON object, and whether every target was met.

**Recovery time** (docs/chaos.md): from the moment a fault is cleared to the first delivery across the
affected link (both ways), on the restarted master (to a subscriber that registered after the restart), or of
the restarted/frozen node's output on every other master; the target is ``RECOVERY_TARGET_S``.
"""

from __future__ import annotations

import math
import statistics
from collections import Counter, defaultdict
from dataclasses import asdict, dataclass, field
from typing import Any

from gidabot_sim.chaos.bookkeeping import GoalFate, StepFate
from gidabot_sim.chaos.schedule import KINDS, Fault, Kind

RECOVERY_TARGET_S = 5.0
# what the relay ends did (their /diagnostics): links lost, events sent again on a new connection, events the
# peer said at reconnection it had stored (their acknowledgement was lost), duplicates the receiver dropped
RELAY_COUNTERS = ("link_losses", "connections", "resent", "acked_on_reconnect", "duplicates_suppressed", "dropped")


@dataclass
class FaultResult:
    """What happened to one fault: wall times (s since the epoch), recovery in s (None: not measured for
    this kind, or not recovered within the wait: see ``recovered``)."""

    fault: Fault
    injected: float | None = None
    cleared: float | None = None
    recovery_s: float | None = None
    recovered: bool = True
    skipped: str = ""                  # why it was not injected
    detail: str = ""
    accounted: dict[str, int] | None = None   # hostile messages: rejection counters that grew (node.counter: +n)

    def row(self) -> dict[str, Any]:
        d = asdict(self.fault)
        d.update(injected=self.injected, cleared=self.cleared, recovery_s=self.recovery_s, recovered=self.recovered,
                 skipped=self.skipped, detail=self.detail)
        if self.accounted is not None:
            d["accounted"] = self.accounted
        return d


@dataclass
class ChaosResult:
    seed: int
    tour: str
    speed: float
    faults: list[FaultResult]
    fates: dict[str, GoalFate]
    duplicated_cancels: dict[str, list[str]]
    table3_expected: dict[str, tuple[int, int]]
    table3_measured: dict[str, tuple[int, int]]
    table3_bags: dict[str, tuple[int, int]]
    tours_intact: bool
    tours_problems: list[str]
    crashes: list[str]
    tracebacks: dict[str, int]
    hostile_rejected: dict[str, int]
    partner_lost: int
    partner_answered: int
    tour_completed: bool
    outcome: str
    run_folder: str
    wall_s: float = 0.0
    sim_s: float = 0.0
    steps: list[StepFate] = field(default_factory=list)            # what the visitor asked for, and its fate
    table3_bags_expected: dict[str, tuple[int, int]] = field(default_factory=dict)   # expected + retried trips
    bags_error: str = ""                                           # the bags could not be read
    machines: bool = False
    relay_counters: dict[str, int] = field(default_factory=dict)   # RELAY_COUNTERS summed over every relay end
    republished_cancels: dict[str, list[str]] = field(default_factory=dict)   # published again by their node
    table3_tour: dict[str, tuple[int, int]] = field(default_factory=dict)     # the tour's, before retries

    # -- derived --------------------------------------------------------------------------
    def injected(self) -> list[FaultResult]:
        return [f for f in self.faults if f.injected is not None]

    def counts(self) -> dict[str, int]:
        c = Counter(f.fault.kind for f in self.injected())
        return {k: c.get(k, 0) for k in KINDS}

    def recoveries(self) -> dict[str, list[float]]:
        out: dict[str, list[float]] = defaultdict(list)
        for f in self.injected():
            if f.recovery_s is not None:
                out[f.fault.kind].append(f.recovery_s)
        return out

    def unrecovered(self) -> list[FaultResult]:
        return [f for f in self.injected() if not f.recovered]

    def max_recovery(self) -> float | None:
        values = [v for vs in self.recoveries().values() for v in vs]
        if self.unrecovered():
            return math.inf
        return max(values) if values else None

    def lost(self) -> list[str]:
        return sorted(uid for uid, f in self.fates.items() if f.lost)

    def duplicated(self) -> list[str]:
        return sorted(uid for uid, f in self.fates.items() if f.duplicated)

    def republished(self) -> list[str]:
        """Goals their own node published again after its restart (or replayed on a new connection): no
        duplicate, each receiver ignores the copy (:func:`republication`); listed apart."""
        return sorted(uid for uid, f in self.fates.items() if f.republished)

    def node_crashes(self) -> int:
        return len(self.crashes) + sum(self.tracebacks.values())

    def unaccounted_hostile(self) -> list[str]:
        """Hostile messages injected that no node of the master they were sent to rejected and counted."""
        return [f.fault.label() for f in self.injected() if f.fault.kind == Kind.HOSTILE and not f.accounted]

    def unfinished_steps(self) -> list[StepFate]:
        return [st for st in self.steps if not st.passed]

    def failures(self) -> list[str]:
        """Every target missed (empty: the run passed)."""
        out = []
        if len(self.injected()) < len([f for f in self.faults if not f.skipped]) or \
                any(f.skipped for f in self.faults if f.fault.kind != Kind.CORRIDOR):
            out.append("not every planned fault was injected")
        if self.lost():
            out.append(f"{len(self.lost())} goal(s) lost")
        if self.duplicated() or self.duplicated_cancels:
            out.append(f"{len(self.duplicated())} goal(s) and {len(self.duplicated_cancels)} cancel(s) duplicated")
        mr = self.max_recovery()
        if mr is not None and mr > RECOVERY_TARGET_S:
            out.append(f"a recovery took {'too long (not recovered)' if math.isinf(mr) else f'{mr:.1f} s'}")
        if self.unfinished_steps():
            out.append(f"{len(self.unfinished_steps())} request(s) of the visitor neither completed nor ended by the "
                       "visitor: " + "; ".join(st.describe() for st in self.unfinished_steps()))
        if self.table3_measured != self.table3_expected:
            out.append("Table 3 counts differ from the fault-free tour")
        if self.bags_error:
            out.append(f"the bags could not be read: {self.bags_error}")
        elif self.table3_bags != self.table3_bags_expected:
            out.append("Table 3 from the bags differs from the tour's (with the retried trips)")
        if self.unaccounted_hostile():
            out.append(f"{len(self.unaccounted_hostile())} hostile message(s) not rejected and counted by any node: "
                       + "; ".join(self.unaccounted_hostile()))
        if not self.tours_intact:
            out.append("a tour directory changed")
        if self.partner_answered < self.partner_lost:
            out.append(f"{self.partner_lost - self.partner_answered} 'partner lost' notice(s) never followed by "
                       "'partner back' or the end of that robot's part")
        if self.node_crashes():
            out.append(f"{self.node_crashes()} node crash(es)")
        if not self.tour_completed:
            out.append(f"the tour was not completed ({self.outcome})")
        return out

    def to_json(self) -> dict[str, Any]:
        rec = {k: {"n": len(v), "max_s": round(max(v), 2), "median_s": round(statistics.median(v), 2)}
               for k, v in self.recoveries().items()}
        mr = self.max_recovery()
        table = {k: list(v) for k, v in self.table3_bags.items()}
        return {
            "seed": self.seed, "tour": self.tour, "speed": self.speed, "machines": self.machines,
            "faults": [f.row() for f in self.faults], "fault_counts": self.counts(),
            "faults_injected": len(self.injected()), "faults_planned": len(self.faults),
            "accepted": len(self.fates),
            "completed": sum(1 for f in self.fates.values() if f.completed),
            "cancelled": sum(1 for f in self.fates.values() if f.cancelled),
            "lost": len(self.lost()), "duplicated": len(self.duplicated()),
            "cancels_duplicated": len(self.duplicated_cancels),
            "republished": len(self.republished()), "cancels_republished": len(self.republished_cancels),
            "republished_goals": {u: self.fates[u].republished for u in self.republished()},
            "republished_cancels": self.republished_cancels,
            "max_recovery_s": None if mr is None else (round(mr, 2) if math.isfinite(mr) else "not recovered"),
            "recovery": rec,
            "requests": [{"step": st.step, "passed": st.passed, "goals": st.goals, "completed_by": st.completed_by,
                          "system_ends": st.system_ends, "visitor_ends": st.visitor_ends, "refusals": st.refusals}
                         for st in self.steps],
            "ended_by_system": [e for st in self.steps for e in st.system_ends],
            "node_crashes": self.node_crashes(), "crashes": self.crashes, "tracebacks": self.tracebacks,
            "table3_bags": table,
            "table3": {"expected": {k: list(v) for k, v in self.table3_expected.items()},
                       "measured": {k: list(v) for k, v in self.table3_measured.items()},
                       "bags": table, "bags_expected": {k: list(v) for k, v in self.table3_bags_expected.items()},
                       "bags_error": self.bags_error,
                       "tour": {k: list(v) for k, v in (self.table3_tour or self.table3_expected).items()},
                       "unchanged": self.table3_measured == self.table3_expected},
            "tours_intact": self.tours_intact, "tours_problems": self.tours_problems,
            "hostile_rejected": self.hostile_rejected,
            "hostile_unaccounted": self.unaccounted_hostile(),
            "relay_counters": self.relay_counters,
            "partner_lost": self.partner_lost, "partner_lost_answered": self.partner_answered,
            "tour_completed": self.tour_completed, "outcome": self.outcome,
            "lost_goals": self.lost(), "duplicated_goals": {u: self.fates[u].duplicated for u in self.duplicated()},
            "visible_failures": {u: f.visible_failures for u, f in self.fates.items() if f.visible_failures},
            "wall_s": round(self.wall_s, 1), "sim_s": round(self.sim_s, 1),
            "passed": not self.failures(), "failures": self.failures(),
            "run_folder": self.run_folder,
        }

    def format(self) -> str:
        lines = [f"Chaos run: seed {self.seed}, tour {self.tour}, speed {self.speed:g}x; "
                 f"wall {self.wall_s:.0f} s, sim {self.sim_s:.0f} s", "",
                 f"{'Fault kind':<28} {'Injected':>8} {'Recovery max (s)':>17} {'median (s)':>11}"]
        lines.append("-" * len(lines[-1]))
        recs = self.recoveries()
        counts = self.counts()
        for kind in KINDS:
            v = recs.get(kind, [])
            unrec = sum(1 for f in self.unrecovered() if f.fault.kind == kind)
            mx = "not recovered" if unrec else (f"{max(v):.2f}" if v else "-")
            med = f"{statistics.median(v):.2f}" if v else "-"
            lines.append(f"{kind:<28} {counts[kind]:>8} {mx:>17} {med:>11}")
        lines.append(f"{'total':<28} {len(self.injected()):>8}")
        mr = self.max_recovery()
        fates = self.fates
        crashes = f" ({'; '.join(self.crashes[:5])}{'; ...' if len(self.crashes) > 5 else ''})" if self.crashes else ""
        tbs = f"; tracebacks: {', '.join(f'{k} {v}' for k, v in self.tracebacks.items())}" if self.tracebacks else ""
        tours = "yes" if self.tours_intact else "NO: " + "; ".join(self.tours_problems)
        lines += ["",
                  f"Goals accepted {len(fates)}, completed {sum(1 for f in fates.values() if f.completed)}, "
                  f"cancelled {sum(1 for f in fates.values() if f.cancelled)}, lost {len(self.lost())}, "
                  f"duplicated {len(self.duplicated())} (cancels duplicated {len(self.duplicated_cancels)})",
                  f"Published again by their own node after its restart (same uid, ignored by every receiver; "
                  f"not duplicates): {len(self.republished())} goal(s), {len(self.republished_cancels)} cancel(s)"
                  + "".join(f"\n  {u}: {'; '.join(self.fates[u].republished)}" for u in self.republished())
                  + "".join(f"\n  cancel {u}: {'; '.join(v)}" for u, v in self.republished_cancels.items()),
                  "Max recovery: " + ("-" if mr is None else "not recovered" if math.isinf(mr) else f"{mr:.2f} s")
                  + f" (target {RECOVERY_TARGET_S:g} s)",
                  f"Partner offline notices: {self.partner_lost}, followed by 'back' or the end of the leg: "
                  f"{self.partner_answered}",
                  "Hostile messages rejected (counters): "
                  + (", ".join(f"{k} {v}" for k, v in sorted(self.hostile_rejected.items())) or "-"),
                  "Hostile messages, each rejected and counted on the master it was sent to: "
                  + (", ".join(f"{f.fault.target}@{f.fault.robot} -> "
                               + (",".join(f"{k} +{v}" for k, v in sorted((f.accounted or {}).items())) or "NOTHING")
                               for f in self.injected() if f.fault.kind == Kind.HOSTILE) or "-"),
                  "Relay ends (all links, summed): "
                  + (", ".join(f"{k} {self.relay_counters.get(k, 0)}" for k in RELAY_COUNTERS)
                     if self.relay_counters else "-"),
                  "What the visitor asked for: "
                  + (f"{sum(st.passed for st in self.steps)} of {len(self.steps)} completed or ended by the visitor"
                     if self.steps else "-"),
                  *[f"  {st.describe()}" for st in self.steps if st.system_ends or st.refusals or not st.passed],
                  f"Node crashes: {self.node_crashes()}{crashes}{tbs}",
                  f"Tour directories intact: {tours}",
                  "", f"{'Table 3':<14} {'expected':>12} {'probes':>12} {'bags':>12} {'bags expected':>14}"]
        for name, exp in self.table3_expected.items():
            m = self.table3_measured.get(name, (0, 0))
            b = self.table3_bags.get(name)
            be = self.table3_bags_expected.get(name, exp)
            lines.append(f"{name:<14} {exp[0]:>5} / {exp[1]:<4} {m[0]:>5} / {m[1]:<4} "
                         + (f"{b[0]:>5} / {b[1]:<4}" if b else f"{'-':>12}") + f" {be[0]:>6} / {be[1]:<5}")
        if self.table3_tour and self.table3_tour != self.table3_expected:
            lines.append("(expected: a step the system ended counted as the trip of the retry that completed it; "
                         "the tour's: " + ", ".join(f"{k} {a} / {b}" for k, (a, b) in self.table3_tour.items()) + ")")
        if self.bags_error:
            lines.append(f"(bags: {self.bags_error})")
        lines += ["", f"Tour: {self.outcome}"]
        failures = self.failures()
        lines.append("RESULT: " + ("PASSED (every request completed, 0 lost, 0 duplicated, recoveries within 5 s, "
                                   "Table 3 as expected from probes and bags, every hostile message counted, no "
                                   "crash, tours intact)" if not failures else "FAILED: " + "; ".join(failures)))
        return "\n".join(lines)
