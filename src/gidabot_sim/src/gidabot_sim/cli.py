"""``bin/gidabot``: the one entry point for people.

Each subcommand lives in the package whose tools it runs, in a module with a
``main(argv) -> int``: ``check`` in gidabot_navigation (it runs on a robot), the
tools that run the simulated building here. Modules are imported only when their
subcommand runs, so ``check`` works without ROS running.
"""

from __future__ import annotations

import importlib
import sys

# subcommand -> (module, one-line help). Keep sorted.
COMMANDS: dict[str, tuple[str, str]] = {
    "admin-passwd": ("gidabot_gui.admin_passwd", "the touch screen's admin password as a salted hash "
                                                 "(admin_password_hash:=...)"),
    "bench": ("gidabot_sim.cli", "benchmarks: 'bench dashboard', 'bench demo', 'bench idle', 'bench relay', "
                                 "'bench sim' (--json)"),
    "chaos": ("gidabot_sim.chaos.command",
              "a tour under injected faults (links, masters, nodes, hostile input); table"),
    "check": ("gidabot_navigation.cli", "validate a building directory or tour files"),
    "dashboard-passwd": ("gidabot_web.dashboard.passwd", "set (or --delete) a user of a robot's staff dashboard"),
    "demo": ("gidabot_sim.demo.command", "run the simulated building through a tour, record it, print the tables"),
    "edit": ("gidabot_web.editor.app", "the building editor in the browser: maps and blueprints in, a building out"),
    "report": ("gidabot_sim.report.command", "the paper's tables and path plots from a run folder's rosbags"),
}

# gidabot bench <name>
BENCHES: dict[str, tuple[str, str]] = {
    "dashboard": ("gidabot_sim.bench.dashboard", "20 live clients on a robot's dashboard during the Table 2 tour: "
                                                 "Table 3, the dashboard's CPU, p95 delay to the clients"),
    "demo": ("gidabot_sim.bench.demo", "the Table 2 tour at 10x, 20x, 50x and max: times, rates, tables, judged"),
    "idle": ("gidabot_sim.bench.idle", "a building at rest (1x, no visitor): CPU per robot per wall second"),
    "flood": ("gidabot_sim.bench.flood", "a valid request answered under 1000 invalid messages/s per master"),
    "relay": ("gidabot_sim.bench.relay", "relay latency vs direct, and 4/8-robot meshes"),
    "sim": ("gidabot_sim.bench.sim", "planner time per floor and simulator real-time factor"),
}


def usage() -> str:
    lines = ["usage: gidabot <command> [options]   (gidabot <command> --help for its options)", "", "commands:"]
    lines += [f"  {name:<16} {text}" for name, (_, text) in sorted(COMMANDS.items())]
    return "\n".join(lines)


def bench(argv: list[str]) -> int:
    """``gidabot bench <name>``: dispatch to the benchmark modules."""
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: gidabot bench <name> [--json]\n\nbenchmarks:")
        for name, (_, text) in sorted(BENCHES.items()):
            print(f"  {name:<8} {text}")
        return 0
    if argv[0] not in BENCHES:
        print(f"gidabot bench: unknown benchmark {argv[0]!r} (known: {', '.join(sorted(BENCHES))})", file=sys.stderr)
        return 2
    return int(importlib.import_module(BENCHES[argv[0]][0]).main(argv[1:]) or 0)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(usage())
        return 0
    name, rest = argv[0], argv[1:]
    if name not in COMMANDS:
        print(f"gidabot: unknown command {name!r}\n\n{usage()}", file=sys.stderr)
        return 2
    if name == "bench":
        return bench(rest)
    module = importlib.import_module(COMMANDS[name][0])
    return int(module.main(rest) or 0)


if __name__ == "__main__":
    sys.exit(main())
