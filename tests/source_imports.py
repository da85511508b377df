"""Every import of the packages' Python code, read from the source (AST), for the rule checks
(tests/foundation/test_purity.py, tests/foundation/test_package_deps.py).

Every ``import`` statement counts, at module level or inside a function or a ``try``; relative imports
are resolved against the module's own name. ``from a.b import c`` is recorded as ``a.b.c`` (``c`` may be
a module). Imports by name at run time (``importlib.import_module``) are not seen.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

# ROS client libraries and tools whose Python module is named as their ROS package (plus every message
# package: ``*_msgs``, ``*_srvs``); Qt's Python bindings
ROS = frozenset({"rospy", "actionlib", "roslib", "rosgraph", "genpy", "genmsg", "rosbag", "roslaunch", "rosnode",
                 "rostopic", "rosservice", "rosparam", "rosmsg", "rostest", "tf", "tf2_ros", "tf2_py",
                 "message_filters", "dynamic_reconfigure"})
QT = frozenset({"PyQt5", "PyQt6", "PySide2", "PySide6", "sip"})


@dataclass(frozen=True)
class Import:
    path: Path        # the importing file
    line: int
    module: str       # absolute dotted name

    @property
    def top(self) -> str:
        return self.module.split(".")[0]

    @property
    def is_ros(self) -> bool:
        """A ROS library or a message package (the top-level name is the ROS package's)."""
        return self.top in ROS or self.top.endswith(("_msgs", "_srvs"))

    def where(self, root: Path) -> str:
        return f"{self.path.relative_to(root)}:{self.line}"


def packages(root: Path) -> list[Path]:
    """The catkin packages of the repository at ``root`` (``src/<pkg>/package.xml``)."""
    return sorted(p.parent for p in (root / "src").glob("*/package.xml"))


def module_files(package: Path) -> Iterator[tuple[str, Path]]:
    """(dotted module name, file) of every module of ``package``'s Python package ``src/<pkg>/``."""
    top = package / "src" / package.name
    for path in sorted(top.rglob("*.py")):
        parts = [package.name, *path.relative_to(top).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        yield ".".join(parts), path


def node_files(package: Path) -> list[Path]:
    """The node executables ``nodes/*`` (Python scripts without a suffix)."""
    return sorted(p for p in (package / "nodes").glob("*") if p.is_file())


def imports(path: Path, module: str = "") -> list[Import]:
    """Every import of the file ``path``, whose module name is ``module`` (for relative imports)."""
    found: list[Import] = []
    is_package = path.name == "__init__.py"
    for node in ast.walk(ast.parse(path.read_bytes(), str(path))):
        if isinstance(node, ast.Import):
            found += [Import(path, node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = module.split(".")
                keep = len(parts) - node.level + (1 if is_package else 0)
                base = ".".join(parts[:keep] + ([base] if base else []))
            found += [Import(path, node.lineno, f"{base}.{alias.name}" if alias.name != "*" else base)
                      for alias in node.names]
    return sorted(found, key=lambda i: i.line)
