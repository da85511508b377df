"""rospy's private API is used in one module only: gidabot_navigation/ros/rospy_internals.py.

Every other module (and node executable) of every package is read (AST, not text: docstrings and
comments may name them) for imports of rospy's submodules (``rospy.core``, ``rospy.impl...``,
``rospy.topics``...: what rospy exports is used as ``rospy.X``), attribute access through them, and the
private names themselves (``Topic.impl``, connections' ``endpoint_id``, ``_PublisherImpl``, ...).
"""

from __future__ import annotations

import ast
import pkgutil
import shutil
from pathlib import Path

import rospy
from source_imports import imports, module_files, node_files, packages

REPO = Path(__file__).resolve().parents[2]
ALLOWED = Path("src/gidabot_navigation/src/gidabot_navigation/ros/rospy_internals.py")
SUBMODULES = frozenset(m.name for m in pkgutil.iter_modules(rospy.__path__))
# attributes of rospy's objects (also as getattr strings)
ATTRIBUTES = frozenset({"impl", "endpoint_id", "publock", "c_lock", "_ServerProxy__transport", "_clock_sub",
                        "_set_rostime"})
# names from rospy's private modules, wherever they appear
NAMES = frozenset({"_PublisherImpl", "_SubscriberImpl", "_TopicImpl", "get_topic_manager", "get_service_manager",
                   "get_registration_listeners", "RegManager", "get_param_server_cache", "xmlrpcapi",
                   "add_shutdown_hook", "_set_rostime", "_clock_sub"})


def uses(path: Path, module: str = "") -> list[tuple[int, str]]:
    """(line, what) of every use of rospy's private API in the file ``path``."""
    found = [(imp.line, f"import {imp.module}") for imp in imports(path, module)
             if imp.top == "rospy" and (imp.module.split(".") + [""])[1] in SUBMODULES
             or imp.module.split(".")[-1] in NAMES]
    for node in ast.walk(ast.parse(path.read_bytes(), str(path))):
        if isinstance(node, ast.Attribute):
            if node.attr in ATTRIBUTES | NAMES:
                found.append((node.lineno, f".{node.attr}"))
            elif isinstance(node.value, ast.Name) and node.value.id == "rospy" and node.attr in SUBMODULES:
                found.append((node.lineno, f"rospy.{node.attr}"))
        elif isinstance(node, ast.Name) and node.id in NAMES:
            found.append((node.lineno, node.id))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in ATTRIBUTES | NAMES:
            found.append((node.lineno, repr(node.value)))
    return sorted(set(found))


def violations(root: Path) -> list[str]:
    """``file:line: what`` for every use outside rospy_internals.py, in the repository at ``root``."""
    found = []
    for package in packages(root):
        files = list(module_files(package)) + [("", p) for p in node_files(package)]
        for module, path in files:
            if path.relative_to(root) == ALLOWED:
                continue
            found += [f"{path.relative_to(root)}:{line}: {what}" for line, what in uses(path, module)]
    return found


def test_only_rospy_internals_uses_rospy_s_private_api() -> None:
    found = violations(REPO)
    assert not found, ("rospy's private API outside gidabot_navigation/ros/rospy_internals.py (add a function "
                       "there):\n" + "\n".join(found))


def test_rospy_internals_itself_is_seen_using_it() -> None:
    assert len(uses(REPO / ALLOWED, "gidabot_navigation.ros.rospy_internals")) >= 10


def test_the_check_fails_on_planted_uses(tmp_path: Path) -> None:
    pkg = tmp_path / "src/gidabot_navigation"
    pkg.mkdir(parents=True)
    shutil.copy(REPO / "src/gidabot_navigation/package.xml", pkg / "package.xml")
    mod = pkg / "src/gidabot_navigation/guiding/some_node.py"
    mod.parent.mkdir(parents=True)
    mod.write_text('"""Mentions rospy.impl and pub.impl in a docstring: fine."""\n'
                   "import rospy\n"
                   "import rospy.core\n"
                   "from rospy.impl.registration import get_topic_manager\n"
                   "def f(pub):\n"
                   "    rospy.core.is_initialized()\n"
                   "    n = len(pub.impl.connections)\n"
                   "    return getattr(rospy.rostime, '_set_rostime'), rospy.Publisher, n\n")
    rel = "src/gidabot_navigation/src/gidabot_navigation/guiding/some_node.py"
    assert violations(tmp_path) == [
        f"{rel}:3: import rospy.core", f"{rel}:4: import rospy.impl.registration.get_topic_manager",
        f"{rel}:6: rospy.core", f"{rel}:7: .impl", f"{rel}:8: '_set_rostime'", f"{rel}:8: rospy.rostime"]
