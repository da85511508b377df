"""``gidabot bench <name>``: dispatch to the benchmark modules."""

from __future__ import annotations

import importlib
import sys

BENCHES: dict[str, tuple[str, str]] = {
    "relay": ("gidabot_navigation.bench_relay", "relay latency vs direct, and 4/8-robot meshes"),
    "sim": ("gidabot_sim.bench", "planner time per floor and simulator real-time factor"),
}


def main(argv: list[str]) -> int:
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: gidabot bench <name> [--json]\n\nbenchmarks:")
        for name, (_, text) in sorted(BENCHES.items()):
            print(f"  {name:<8} {text}")
        return 0
    if argv[0] not in BENCHES:
        print(f"gidabot bench: unknown benchmark {argv[0]!r} (known: {', '.join(sorted(BENCHES))})", file=sys.stderr)
        return 2
    return int(importlib.import_module(BENCHES[argv[0]][0]).main(argv[1:]) or 0)
