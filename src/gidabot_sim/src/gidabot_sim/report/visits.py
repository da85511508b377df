"""What a run's records say about visits (ROS-free), shared by the demo's progress and the report.

The progress monitor (``gidabot_sim.demo.monitor_node``) writes every goal, event and cancel it sees as one JSON
object per line (``monitor.jsonl``); a :class:`MonitorFeed` takes those lines. A visit is complete when
:func:`visit_completed` says so; the stops of a tour that are done are :func:`stops_done`.
"""

from __future__ import annotations

import json

from gidabot_navigation.interface import Phase


class MonitorFeed:
    """Something fed the monitor's JSON lines (monitor.jsonl): :meth:`feed` takes one record."""

    def feed(self, rec: dict) -> bool:
        raise NotImplementedError

    def feed_line(self, line: str) -> bool:
        """Take one JSON line; return True when the visible progress changed (a line that is not a JSON
        object changes nothing)."""
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            return False
        return self.feed(rec) if isinstance(rec, dict) else False


def visit_completed(phase: object, tour: bool) -> bool:
    """Whether an event of a visit's trip completes the visit: a tour's TOUR_FINISHED; one target's GOAL_REACHED,
    or NO_ROBOT_ON_FLOOR (the visitor sent to a floor without robot finds the place alone)."""
    return phase == Phase.TOUR_FINISHED or (not tour and phase in (Phase.GOAL_REACHED, Phase.NO_ROBOT_ON_FLOOR))


def stops_done(steps: set[int], alone: frozenset[int]) -> set[int]:
    """The tour stops done, from the steps whose goal was completed: a goal that sends the visitor to a stop on
    a floor without robot (``alone``: those steps) also covers the stops on such floors right after it, which
    get no goal of their own (docs/guiding.md, tour mode)."""
    done = set(steps)
    for k in sorted(steps):
        j = k + 1
        while k in alone and j in alone:
            done.add(j)
            j += 1
    return done
