"""The exception hierarchy of gidabot_web (ROS-free). Every message names the bad value and what was
expected."""

from __future__ import annotations


class WebError(Exception):
    """Base class of every error raised by gidabot_web."""


class ConfigError(WebError):
    """A parameter or file of the web stack or the dashboard is invalid (a port, an address, a limit)."""


class PasswordFileError(WebError):
    """The dashboard's password file cannot be read or written, or a user name, role or password is invalid."""


class HistoryError(WebError):
    """The dashboard's history database cannot be opened or written."""


class Refused(WebError):
    """A request or a staff action is refused: ``status`` is the HTTP status to answer, ``reason`` the counter it
    is counted under (docs/dashboard.md, *Security*)."""

    def __init__(self, status: int, reason: str, message: str = "") -> None:
        self.status = status
        self.reason = reason
        super().__init__(message or reason)


class EditError(WebError):
    """An edit of the building editor cannot be applied (a path that is not in the document, a value that is not
    plain data, a file name outside the building folder); nothing of it was applied."""


class PreviewError(WebError):
    """The building editor's preview (the simulated building on the edited building) cannot start or run."""
