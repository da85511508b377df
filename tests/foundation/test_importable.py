"""Every module of the packages imports: a node module is run only by its executable, so a name a merge
or a rename left behind (``from x import GONE``) would otherwise surface only when a robot starts."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

PACKAGES = ("gidabot_navigation", "gidabot_sim", "gidabot_gui", "gidabot_web")


def _modules() -> list[str]:
    names = []
    for package in PACKAGES:
        root = importlib.import_module(package)
        names += [info.name for info in pkgutil.walk_packages(root.__path__, f"{package}.")]
    return sorted(names)


@pytest.mark.parametrize("module", _modules())
def test_the_module_imports(module: str) -> None:
    importlib.import_module(module)
