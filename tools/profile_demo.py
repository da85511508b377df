"""Where the demo's CPU goes: py-spy on every Python process of one robot's master during a tour.

Runs ``bin/gidabot demo`` with the given options, waits for the tour's first goal, then samples
every Python process whose ``ROS_MASTER_URI`` is ``--robot``'s master (sim, move_base, amcl,
guiding nodes, relay ends, tour store, visitor, ...) with ``py-spy record`` for ``--seconds``
wall seconds, and prints per process its CPU in that window (``/proc``) and the functions its
samples were in (self, and inclusive by "area": receiving messages, serialising, /clock, ...).
py-spy is a pinned dependency (requirements.txt). Run it alone, under the heavy lock:

    source tools/env.sh
    flock /tmp/gidabot-heavy.lock python tools/profile_demo.py --robot Kbot --seconds 40 -- \\
        --tour tours/long_tour.tour --speed 20

Raw stacks are kept in ``<out>/<process>.txt`` (py-spy's raw format: one stack per line and its count).
"""
from __future__ import annotations

import argparse
import collections
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# inclusive areas: the first pattern found in a stack (outermost first) names where the sample went
AREAS = (
    ("receive /clock", re.compile(r"_set_rostime|simtime\.py|_clock_sub|rospy/impl/simtime")),
    ("receive messages", re.compile(r"tcpros_base\.py.*receive_loop|receive_once|_invoke_callback")),
    ("publish", re.compile(r"topics\.py.*publish|write_data|tcpros_pubsub")),
    ("timers / sleep", re.compile(r"timer\.py|rostime\.py.*sleep|rospy/timer")),
    ("actionlib", re.compile(r"actionlib/")),
    ("xmlrpc / master", re.compile(r"xmlrpc|registration\.py|masterslave")),
)


def processes_of(master_uri: str) -> dict[int, str]:
    """pid -> label of every Python process whose environment points at ``master_uri``."""
    found = {}
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            env = Path(f"/proc/{entry.name}/environ").read_bytes().split(b"\0")
            argv = [a.decode(errors="replace") for a in Path(f"/proc/{entry.name}/cmdline").read_bytes().split(b"\0")
                    if a]
        except OSError:
            continue
        if f"ROS_MASTER_URI={master_uri}".encode() not in env or not argv or "python" not in Path(argv[0]).name:
            continue
        name = next((a.split(":=", 1)[1] for a in argv if a.startswith("__name:=")), "")
        found[int(entry.name)] = name or Path(argv[1] if len(argv) > 1 else argv[0]).name
    return found


def cpu_seconds(pid: int) -> float:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def summarise(raw: Path, top: int) -> list[str]:
    selfs: collections.Counter[str] = collections.Counter()
    areas: collections.Counter[str] = collections.Counter()
    total = 0
    for line in raw.read_text(errors="replace").splitlines():
        stack, _, count = line.rpartition(" ")
        if not count.isdigit():
            continue
        n = int(count)
        total += n
        frames = stack.split(";")
        selfs[frames[-1]] += n
        area = next((name for name, pat in AREAS if any(pat.search(f) for f in frames)), "other")
        areas[area] += n
    if not total:
        return ["    (no samples)"]
    out = ["    areas: " + ", ".join(f"{a} {100 * n / total:.0f}%" for a, n in areas.most_common())]
    out += [f"    {100 * n / total:5.1f}%  {frame[:140]}" for frame, n in selfs.most_common(top)]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="Kbot", help="the robot whose master's processes are sampled")
    ap.add_argument("--seconds", type=float, default=40.0, help="wall seconds of sampling, from the first goal")
    ap.add_argument("--rate", type=int, default=200, help="py-spy samples per second")
    ap.add_argument("--top", type=int, default=8, help="functions listed per process")
    ap.add_argument("--out", type=Path, default=Path("/tmp/gidabot-profile"))
    ap.add_argument("demo_args", nargs="*", help="options of gidabot demo (after --)")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    demo = subprocess.Popen([str(REPO / "bin" / "gidabot"), "demo", "--out", str(args.out / "runs"), *args.demo_args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    assert demo.stdout is not None
    run_dir = None
    spies: dict[int, tuple[str, subprocess.Popen, float]] = {}
    try:
        for line in demo.stdout:
            print(line, end="", flush=True)
            if line.startswith("run folder: ") and run_dir is None:
                run_dir = Path(line.split(": ", 1)[1].strip())
            if "goal 1 of" in line:
                break
        if run_dir is None:
            print("profile_demo: the demo never started its tour", file=sys.stderr)
            return 1
        uri = master_uri(run_dir, args.robot)
        for pid, label in processes_of(uri).items():
            raw = args.out / f"{label}.{pid}.txt"
            spy = subprocess.Popen([str(Path(sys.executable).parent / "py-spy"), "record", "--gil", "-r",
                                    str(args.rate), "-d", str(int(args.seconds)), "-f", "raw", "-o", str(raw), "-p",
                                    str(pid)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            spies[pid] = (label, spy, cpu_seconds(pid))
        began = time.monotonic()
        threading.Thread(target=lambda: [print(line, end="", flush=True) for line in demo.stdout],  # type: ignore[union-attr]
                         daemon=True).start()
        for _, spy, _ in spies.values():
            spy.wait(timeout=args.seconds + 60)
        cpu = {pid: cpu_seconds(pid) - c0 for pid, (_, _, c0) in spies.items()}
        wall = time.monotonic() - began
        print(f"\nCPU of {args.robot}'s processes over {wall:.0f} s of wall time (cores), and their py-spy samples:")
        for pid, (label, _, _) in sorted(spies.items(), key=lambda kv: -cpu[kv[0]]):
            print(f"  {label:<28} pid {pid:>7}  {cpu[pid] / wall:5.3f} cores")
            raw = args.out / f"{label}.{pid}.txt"
            if raw.exists():
                print("\n".join(summarise(raw, args.top)))
        return 0
    finally:
        for _, spy, _ in spies.values():
            if spy.poll() is None:
                spy.terminate()
        if demo.poll() is None:
            os.killpg(demo.pid, signal.SIGINT)
            demo.wait(timeout=120)


def master_uri(run_dir: Path, robot: str) -> str:
    """``robot``'s master URI from the run's relocated building file."""
    from gidabot_navigation.building.model import load_building

    try:
        return load_building(run_dir / "building").robot(robot).master_uri
    except KeyError as err:
        raise SystemExit(f"profile_demo: {err}") from err


if __name__ == "__main__":
    sys.exit(main())
