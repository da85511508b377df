"""The translation catalogs: up to date with the code, complete, placeholders intact."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from gidabot_gui.core.i18n import Translator, format_number, package_locale_dir
from gidabot_gui.errors import ConfigError
from gidabot_navigation.interface import LANGUAGES

PKG = Path(__file__).resolve().parents[2]
SRC = PKG / "src" / "gidabot_gui"
# the staff dashboard's page texts share these catalogs (gidabot_web/dashboard/texts.py)
SOURCES = (SRC, PKG.parent / "gidabot_web" / "src" / "gidabot_web")
# identical in the three languages on purpose
SAME = {"{who}: {pending}, {wait}", "{n} s", "{n} min", "{ms} ms", "Robot"}
PLACEHOLDER = re.compile(r"\{(\w*)\}")


def msgids(pot_text: str) -> list[tuple[str, str]]:
    """(msgid, msgid_plural or "") of a no-wrap catalog."""
    out = []
    lines = pot_text.splitlines()
    for i, line in enumerate(lines):
        m = re.match(r'^msgid "(.+)"$', line)
        if m:
            plural = re.match(r'^msgid_plural "(.+)"$', lines[i + 1]) if i + 1 < len(lines) else None
            out.append((m.group(1).replace('\\"', '"'), plural.group(1).replace('\\"', '"') if plural else ""))
    return out


@pytest.mark.skipif(shutil.which("xgettext") is None, reason="gettext tools not installed")
def test_catalogs_hold_every_string_of_the_code(tmp_path: Path) -> None:
    fresh = tmp_path / "fresh.pot"
    subprocess.run(["xgettext", "-L", "Python", "--from-code=UTF-8", "-k", "-k_", "-kn_:1,2", "-kN_", "--no-wrap",
                    "-o", str(fresh), *sorted(str(p) for src in SOURCES for p in src.rglob("*.py"))],
                   check=True)
    in_code = set(msgids(fresh.read_text(encoding="utf-8")))
    committed = set(msgids((PKG / "locale" / "gidabot_gui.pot").read_text(encoding="utf-8")))
    assert in_code == committed, ("run bash src/gidabot_gui/tools/update-translations.sh; new: "
                                  f"{sorted(in_code - committed)}, gone: {sorted(committed - in_code)}")
    for lang in ("eu", "es"):
        po = set(msgids((PKG / "locale" / lang / "LC_MESSAGES" / "gidabot_gui.po").read_text(encoding="utf-8")))
        assert po == in_code, f"{lang}: catalog not merged"


def test_no_translation_call_inside_f_strings() -> None:
    """xgettext cannot see _() calls inside f-strings: such texts would never be translated."""
    bad = []
    for path in (p for src in SOURCES for p in src.rglob("*.py")):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"""\bf["'][^"']*\{[^}]*\b(_|n_)\(""", line):
                bad.append(f"{path}:{n}: {line.strip()}")
    assert not bad


@pytest.mark.parametrize("language", ["eu", "es"])
def test_every_string_is_translated_with_its_placeholders(locale_dir, language) -> None:
    tr = Translator(language, locale_dir)
    assert not tr.missing
    pot = (PKG / "locale" / "gidabot_gui.pot").read_text(encoding="utf-8")
    assert "fuzzy" not in (PKG / "locale" / language / "LC_MESSAGES" / "gidabot_gui.po").read_text(encoding="utf-8")
    for msgid, plural in msgids(pot):
        if plural:
            forms = [tr.n_(msgid, plural, 1), tr.n_(msgid, plural, 5)]
            sources = [msgid, plural]
        else:
            forms, sources = [tr._(msgid)], [msgid]
        for text, source in zip(forms, sources, strict=True):
            assert text, f"{language}: {source!r} is empty"
            if source not in SAME:
                assert text != source, f"{language}: {source!r} is not translated"
            assert sorted(PLACEHOLDER.findall(text)) == sorted(PLACEHOLDER.findall(source)), (language, source, text)
            text.format(**{k: "x" for k in PLACEHOLDER.findall(source)})


def test_language_switch_notifies(locale_dir) -> None:
    tr = Translator("en", locale_dir)
    seen = []
    tr.on_change(seen.append)
    assert tr.set_language("eu") and not tr.set_language("eu")
    assert seen == ["eu"] and tr._("Offices") == "Bulegoak" and tr.in_language("es", "Offices") == "Despachos"
    with pytest.raises(Exception, match="not one of"):
        tr.set_language("fr")
    assert set(LANGUAGES) == {"eu", "en", "es"}


def test_catalogs_are_found_through_the_package(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    assert package_locale_dir() == PKG / "locale"                  # the source checkout (devel space)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    with pytest.raises(ConfigError, match="gidabot_gui is not on ROS_PACKAGE_PATH .*~locale_dir"):
        package_locale_dir()


def test_numbers_as_each_language_writes_them() -> None:
    assert (format_number(2.345, 2, "en"), format_number(2.345, 1, "eu"), format_number(-0.5, 2, "es")) == (
        "2.35", "2,3", "-0,50")
