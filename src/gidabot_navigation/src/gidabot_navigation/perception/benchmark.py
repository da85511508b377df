"""What a scan costs the people detector and tracker (ROS-free): ``python -m gidabot_navigation.perception.benchmark``.

The scans are synthetic (:mod:`~gidabot_navigation.perception.synthetic`), made beforehand so only the
detector and the tracker are timed, in CPU time of the calling thread (what the scan costs, not what
other processes on a loaded machine take from it): a 12 x 8 m room with a square and a round pillar, a door frame, and
five people (three bodies, two pairs of legs) walking while the robot drives, with 0.01 m range noise.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.perception import synthetic as sy
from gidabot_navigation.perception.detector import Detector
from gidabot_navigation.perception.people import PeopleTracker

RATE = 10.0           # Hz, scans


def _scene(t: float) -> sy.Scene:
    walls = sy.box(0.0, 0.0, 12.0, 8.0) + sy.box(3.0, 2.0, 0.4, 0.4, 0.3) + \
        sy.Scene(discs=(sy.Disc(-3.0, -2.0, 0.3),),
                 walls=(sy.Wall(5.0, -4.0, 5.0, -0.45), sy.Wall(5.0, 0.45, 5.0, 4.0)))
    people = sy.Scene()
    for k, (x, y, vx, vy, legs) in enumerate([(-1.0, 0.0, 0.6, 0.0, False), (2.0, -2.5, -0.4, 0.3, True),
                                               (-4.0, 2.5, 0.5, -0.2, False), (1.0, 3.0, 0.0, -0.5, True),
                                               (4.0, 0.0, -0.7, 0.1, False)]):
        px, py = x + vx * t, y + vy * t
        people += sy.person(max(-5.5, min(5.5, px)), max(-3.5, min(3.5, py)), legs=legs, heading=k + 0.3 * t)
    return walls + people


def benchmark(beams: tuple[int, ...] = (360, 720), scans: int = 300, seed: int = 0) -> dict[int, dict[str, float]]:
    """Mean and largest CPU time (ms) of detecting and of a whole tracker step, per scan, for each beam count."""
    out: dict[int, dict[str, float]] = {}
    for n in beams:
        rng = np.random.default_rng(seed)
        laser = sy.Laser(beams=n)
        frames = []
        for k in range(scans):
            t = k / RATE
            robot = Pose2D(-2.0 + 0.3 * math.sin(0.2 * t), 0.5 * math.cos(0.2 * t), 0.3 * t)
            frames.append((sy.scan(_scene(t), robot, laser, rng), robot, t))
        detector, tracker = Detector(), PeopleTracker()
        detect_ms, step_ms = [], []
        for scan, robot, t in frames:
            start = time.thread_time()
            detector.detect(scan, robot)
            detect_ms.append((time.thread_time() - start) * 1e3)
            start = time.thread_time()
            report = tracker.step(scan, robot, t)
            step_ms.append((time.thread_time() - start) * 1e3)
        out[n] = {"detect_ms": float(np.mean(detect_ms)), "detect_max_ms": float(np.max(detect_ms)),
                  "step_ms": float(np.mean(step_ms)), "step_max_ms": float(np.max(step_ms)),
                  "people": float(len(report.tracks))}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scans", type=int, default=300, help="scans per beam count (default 300)")
    parser.add_argument("--beams", type=int, nargs="+", default=[360, 720], help="beam counts (default 360 720)")
    args = parser.parse_args(argv)
    for n, f in benchmark(tuple(args.beams), args.scans).items():
        print(f"{n} beams: detect {f['detect_ms']:.3f} ms mean ({f['detect_max_ms']:.3f} max), "
              f"detect + track {f['step_ms']:.3f} ms mean ({f['step_max_ms']:.3f} max), "
              f"{f['people']:.0f} people tracked at the end")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
