"""The tools of bin/gidabot keep to themselves: a tool imports no other tool, only the libraries they share.

The tools are gidabot_sim's ``demo/``, ``chaos/``, ``bench/`` and ``report/`` (``gidabot report``); the libraries
``runner/`` (processes, the simulated building, the command line's helpers) and ``report/`` (a run folder's
recordings and tables, through its modules other than ``command``). A library imports no tool, and no module
imports a tool's ``command`` (bin/gidabot reaches them by name).
"""

from __future__ import annotations

from pathlib import Path

from source_imports import imports, module_files

PACKAGE = Path(__file__).resolve().parents[1]          # src/gidabot_sim
TOOLS = ("demo", "chaos", "bench", "report")
LIBRARIES = ("runner", "report")


def subpackage(module: str) -> str:
    """The subpackage of gidabot_sim a dotted name is in ("" for another package or a top-level module)."""
    parts = module.split(".")
    return parts[1] if parts[0] == "gidabot_sim" and len(parts) > 2 else ""


def wrong(module: str, imported: str) -> str:
    """Why ``module`` may not import ``imported`` ('' = it may)."""
    mine, theirs = subpackage(module), subpackage(imported)
    if theirs and imported.split(".")[:3] == ["gidabot_sim", theirs, "command"]:
        return "a tool's command is reached through bin/gidabot only"
    if mine in TOOLS + LIBRARIES and theirs != mine and theirs in TOOLS and theirs not in LIBRARIES:
        return f"{mine}/ imports the tool {theirs}/"
    return ""


def violations(package: Path) -> list[str]:
    found = []
    for module, path in module_files(package):
        for imp in imports(path, module):
            why = wrong(module, imp.module)
            if why:
                found.append(f"{imp.where(package)}: {imp.module} ({why})")
    return found


def test_no_tool_imports_another() -> None:
    found = violations(PACKAGE)
    assert not found, "imports between the tools (use runner/ or report/):\n" + "\n".join(found)


def test_the_rule() -> None:
    assert wrong("gidabot_sim.chaos.command", "gidabot_sim.report.tables.analyse") == ""
    assert wrong("gidabot_sim.demo.run", "gidabot_sim.runner.command_line.Signals") == ""
    assert wrong("gidabot_sim.chaos.command", "gidabot_sim.demo.run.DemoPlan") == "chaos/ imports the tool demo/"
    assert wrong("gidabot_sim.bench.flood", "gidabot_sim.bench.workers.Worker") == ""
    assert wrong("gidabot_sim.report.tables", "gidabot_sim.chaos.table3") == "report/ imports the tool chaos/"
    assert wrong("gidabot_sim.runner.procs", "gidabot_sim.demo.timing") == "runner/ imports the tool demo/"
    assert wrong("gidabot_sim.demo.run", "gidabot_sim.report.command.main") != ""
    assert wrong("gidabot_sim.chaos.run", "gidabot_navigation.interface.Node") == ""
