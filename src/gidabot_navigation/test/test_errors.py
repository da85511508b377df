"""One exception hierarchy per package: every exception class of the packages under src/ is defined in
its package's errors.py (test code excepted), with a test of that check."""

from __future__ import annotations

import ast
import builtins
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
BUILTIN_EXCEPTIONS = {name for name, obj in vars(builtins).items()
                      if isinstance(obj, type) and issubclass(obj, BaseException)}


def _base_names(cls: ast.ClassDef) -> set[str]:
    """The last part of every base class name (``errors.GidaBotError`` -> ``GidaBotError``)."""
    out = set()
    for base in cls.bases:
        if isinstance(base, ast.Name):
            out.add(base.id)
        elif isinstance(base, ast.Attribute):
            out.add(base.attr)
    return out


def misplaced_exceptions(files: list[Path]) -> list[str]:
    """``file:line: Class`` of every exception class defined in a module that is not an ``errors.py``.

    An exception class is one that derives, through classes defined in ``files`` (by name), from a
    built-in exception or from a class defined in an ``errors.py``."""
    classes = [(path, node) for path in files
               for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path)))
               if isinstance(node, ast.ClassDef)]
    exceptions = BUILTIN_EXCEPTIONS | {c.name for p, c in classes if p.name == "errors.py"}
    grew = True
    while grew:
        found = {c.name for _, c in classes if _base_names(c) & exceptions}
        grew = not found <= exceptions
        exceptions |= found
    return [f"{p}:{c.lineno}: {c.name}" for p, c in sorted(classes, key=lambda pc: (pc[0], pc[1].lineno))
            if p.name != "errors.py" and _base_names(c) & exceptions]


def package_modules() -> list[Path]:
    """The Python modules of every package under src/ (src/<pkg>/src/...), not their tests."""
    return sorted((REPO / "src").glob("*/src/**/*.py"))


def test_every_exception_class_is_in_its_packages_errors_module() -> None:
    files = package_modules()
    assert {p.parts[len(REPO.parts) + 1] for p in files} >= {"gidabot_navigation", "gidabot_sim", "gidabot_gui"}
    found = misplaced_exceptions(files)
    assert not found, "exception classes belong in their package's errors.py:\n" + "\n".join(found)


def test_the_check_finds_a_planted_exception_class(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "errors.py").write_text("class PkgError(Exception):\n    pass\n\n\nclass Rejected(PkgError):\n    pass\n")
    (pkg / "core.py").write_text("import errors\n\n\n"
                                 "class Widget:\n    pass\n\n\n"                     # not an exception
                                 "class Broken(errors.Rejected):\n    pass\n\n\n"   # through errors.py
                                 "class Worse(Broken):\n    pass\n\n\n"             # through a misplaced one
                                 "class Plain(ValueError):\n    pass\n")            # a built-in base
    found = misplaced_exceptions(sorted(pkg.glob("*.py")))
    assert [f.split(": ", 1)[1] for f in found] == ["Broken", "Worse", "Plain"]
    assert found[0].startswith(f"{pkg / 'core.py'}:8")
