"""``gidabot check`` (also ``python -m gidabot_navigation.cli``): validate a building, or tour files against one.

    gidabot check maps/faculty         (the rules: docs/building-format.md)
    gidabot check tours/long_tour.tour [more.tour ...] --building maps/faculty

Prints every problem (file, key or line, value) and exits 1 if there is any. A building
that passes may still get warnings (``WARN`` lines: a parked robot leaving too little room
for another robot of its floor to pass, ``building/passing.py``); they do not fail it. A
draft (``draft: true``, saved by ``gidabot edit`` while its checks failed) fails. A tour
file in a form the tour store accepts but writes differently (CRLF line endings,
byte-order mark, spacing...) passes, with a note.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gidabot_navigation.building.model import Building, load_building
from gidabot_navigation.building.passing import passing_warnings
from gidabot_navigation.building.reachability import reachability_problems
from gidabot_navigation.errors import BuildingError, TourError, TourNameError
from gidabot_navigation.tours.tour_file import check_tour_file_name, format_tour, parse_tour


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="gidabot check", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("paths", nargs="+", type=Path, help="building directory/YAML, or tour files")
    parser.add_argument("--building", type=Path, help="building to check tours against (rooms, floors)")
    args = parser.parse_args(argv)

    building: Building | None = None
    if args.building is not None:
        try:
            building = load_building(args.building)
        except BuildingError as err:
            print(f"building {args.building}: {err}")
            return 1
    failures = 0
    for path in args.paths:
        if path.is_dir() or path.suffix in (".yaml", ".yml"):
            try:
                b = load_building(path)
                problems = reachability_problems(b)
                if problems:
                    raise BuildingError(problems)
            except BuildingError as err:
                print(f"FAIL {path}: {err}")
                failures += 1
                continue
            warnings = passing_warnings(b)
            print(f"ok   {path}: building {b.id!r}: {len(b.floors)} floors, {len(b.locations)} locations, "
                  f"{len(b.connectors)} connectors, {len(b.robots)} robots, {len(b.relay_pairs())} relays"
                  + (f", {len(warnings)} warning(s)" if warnings else ""))
            for warning in warnings:
                print(f"WARN {warning}")
            continue
        try:
            check_tour_file_name(path.name)
            data = path.read_bytes()
            tour = parse_tour(data, path.name, building, source=str(path))
        except (TourError, TourNameError) as err:
            print(f"FAIL {path}: {err}")
            failures += 1
            continue
        except OSError as err:
            print(f"FAIL {path}: cannot read: {err.strerror}")
            failures += 1
            continue
        floors = sorted({g.floor for g in tour.goals})
        note = "" if building else " (rooms not checked: pass --building)"
        if format_tour(tour).encode("utf-8") != data:
            note += " (not in the canonical form: the tour store writes it with '\\n' line endings, no BOM, "\
                    "', ' between columns)"
        print(f"ok   {path}: tour {tour.display_name!r}: {len(tour.goals)} goals on floors "
              f"{', '.join(f'{f:g}' for f in floors)}{note}")
    return 1 if failures else 0


if __name__ == "__main__":
    import sys

    sys.exit(main(sys.argv[1:]))
