"""Every package.xml declares what the package uses at run time, and nothing else.

Used = imported by the package's Python code (``src/<pkg>/``, every import, also inside functions) or
by its node executables (``nodes/*``), and the packages its launch files start or find (``pkg="..."``,
``$(find ...)``). Each import names a dependency key: a ROS package (ours, a ROS library, a message
package), or the rosdep key of a Debian Python library (:data:`PYTHON_KEYS`). Python's standard library
and the pinned PyPI extras of requirements.txt (the venv) are not package.xml dependencies.
Declared = ``<depend>`` and ``<exec_depend>``; extras declared without a use need a reason in :data:`EXTRAS`.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from catkin_pkg.package import parse_package
from source_imports import Import, imports, module_files, node_files, packages

REPO = Path(__file__).resolve().parents[2]
PYTHON_KEYS = {"PyQt5": "python3-pyqt5", "rospkg": "python3-rospkg", "yaml": "python3-yaml",
               "numpy": "python3-numpy", "scipy": "python3-scipy", "PIL": "python3-pil",
               "matplotlib": "python3-matplotlib", "aiohttp": "python3-aiohttp", "selenium": "python3-selenium"}
# package -> {declared key: why it is declared though no code imports it}
EXTRAS: dict[str, dict[str, str]] = {}
LAUNCH_USE = re.compile(r'\bpkg="([A-Za-z0-9_]+)"|\$\(find ([A-Za-z0-9_]+)\)')


def pypi_names(root: Path) -> set[str]:
    """The distributions pinned in requirements.txt, as import names (lower case, ``_`` for ``-``)."""
    names = set()
    for line in (root / "requirements.txt").read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name = re.split(r"[=<>~!\[; ]", line, maxsplit=1)[0].lower().replace("-", "_")
            names |= {name, name.split(".")[0]}          # ruamel.yaml is imported as ruamel
    return names


def key_of(imp: Import, pypi: set[str]) -> str | None:
    """The package.xml key ``imp`` needs; None for the standard library and PyPI extras. Raises on an
    import that is none of these."""
    top = imp.top
    if top in sys.stdlib_module_names or top == "__future__" or top.lower() in pypi:
        return None
    if imp.is_ros or top.startswith("gidabot_"):
        return top
    if top in PYTHON_KEYS:
        return PYTHON_KEYS[top]
    raise AssertionError(f"{imp.where(REPO)}: {imp.module}: not a ROS package, a known rosdep key "
                         f"(PYTHON_KEYS) or a requirements.txt pin")


def used(package: Path, pypi: set[str]) -> dict[str, str]:
    """key -> where it is first used (``file:line``)."""
    found: dict[str, str] = {}
    sources = [*module_files(package), *(("", path) for path in node_files(package))]
    for module, path in sources:
        for imp in imports(path, module):
            key = key_of(imp, pypi)
            if key is not None and key != package.name:
                found.setdefault(key, imp.where(REPO))
    for launch in sorted((package / "launch").glob("*.launch")):
        for number, line in enumerate(launch.read_text().splitlines(), 1):
            for match in LAUNCH_USE.finditer(line):
                key = match.group(1) or match.group(2)
                if key != package.name:
                    found.setdefault(key, f"{launch.relative_to(REPO)}:{number}")
    return found


def declared(package: Path) -> set[str]:
    return {d.name for d in parse_package(str(package / "package.xml")).exec_depends}


def checked_packages() -> list[Path]:
    """The packages with Python code or launch files (gidabot_msgs has neither)."""
    return [p for p in packages(REPO) if any(module_files(p)) or node_files(p) or any(p.glob("launch/*.launch"))]


def test_every_package_xml_matches_what_its_code_uses() -> None:
    pypi = pypi_names(REPO)
    problems = []
    for package in checked_packages():
        uses, decl = used(package, pypi), declared(package)
        extras = EXTRAS.get(package.name, {})
        problems += [f"{package.name}/package.xml: {key} not declared (used at {where})"
                     for key, where in sorted(uses.items()) if key not in decl]
        problems += [f"{package.name}/package.xml: {key} declared but not used (no import, no launch file)"
                     for key in sorted(decl - set(uses) - set(extras))]
        problems += [f"EXTRAS[{package.name!r}]: {key} is used after all, or not declared"
                     for key in sorted(extras) if key in uses or key not in decl]
    assert not problems, "\n".join(problems)


def test_the_packages_checked() -> None:
    assert [p.name for p in checked_packages()] == ["gidabot_gui", "gidabot_navigation", "gidabot_sim", "gidabot_web"]
