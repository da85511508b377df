"""The exception hierarchy of gidabot_gui (ROS-free).

Every message names the bad value and what was expected.
"""

from __future__ import annotations


class GuiError(Exception):
    """Base class of every error raised by gidabot_gui."""


class ConfigError(GuiError):
    """A parameter of the GUI is invalid (unknown language, malformed password hash...)."""


class BadInput(GuiError):
    """A message from another node cannot be used (unknown robot, NaN pose, unknown phase...)."""


class TourEditError(GuiError):
    """An administrator's tour is invalid; nothing was sent to the tour store."""
