"""``bin/gidabot``: the one entry point for people.

Each subcommand lives in its own module with a ``main(argv) -> int``; modules are
imported only when their subcommand runs, so ``check`` works without ROS running.
"""

from __future__ import annotations

import importlib
import sys

# subcommand -> (module, one-line help). Keep sorted.
COMMANDS: dict[str, tuple[str, str]] = {
    "bench": ("gidabot_navigation.cli_bench", "benchmarks: 'bench relay', 'bench sim' (--json)"),
    "chaos": ("gidabot_sim.chaos", "run a tour while injecting faults (links, masters, nodes, hostile input); table"),
    "check": ("gidabot_navigation.cli_check", "validate a building directory or tour files"),
    "demo": ("gidabot_sim.demo", "run the simulated building through a tour, record it, print the tables"),
    "report": ("gidabot_sim.report", "the paper's tables and path plots from a run folder's rosbags"),
}


def usage() -> str:
    lines = ["usage: gidabot <command> [options]   (gidabot <command> --help for its options)", "", "commands:"]
    lines += [f"  {name:<8} {text}" for name, (_, text) in sorted(COMMANDS.items())]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(usage())
        return 0
    name, rest = argv[0], argv[1:]
    if name not in COMMANDS:
        print(f"gidabot: unknown command {name!r}\n\n{usage()}", file=sys.stderr)
        return 2
    module = importlib.import_module(COMMANDS[name][0])
    return int(module.main(rest) or 0)


if __name__ == "__main__":
    sys.exit(main())
