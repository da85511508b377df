"""Core purity, enforced: where ROS and Qt may be imported (the rule of docs/architecture.md).

By location, in every package's Python package ``src/<pkg>/src/<pkg>/``:

- **adapters** may import anything: modules named ``*_node.py`` and every module of a ``ros/``
  subpackage (the tooling's processes on a master too: the monitor, the chaos probe, the benchmarks'
  workers and drivers);
- **tooling**: gidabot_sim's ``runner/``, ``demo/``, ``chaos/``, ``bench/`` and ``report/``, and gidabot_web's
  ``editor/`` (the building editor, whose preview runs ``gidabot demo``) never run on a robot: no module
  outside them imports one of them. Of the tooling, ``runner/`` (it starts masters and launches and finds
  node executables) may import ROS; the rest of it (the report, the chaos bookkeeping,
  the governor, the timing...) is ROS-free like a core, its adapters aside. The tools keep to themselves:
  one imports no other, only what they share (``runner/``, and ``report/``'s modules: the report of a run
  folder), and no module imports a tool's ``command.py`` (bin/gidabot reaches it by name);
- **Qt part**: in gidabot_gui, every module outside ``core/`` (and not an adapter) may import Qt,
  never ROS;
- everything else is **ROS-free**: it imports no ROS client library or tool (``source_imports.ROS``), no
  message package (``*_msgs``, ``*_srvs``), no Qt (``source_imports.QT``), and none of our adapters (which
  would bring ROS in with them).

Every import counts, also inside a function (tests/source_imports.py). rospkg is allowed anywhere: it
reads package paths from the environment (gidabot_navigation.resources), it is not ROS at run time.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from source_imports import QT, Import, imports, module_files, packages

REPO = Path(__file__).resolve().parents[2]
TOOLING = {"gidabot_sim": ("runner", "demo", "chaos", "bench", "report"),    # never runs on a robot
           "gidabot_web": ("editor",)}            # the building editor: its preview runs gidabot demo
ROS_TOOLING = {"gidabot_sim": ("runner",)}   # the tooling that may import ROS (besides its adapters)
SHARED_TOOLING = {"gidabot_sim": ("runner", "report")}   # what every tool may import; no tool imports another
QT_PACKAGES = {"gidabot_gui": "core"}    # package -> its Qt-free subpackage; the rest is the Qt part
ROS_WHERE = "ROS: only in *_node.py, ros/, and gidabot_sim's runner/"
QT_WHERE = "Qt: only in gidabot_gui outside core/"
TOOLING_WHERE = "tooling: only imported by the tooling"
TOOL_WHERE = "a tool imports no other tool, only gidabot_sim's runner/ and report/"
COMMAND_WHERE = "a tool's command.py: reached through bin/gidabot only"


def is_adapter(module: str) -> bool:
    parts = module.split(".")[1:]
    return "ros" in parts or any(p.endswith("_node") for p in parts)


def tooling(module: str) -> str:
    """The tooling subpackage a dotted name is in ('' if none)."""
    package, *rest = module.split(".")
    return rest[0] if len(rest) > 1 and rest[0] in TOOLING.get(package, ()) else ""


def kind(module: str) -> str:
    """``adapter``, ``ros tooling``, ``qt`` or ``core`` (ROS-free: the rest of the tooling too) for a dotted
    module name of ours."""
    package, *rest = module.split(".")
    if is_adapter(module):
        return "adapter"
    if rest and rest[0] in ROS_TOOLING.get(package, ()):
        return "ros tooling"
    if package in QT_PACKAGES and not (rest and rest[0] == QT_PACKAGES[package]):
        return "qt"
    return "core"


def wrong(imp: Import, where: str, module: str = "") -> str:
    """Why ``imp`` is not allowed in ``module``, of kind ``where`` ('' = allowed)."""
    theirs, mine = tooling(imp.module), tooling(module)
    if theirs and not mine:
        return TOOLING_WHERE
    if theirs and imp.module.split(".")[2] == "command":
        return COMMAND_WHERE
    if theirs and theirs != mine and theirs not in SHARED_TOOLING.get(imp.top, ()):
        return TOOL_WHERE
    if where in ("adapter", "ros tooling"):
        return ""
    if imp.is_ros or is_adapter(imp.module) and imp.top.startswith("gidabot_"):
        return ROS_WHERE
    if imp.top in QT and where == "core":
        return QT_WHERE
    return ""


def violations(root: Path) -> list[str]:
    """``file:line: module (why)`` for every import that breaks the rule, in the repository at ``root``."""
    found = []
    for package in packages(root):
        for module, path in module_files(package):
            where = kind(module)
            for imp in imports(path, module):
                why = wrong(imp, where, module)
                if why:
                    found.append(f"{imp.where(root)}: {imp.module} ({why})")
    return found


def test_no_ros_free_module_imports_ros_or_qt() -> None:
    found = violations(REPO)
    assert not found, "imports that break the purity rule (docs/architecture.md):\n" + "\n".join(found)


def test_the_rule_by_location() -> None:
    assert kind("gidabot_navigation.guiding.goal_manager") == "core"
    assert kind("gidabot_navigation.guiding.goal_manager_node") == "adapter"
    assert kind("gidabot_navigation.ros.master_watch") == "adapter"
    assert kind("gidabot_sim.runner.building_runner") == "ros tooling"
    assert kind("gidabot_sim.chaos.bookkeeping") == "core" and kind("gidabot_sim.report.bags") == "core"
    assert kind("gidabot_sim.bench.relay") == "core" and kind("gidabot_sim.bench.relay_node") == "adapter"
    assert kind("gidabot_sim.demo.monitor_node") == "adapter" and kind("gidabot_sim.world.world") == "core"
    assert tooling("gidabot_sim.demo.governor") == "demo" and tooling("gidabot_sim.visitor.population") == ""
    assert kind("gidabot_gui.core.model") == "core"
    assert kind("gidabot_gui.window") == "qt"
    assert kind("gidabot_gui.gui_node") == "adapter"


def plant(root: Path, rel: str, text: str) -> Path:
    path = root / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_the_check_fails_on_a_planted_import(tmp_path: Path) -> None:
    pkg = "src/gidabot_navigation"
    (tmp_path / pkg).mkdir(parents=True)
    shutil.copy(REPO / pkg / "package.xml", tmp_path / pkg / "package.xml")
    core = REPO / pkg / "src/gidabot_navigation/guiding/goal_manager.py"
    copy = plant(tmp_path, f"{pkg}/src/gidabot_navigation/guiding/goal_manager.py", core.read_text())
    assert violations(tmp_path) == []          # the copy as it is passes
    late = "def late():\n    from gidabot_msgs.msg import Goal\n    from ..ros import log\n    return Goal, log\n"
    copy.write_text("import rospy\n" + core.read_text() + late)
    n = len(core.read_text().splitlines()) + 3      # the line of the first import in late()
    rel = f"{pkg}/src/gidabot_navigation/guiding/goal_manager.py"
    assert violations(tmp_path) == [f"{rel}:1: rospy ({ROS_WHERE})", f"{rel}:{n}: gidabot_msgs.msg.Goal ({ROS_WHERE})",
                                    f"{rel}:{n + 1}: gidabot_navigation.ros.log ({ROS_WHERE})"]


def test_the_check_knows_the_gui_parts(tmp_path: Path) -> None:
    gui = "src/gidabot_gui"
    plant(tmp_path, f"{gui}/package.xml", "<package/>")
    plant(tmp_path, f"{gui}/src/gidabot_gui/core/model.py", "from PyQt5 import QtCore\n")
    plant(tmp_path, f"{gui}/src/gidabot_gui/window.py", "from PyQt5 import QtWidgets\nimport rospy\n")
    plant(tmp_path, f"{gui}/src/gidabot_gui/gui_node.py", "import rospy\nfrom PyQt5 import QtCore\n")
    assert violations(tmp_path) == [f"{gui}/src/gidabot_gui/core/model.py:1: PyQt5.QtCore ({QT_WHERE})",
                                    f"{gui}/src/gidabot_gui/window.py:2: rospy ({ROS_WHERE})"]


def test_the_check_knows_the_tooling(tmp_path: Path) -> None:
    """ROS in runner/ and the tooling's adapters only; nothing else imports the tooling; no tool another."""
    sim = "src/gidabot_sim"
    files = {"runner/procs.py": "import rospy\n",
             "bench/flood.py": "from gidabot_sim.runner import procs\nimport rospy\n",
             "bench/flood_node.py": "import rospy\n",
             "report/tables.py": "from PyQt5 import QtCore\n",
             "chaos/run.py": "from gidabot_sim.report.tables import analyse\n"
                             "from gidabot_sim.demo.run import DemoPlan\n",
             "demo/run.py": "from gidabot_sim.report.command import main\n",
             "visitor/visitor.py": "from gidabot_sim.report import tables\n"}
    for path, text in {"package.xml": "<package/>", **{f"src/gidabot_sim/{k}": v for k, v in files.items()}}.items():
        plant(tmp_path, f"{sim}/{path}", text)
    here = f"{sim}/src/gidabot_sim"
    assert violations(tmp_path) == [f"{here}/bench/flood.py:2: rospy ({ROS_WHERE})",
                                    f"{here}/chaos/run.py:2: gidabot_sim.demo.run.DemoPlan ({TOOL_WHERE})",
                                    f"{here}/demo/run.py:1: gidabot_sim.report.command.main ({COMMAND_WHERE})",
                                    f"{here}/report/tables.py:1: PyQt5.QtCore ({QT_WHERE})",
                                    f"{here}/visitor/visitor.py:1: gidabot_sim.report.tables ({TOOLING_WHERE})"]
