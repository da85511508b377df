"""Translations of the GUI: gettext catalogs for Basque and Spanish, English source strings.

Catalogs live in ``src/gidabot_gui/locale/<lang>/LC_MESSAGES/gidabot_gui.po``. They are
found through the package (:func:`package_locale_dir`): in a source checkout that is
``src/gidabot_gui/locale``, where ``tools/build-translations.sh`` (run by ``make setup``)
compiles them to ``.mo``; in an install space ``share/gidabot_gui/locale``, where
``catkin_make install`` puts the catalogs compiled by the package's CMake build.
A :class:`Translator` holds the three catalogs and the current language; widgets
ask it for every visible string each time they (re)translate, so a language
switch changes every text at once. Names of floors, locations, connectors come
from the building file, which already has them in the three languages.
"""

from __future__ import annotations

import gettext
import os
from collections.abc import Callable
from pathlib import Path

import rospkg

from gidabot_gui.errors import ConfigError
from gidabot_navigation.interface import LANGUAGES

DOMAIN = "gidabot_gui"
# Each language is offered under its own name (never translated).
LANGUAGE_NAMES = {"eu": "Euskara", "en": "English", "es": "Español"}
PACKAGE = "gidabot_gui"


def package_locale_dir() -> Path:
    """The ``locale`` directory of the gidabot_gui package (source checkout or install space).

    Raises :class:`ConfigError` when the package cannot be found (no workspace sourced).
    """
    try:
        return Path(rospkg.RosPack().get_path(PACKAGE)) / "locale"
    except rospkg.ResourceNotFound as err:
        raise ConfigError(f"package {PACKAGE} is not on ROS_PACKAGE_PATH "
                          f"({os.environ.get('ROS_PACKAGE_PATH', '')!r}), so its translations cannot be found: "
                          "source devel/setup.bash or install/setup.bash, or set ~locale_dir") from err


def N_(message: str) -> str:  # noqa: N802 - the conventional gettext marker
    """Mark ``message`` for extraction; it is translated later, when shown."""
    return message


def format_number(value: float, digits: int, language: str) -> str:
    """``value`` with ``digits`` decimals as written in ``language`` (decimal comma in Basque and Spanish)."""
    text = f"{value:.{digits}f}"
    return text.replace(".", ",") if language in ("eu", "es") else text


def check_language(language: object) -> str:
    """Return ``language`` if it is eu, en or es; raise :class:`ConfigError` otherwise."""
    if language not in LANGUAGES:
        raise ConfigError(f"language {language!r} is not one of {', '.join(LANGUAGES)}")
    return str(language)


class Translator:
    """The catalogs of the three languages and the language currently shown.

    ``locale_dir`` holds the compiled catalogs (default: the package's, see
    :func:`package_locale_dir`). ``missing`` lists the languages whose compiled
    catalog was not found (their texts fall back to English): the node logs it at start.
    """

    def __init__(self, language: str = "en", locale_dir: str | Path | None = None) -> None:
        self.locale_dir = Path(locale_dir) if locale_dir else package_locale_dir()
        self.missing: list[str] = []
        self._catalogs: dict[str, gettext.NullTranslations] = {}
        for lang in LANGUAGES:
            if lang == "en":
                self._catalogs[lang] = gettext.NullTranslations()
                continue
            try:
                self._catalogs[lang] = gettext.translation(DOMAIN, str(self.locale_dir), languages=[lang])
            except OSError:
                self.missing.append(lang)
                self._catalogs[lang] = gettext.NullTranslations()
        self.language = check_language(language)
        self._listeners: list[Callable[[str], None]] = []

    def set_language(self, language: str) -> bool:
        """Switch the language; True if it changed (listeners are then called)."""
        language = check_language(language)
        if language == self.language:
            return False
        self.language = language
        for listener in list(self._listeners):
            listener(language)
        return True

    def on_change(self, listener: Callable[[str], None]) -> None:
        self._listeners.append(listener)

    def _(self, message: str) -> str:
        """``message`` (English source) in the current language."""
        return self._catalogs[self.language].gettext(message)

    def n_(self, singular: str, plural: str, n: int) -> str:
        """Singular or plural form for ``n`` in the current language."""
        return self._catalogs[self.language].ngettext(singular, plural, n)

    def in_language(self, language: str, message: str) -> str:
        """``message`` in ``language`` (for texts of another language than the one shown)."""
        return self._catalogs[check_language(language)].gettext(message)
