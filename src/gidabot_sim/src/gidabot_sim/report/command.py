"""``gidabot report <run folder>``: the paper's tables from a run's rosbags (no ROS needed).

A run folder (written by ``gidabot demo``/``chaos``) holds ``run.json`` and one
rosbag per robot (``<robot>.bag``, recorded on that robot's master; after a restart
of its master the recording goes on in further parts, ``run.json`` lists them as
``bags``, and every part is read: a message in two parts counts once). Bags are
read with the ``rosbags`` library, which takes the message definitions from the
bags themselves. Printed (``--json``: the same as one JSON object):

* per robot, goal messages received and processed (paper Table 3), hostile input left
  out (docs/demo.md, *The report*):

  - *received*: the goals the robot validated and kept: distinct goals on
    ``/gidabot/goals`` of its master that pass the goal manager's own check
    (``guiding.messages.validate_trip`` against the run's building) and were published
    by their origin robot's goal manager (the bag's connection header: ``callerid``
    ``/goal_manager`` for the robot's own goals, the relay end from the origin robot
    for the others'). Other messages are counted apart (``rejected_goals``);
  - *processed*: the trips the robot ran: its goal manager accepted them (an
    ``ACCEPTED`` event published by its own ``/goal_manager``) and its navigation
    worked on them (an event of its own ``/multirobot_navigation``).

  A robot's events (Table 5, completions) are the ones its own guiding nodes published
  (bags without publisher information: every event naming the robot);
* per robot, time, distance and mean velocity while guiding the visitor (paper
  Table 5): from the robot's ``ON_THE_WAY`` event (or, if later, from when its move_base took
  that leg's goal: ``move_base/current_goal``) to the end of that leg, with the
  distance integrated over the robot's own localisation (``/amcl_pose`` of its bag:
  a sample every 0.1 m, whatever the sim speed; bags without it: the robot's
  ``/gidabot/poses``); and the tour total;
* a run with many visitors (``gidabot demo --visitors``: ``population`` in ``run.json``): per
  robot legs served, busy fraction and queue length, per visitor wait and trip time, the mean
  and 95th percentile wait, visits completed, cancelled and timed out (:mod:`gidabot_sim.report.crowd`
  over the run's ``monitor.jsonl``), and a verdict: FAILED (exit 1) on a visit that did not end as
  its visitor chose, a lost or duplicated goal, a leg served by two robots or by none;
* one PNG per floor with the path each robot followed over the blueprint (Fig. 7):
  thick while guiding the visitor, thin dashed while driving alone (to a meeting
  point, back to the visitor), the tour's goals numbered by step;
* the run's timing (:mod:`gidabot_sim.report.rates`): per floor over the tour, the achieved factor and
  the wall time its clock was behind its speed ceiling (``run.json``, from the floors' timeline),
  each lockstep controller's answers against the steps it owed (move_base, amcl: its rate in
  sim time against nominal) and each guiding node's loop rate against nominal (the floor's
  ``/diagnostics`` in its bag), the largest drift between floors; the run is *degraded* when a
  floor was behind for more than 1 % of the tour or a rate fell below 80 % of nominal.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gidabot_sim.report.run_report import report_run


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="gidabot report", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", type=Path, help="run folder written by gidabot demo / chaos")
    parser.add_argument("--json", action="store_true", help="print the tables as one JSON object")
    parser.add_argument("--markdown", action="store_true",
                        help="print the tables (and the run's timing and CPU) as Markdown, as the docs show them")
    parser.add_argument("--no-plots", action="store_true", help="do not write the per-floor path PNGs")
    args = parser.parse_args(argv)
    return report_run(args.run, json_out=args.json, markdown=args.markdown, plots=not args.no_plots)
